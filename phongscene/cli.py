# SPDX-License-Identifier: Apache-2.0
"""The ``phongscene`` command line: every subcommand's parser, and a thin ``_run_<command>``
that calls the public API and prints the result. Exit codes: 0 success, 1 images differ
(diff/compare), 2 bad scene or usage, 3 backend failure, 130 interrupted.

pxr, OpenImageIO and the backends are imported inside the run functions, so ``import
phongscene.cli`` and ``phongscene --help`` stay fast."""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path

from . import __version__
from .errors import BackendError, PhongSceneError, SceneError
from .limits import MAX_CELL_SAMPLES, MAX_IMAGE_SIDE, MAX_SAMPLES, MAX_STRATIFIED_SAMPLES, MAX_THREADS

EXIT_OK, EXIT_DIFFERENT, EXIT_SCENE, EXIT_BACKEND, EXIT_INTERRUPTED = 0, 1, 2, 3, 130

SCENE_HELP = "USD file (.usda, .usdc, .usd, .usdz)"
# The POV-Ray backend's mappings (phongscene.backends.povray.MAPPINGS, which a test checks this
# against), named here so that building the parser imports no backend.
MAPPING_CHOICES = ("exact", "classic")
# The backends (phongscene.rendering.BACKENDS, checked by a test), named here so that importing
# the CLI imports no numpy: Ctrl-C before main() has no handler yet.
BACKEND_CHOICES = ("native", "povray")
SPP_HELP = (f"anti-aliasing: N x N samples per pixel, N in 1..{MAX_SAMPLES} "
            f"(stratified: at most N x N, N up to {MAX_STRATIFIED_SAMPLES}; adaptive: cells down to 1/N pixel, "
            f"N a power of 2 up to {MAX_STRATIFIED_SAMPLES})")
# `bench` renders its references at 27² samples per pixel: a small default image keeps that
# to seconds.
BENCH_WIDTH = 320


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
        _add_bench_command,
    ):
        add_command(sub)
    return parser


class Terminated(BaseException):
    """SIGTERM or SIGHUP arrived: raised in the main thread, like KeyboardInterrupt for SIGINT, so
    that every ``finally`` runs (POV-Ray is killed, its temporary folder removed) before exit.
    A BaseException, so that no ``except Exception`` swallows it."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


# Signals that end phongscene with cleanup and exit status 128 + the signal number (the shell's
# convention for "killed by signal N", as 130 is for Ctrl-C); SIGINT stays KeyboardInterrupt.
TERMINATING_SIGNALS = ("SIGTERM", "SIGHUP")
# Modules whose import a command needs, imported before the command runs with Ctrl-C deferred:
# USD's Python bindings catch a KeyboardInterrupt raised while they import (Tf prints "Error
# occurred postprocessing module" and the import goes on half-done), so an early Ctrl-C was lost.
PREIMPORTS = {
    "compare": ("OpenImageIO",),
    **{command: ("pxr.Usd", "OpenImageIO") for command in ("diff", "info", "validate", "import", "compile")},
    # OpenImageIO's libraries (~32 MiB resident) only once the C++ scene is freed, for the write
    # (_run_render): imported first, they sat under the BVH build's peak (benchmarks/README.md).
    "render": ("pxr.Usd",),
}


def _on_terminating_signal(signum, frame) -> None:
    import signal

    # Cleanup is under way: a second SIGTERM must not interrupt it half-done.
    for name in TERMINATING_SIGNALS:
        signal.signal(getattr(signal, name), signal.SIG_IGN)
    raise Terminated(signum)


def _install_signal_handlers() -> dict:
    """Handle TERMINATING_SIGNALS; returns the previous handlers (``main`` restores them, so
    calling it in-process, as the tests do, leaves the caller's handlers as they were)."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        return {}  # main() called from a worker thread: Python allows handlers only in the main one
    return {
        signum: signal.signal(signum, _on_terminating_signal)
        for signum in (getattr(signal, name) for name in TERMINATING_SIGNALS)
    }


def _preimport(modules) -> None:
    """Import ``modules`` with SIGINT held back, then raise KeyboardInterrupt if one came."""
    import importlib
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        for module in modules:
            importlib.import_module(module)
        return
    caught: list[int] = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: caught.append(signum))
    try:
        for module in modules:
            try:
                importlib.import_module(module)
            except ImportError:
                pass  # a missing module is the command's to report, in its own words
    finally:
        signal.signal(signal.SIGINT, previous)
    if caught:
        raise KeyboardInterrupt


def main(argv: list[str] | None = None) -> int:
    import signal

    previous = _install_signal_handlers()
    try:
        return _main(argv)
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


def _main(argv: list[str] | None) -> int:
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        problem = _estimator_option_problem(args)
        if problem:  # as argparse reports a bad option: before the scene is read
            print(f"phongscene {args.command}: error: {problem}", file=sys.stderr)
            return EXIT_SCENE
        _preimport(PREIMPORTS.get(args.command, ()))
        return int(args.func(args) or 0)
    except Terminated as e:
        import signal

        print(f"terminated by {signal.Signals(e.signum).name}", file=sys.stderr)
        return 128 + e.signum
    except SceneError as e:
        from .rendering import in_file_terms

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


def _float_in(low: float, high: float):
    """An argparse type: a number in [low, high]."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
        if not low <= value <= high:  # also rejects nan
            raise argparse.ArgumentTypeError(f"expected a number in [{low:g}, {high:g}], got {text}")
        return value

    return parse


# The estimators only the native tracer has (validate.py refuses them for POV-Ray, naming the
# scene's attribute; from the command line the option is named instead).
NATIVE_ONLY_PATTERNS = ("stratified", "adaptive")


def _estimator_option_problem(args) -> str | None:
    """What is wrong with the command line's estimator options together (each alone is checked
    by its argparse type), or None."""
    pattern, spp = getattr(args, "sample_pattern", None), getattr(args, "spp", None)
    if pattern == "adaptive" and spp is not None and spp & (spp - 1):
        return f"argument --spp: expected a power of 2 with --sample-pattern adaptive, got {spp}"
    povray = args.command in ("diff", "compile") or getattr(args, "backend", None) == "povray"
    if povray and pattern in NATIVE_ONLY_PATTERNS:
        return (f"argument --sample-pattern: {pattern!r} is the native tracer's own; POV-Ray renders grid, "
                "povray-am1, povray-am2")
    return None


def _power_of_two_in(low: int, high: int):
    """An argparse type: a power of 2 in [low, high]."""
    whole = _int_in(low, high)

    def parse(text: str) -> int:
        value = whole(text)
        if value & (value - 1):
            raise argparse.ArgumentTypeError(f"expected a power of 2, got {value}")
        return value

    return parse


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
# The model's anti-aliasing range (RenderSettings.samples; above MAX_SAMPLES: stratified and adaptive only).
_samples_per_axis = _int_in(1, MAX_STRATIFIED_SAMPLES)


def _add_scene_argument(p: argparse.ArgumentParser) -> None:
    p.add_argument("scene", metavar="SCENE", help=SCENE_HELP)


def _add_mapping_option(p: argparse.ArgumentParser, help: str, default: str | None = None) -> None:
    p.add_argument("--mapping", choices=MAPPING_CHOICES, default=default, help=help)


def _add_size_options(p: argparse.ArgumentParser, spp_help: str = SPP_HELP) -> None:
    p.add_argument("--width", type=_image_side, metavar="W", help="image width (alone: keeps the aspect ratio)")
    p.add_argument("--height", type=_image_side, metavar="H", help="image height (alone: keeps the aspect ratio)")
    p.add_argument("--spp", type=_samples_per_axis, metavar="N", help=spp_help)
    _add_estimator_options(p)


def _add_estimator_options(p: argparse.ArgumentParser) -> None:
    from .scene import SAMPLE_PATTERNS
    from .limits import MAX_ADAPTIVE

    p.add_argument("--sample-pattern", choices=SAMPLE_PATTERNS,
                   help="anti-aliasing pattern (RenderSettings.sample_pattern; default: the scene's)")
    p.add_argument("--aa-threshold", type=_float_in(0.0, 1.0), metavar="T",
                   help="POV-Ray's +A threshold of povray-am1/am2: supersample where colours differ by >= T "
                   "(0: everywhere); stratified: its stopping tolerance; adaptive: split a cell of side s while "
                   "its corners' spread x s^1.5 >= T")
    p.add_argument("--shadow-adaptive", type=_int_in(0, MAX_ADAPTIVE), metavar="N",
                   help="POV-Ray's 'adaptive N' on every area light (default: each light's own)")


def _seconds(text: str) -> float:
    """An argparse type: a number of seconds > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of seconds, got {text!r}") from None
    if not value > 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"expected a number of seconds > 0, got {text}")
    return value


def _add_timeout_option(p: argparse.ArgumentParser, help: str) -> None:
    p.add_argument("--timeout", type=_seconds, metavar="SECONDS", help=help)


def _time_code(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number (a USD time code), got {text!r}") from None
    if value != value or value in (float("inf"), float("-inf")):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


def _frame_range(text: str) -> tuple[int, ...]:
    from .animation import parse_frames

    try:
        return parse_frames(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def _add_time_options(p: argparse.ArgumentParser, output: str) -> None:
    group = p.add_argument_group("time (an animated stage; default: its start time, with a warning)")
    when = group.add_mutually_exclusive_group()
    when.add_argument("--time", type=_time_code, metavar="T", help="read the stage at USD time code T")
    when.add_argument("--frames", type=_frame_range, metavar="START:END[:STEP]",
                      help=f"frames START, START+STEP, ... END (whole time codes): {output}. Frames run as Dask "
                      "tasks: a LocalCluster here, or --scheduler")
    _add_cluster_options(group, "with --frames: ", "one per core")


def _add_cluster_options(group, which: str, default_workers: str) -> None:
    """--scheduler and --workers: where Dask runs the tasks (frames, bench settings)."""
    group.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                       help=f"{which}an existing Dask scheduler (default: $DASK_SCHEDULER_ADDRESS, else a "
                       "LocalCluster); workers must see the scene and the output at the same paths")
    group.add_argument("--workers", type=_int_in(1), metavar="N",
                       help=f"{which}LocalCluster worker processes (default: {default_workers})")


def _frame_options(args) -> dict:
    """The plain options a frame task renders with. Each LocalCluster worker renders one frame at
    a time; unless --threads says otherwise it gets its share of the cores (so workers x threads
    = cores); on an existing cluster the scene's setting applies unless --threads is given."""
    from .dask_runtime import scheduler_address

    threads = getattr(args, "threads", None)
    if threads is None and "threads" in args and scheduler_address(args.scheduler) is None:
        cores = os.cpu_count() or 1
        threads = max(1, cores // min(args.workers or cores, len(args.frames)))
    return {"mapping": args.mapping, "width": args.width, "height": args.height, "samples": args.spp,
            "threads": threads, "sample_pattern": getattr(args, "sample_pattern", None),
            "aa_threshold": getattr(args, "aa_threshold", None), "shadow_adaptive": getattr(args, "shadow_adaptive", None),
            "shadow_cells": getattr(args, "shadow_cells", None)}


def _run_frames(args, task, arguments, label: str):
    """Run ``task`` for every frame of ``args.frames``: one frame in this process, more on Dask.
    The stage is read once here first (at the first frame), so a bad file is one error before
    any cluster starts, and its warnings are printed once."""
    from .dask_runtime import TASK_RETRIES, run_frames, run_serially
    from .progress import ProgressBar
    from .rendering import load_scene

    _, warnings = load_scene(args.scene, time=float(args.frames[0]))
    _print_warnings(warnings)
    bar = ProgressBar("frames")

    def on_frame(frame, metrics, error):
        if error is not None:
            print(f"error: frame {frame}: {error}", file=sys.stderr)

    # One frame, no cluster asked for: this process (a cluster's start-up would cost more).
    if len(args.frames) == 1 and not (args.scheduler or args.workers):
        run = run_serially(task, args.frames, arguments, progress=bar, on_frame=on_frame)
    else:
        run = run_frames(task, args.frames, arguments, scheduler=args.scheduler, workers=args.workers,
                         progress=bar, on_frame=on_frame)
    bar.done(run.seconds)
    # Warnings the first frame did not have (a light that clips only later, ...), once each.
    later: dict[str, list[int]] = {}
    for frame in sorted(run.results):
        for warning in run.results[frame].get("warnings", ()):
            if warning not in warnings:
                later.setdefault(warning, []).append(frame)
    _print_warnings(f"frames {', '.join(map(str, frames))}: {warning}" for warning, frames in later.items())
    where = f"on {run.workers} Dask worker{'' if run.workers == 1 else 's'} ({run.cluster})" if run.cluster else "in this process"
    print(f"{args.scene}: {len(run.results)} of {len(args.frames)} {label} {where} in {run.seconds:.2f} s")
    if run.failures:
        print(f"error: frames failed (each tried {1 + TASK_RETRIES} times): "
              f"{', '.join(map(str, sorted(run.failures)))}", file=sys.stderr)
    return run


def _cluster_without_frames(args) -> bool:
    """--scheduler/--workers without --frames: said (one error line), since nothing would use them."""
    if (args.scheduler or args.workers) and not args.frames:
        print("error: --scheduler and --workers run frames: give --frames START:END", file=sys.stderr)
        return True
    return False


def _output_at_time(args, output: str) -> str | None:
    """A single frame's output name: #### replaced by --time when it is a whole number. None
    (after an error message) when the name has #### and there is no frame number for it."""
    from .animation import frame_name, has_frame_pattern

    if not has_frame_pattern(output):
        return output
    if args.time is None or args.time != int(args.time):
        print(f"error: {output}: #### in the name needs --frames, or a whole --time", file=sys.stderr)
        return None
    return frame_name(output, int(args.time))


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
    from .rendering import load_scene, settings_with, with_shadow_adaptive, with_shadow_cells

    scene, warnings = load_scene(args.scene, time=getattr(args, "time", None))
    _print_warnings(warnings)
    scene = with_shadow_adaptive(scene, args.shadow_adaptive)
    scene = with_shadow_cells(scene, getattr(args, "shadow_cells", None))
    settings = settings_with(scene, args.mapping, width=args.width, height=args.height, samples=args.spp,
                             threads=getattr(args, "threads", None), sample_pattern=args.sample_pattern,
                             aa_threshold=args.aa_threshold)
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
    _add_timeout_option(p, "stop POV-Ray after SECONDS per process (exit 3)")
    _add_threshold_options(p)
    _add_time_options(p, "a report per frame in OUTDIR/frame.####, and OUTDIR/index.html with a row per frame; "
                      "exit 1 if any frame fails")
    _add_sandbox_option(p)
    p.set_defaults(func=_run_diff)


def _run_diff(args) -> int:
    from .crossvalidation import diff

    from .files import check_output_folder

    try:
        thresholds = _thresholds(args)
    except ValueError as e:
        print(f"error: {e}", file=sys.stderr)
        return EXIT_SCENE
    if _cluster_without_frames(args):
        return EXIT_SCENE
    if args.frames:
        return _diff_frames(args, thresholds)
    check_output_folder(args.outdir)  # before the renders; OUTDIR may be new, its parent must exist
    result = diff(
        args.scene, args.outdir, mapping=args.mapping, width=args.width, height=args.height, samples=args.spp,
        threads=args.threads, thresholds=thresholds, progress=sys.stderr, timeout=args.timeout, time=args.time,
        sample_pattern=args.sample_pattern, aa_threshold=args.aa_threshold, shadow_adaptive=args.shadow_adaptive,
        sandbox=args.sandbox,
    )
    s = result.settings
    print(f"{args.scene}: {s.width} x {s.height}, mapping {result.mapping} (native {s.specular})")
    print(f"  povray {result.timings['povray']:.3f} s, native {result.timings['native']:.3f} s")
    print(result.report.summary())
    if result.explanation():
        print(result.explanation())
    print(f"report: {result.outdir / 'index.html'}")
    return EXIT_OK if result.ok else EXIT_DIFFERENT


def _diff_frames(args, thresholds) -> int:
    from .animation import FRAME_FOLDER, diff_frame, frame_name
    from .backends.povray import check_mapping
    from .report import write_frames_report

    check_mapping(args.mapping)
    options = _frame_options(args)
    outdir = os.path.abspath(args.outdir)
    folder = lambda f: os.path.join(outdir, frame_name(FRAME_FOLDER, f))  # noqa: E731
    run = _run_frames(args, diff_frame, lambda f: (os.path.abspath(args.scene), f, folder(f), options, thresholds),
                      "frames diffed")
    for frame in sorted(run.results):
        m = run.results[frame]
        print(f"  frame {frame}: {'PASS' if m['ok'] else 'FAIL'}, max error {m['max_error']:.6g}, "
              f"{m['failing_pixels']} failing pixels ({m['failing_percent']:.4g}%)")
    index = write_frames_report(outdir, os.path.abspath(args.scene), run,
                                {"mapping": args.mapping, "workers": run.workers, "seconds": run.seconds})
    print(f"report: {index}")
    if run.failures:
        return EXIT_BACKEND
    return EXIT_OK if all(m["ok"] for m in run.results.values()) else EXIT_DIFFERENT


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

        from .files import atomic_folder

        with atomic_folder(args.outdir) as tmp:  # the whole report, or none of it
            index = write_report(
                tmp, a, b, report, labels=(Path(args.a).stem, Path(args.b).stem),
                title=f"phongscene compare: {Path(args.a).name} vs {Path(args.b).name}",
                meta={"a": os.path.abspath(args.a), "b": os.path.abspath(args.b)},
            )
        print(f"report: {Path(args.outdir) / index.name}")
    return EXIT_OK if report.ok else EXIT_DIFFERENT


# ----------------------------------------------------------------------------------------------
# info, validate, import (USD)


def _add_info_command(sub) -> None:
    p = sub.add_parser(
        "info",
        help="show what phongscene reads from a USD scene",
        description="Read SCENE and print which prims became which model nodes, the counts of meshes, "
        "triangles, spheres, lights and materials, the textures each material samples, the camera, the render settings and every warning "
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
    textured = [m for m in materials if m.textures]
    if textured:
        print("textures:")
        for m in sorted(textured, key=lambda m: m.source):
            for role, t in (("diffuseColor", m.diffuse_texture), ("specularColor", m.specular_texture)):
                if t is not None:
                    # The file, not t.source: equal textures are shared, and source is the first prim read.
                    print(f"  {m.source or '(material)'} {role} <- {t.file or '(no file)'}, "
                          f"{t.width}x{t.height}, wrap {t.wrap_s}/{t.wrap_t}")
    print(f"ambient: {_vector(scene.ambient.color)}")
    cam = scene.camera
    extent = f"hfov {cam.horizontal_fov_deg:.6g} deg" if cam.projection == "perspective" else f"width {cam.ortho_width:.6g}"
    print(
        f"camera: {cam.source or '(model default)'}: {cam.projection}, {extent}, position {_vector(cam.position)}, "
        f"forward {_vector(cam.forward)}, up {_vector(cam.up)}"
    )
    s = scene.settings
    print(
        f"settings: {s.source or '(defaults)'}: {s.width}x{s.height}, samples {s.samples} ({s.sample_pattern}"
        f"{f', threshold {s.aa_threshold:g}' if s.aa_threshold else ''}), "
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
    _add_sandbox_option(p)
    p.set_defaults(func=_run_validate)


def _add_sandbox_option(p: argparse.ArgumentParser) -> None:
    p.add_argument("--no-sandbox", dest="sandbox", action="store_false",
                   help="read SCENE in this process (default: in a child process with a memory limit, so that a "
                   "corrupt file that crashes USD is an error, not a crash; ~0.5 s more)")


def _run_validate(args) -> int:
    if args.sandbox:
        from .sandbox import read_usd_sandboxed as read_usd
    else:
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
# bench


def _add_bench_command(sub) -> None:
    p = sub.add_parser(
        "bench",
        help="speed against error: every estimator of both backends, wall and CPU time",
        description="Render SCENE with every anti-aliasing estimator (grid, POV-Ray's +AM1/+AM2 with thresholds, "
        "the native stratified and adaptive ones) and, if it has area lights, every shadow estimator (grids, "
        "POV-Ray's 'adaptive n', the native cells) on both backends; "
        "time each (wall and CPU, best of --repeat) and measure its RMS and max error against a reference "
        "whose own error is measured too. Prints the table and writes OUTDIR/bench.csv, bench.json and "
        "bench.png (log-log, with each backend's Pareto front).",
        epilog="Exit codes: 0 ok, 2 bad scene or usage, 3 backend failure.",
    )
    _add_scene_argument(p)
    p.add_argument("-o", "--outdir", required=True, metavar="OUTDIR", help="folder for bench.csv/.json/.png (created)")
    _add_mapping_option(p, "POV-Ray mapping (default: the scene's specular convention)")
    p.add_argument("--width", type=_image_side, metavar="W",
                   help=f"image width (default {BENCH_WIDTH}; the height keeps the aspect ratio)")
    p.add_argument("--threads", type=_thread_count, metavar="N", help="threads of both renderers (0 = all cores)")
    p.add_argument("--repeat", type=_int_in(1, 100), default=3, metavar="N", help="runs per setting; the best counts")
    p.add_argument("--quick", action="store_true", help="a few estimators of each kind")
    p.add_argument("--native-only", action="store_true", help="measure the native tracer only")
    p.add_argument("--family", choices=("anti-aliasing", "area-light shadows"), action="append",
                   help="study only this family of estimators (repeatable; default: every one that applies; "
                   "the anti-aliasing reference of a scene with area lights is slow)")
    p.add_argument("--target-rms", type=_float_in(0.0, math.inf), metavar="E",
                   help="say which setting of each backend reaches RMS error E fastest")
    group = p.add_argument_group("where the settings run (each one a Dask task; a task never shares its cores "
                                 "with another)")
    _add_cluster_options(group, "", "as many as the cores hold renders of --threads, one with all threads")
    p.set_defaults(func=_run_bench)


def _run_bench(args) -> int:
    from pathlib import Path

    from . import bench, bench_tasks
    from .rendering import check_settings, load_scene, settings_with

    scene, warnings = load_scene(args.scene)
    _print_warnings(warnings)
    settings = check_settings(scene, settings_with(scene, args.mapping, width=args.width or BENCH_WIDTH,
                                                   threads=args.threads))
    backends = ("native",) if args.native_only else bench.BACKEND_NAMES
    print(f"{args.scene}: {settings.width} x {settings.height}, specular {settings.specular}, "
          f"threads {settings.threads or 'all'}, best of {args.repeat}", flush=True)
    result = bench_tasks.run(os.path.abspath(args.scene), scene, settings, repeat=args.repeat, quick=args.quick,
                             backends=backends, families=args.family, scheduler=args.scheduler, workers=args.workers,
                             log=lambda line: print(line, flush=True))
    print()
    print(bench.table(result), end="")
    if args.target_rms is not None:
        print("\n".join(bench.target(result, args.target_rms)))
    paths = bench.write_all(result, Path(args.outdir), "bench", title=f"{Path(args.scene).name}: speed against error")
    print("wrote " + ", ".join(str(p) for p in paths))
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
    p.add_argument("--backend", choices=BACKEND_CHOICES, default="native", help="renderer (default: native)")
    _add_mapping_option(p, "specular convention: exact (the seed model) or classic (plain POV-Ray phong, native "
                        "'povray-classic'); default: the scene's")
    _add_size_options(p)
    p.add_argument("--shadow-cells", type=_power_of_two_in(2, MAX_CELL_SAMPLES), metavar="K",
                   help="native only: the cells shadow estimator on every area light, K x K points in each grid "
                   "cell whose corners disagree (K a power of 2; phong:shadowCellSamples)")
    p.add_argument("--threads", type=_thread_count, metavar="N", help="worker threads (0 = all cores)")
    _add_timeout_option(p, "--backend povray only: stop POV-Ray after SECONDS (exit 3)")
    _add_time_options(p, "one image per frame, #### in IMAGE becomes the frame number")
    p.set_defaults(func=_run_render)


def _run_render(args) -> int:
    import time

    from .files import check_output
    from .images import WRITABLE, write_image
    from .memory import release_free_heap
    from .progress import ProgressBar
    from .rendering import prepare_render

    if not args.output.lower().endswith(WRITABLE):
        print(f"error: {args.output}: the output must end in one of {', '.join(WRITABLE)}", file=sys.stderr)
        return EXIT_SCENE
    if args.timeout is not None and args.backend != "povray":
        print("error: --timeout applies to --backend povray only (the native tracer stops on Ctrl-C)", file=sys.stderr)
        return EXIT_SCENE
    if _cluster_without_frames(args):
        return EXIT_SCENE
    if args.frames:
        _preimport(("OpenImageIO",))
        return _render_frames(args)
    output = _output_at_time(args, args.output)
    if output is None:
        return EXIT_SCENE
    args.output = output
    check_output(args.output)  # before the render, not after it
    bar = ProgressBar(args.backend)
    start = time.perf_counter()
    bar.phase(f"reading {Path(args.scene).name}")  # a big USD file takes seconds
    scene, settings = _scene_and_settings(args)
    # Peak memory (benchmarks/memory_stages.py): what the reader freed, then the model once the
    # C++ scene holds its own copy, then the C++ scene before OpenImageIO's import and the write,
    # each handed back to the system as soon as it is garbage.
    release_free_heap()
    render = prepare_render(scene, args.backend, settings, progress=bar, timeout=args.timeout)
    del scene
    release_free_heap()
    image = render()
    del render
    release_free_heap()
    bar.done(time.perf_counter() - start)
    _preimport(("OpenImageIO",))
    write_image(args.output, image)
    print(f"{args.output}: {settings.width} x {settings.height}, {args.backend}, specular {settings.specular}")
    return EXIT_OK


def _has_frame_pattern(output: str, example: str) -> bool:
    """Whether an output name for --frames has #### for the frame number (else said, one line)."""
    from .animation import has_frame_pattern

    if has_frame_pattern(output):
        return True
    print(f"error: {output}: with --frames the name needs #### for the frame number (e.g. {example})", file=sys.stderr)
    return False


def _render_frames(args) -> int:
    from .animation import frame_name, render_frame

    if not _has_frame_pattern(args.output, "out.####.exr"):
        return EXIT_SCENE
    options = _frame_options(args)
    scene = os.path.abspath(args.scene)
    run = _run_frames(args, render_frame,
                      lambda f: (scene, f, os.path.abspath(frame_name(args.output, f)), args.backend, options),
                      "frames rendered")
    if run.results:
        m = next(iter(run.results.values()))
        print(f"{args.output}: {m['width']} x {m['height']}, {args.backend}, specular {m['specular']}")
    return EXIT_BACKEND if run.failures else EXIT_OK


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
    _add_time_options(p, "a .pov and an .ini per frame, #### in OUT.pov becomes the frame number")
    p.set_defaults(func=_run_compile)


def _run_compile(args) -> int:
    import shlex

    from .backends.povray import MAPPING_OF_SPECULAR, pov_quoted, prepare
    from .files import atomic_files, check_output
    from .rendering import check_settings

    out = Path(args.output)
    if out.suffix.lower() != ".pov":
        print(f"error: {out}: the output must end in .pov", file=sys.stderr)
        return EXIT_SCENE
    if _cluster_without_frames(args):
        return EXIT_SCENE
    if args.frames:
        return _compile_frames(args)
    output = _output_at_time(args, args.output)
    if output is None:
        return EXIT_SCENE
    out = Path(output)
    ini, image = out.with_suffix(".ini"), out.with_suffix(".exr")
    if '"' in out.name:
        print(f"error: {out}: POV-Ray cannot read a file name with a double quote", file=sys.stderr)
        return EXIT_SCENE
    check_output(out)
    scene, settings = _scene_and_settings(args)
    job = prepare(scene, check_settings(scene, settings), args.mapping)
    with atomic_files(out, ini) as (tmp_pov, tmp_ini):  # both appear, or neither
        tmp_pov.write_text(job.sdl, encoding="ascii")
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
    from .animation import compile_frame, frame_name

    if not _has_frame_pattern(args.output, "out.####.pov"):
        return EXIT_SCENE
    options = _frame_options(args)
    scene = os.path.abspath(args.scene)
    run = _run_frames(args, compile_frame, lambda f: (scene, f, os.path.abspath(frame_name(args.output, f)), options),
                      "frames compiled")
    for frame in sorted(run.results):
        print(f"  {run.results[frame]['output']}")
    return EXIT_BACKEND if run.failures else EXIT_OK
