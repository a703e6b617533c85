# SPDX-License-Identifier: Apache-2.0
"""The ``phongscene`` command line: every subcommand's parser, and a thin ``_run_<command>``
that calls the public API and prints the result. Exit codes: 0 success, 1 images differ
(diff/compare), 2 bad scene or usage, 3 backend failure, 130 interrupted.

pxr, OpenImageIO and the backends are imported inside the run functions, so ``import
phongscene.cli`` and ``phongscene --help`` stay fast."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from . import __version__
from .errors import BackendError, PhongSceneError, SceneError
from .rendering import BACKENDS, in_file_terms
from .validate import MAX_IMAGE_SIDE, MAX_SAMPLES, MAX_THREADS

EXIT_OK, EXIT_DIFFERENT, EXIT_SCENE, EXIT_BACKEND, EXIT_INTERRUPTED = 0, 1, 2, 3, 130

SCENE_HELP = "USD file (.usda, .usdc, .usd, .usdz)"
# The POV-Ray backend's mappings (phongscene.backends.povray.MAPPINGS, which a test checks this
# against), named here so that building the parser imports no backend.
MAPPING_CHOICES = ("exact", "classic")
SPP_HELP = f"anti-aliasing: N x N samples per pixel, N in 1..{MAX_SAMPLES}"


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="phongscene",
        description="Author Phong scenes in USD, compile them to POV-Ray, render natively, diff the backends.",
        epilog="Exit codes: 0 ok, 1 images differ, 2 bad scene or usage, 3 backend failure.",
    )
    parser.add_argument("--version", action="version", version=f"phongscene {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for add_command in (
        _add_diff_command,
        _add_compare_command,
        _add_info_command,
        _add_validate_command,
        _add_import_command,
        _add_render_command,
        _add_compile_command,
    ):
        add_command(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except SceneError as e:
        for p in in_file_terms(e).problems:
            print(f"error: {p}", file=sys.stderr)
        return EXIT_SCENE
    except BackendError as e:
        print(f"error: {e}", file=sys.stderr)
        return EXIT_BACKEND
    except (PhongSceneError, OSError) as e:  # an output that cannot be written, an unreadable input
        print(f"error: {e}", file=sys.stderr)
        return EXIT_SCENE
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


# ----------------------------------------------------------------------------------------------
# Arguments more than one command takes


def _int_in(low: int, high: int | None = None):
    """An argparse type: a whole number in [low, high] (no upper bound when high is None)."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
        if value < low or (high is not None and value > high):
            bound = f">= {low}" if high is None else f"in {low}..{high}"
            raise argparse.ArgumentTypeError(f"expected a number {bound}, got {value}")
        return value

    return parse


_image_side = _int_in(1, MAX_IMAGE_SIDE)
_thread_count = _int_in(0, MAX_THREADS)  # 0 = all cores
_samples_per_axis = _int_in(1, MAX_SAMPLES)  # the model's anti-aliasing range (RenderSettings.samples)


def _add_scene_argument(p: argparse.ArgumentParser) -> None:
    p.add_argument("scene", metavar="SCENE", help=SCENE_HELP)


def _add_mapping_option(p: argparse.ArgumentParser, help: str, default: str | None = None) -> None:
    p.add_argument("--mapping", choices=MAPPING_CHOICES, default=default, help=help)


def _add_size_options(p: argparse.ArgumentParser, spp_help: str = SPP_HELP) -> None:
    p.add_argument("--width", type=_image_side, metavar="W", help="image width (alone: keeps the aspect ratio)")
    p.add_argument("--height", type=_image_side, metavar="H", help="image height (alone: keeps the aspect ratio)")
    p.add_argument("--spp", type=_samples_per_axis, metavar="N", help=spp_help)


def _add_threshold_options(p: argparse.ArgumentParser, by_format: bool = False) -> None:
    from .comparison import HALF_FLOAT as t  # OpenImageIO: only when a parser is built

    title = ("thresholds (idiff vocabulary; default: by the files' formats: half-float precision for float "
             "images, one code step for 8-bit ones)" if by_format else
             "thresholds (idiff vocabulary; default: half-float precision)")
    group = p.add_argument_group(title)
    # Defaults are None: a given option overrides one field of the default thresholds.
    group.add_argument("--fail", type=float, metavar="ABS",
                       help=f"absolute error always accepted (half-float default {t.fail:.3g}, one subnormal half step)")
    group.add_argument("--fail-relative", type=float, metavar="REL",
                       help=f"error accepted relative to mean(|a|,|b|) (half-float default {t.fail_relative:.3g} "
                       "= 2 x 2^-11)")
    group.add_argument("--fail-percent", type=float, metavar="PCT",
                       help=f"%% of pixels allowed to fail (default {t.fail_percent:g})")
    group.add_argument("--hard-fail", type=float, metavar="ABS",
                       help="any error above this fails (default: none)")


def _thresholds(args, base=None):
    """``base`` (default: half-float precision) with the threshold options given on the command line."""
    from dataclasses import replace

    from .comparison import HALF_FLOAT

    given = {name: getattr(args, name) for name in ("fail", "fail_relative", "fail_percent", "hard_fail")}
    return replace(HALF_FLOAT if base is None else base, **{k: v for k, v in given.items() if v is not None})


def _print_warnings(warnings, stream=None) -> None:
    for warning in warnings:
        print(f"warning: {warning}", file=sys.stderr if stream is None else stream)


def _scene_and_settings(args):
    """The scene of ``args.scene`` (its warnings printed) and its settings with the command's
    mapping, size, sample and thread overrides."""
    from .rendering import load_scene, settings_with

    scene, warnings = load_scene(args.scene)
    _print_warnings(warnings)
    settings = settings_with(scene, args.mapping, width=args.width, height=args.height, samples=args.spp,
                             threads=getattr(args, "threads", None))
    return scene, settings


# ----------------------------------------------------------------------------------------------
# diff, compare


def _add_diff_command(sub) -> None:
    p = sub.add_parser(
        "diff",
        help="render a scene with POV-Ray and the native tracer and compare",
        description="Render SCENE with both backends under matching conventions (exact: native 'seed'; "
        "classic: native 'povray-classic'), compare at half-float precision and write a report "
        "(images as EXR and PNG, heat map, metrics.json, index.html) into OUTDIR.",
        epilog="Exit codes: 0 the images agree, 1 they differ, 2 bad scene or usage, 3 backend failure.",
    )
    _add_scene_argument(p)
    p.add_argument("-o", "--outdir", required=True, metavar="OUTDIR", help="report folder (created)")
    _add_mapping_option(p, "POV-Ray mapping: exact (the seed model, default) or classic (plain POV-Ray phong)",
                        default="exact")
    _add_size_options(p, spp_help=f"{SPP_HELP} (RenderSettings.samples; default: the scene's)")
    p.add_argument("--threads", type=_thread_count, metavar="N", help="native worker threads (0 = all cores)")
    _add_threshold_options(p)
    p.set_defaults(func=_run_diff)


def _run_diff(args) -> int:
    from .crossvalidation import diff

    try:
        thresholds = _thresholds(args)
    except ValueError as e:
        print(f"error: {e}", file=sys.stderr)
        return EXIT_SCENE
    result = diff(
        args.scene, args.outdir, mapping=args.mapping, width=args.width, height=args.height, samples=args.spp,
        threads=args.threads, thresholds=thresholds, progress=sys.stderr,
    )
    s = result.settings
    print(f"{args.scene}: {s.width} x {s.height}, mapping {result.mapping} (native {s.specular})")
    print(f"  povray {result.timings['povray']:.3f} s, native {result.timings['native']:.3f} s")
    print(result.report.summary())
    if result.explanation():
        print(result.explanation())
    print(f"report: {result.outdir / 'index.html'}")
    return EXIT_OK if result.ok else EXIT_DIFFERENT


def _add_compare_command(sub) -> None:
    p = sub.add_parser(
        "compare",
        help="compare two images (EXR, PNG, ...) at the precision of their formats",
        description="Compare image B against reference A pixel by pixel (OpenImageIO) and print the "
        "errors; with -o, also write the report folder.",
        epilog="Exit codes: 0 the images agree, 1 they differ (or differ in size), 2 unreadable file.",
    )
    p.add_argument("a", metavar="A", help="reference image")
    p.add_argument("b", metavar="B", help="image under test")
    p.add_argument("-o", "--outdir", metavar="OUTDIR", help="write the report folder here")
    _add_threshold_options(p, by_format=True)
    p.set_defaults(func=_run_compare)


def _run_compare(args) -> int:
    from .comparison import ImageMismatchError, compare, thresholds_for_files
    from .images import read_image

    try:
        base, why = thresholds_for_files(args.a, args.b)
        thresholds = _thresholds(args, base)
        a, b = read_image(args.a), read_image(args.b)
    except (PhongSceneError, ValueError) as e:
        print(f"error: {e}", file=sys.stderr)
        return EXIT_SCENE
    try:
        report = compare(a, b, thresholds)
    except ImageMismatchError as e:
        print(f"error: {e}", file=sys.stderr)
        return EXIT_DIFFERENT
    print(f"comparing {args.a} and {args.b}")
    print(f"  thresholds: {why}" + (" (with the options given)" if thresholds != base else ""))
    print(report.summary())
    if args.outdir:
        from .report import write_report

        index = write_report(
            args.outdir, a, b, report, labels=(Path(args.a).stem, Path(args.b).stem),
            title=f"phongscene compare: {Path(args.a).name} vs {Path(args.b).name}",
            meta={"a": os.path.abspath(args.a), "b": os.path.abspath(args.b)},
        )
        print(f"report: {index}")
    return EXIT_OK if report.ok else EXIT_DIFFERENT


# ----------------------------------------------------------------------------------------------
# info, validate, import (USD)


def _add_info_command(sub) -> None:
    p = sub.add_parser(
        "info",
        help="show what phongscene reads from a USD scene",
        description="Read SCENE and print which prims became which model nodes, the counts of meshes, "
        "triangles, spheres, lights and materials, the camera, the render settings and every warning "
        "(unsupported prims, defaults used).",
        epilog="Exit codes: 0 ok, 2 the scene is invalid (one problem per line on stderr).",
    )
    p.add_argument("scene", metavar="SCENE", nargs="?", help=SCENE_HELP)
    p.add_argument("--usd-plugin-path", action="store_true",
                   help="print the folder of the Phong shader's Sdr definition and exit: other USD tools know the "
                   "shader with PXR_SDR_FS_PLUGIN_SEARCH_PATHS=<it> PXR_SDR_FS_PLUGIN_ALLOWED_EXTS=usda")
    p.set_defaults(func=_run_info)


def _run_info(args) -> int:
    if args.usd_plugin_path:
        from .schemas import folder

        print(folder())
        return EXIT_OK
    if args.scene is None:
        print("error: info needs SCENE (or --usd-plugin-path)", file=sys.stderr)
        return EXIT_SCENE
    from .usd import read_usd

    result = read_usd(args.scene)
    scene = result.scene
    print(f"file: {scene.source_file}")
    print("prims -> model nodes:")
    for prim, node in result.nodes:
        print(f"  {prim} -> {node}")
    materials = {m.material for m in (*scene.spheres, *scene.meshes)}  # equal materials count once
    kinds: dict[str, int] = {}
    for light in scene.lights:
        kinds[type(light).__name__] = kinds.get(type(light).__name__, 0) + 1
    print(
        f"counts: {len(scene.meshes)} meshes, {scene.triangle_count} triangles, {len(scene.spheres)} spheres, "
        f"{len(scene.lights)} lights ({', '.join(f'{n} {k}' for k, n in sorted(kinds.items())) or 'none'}), "
        f"{len(materials)} materials"
    )
    print(f"ambient: {_vector(scene.ambient.color)}")
    cam = scene.camera
    extent = f"hfov {cam.horizontal_fov_deg:.6g} deg" if cam.projection == "perspective" else f"width {cam.ortho_width:.6g}"
    print(
        f"camera: {cam.source or '(model default)'}: {cam.projection}, {extent}, position {_vector(cam.position)}, "
        f"forward {_vector(cam.forward)}, up {_vector(cam.up)}"
    )
    s = scene.settings
    print(
        f"settings: {s.source or '(defaults)'}: {s.width}x{s.height}, samples {s.samples} ({s.sample_pattern}), "
        f"specular {s.specular}, background {_vector(s.background)}"
    )
    _print_warnings(result.warnings, sys.stdout)
    return EXIT_OK


def _vector(v) -> str:
    return "(" + ", ".join(f"{float(c):.6g}" for c in v) + ")"


def _add_validate_command(sub) -> None:
    p = sub.add_parser(
        "validate",
        help="check a USD scene; list every problem",
        description="Read and validate SCENE. Prints 'ok' and exits 0 when it is valid; otherwise prints "
        "one problem per line on stderr (file: prim.attribute: what is wrong) and exits 2.",
        epilog="Exit codes: 0 valid, 2 invalid (with --strict: also when there is a warning).",
    )
    _add_scene_argument(p)
    p.add_argument("-q", "--quiet", action="store_true", help="do not print warnings")
    p.add_argument("--strict", action="store_true",
                   help="treat every warning (a typo'd name, an ignored feature, a default camera or light) as an error")
    p.set_defaults(func=_run_validate)


def _run_validate(args) -> int:
    from .usd import read_usd

    result = read_usd(args.scene)
    if args.strict and result.warnings:
        for warning in result.warnings:
            print(f"error: {args.scene}: {warning}", file=sys.stderr)
        return EXIT_SCENE
    if not args.quiet:
        _print_warnings(result.warnings)
    print(f"ok: {args.scene}")
    return EXIT_OK


def _add_import_command(sub) -> None:
    p = sub.add_parser(
        "import",
        help="convert a mesh file (OBJ, PLY, STL, GLB, ...) to a USD scene",
        description="Read MESHFILE with trimesh and write a USD file with one Mesh (subdivisionScheme none) "
        "bound to a default Phong material. Normals: the file's when it has them, else smooth across "
        "edges and split at creases (faces meeting at more than --crease-angle). The scene has no camera or "
        "lights, so renderers use the framing camera and the head light.",
        epilog="Exit codes: 0 ok, 2 unreadable input or bad output path.",
    )
    p.add_argument("mesh", metavar="MESHFILE", help="any format trimesh.load reads")
    p.add_argument("-o", "--output", required=True, metavar="OUT", help="USD file to write (.usda, .usdc, .usd)")
    p.add_argument("--crease-angle", type=_degrees, default=None, metavar="DEG",
                   help="for files without normals: split normals where faces meet at more than DEG degrees "
                   "(default 30, Blender's auto smooth; 0 = flat, 180 = smooth everywhere)")
    p.set_defaults(func=_run_import)


def _degrees(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an angle in degrees, got {text!r}") from None
    if not 0.0 <= value <= 180.0:
        raise argparse.ArgumentTypeError(f"expected an angle in 0..180 degrees, got {value:g}")
    return value


def _run_import(args) -> int:
    from .usd import import_mesh

    extra = {} if args.crease_angle is None else {"crease_angle_deg": args.crease_angle}
    path = import_mesh(args.mesh, args.output, **extra)
    print(f"wrote {path}")
    return EXIT_OK


# ----------------------------------------------------------------------------------------------
# render, compile


def _add_render_command(sub) -> None:
    p = sub.add_parser(
        "render",
        help="render a scene to an image (native tracer by default, or POV-Ray)",
        description="Render SCENE (USD) with one backend and write a linear EXR (float) or an sRGB PNG. "
        "A progress bar is drawn on stderr when it is a terminal (logs stay free of carriage returns).",
        epilog="Exit codes: 0 ok, 2 bad scene or usage, 3 backend failure, 130 interrupted (Ctrl-C).",
    )
    _add_scene_argument(p)
    p.add_argument("-o", "--output", required=True, metavar="IMAGE", help="output image, .exr or .png (atomic write)")
    p.add_argument("--backend", choices=BACKENDS, default="native", help="renderer (default: native)")
    _add_mapping_option(p, "specular convention: exact (the seed model) or classic (plain POV-Ray phong, native "
                        "'povray-classic'); default: the scene's")
    _add_size_options(p)
    p.add_argument("--threads", type=_thread_count, metavar="N", help="worker threads (0 = all cores)")
    p.set_defaults(func=_run_render)


def _run_render(args) -> int:
    import time

    from .images import WRITABLE, write_image
    from .progress import ProgressBar
    from .rendering import render

    if not args.output.lower().endswith(WRITABLE):
        print(f"error: {args.output}: the output must end in one of {', '.join(WRITABLE)}", file=sys.stderr)
        return EXIT_SCENE
    scene, settings = _scene_and_settings(args)
    bar = ProgressBar(args.backend)
    start = time.perf_counter()
    image = render(scene, args.backend, settings, progress=bar)
    bar.done(time.perf_counter() - start)
    write_image(args.output, image)
    print(f"{args.output}: {settings.width} x {settings.height}, {args.backend}, specular {settings.specular}")
    return EXIT_OK


def _add_compile_command(sub) -> None:
    p = sub.add_parser(
        "compile",
        help="compile a scene to POV-Ray 3.7 SDL (.pov) and an .ini with the render options",
        description="Compile SCENE (USD) to POV-Ray 3.7 SDL. Writes OUT.pov and OUT.ini (atomically) and prints "
        "the povray command line. The exact mapping renders one frame per light: add the linear frame images "
        "(phongscene render --backend povray does all of this for you).",
        epilog="Exit codes: 0 ok, 2 bad scene or usage.",
    )
    _add_scene_argument(p)
    p.add_argument("-o", "--output", required=True, metavar="OUT.pov", help="the SDL file to write")
    _add_mapping_option(p, "exact (the seed model, one pass per light) or classic (one plain POV-Ray finish per "
                        "material); default: the scene's specular convention")
    _add_size_options(p)
    p.set_defaults(func=_run_compile)


def _run_compile(args) -> int:
    import shlex

    from .backends.povray import MAPPING_OF_SPECULAR, prepare
    from .files import write_text_atomic
    from .rendering import check_settings

    out = Path(args.output)
    if out.suffix.lower() != ".pov":
        print(f"error: {out}: the output must end in .pov", file=sys.stderr)
        return EXIT_SCENE
    scene, settings = _scene_and_settings(args)
    job = prepare(scene, check_settings(scene, settings), args.mapping)
    ini, image = out.with_suffix(".ini"), out.with_suffix(".exr")
    write_text_atomic(out, job.sdl, encoding="ascii")
    write_text_atomic(ini, job.ini(out.name, image.name), encoding="ascii")
    for texture in job.write_textures(out.parent):
        print(f"{texture}: a texture the scene reads (keep it beside {out.name})")
    mapping = MAPPING_OF_SPECULAR[settings.specular]  # args.mapping, or the scene's
    print(f"{out}: {mapping} mapping, {job.frames} frame(s), {settings.width} x {settings.height}")
    print(f"{ini}: the same options; render in {out.parent} with: povray {ini.name}")
    print("  " + shlex.join(job.command(out.name, image.name)))
    if job.frames > 1:
        print(f"  then add the {job.frames} linear frame images (one per light)")
    if job.supersample > 1:
        print(f"  then average {job.supersample} x {job.supersample} pixel blocks (grid anti-aliasing)")
    return EXIT_OK
