# SPDX-License-Identifier: Apache-2.0
"""Cross-validation: render one scene with POV-Ray and with the native tracer under matching
conventions (mapping "exact" ↔ native "seed", "classic" ↔ native "povray-classic"), compare the
two images at half-float precision and, optionally, write the report folder.

POV-Ray's image is the reference ``a`` (it is the one rounded to half floats); the native
image is ``b``."""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass, fields
from pathlib import Path
from typing import TextIO

import numpy as np

from .comparison import HALF_FLOAT, ImageMismatchError, Report, Thresholds, compare
from .errors import BackendError
from .progress import ProgressBar
from .rendering import load_scene, render, settings_with
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
        ValueError: ``mapping`` is not "exact" or "classic".
        SceneError: the scene file is invalid.
        BackendError: a backend failed, or the two images came back in different sizes.
    """
    from .backends.povray import check_mapping

    check_mapping(mapping)  # before the scene is read
    scene, warnings = load_scene(scene_or_path)
    if progress is not None:
        for w in warnings:
            progress.write(f"warning: {w}\n")
    settings = settings_with(scene, mapping, width=width, height=height, samples=samples, threads=threads)

    images, timings = {}, {}
    for backend in LABELS:
        bar = ProgressBar(backend, progress) if progress is not None else None
        start = time.perf_counter()
        images[backend] = render(scene, backend, settings, progress=bar, timeout=timeout)
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

