# SPDX-License-Identifier: Apache-2.0
"""``phongscene diff`` (both backends on one scene, compared, with a report; per frame with
--frames) and ``phongscene compare`` (two image files)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

from ..errors import PhongSceneError
from .frames import check_cluster_needs_frames, frame_overrides, run_frames
from .options import (
    SPP_HELP,
    add_override_options,
    add_sandbox_option,
    add_scene_argument,
    add_threshold_options,
    add_time_options,
    add_timeout_option,
    overrides_from_args,
    print_warnings,
    thresholds,
)
from .process import EXIT_BACKEND, EXIT_DIFFERENT, EXIT_OK, EXIT_SCENE


def add_diff_command(sub) -> None:
    p = sub.add_parser(
        "diff",
        help="render a scene with POV-Ray and the native tracer and compare",
        description="Render SCENE with both backends under matching conventions (exact: native 'seed'; "
        "classic: native 'povray-classic'), compare at half-float precision and write a report "
        "(images as EXR and PNG, heat map, metrics.json, index.html) into OUTDIR.",
        epilog="Exit codes: 0 the images agree, 1 they differ, 2 bad scene or usage, 3 backend failure.",
    )
    add_scene_argument(p)
    p.add_argument("-o", "--outdir", required=True, metavar="OUTDIR", help="report folder (created)")
    add_override_options(
        p,
        mapping_help="POV-Ray mapping: exact (the seed model) or classic (plain POV-Ray phong); default: exact, "
        "or classic where the scene has what the exact mapping cannot render (a transmissive material with a "
        "highlight), with a warning",
        spp_help=f"{SPP_HELP} (RenderSettings.samples; default: the scene's)",
        threads_help="native worker threads (0 = all cores)",
    )
    add_timeout_option(p, "stop POV-Ray after SECONDS per process (exit 3)")
    add_threshold_options(p)
    add_time_options(
        p,
        "a report per frame in OUTDIR/frame.####, and OUTDIR/index.html with a row per frame; "
        "exit 1 if any frame fails",
    )
    add_sandbox_option(p)
    p.set_defaults(func=run_diff)


def run_diff(args) -> int:
    from ..crossvalidation import diff
    from ..files import check_output_folder

    limits = thresholds(args)
    check_cluster_needs_frames(args)
    # Before the renders (and before any frame's task): OUTDIR may be new, its parent must exist.
    check_output_folder(args.outdir)
    if args.frames:
        return _diff_frames(args, limits)
    result = diff(
        args.scene,
        args.outdir,
        overrides=overrides_from_args(args),
        thresholds=limits,
        progress=sys.stderr,
        timeout=args.timeout,
        sandbox=args.sandbox,
    )
    print_warnings(result.image_warnings)
    s = result.settings
    print(f"{args.scene}: {s.width} x {s.height}, mapping {result.mapping} (native {s.specular})")
    print(f"  povray {result.timings['povray']:.3f} s, native {result.timings['native']:.3f} s")
    print(result.report.summary())
    if result.explanation():
        print(result.explanation())
    print(f"report: {result.outdir / 'index.html'}")
    return EXIT_OK if result.ok else EXIT_DIFFERENT


def _diff_frames(args, limits) -> int:
    from ..animation import FRAME_FOLDER, diff_frame, frame_name
    from ..backends.povray import check_mapping
    from ..report import write_frames_report

    if args.mapping is not None:
        check_mapping(args.mapping)
    overrides = frame_overrides(args)
    outdir = os.path.abspath(args.outdir)
    folder = lambda f: os.path.join(outdir, frame_name(FRAME_FOLDER, f))  # noqa: E731
    run = run_frames(
        args, diff_frame, lambda f: (os.path.abspath(args.scene), f, folder(f), overrides, limits), "frames diffed"
    )
    for frame in sorted(run.results):
        m = run.results[frame]
        print(
            f"  frame {frame}: {'PASS' if m['ok'] else 'FAIL'}, max error {m['max_error']:.6g}, "
            f"{m['failing_pixels']} failing pixels ({m['failing_percent']:.4g}%)"
        )
    index = write_frames_report(
        outdir,
        os.path.abspath(args.scene),
        run,
        {"mapping": args.mapping or "exact (classic where needed)", "workers": run.workers, "seconds": run.seconds},
    )
    print(f"report: {index}")
    if run.failures:
        return EXIT_BACKEND
    return EXIT_OK if all(m["ok"] for m in run.results.values()) else EXIT_DIFFERENT


def add_compare_command(sub) -> None:
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
    p.add_argument(
        "--metric",
        choices=("pixel", "flip"),
        default="pixel",
        help="pixel: every pixel within the thresholds (default; for two phongscene renders); flip: NVIDIA's "
        "perceptual FLIP (pip install flip-evaluator), for another renderer's image, whose noise fails "
        "every pixel test. Both list the failing regions, the worst first",
    )
    add_threshold_options(p, by_format=True)
    p.set_defaults(func=run_compare)


def run_compare(args) -> int:
    from ..comparison import ImageMismatchError, compare, thresholds_for_files
    from ..images import read_image

    try:
        base, why = thresholds_for_files(args.a, args.b)
        limits = thresholds(args, base)
        a, b = read_image(args.a), read_image(args.b)
    except (PhongSceneError, ValueError) as e:
        print(f"error: {e}", file=sys.stderr)
        return EXIT_SCENE
    if args.metric == "flip":
        return _compare_flip(args, a, b, ldr=limits.space.lower() == "srgb")
    try:
        report = compare(a, b, limits)
    except ImageMismatchError as e:
        print(f"error: {e}", file=sys.stderr)
        return EXIT_DIFFERENT
    print(f"comparing {args.a} and {args.b}")
    print(f"  thresholds: {why}" + (" (with the options given)" if limits != base else ""))
    print(report.summary())
    if not report.ok:
        _print_regions(a, b, limits)
    if args.outdir:
        from ..files import atomic_folder
        from ..report import write_report

        with atomic_folder(args.outdir) as tmp:  # the whole report, or none of it
            index = write_report(
                tmp,
                a,
                b,
                report,
                labels=(Path(args.a).stem, Path(args.b).stem),
                title=f"phongscene compare: {Path(args.a).name} vs {Path(args.b).name}",
                meta={"a": os.path.abspath(args.a), "b": os.path.abspath(args.b)},
            )
        print(f"report: {Path(args.outdir) / index.name}")
    return EXIT_OK if report.ok else EXIT_DIFFERENT


def _print_regions(a, b, limits) -> None:
    """The failing regions of a pixel comparison, ranked by their total error (a region where an
    object is wrong before scattered near-black pixels whose relative error is large)."""
    import numpy as np

    from ..comparison import failing_mask, in_space
    from ..perceptual import REGION_SIZE, REGIONS_LISTED, failing_regions

    failing = failing_mask(a, b, limits)
    a_s, b_s = (np.nan_to_num(in_space(x, limits.space).astype(np.float64)) for x in (a, b))
    regions = failing_regions(np.abs(a_s - b_s).max(axis=2), failing)
    print(f"  worst regions ({REGION_SIZE} x {REGION_SIZE} tiles, by total absolute error of their failing pixels):")
    for region in regions[:REGIONS_LISTED]:
        print(f"    {region}")


def _compare_flip(args, a, b, ldr: bool) -> int:
    from ..comparison import ImageMismatchError
    from ..perceptual import FLIP_FAIL_PERCENT, flip_compare

    allowed = FLIP_FAIL_PERCENT if args.fail_percent is None else args.fail_percent  # --fail-percent applies
    try:
        report = flip_compare(a, b, ldr=ldr, fail_percent=allowed)
    except ImportError as e:
        print(f"error: {e}", file=sys.stderr)
        return EXIT_SCENE
    except ImageMismatchError as e:
        print(f"error: {e}", file=sys.stderr)
        return EXIT_DIFFERENT
    print(f"comparing {args.a} and {args.b}")
    print(report.summary())
    if args.outdir:
        from ..files import atomic_folder
        from ..images import write_image

        with atomic_folder(args.outdir) as tmp:
            import numpy as np

            write_image(tmp / "flip.exr", np.repeat(report.error_map[:, :, None], 3, axis=2).astype(np.float32))
        print(f"FLIP error map: {Path(args.outdir) / 'flip.exr'}")
    return EXIT_OK if report.ok else EXIT_DIFFERENT
