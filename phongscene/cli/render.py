# SPDX-License-Identifier: Apache-2.0
"""``phongscene render`` (one backend, an image) and ``phongscene compile`` (POV-Ray SDL and its
.ini), each also per frame with --frames."""

from __future__ import annotations

import os
from pathlib import Path

from ..errors import PhongSceneError
from .frames import (
    check_cluster_needs_frames,
    check_frame_pattern,
    frame_overrides,
    frames_to_run,
    output_at_time,
    run_frames,
)
from .options import (
    BACKEND_CHOICES,
    UsageError,
    add_override_options,
    add_sandbox_option,
    add_scene_argument,
    add_time_options,
    add_timeout_option,
    print_warnings,
    scene_and_settings,
)
from .process import EXIT_BACKEND, EXIT_OK, preimport


def add_render_command(sub) -> None:
    p = sub.add_parser(
        "render",
        help="render a scene to an image (native tracer by default, or POV-Ray)",
        description="Render SCENE (USD) with one backend and write a linear EXR (float) or an sRGB PNG. "
        "A progress bar is drawn on stderr when it is a terminal (logs stay free of carriage returns).",
        epilog="Exit codes: 0 ok, 2 bad scene or usage, 3 backend failure, 130 interrupted (Ctrl-C).",
    )
    add_scene_argument(p)
    p.add_argument("-o", "--output", required=True, metavar="IMAGE", help="output image, .exr or .png (atomic write)")
    p.add_argument("--backend", choices=BACKEND_CHOICES, default="native", help="renderer (default: native)")
    add_override_options(
        p,
        mapping_help="specular convention: exact (the seed model) or classic (plain POV-Ray "
        "phong, native 'povray-classic'); default: the scene's",
        shadow_cells=True,
        threads_help="worker threads (0 = all cores)",
    )
    add_timeout_option(p, "--backend povray only: stop POV-Ray after SECONDS (exit 3)")
    p.add_argument(
        "--display",
        choices=("srgb", "book", "book-gamut"),
        default="srgb",
        help="how a .png encodes the linear image: srgb (default: clip, sRGB), book (Suffern's display: "
        "max_to_one, gamma 1, truncation) or book-gamut (its out-of-gamut red instead of max_to_one)",
    )
    add_time_options(
        p, "one image per frame, #### in IMAGE becomes the frame number", skip_existing=True, contact_sheet=True
    )
    add_sandbox_option(p)
    p.set_defaults(func=run_render)


def run_render(args) -> int:
    import time

    from ..diagnostics import ImageChecks
    from ..files import check_output
    from ..images import WRITABLE, write_image
    from ..memory import release_free_heap
    from ..progress import ProgressBar
    from ..rendering import prepare_render

    if not args.output.lower().endswith(WRITABLE):
        raise UsageError(f"{args.output}: the output must end in one of {', '.join(WRITABLE)}")
    if args.timeout is not None and args.backend != "povray":
        raise UsageError("--timeout applies to --backend povray only (the native tracer stops on Ctrl-C)")
    if args.display != "srgb" and not args.output.lower().endswith(".png"):
        raise UsageError(f"--display {args.display} applies to a .png output (an EXR stays linear)")
    check_cluster_needs_frames(args)
    if args.frames:
        if args.display != "srgb":
            raise UsageError("--display applies to single images, not --frames")
        preimport(("OpenImageIO",))
        return _render_frames(args)
    args.output = output_at_time(args, args.output)
    check_output(args.output)  # before the render, not after it
    bar = ProgressBar(args.backend)
    start = time.perf_counter()
    bar.phase(f"reading {Path(args.scene).name}")  # a big USD file takes seconds
    scene, settings, warnings = scene_and_settings(args, with_warnings=True)
    # Peak memory (benchmarks/memory_stages.py): what the reader freed, then the model once the
    # C++ scene holds its own copy, then the C++ scene before OpenImageIO's import and the write,
    # each handed back to the system as soon as it is garbage.
    release_free_heap()
    render = prepare_render(scene, args.backend, settings, progress=bar, timeout=args.timeout)
    checks = ImageChecks.of(scene, settings, warnings)  # what the image checks need, before the scene is freed
    del scene
    release_free_heap()
    image = render()
    del render
    release_free_heap()
    bar.done(time.perf_counter() - start)
    preimport(("OpenImageIO",))
    write_image(args.output, image, display=args.display)
    print_warnings(checks.warnings(image))
    print(f"{args.output}: {settings.width} x {settings.height}, {args.backend}, specular {settings.specular}")
    return EXIT_OK


def _render_frames(args) -> int:
    from ..animation import frame_name, render_frame
    from ..files import check_output
    from ..images import WRITABLE

    check_frame_pattern(args.output, "out.####.exr")
    # One check of the folder every frame writes into, before any task (not one error per frame).
    check_output(frame_name(args.output, args.frames[0]))
    if args.contact_sheet is not None:
        if not args.contact_sheet.lower().endswith(WRITABLE):
            raise UsageError(f"{args.contact_sheet}: the contact sheet must end in one of {', '.join(WRITABLE)}")
        check_output(args.contact_sheet)
    overrides = frame_overrides(args)
    scene = os.path.abspath(args.scene)
    frames = frames_to_run(args, lambda f: frame_name(args.output, f))
    failed = False
    if frames:
        run = run_frames(
            args,
            render_frame,
            lambda f: (scene, f, os.path.abspath(frame_name(args.output, f)), args.backend, overrides),
            "frames rendered",
            frames,
        )
        if run.results:
            m = next(iter(run.results.values()))
            print(f"{args.output}: {m['width']} x {m['height']}, {args.backend}, specular {m['specular']}")
        failed = bool(run.failures)
    if args.contact_sheet is not None:
        from ..contact_sheet import write_contact_sheet

        present = [(f, frame_name(args.output, f)) for f in args.frames if os.path.exists(frame_name(args.output, f))]
        if present:
            sheet = write_contact_sheet(args.contact_sheet, present)
            print(f"{sheet}: contact sheet of {len(present)} frames")
    return EXIT_BACKEND if failed else EXIT_OK


def add_compile_command(sub) -> None:
    p = sub.add_parser(
        "compile",
        help="compile a scene to POV-Ray 3.7 SDL (.pov) and an .ini with the render options",
        description="Compile SCENE (USD) to POV-Ray 3.7 SDL. Writes OUT.pov and OUT.ini (atomically) and prints "
        "the povray command line. The exact mapping renders one frame per light: add the linear frame images "
        "(phongscene render --backend povray does all of this for you).",
        epilog="Exit codes: 0 ok, 2 bad scene or usage.",
    )
    add_scene_argument(p)
    p.add_argument("-o", "--output", required=True, metavar="OUT.pov", help="the SDL file to write")
    add_override_options(
        p,
        mapping_help="exact (the seed model, one pass per light) or classic (one plain POV-Ray "
        "finish per material); default: the scene's specular convention",
    )
    add_time_options(p, "a .pov and an .ini per frame, #### in OUT.pov becomes the frame number", skip_existing=True)
    add_sandbox_option(p)
    p.set_defaults(func=run_compile)


def run_compile(args) -> int:
    import shlex

    from ..backends.povray import MAPPING_OF_SPECULAR, pov_quoted, prepare
    from ..diagnostics import ImageChecks
    from ..files import atomic_files, check_output
    from ..rendering import check_settings

    out = Path(args.output)
    if out.suffix.lower() != ".pov":
        raise UsageError(f"{out}: the output must end in .pov")
    check_cluster_needs_frames(args)
    if args.frames:
        return _compile_frames(args)
    out = Path(output_at_time(args, args.output))
    ini, image = out.with_suffix(".ini"), out.with_suffix(".exr")
    try:  # before anything is read: a name POV-Ray cannot read, or one that would inject .ini lines
        pov_quoted(out.name)
    except PhongSceneError as e:
        raise UsageError(str(e)) from None  # the name's repr: one line, whatever it holds
    check_output(out)
    scene, settings = scene_and_settings(args)
    job = prepare(scene, check_settings(scene, settings), args.mapping)
    print_warnings(ImageChecks.of(scene, settings).model_warnings())  # the image to come shows nothing
    with atomic_files(out, ini) as (tmp_pov, tmp_ini):  # both appear, or neither
        job.save_sdl(tmp_pov)  # compiled as it is written: never held whole
        tmp_ini.write_text(job.ini(out.name, image.name), encoding="ascii")
    for texture in job.write_textures(out.parent):
        print(f"{texture}: a texture the scene reads (keep it beside {out.name})")
    mapping = MAPPING_OF_SPECULAR[settings.specular]  # args.mapping, or the scene's
    print(f"{out}: {mapping} mapping, {job.frames} frame(s), {settings.width} x {settings.height}")
    print(f"{ini}: the same options; render in {out.parent} with: povray {shlex.quote(pov_quoted(ini.name))}")
    print("  " + shlex.join(job.command(pov_quoted(out.name), pov_quoted(image.name))))
    if job.frames > 1:
        print(f"  then add the {job.frames} linear frame images (one per light)")
    if job.supersample > 1:
        print(f"  then average {job.supersample} x {job.supersample} pixel blocks (grid anti-aliasing)")
    return EXIT_OK


def _compile_frames(args) -> int:
    from ..animation import compile_frame, frame_name
    from ..files import check_output

    check_frame_pattern(args.output, "out.####.pov")
    check_output(frame_name(args.output, args.frames[0]))  # the one folder of every frame, before any task
    overrides = frame_overrides(args)
    scene = os.path.abspath(args.scene)
    frames = frames_to_run(args, lambda f: frame_name(args.output, f))
    if not frames:
        return EXIT_OK
    run = run_frames(
        args,
        compile_frame,
        lambda f: (scene, f, os.path.abspath(frame_name(args.output, f)), overrides),
        "frames compiled",
        frames,
    )
    for frame in sorted(run.results):
        print(f"  {run.results[frame]['output']}")
    return EXIT_BACKEND if run.failures else EXIT_OK
