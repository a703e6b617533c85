# SPDX-License-Identifier: Apache-2.0
"""``phongscene bench``: speed against error of every estimator of both backends."""

from __future__ import annotations

import math
import os

from .options import (
    add_cluster_options,
    add_mapping_option,
    add_scene_argument,
    add_threads_option,
    float_in,
    image_side,
    int_in,
    overrides_from_args,
    print_warnings,
)
from .process import EXIT_OK

# `bench` renders its references at 27² samples per pixel: a small default image keeps that
# to seconds.
BENCH_WIDTH = 320


def add_bench_command(sub) -> None:
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
    add_scene_argument(p)
    p.add_argument("-o", "--outdir", required=True, metavar="OUTDIR", help="folder for bench.csv/.json/.png (created)")
    add_mapping_option(p, "POV-Ray mapping (default: the scene's specular convention)")
    p.add_argument(
        "--width",
        type=image_side,
        metavar="W",
        help=f"image width (default {BENCH_WIDTH}; the height keeps the aspect ratio)",
    )
    add_threads_option(p, "threads of both renderers (0 = all cores)")
    p.add_argument("--repeat", type=int_in(1, 100), default=3, metavar="N", help="runs per setting; the best counts")
    p.add_argument("--quick", action="store_true", help="a few estimators of each kind")
    p.add_argument("--native-only", action="store_true", help="measure the native tracer only")
    p.add_argument(
        "--family",
        choices=("anti-aliasing", "area-light shadows"),
        action="append",
        help="study only this family of estimators (repeatable; default: every one that applies; "
        "the anti-aliasing reference of a scene with area lights is slow)",
    )
    p.add_argument(
        "--target-rms",
        type=float_in(0.0, math.inf),
        metavar="E",
        help="say which setting of each backend reaches RMS error E fastest",
    )
    group = p.add_argument_group(
        "where the settings run (each one a Dask task; a task never shares its cores with another)"
    )
    add_cluster_options(group, "", "as many as the cores hold renders of --threads, one with all threads")
    p.set_defaults(func=run_bench)


def run_bench(args) -> int:
    from dataclasses import replace
    from pathlib import Path

    from .. import bench, bench_tasks
    from ..rendering import check_settings, load_scene

    scene, warnings = load_scene(args.scene)
    print_warnings(warnings)
    overrides = replace(overrides_from_args(args), width=args.width or BENCH_WIDTH)
    settings = check_settings(scene, overrides.settings(scene))
    backends = ("native",) if args.native_only else bench.BACKEND_NAMES
    print(
        f"{args.scene}: {settings.width} x {settings.height}, specular {settings.specular}, "
        f"threads {settings.threads or 'all'}, best of {args.repeat}",
        flush=True,
    )
    result = bench_tasks.run(
        os.path.abspath(args.scene),
        scene,
        settings,
        repeat=args.repeat,
        quick=args.quick,
        backends=backends,
        families=args.family,
        scheduler=args.scheduler,
        workers=args.workers,
        log=lambda line: print(line, flush=True),
    )
    print()
    print(bench.table(result), end="")
    if args.target_rms is not None:
        print("\n".join(bench.target(result, args.target_rms)))
    paths = bench.write_all(result, Path(args.outdir), "bench", title=f"{Path(args.scene).name}: speed against error")
    print("wrote " + ", ".join(str(p) for p in paths))
    return EXIT_OK
