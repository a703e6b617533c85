# SPDX-License-Identifier: Apache-2.0
"""Cross-validation: render one scene with POV-Ray and with the native tracer under matching
conventions (mapping "exact" ↔ native "seed", "classic" ↔ native "povray-classic"), compare the
two images at half-float precision and, optionally, write the report folder.

POV-Ray's image is the reference ``a`` (it is the one rounded to half floats); the native
image is ``b``."""

from __future__ import annotations

import math
import os
import sys
import time
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import TextIO

import numpy as np

from .compare import HALF_FLOAT, ImageMismatchError, Report, Thresholds, compare
from .errors import BackendError
from .render import SPECULAR_OF_MAPPING, render, settings_for
from .scene import RenderSettings, Scene

LABELS = ("povray", "native")


@dataclass(frozen=True)
class DiffResult:
    """What ``diff`` produced."""

    report: Report
    outdir: Path | None  # the report folder, if one was written
    timings: dict[str, float]  # wall-clock seconds per backend ("povray", "native")
    povray: np.ndarray  # the reference image
    native: np.ndarray
    settings: RenderSettings  # what both backends rendered with
    mapping: str
    warnings: list[str]  # the USD reader's warnings (things the model cannot represent)

    @property
    def ok(self) -> bool:
        return self.report.ok


class ProgressBar:
    """A one-line text progress bar on a stream (stderr). Accepts ``bar(fraction)`` or
    ``bar(done, total)``, whichever a backend reports; redraws only on a terminal, so logs
    get one line per render instead of a stream of carriage returns."""

    WIDTH = 30

    def __init__(self, label: str, stream: TextIO | None = None):
        self.label = label
        self.stream = sys.stderr if stream is None else stream
        self.interactive = bool(getattr(self.stream, "isatty", lambda: False)())
        self._shown = -1

    def __call__(self, *args) -> None:
        if len(args) >= 2:
            done, total = args[0], args[1]
            fraction = done / total if total else 1.0
        elif args:
            fraction = float(args[0])
        else:
            return
        if not self.interactive:
            return
        percent = int(100 * min(max(fraction, 0.0), 1.0))
        if percent != self._shown:
            self._shown = percent
            filled = self.WIDTH * percent // 100
            self.stream.write(f"\r{self.label:<7} [{'#' * filled}{'.' * (self.WIDTH - filled)}] {percent:3d}%")
            self.stream.flush()

    def done(self, seconds: float) -> None:
        end = f"\r{self.label:<7} [{'#' * self.WIDTH}] done in {seconds:.2f} s" if self.interactive else (
            f"{self.label}: rendered in {seconds:.2f} s"
        )
        self.stream.write(end + "\n")
        self.stream.flush()


def load_scene(scene_or_path: Scene | str | os.PathLike) -> tuple[Scene, list[str]]:
    """A Scene as given, or read from a USD file, with the reader's warnings (raises
    SceneError for a bad file)."""
    if isinstance(scene_or_path, Scene):
        return scene_or_path, []
    from .usd import read_usd  # lazily: the USD reader imports pxr

    result = read_usd(os.fspath(scene_or_path))
    return result.scene, list(result.warnings)


def diff_settings(
    scene: Scene,
    mapping: str = "exact",
    *,
    width: int | None = None,
    height: int | None = None,
    samples: int | None = None,
    threads: int | None = None,
) -> RenderSettings:
    """The scene's settings with the overrides applied and the specular convention that the
    POV-Ray ``mapping`` reproduces. Giving only one of width/height keeps the aspect ratio."""
    s = settings_for(scene, mapping=mapping)
    if width is not None and height is None:
        height = max(1, round(width * s.height / s.width))
    elif height is not None and width is None:
        width = max(1, round(height * s.width / s.height))
    changes = {"width": width, "height": height, "samples": samples, "threads": threads}
    return replace(s, **{k: v for k, v in changes.items() if v is not None})


def diff(
    scene_or_path: Scene | str | os.PathLike,
    outdir: str | os.PathLike | None = None,
    *,
    mapping: str = "exact",
    width: int | None = None,
    height: int | None = None,
    samples: int | None = None,
    threads: int | None = None,
    thresholds: Thresholds = HALF_FLOAT,
    progress: TextIO | None = None,
    timeout: float | None = None,
) -> DiffResult:
    """Render a scene with both backends, compare, and write the report if ``outdir`` is given.

    Args:
        scene_or_path: a Scene, or the path of a USD file.
        outdir: report folder (images, heat map, metrics.json, index.html); None writes nothing.
        mapping: "exact" (POV-Ray exact mapping vs native "seed") or "classic" (the idiomatic
            POV-Ray finish vs native "povray-classic").
        width, height: image size override (one alone keeps the aspect ratio).
        samples: anti-aliasing samples per axis override (``RenderSettings.samples``).
        threads: native worker threads override (0 = all cores).
        thresholds: when the images agree (default: half-float precision at every pixel).
        progress: stream for progress bars (e.g. ``sys.stderr``); None shows none.
        timeout: seconds before POV-Ray is abandoned.

    Returns:
        A ``DiffResult``: the report, the folder, both timings and both images.

    Raises:
        SceneError: the scene file is invalid.
        BackendError: a backend failed, or the two images came back in different sizes.
    """
    if mapping not in SPECULAR_OF_MAPPING:
        raise ValueError(f"unknown mapping {mapping!r}; expected one of {', '.join(SPECULAR_OF_MAPPING)}")
    scene, warnings = load_scene(scene_or_path)
    if progress is not None:
        for w in warnings:
            progress.write(f"warning: {w}\n")
    settings = diff_settings(scene, mapping, width=width, height=height, samples=samples, threads=threads)

    images, timings = {}, {}
    for backend in LABELS:
        bar = ProgressBar(backend, progress) if progress is not None else None
        start = time.perf_counter()
        images[backend] = render(scene, backend, settings, mapping=mapping, progress=bar, timeout=timeout)
        timings[backend] = time.perf_counter() - start
        if bar is not None:
            bar.done(timings[backend])
    try:
        report = compare(images["povray"], images["native"], thresholds)
    except ImageMismatchError as e:
        raise BackendError(f"the backends returned images of different sizes: {e}") from e

    written = None
    if outdir is not None:
        from .report import write_report

        source = scene.source_file or (os.fspath(scene_or_path) if not isinstance(scene_or_path, Scene) else "")
        index = write_report(
            outdir,
            images["povray"],
            images["native"],
            report,
            labels=LABELS,
            title=f"phongscene diff: {Path(source).name if source else 'scene'} ({mapping} mapping)",
            timings=timings,
            meta={
                "scene": source,
                "mapping": mapping,
                "native_specular": settings.specular,
                "settings": _settings_dict(settings),
                "scene_warnings": warnings,
            },
        )
        written = index.parent
    return DiffResult(report, written, timings, images["povray"], images["native"], settings, mapping, warnings)


def _settings_dict(settings: RenderSettings) -> dict:
    out = {}
    for f in fields(RenderSettings):
        name, value = f.name, getattr(settings, f.name)
        out[name] = list(value) if isinstance(value, tuple) else value
        if isinstance(value, float) and not math.isfinite(value):
            out[name] = str(value)
    return out


# ----------------------------------------------------------------------------------------------
# Command line: ``phongscene diff`` and ``phongscene compare`` (registered by cli.build_parser)


def _positive_int(text: str) -> int:
    import argparse

    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a number >= 1, got {value}")
    return value


def _threshold_options(parser) -> None:
    t = HALF_FLOAT
    group = parser.add_argument_group("thresholds (idiff vocabulary; default: half-float precision)")
    group.add_argument("--fail", type=float, default=t.fail, metavar="ABS",
                       help=f"absolute error always accepted (default {t.fail:.3g}, one subnormal half step)")
    group.add_argument("--fail-relative", type=float, default=t.fail_relative, metavar="REL",
                       help=f"error accepted relative to mean(|a|,|b|) (default {t.fail_relative:.3g} = 2 x 2^-11)")
    group.add_argument("--fail-percent", type=float, default=t.fail_percent, metavar="PCT",
                       help=f"%% of pixels allowed to fail (default {t.fail_percent:g})")
    group.add_argument("--hard-fail", type=float, default=t.hard_fail, metavar="ABS",
                       help="any error above this fails (default: none)")


def _thresholds(args) -> Thresholds:
    return Thresholds(fail=args.fail, fail_relative=args.fail_relative, fail_percent=args.fail_percent,
                      hard_fail=args.hard_fail)


def add_diff_command(sub) -> None:
    """Register ``phongscene diff`` on the CLI's subparsers."""
    p = sub.add_parser(
        "diff",
        help="render a scene with POV-Ray and the native tracer and compare",
        description="Render SCENE with both backends under matching conventions (exact: native 'seed'; "
        "classic: native 'povray-classic'), compare at half-float precision and write a report "
        "(images as EXR and PNG, heat map, metrics.json, index.html) into OUTDIR.",
        epilog="Exit codes: 0 the images agree, 1 they differ, 2 bad scene or usage, 3 backend failure.",
    )
    p.add_argument("scene", metavar="SCENE", help="USD file (.usda, .usdc, .usd, .usdz)")
    p.add_argument("-o", "--outdir", required=True, metavar="OUTDIR", help="report folder (created)")
    p.add_argument("--mapping", choices=tuple(SPECULAR_OF_MAPPING), default="exact",
                   help="POV-Ray mapping: exact (the seed model, default) or classic (plain POV-Ray phong)")
    p.add_argument("--spp", type=_positive_int, metavar="N",
                   help="anti-aliasing: N x N samples per pixel (RenderSettings.samples; default: the scene's)")
    p.add_argument("--width", type=_positive_int, metavar="W", help="image width (alone: keeps the aspect ratio)")
    p.add_argument("--height", type=_positive_int, metavar="H", help="image height (alone: keeps the aspect ratio)")
    p.add_argument("--threads", type=int, metavar="N", help="native worker threads (0 = all cores)")
    _threshold_options(p)
    p.set_defaults(func=_run_diff)


def _run_diff(args) -> int:
    from .cli import EXIT_DIFFERENT, EXIT_OK, EXIT_SCENE

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
    print(f"report: {result.outdir / 'index.html'}")
    return EXIT_OK if result.ok else EXIT_DIFFERENT


def add_compare_command(sub) -> None:
    """Register ``phongscene compare`` on the CLI's subparsers."""
    p = sub.add_parser(
        "compare",
        help="compare two images (EXR, PNG, ...) at half-float precision",
        description="Compare image B against reference A pixel by pixel (OpenImageIO) and print the "
        "errors; with -o, also write the report folder.",
        epilog="Exit codes: 0 the images agree, 1 they differ (or differ in size), 2 unreadable file.",
    )
    p.add_argument("a", metavar="A", help="reference image")
    p.add_argument("b", metavar="B", help="image under test")
    p.add_argument("-o", "--outdir", metavar="OUTDIR", help="write the report folder here")
    _threshold_options(p)
    p.set_defaults(func=_run_compare)


def _run_compare(args) -> int:
    from .cli import EXIT_DIFFERENT, EXIT_OK, EXIT_SCENE
    from .errors import PhongSceneError
    from .images import read_image

    try:
        thresholds = _thresholds(args)
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
