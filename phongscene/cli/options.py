# SPDX-License-Identifier: Apache-2.0
"""What more than one command shares: the argparse types, the options (the render overrides,
time and frames, the Dask cluster, the comparison thresholds, the sandbox), the one usage error
(``UsageError``) and the helpers that turn the parsed options into what the API takes
(``overrides_from_args``, ``thresholds``, ``scene_and_settings``).

Every ``RenderOverrides`` field has its option here, with ``dest`` the field's name, so that
``overrides_from_args`` builds the overrides of any command by name (phongscene/overrides.py)."""

from __future__ import annotations

import argparse
import sys
from dataclasses import fields

from ..limits import (
    MAX_CELL_SAMPLES,
    MAX_IMAGE_SIDE,
    MAX_SAMPLES,
    MAX_STRATIFIED_SAMPLES,
    MAX_SUBDIVISION_LEVEL,
    MAX_THREADS,
)
from ..overrides import RenderOverrides

SCENE_HELP = "USD file (.usda, .usdc, .usd, .usdz)"
# The POV-Ray backend's mappings (phongscene.backends.povray.MAPPINGS, which a test checks this
# against), named here so that building the parser imports no backend.
MAPPING_CHOICES = ("exact", "classic")
# The backends (phongscene.rendering.BACKENDS, checked by a test), named here so that importing
# the CLI imports no numpy: Ctrl-C before main() has no handler yet.
BACKEND_CHOICES = ("native", "povray")
SPP_HELP = (
    f"anti-aliasing: N x N samples per pixel, N in 1..{MAX_SAMPLES} "
    f"(stratified: at most N x N, N up to {MAX_STRATIFIED_SAMPLES}; adaptive: cells down to 1/N pixel, "
    f"N a power of 2 up to {MAX_STRATIFIED_SAMPLES})"
)
# The estimators only the native tracer has (validate.py refuses them for POV-Ray, naming the
# scene's attribute; from the command line the option is named instead).
NATIVE_ONLY_PATTERNS = ("stratified", "adaptive")


class UsageError(Exception):
    """A command line that cannot run (options that do not go together, an output name the
    command cannot write): ``phongscene.cli.main`` prints it as argparse prints a bad option,
    ``phongscene COMMAND: error: MESSAGE``, and exits 2, before any scene is read or written."""


# ----------------------------------------------------------------------------------------------
# argparse types


def float_in(low: float, high: float):
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


def int_in(low: int, high: int | None = None):
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


def _power_of_two_in(low: int, high: int):
    """An argparse type: a power of 2 in [low, high]."""
    whole = int_in(low, high)

    def parse(text: str) -> int:
        value = whole(text)
        if value & (value - 1):
            raise argparse.ArgumentTypeError(f"expected a power of 2, got {value}")
        return value

    return parse


image_side = int_in(1, MAX_IMAGE_SIDE)
thread_count = int_in(0, MAX_THREADS)  # 0 = all cores
# The model's anti-aliasing range (RenderSettings.samples; above MAX_SAMPLES: stratified and adaptive only).
_samples_per_axis = int_in(1, MAX_STRATIFIED_SAMPLES)


def _seconds(text: str) -> float:
    """An argparse type: a number of seconds > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of seconds, got {text!r}") from None
    if not value > 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"expected a number of seconds > 0, got {text}")
    return value


def _time_code(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number (a USD time code), got {text!r}") from None
    if value != value or value in (float("inf"), float("-inf")):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


def _frame_range(text: str) -> tuple[int, ...]:
    from ..animation import parse_frames

    try:
        return parse_frames(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


# ----------------------------------------------------------------------------------------------
# Options


def add_scene_argument(p: argparse.ArgumentParser) -> None:
    p.add_argument("scene", metavar="SCENE", help=SCENE_HELP)


def add_mapping_option(p: argparse.ArgumentParser, help: str, default: str | None = None) -> None:
    p.add_argument("--mapping", choices=MAPPING_CHOICES, default=default, help=help)


def add_threads_option(p: argparse.ArgumentParser, help: str) -> None:
    p.add_argument("--threads", type=thread_count, metavar="N", help=help)


def add_override_options(
    p: argparse.ArgumentParser,
    *,
    mapping_help: str,
    mapping_default: str | None = None,
    spp_help: str = SPP_HELP,
    shadow_cells: bool = False,
    threads_help: str | None = None,
) -> None:
    """The render overrides (``RenderOverrides``) but --time, which ``add_time_options`` adds:
    --mapping, the size, the anti-aliasing and the area-light estimators; --shadow-cells (native
    only) and --threads for the commands that render natively."""
    from ..limits import MAX_ADAPTIVE, MAX_DEPTH
    from ..scene import SAMPLE_PATTERNS

    add_mapping_option(p, mapping_help, mapping_default)
    p.add_argument(
        "--camera",
        metavar="PATH",
        help="the Camera prim to render through, e.g. /World/Cam (default: the "
        "RenderSettings' camera, else the stage's first; `phongscene info` lists them)",
    )
    p.add_argument(
        "--subdivision-level",
        type=int_in(0, MAX_SUBDIVISION_LEVEL),
        metavar="N",
        help="refine every subdivision surface N times (0: its control cage; default: each Mesh's "
        "phong:subdivisionLevel, else 2)",
    )
    p.add_argument("--width", type=image_side, metavar="W", help="image width (alone: keeps the aspect ratio)")
    p.add_argument("--height", type=image_side, metavar="H", help="image height (alone: keeps the aspect ratio)")
    p.add_argument("--spp", dest="samples", type=_samples_per_axis, metavar="N", help=spp_help)
    p.add_argument(
        "--sample-pattern",
        choices=SAMPLE_PATTERNS,
        help="anti-aliasing pattern (RenderSettings.sample_pattern; default: the scene's)",
    )
    p.add_argument(
        "--aa-threshold",
        type=float_in(0.0, 1.0),
        metavar="T",
        help="POV-Ray's +A threshold of povray-am1/am2: supersample where colours differ by >= T "
        "(0: everywhere); stratified: its stopping tolerance; adaptive: split a cell of side s while "
        "its corners' spread x s^1.5 >= T",
    )
    p.add_argument(
        "--max-depth",
        type=int_in(0, MAX_DEPTH),
        metavar="D",
        help="the deepest reflected or refracted ray (RenderSettings.max_depth, phong:maxDepth; the camera "
        "ray has depth 0, deeper rays return black; POV-Ray: max_trace_level D + 1; default: the scene's)",
    )
    p.add_argument(
        "--shadow-adaptive",
        type=int_in(0, MAX_ADAPTIVE),
        metavar="N",
        help="POV-Ray's 'adaptive N' on every area light (default: each light's own)",
    )
    if shadow_cells:
        p.add_argument(
            "--shadow-cells",
            type=_power_of_two_in(2, MAX_CELL_SAMPLES),
            metavar="K",
            help="native only: the cells shadow estimator on every area light, K x K points in each grid "
            "cell whose corners disagree (K a power of 2; phong:shadowCellSamples)",
        )
    if threads_help is not None:
        add_threads_option(p, threads_help)


def add_timeout_option(p: argparse.ArgumentParser, help: str) -> None:
    p.add_argument("--timeout", type=_seconds, metavar="SECONDS", help=help)


def add_single_time_option(p: argparse.ArgumentParser) -> None:
    """--time alone (a command with no --frames: preview)."""
    p.add_argument("--time", type=_time_code, metavar="T", help="read the stage at USD time code T")


def add_time_options(
    p: argparse.ArgumentParser, output: str, *, skip_existing: bool = False, contact_sheet: bool = False
) -> None:
    group = p.add_argument_group("time (an animated stage; default: its start time, with a warning)")
    when = group.add_mutually_exclusive_group()
    when.add_argument("--time", type=_time_code, metavar="T", help="read the stage at USD time code T")
    when.add_argument(
        "--frames",
        type=_frame_range,
        metavar="FRAMES",
        help=f"whole time codes, usdrecord's way: N, START:END, START:ENDxSTRIDE (1:9x4 is 1, 5, 9) or "
        f"START:END:STEP, several separated by commas: {output}. Frames run as Dask tasks: a "
        "LocalCluster here, or --scheduler",
    )
    add_cluster_options(group, "with --frames: ", "one per core")
    if skip_existing:
        group.add_argument(
            "--skip-existing",
            action="store_true",
            help="with --frames: do not redo a frame whose output exists (outputs are written "
            "atomically, so one that exists is whole): resume an interrupted run",
        )
    if contact_sheet:
        group.add_argument(
            "--contact-sheet",
            metavar="SHEET",
            help="with --frames: also write a grid of the frames, each labelled, as one image (.png or .exr)",
        )


def add_cluster_options(group, which: str, default_workers: str) -> None:
    """--scheduler and --workers: where Dask runs the tasks (frames, bench settings)."""
    group.add_argument(
        "--scheduler",
        metavar="tcp://HOST:PORT",
        help=f"{which}an existing Dask scheduler (default: $DASK_SCHEDULER_ADDRESS, else a "
        "LocalCluster); workers must see the scene and the output at the same paths",
    )
    group.add_argument(
        "--workers",
        type=int_in(1),
        metavar="N",
        help=f"{which}LocalCluster worker processes (default: {default_workers})",
    )


def add_threshold_options(p: argparse.ArgumentParser, by_format: bool = False) -> None:
    from ..comparison import HALF_FLOAT as t  # OpenImageIO: only when a parser is built

    title = (
        "thresholds (idiff vocabulary; default: by the files' formats: half-float precision for float "
        "images, one code step for 8-bit ones)"
        if by_format
        else "thresholds (idiff vocabulary; default: half-float precision)"
    )
    group = p.add_argument_group(title)
    # Defaults are None: a given option overrides one field of the default thresholds.
    group.add_argument(
        "--fail",
        type=float,
        metavar="ABS",
        help=f"absolute error always accepted (half-float default {t.fail:.3g}, one subnormal half step)",
    )
    group.add_argument(
        "--fail-relative",
        type=float,
        metavar="REL",
        help=f"error accepted relative to mean(|a|,|b|) (half-float default {t.fail_relative:.3g} = 2 x 2^-11)",
    )
    group.add_argument(
        "--fail-percent", type=float, metavar="PCT", help=f"%% of pixels allowed to fail (default {t.fail_percent:g})"
    )
    group.add_argument("--hard-fail", type=float, metavar="ABS", help="any error above this fails (default: none)")


def add_sandbox_option(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--no-sandbox",
        dest="sandbox",
        action="store_const",
        const=False,
        default=None,
        help="read SCENE in this process (default: a binary file, or one naming other files, is read in "
        "a child process with a memory limit, so that a corrupt file that crashes USD is an error, not a "
        "crash; ~0.5 s more; a self-contained .usda is read in process)",
    )


# ----------------------------------------------------------------------------------------------
# From the parsed options to the API's arguments


def check_estimator_options(args) -> None:
    """UsageError if the command line's estimator options do not go together (each alone is
    checked by its argparse type)."""
    pattern, spp = getattr(args, "sample_pattern", None), getattr(args, "samples", None)
    if pattern == "adaptive" and spp is not None and spp & (spp - 1):
        raise UsageError(f"argument --spp: expected a power of 2 with --sample-pattern adaptive, got {spp}")
    povray = args.command in ("diff", "compile") or getattr(args, "backend", None) == "povray"
    if povray and pattern in NATIVE_ONLY_PATTERNS:
        raise UsageError(
            f"argument --sample-pattern: {pattern!r} is the native tracer's own; POV-Ray renders grid, "
            "povray-am1, povray-am2"
        )


def overrides_from_args(args) -> RenderOverrides:
    """The ``RenderOverrides`` of the command's options: each field from the option of its name
    (None where the command has no such option)."""
    return RenderOverrides(**{f.name: getattr(args, f.name, None) for f in fields(RenderOverrides)})


def thresholds(args, base=None):
    """``base`` (default: half-float precision) with the threshold options given on the command
    line; a UsageError for a value the thresholds refuse."""
    from dataclasses import replace

    from ..comparison import HALF_FLOAT

    given = {name: getattr(args, name) for name in ("fail", "fail_relative", "fail_percent", "hard_fail")}
    try:
        return replace(HALF_FLOAT if base is None else base, **{k: v for k, v in given.items() if v is not None})
    except ValueError as e:
        raise UsageError(str(e)) from None


def print_warnings(warnings, stream=None, *, every: bool = False, leave: int = 0) -> int:
    """Each warning as a ``warning:`` line; the same message about many prims as one line, and
    at most warning_groups.MAX_WARNING_LINES lines, less ``leave`` for warnings the command
    prints before or after (at least the one line that counts what is left out), unless
    ``every`` (`info` lists them all, and keeps apart the messages that name different prims).
    Returns the lines printed."""
    from ..warning_groups import MAX_WARNING_LINES, capped, grouped

    lines = grouped(warnings, merge_named_paths=not every)
    shown = lines if every else capped(lines, max(1, MAX_WARNING_LINES - leave))
    for line in shown:
        print(f"warning: {line}", file=sys.stderr if stream is None else stream)
    return len(shown)


def scene_and_settings(args, with_warnings: bool = False):
    """The scene of ``args.scene`` (its warnings printed) and its settings with the command's
    overrides (and, ``with_warnings``, the reader's warnings: the image checks read them)."""
    from ..rendering import load_scene
    from ..warning_groups import IMAGE_CHECK_LINES

    overrides = overrides_from_args(args)
    scene, warnings = load_scene(
        args.scene,
        time=overrides.time,
        sandbox=getattr(args, "sandbox", None),
        camera=overrides.camera,
        subdivision_level=overrides.subdivision_level,
    )
    print_warnings(warnings, leave=IMAGE_CHECK_LINES)  # render and compile print the image check's after
    scene, settings = overrides.apply(scene)
    return (scene, settings, warnings) if with_warnings else (scene, settings)
