# SPDX-License-Identifier: Apache-2.0
"""Cross-validation: render one scene with POV-Ray and with the native tracer under matching
conventions (mapping "exact" ↔ native "seed", "classic" ↔ native "povray-classic"; the native
tracer in POV-Ray's numerics: its absolute ray tolerances and mesh2 data), compare the two images
at half-float precision and, optionally, write the report folder.

A pixel that fails but agrees with a native render in the 1e-4 window of POV-Ray's per-thread
shadow cache is explained by that cache (which decides such pixels by what the thread rendered
before); one that a turn of the camera by a float32 rounding moves beyond the tolerance, with
POV-Ray's value among those the turn reaches, is explained as ill-conditioned
(``phongscene.conditioning``). ``diff`` passes when every failing pixel is explained and they
are at most ``POVRAY_SHADOW_CACHE.fail_percent`` % of the image, and lists them by cause.

POV-Ray's image is the reference ``a`` (it is the one rounded to half floats); the native
image is ``b``."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, fields, replace
from pathlib import Path
from time import perf_counter
from typing import TextIO

import numpy as np

from .comparison import (
    HALF_FLOAT,
    POVRAY_SHADOW_CACHE,
    ImageMismatchError,
    Report,
    Thresholds,
    compare,
    failing_mask,
    for_povray_passes,
)
from .conditioning import ill_conditioned, tilted_cameras
from .errors import BackendError
from .overrides import RenderOverrides
from .progress import ProgressBar
from .rendering import load_scene, render
from .scene import RenderSettings, Scene

LABELS = ("povray", "native")
# What explains a failing pixel (see _explain).
SHADOW_CACHE_CAUSE = "POV-Ray's shadow cache"
ILL_CONDITIONED_CAUSE = "ill-conditioning (a 2^-24 rad turn of the camera moves it further)"


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
    # Failing pixels (x, y) that POV-Ray's shadow cache explains, and those nothing explains.
    explained: tuple[tuple[int, int], ...] = ()
    unexplained: tuple[tuple[int, int], ...] = ()
    # Pixels where the native tracer's scale-invariant tolerances give another image than
    # POV-Ray's absolute ones (what a plain native render of this scene differs in).
    numerics_differ: int = 0
    # What the native image shows that its author should hear of: nothing in view, no light, too
    # dark, with the causes found in the scene (phongscene.diagnostics).
    image_warnings: tuple[str, ...] = ()
    # Pixels (x, y) the scene's normal maps change in the native image: POV-Ray 3.7 has no
    # tangent-space normal maps, so both backends are compared without them and these are where
    # the native tracer's picture (with them) departs from the compared one.
    normal_map_pixels: tuple[tuple[int, int], ...] = ()
    # Failing pixels (x, y) explained as ill-conditioned (phongscene.conditioning).
    ill_conditioned: tuple[tuple[int, int], ...] = ()

    @property
    def ok(self) -> bool:
        if self.report.ok:
            return True
        allowed = POVRAY_SHADOW_CACHE.fail_percent / 100 * self.report.pixels
        explained = len(self.explained) + len(self.ill_conditioned)
        return not self.report.hard_fail and not self.unexplained and 0 < explained <= allowed

    def _repr_html_(self) -> str:
        """Jupyter's display: the verdict and the report's facts, both images side by side (sRGB
        PNGs, as ``Image`` shows them), the explanation and the image warnings."""
        import base64
        import html

        from .images import Image

        def png(image, label) -> str:
            data = np.asarray(image, dtype=np.float32).view(Image)._repr_png_()
            return (
                f"<figure style='display:inline-block;margin:4px'><img src='data:image/png;base64,"
                f"{base64.b64encode(data).decode('ascii')}' alt='{label}'><figcaption>{label}</figcaption></figure>"
            )

        s = self.settings
        verdict = "PASS" if self.ok else "FAIL"
        notes = "".join(f"<li>{html.escape(line.strip())}</li>" for line in self.explanation().splitlines())
        notes += "".join(f"<li>warning: {html.escape(w)}</li>" for w in self.image_warnings)
        return (
            f"<div class='phongscene-diff'><b>{verdict}</b>: {s.width} x {s.height}, mapping {self.mapping} (native "
            f"{s.specular}){' &rarr; ' + html.escape(str(self.outdir)) if self.outdir else ''}<br>"
            f"{png(self.povray, 'povray')}{png(self.native, 'native')}{self.report._repr_html_()}"
            f"{'<ul>' + notes + '</ul>' if notes else ''}</div>"
        )

    def explanation(self) -> str:
        """Lines for the summary: the explained pixels and the numerics difference."""
        lines = []
        if self.explained:
            shown = ", ".join(f"({x}, {y})" for x, y in self.explained[:10]) + (
                " ..." if len(self.explained) > 10 else ""
            )
            lines.append(f"  {len(self.explained)} failing pixels explained by POV-Ray's shadow cache: {shown}")
        if self.ill_conditioned:
            shown = ", ".join(f"({x}, {y})" for x, y in self.ill_conditioned[:10]) + (
                " ..." if len(self.ill_conditioned) > 10 else ""
            )
            lines.append(
                f"  {len(self.ill_conditioned)} failing pixels ill-conditioned (a 2^-24 rad turn of the camera moves "
                f"the native value further than the backends differ): {shown}"
            )
        if self.unexplained:
            shown = ", ".join(f"({x}, {y})" for x, y in self.unexplained[:10]) + (
                " ..." if len(self.unexplained) > 10 else ""
            )
            lines.append(f"  {len(self.unexplained)} failing pixels not explained: {shown}")
        if self.normal_map_pixels:
            shown = ", ".join(f"({x}, {y})" for x, y in self.normal_map_pixels[:10]) + (
                " ..." if len(self.normal_map_pixels) > 10 else ""
            )
            lines.append(
                f"  {len(self.normal_map_pixels)} pixels change with the scene's normal maps, which POV-Ray 3.7 "
                f"cannot render (compared without them): {shown}"
            )
        if self.numerics_differ:
            lines.append(
                f"  {self.numerics_differ} pixels of a plain native render (scale-invariant tolerances) differ "
                "from the one in POV-Ray's numerics"
            )
        if (self.explained or self.ill_conditioned) and not self.report.ok:
            lines.append("  PASS (every failing pixel explained)" if self.ok else "  FAILURE")
        return "\n".join(lines)


def diff(
    scene_or_path: Scene | str | os.PathLike,
    outdir: str | os.PathLike | None = None,
    *,
    mapping: str | None = None,
    width: int | None = None,
    height: int | None = None,
    samples: int | None = None,
    threads: int | None = None,
    thresholds: Thresholds = HALF_FLOAT,
    progress: TextIO | None = None,
    timeout: float | None = None,
    time: float | None = None,
    sample_pattern: str | None = None,
    aa_threshold: float | None = None,
    shadow_adaptive: int | None = None,
    overrides: RenderOverrides | None = None,
    sandbox: bool | None = None,
) -> DiffResult:
    """Render a scene with both backends, compare, and write the report if ``outdir`` is given.

    Args:
        scene_or_path: a Scene, or the path of a USD file.
        outdir: report folder (images, heat map, metrics.json, index.html); None writes nothing.
        mapping: "exact" (POV-Ray exact mapping vs native "seed") or "classic" (the idiomatic
            POV-Ray finish vs native "povray-classic"); None: exact, unless the scene has what
            the exact mapping cannot render (``exact_mapping_obstacle``: a transmissive material
            with a highlight), then classic, with a warning that says why.
        width, height: image size override (one alone keeps the aspect ratio).
        samples: anti-aliasing samples per axis override (``RenderSettings.samples``).
        threads: native worker threads override (0 = all cores).
        thresholds: when the images agree (default: half-float precision at every pixel).
        progress: stream for progress bars (e.g. ``sys.stderr``); None shows none.
        timeout: seconds before POV-Ray is abandoned.
        time: the USD time code to read a USD file at (None: the reader's choice).
        sample_pattern, aa_threshold: anti-aliasing overrides (``RenderSettings``).
        shadow_adaptive: POV-Ray's ``adaptive n`` for every area light (None: each light's own).
        overrides: all the knobs as one ``RenderOverrides`` (instead of width ... shadow_adaptive
            and time; its ``mapping``, when set, is the mapping).
        sandbox: read a USD file in a child process with a memory limit (``phongscene.sandbox``):
            None decides per file (``phongscene.scene_files``), True / False always / never.

    Returns:
        A ``DiffResult``: the report, the folder, both timings and both images.

    Raises:
        ValueError: ``mapping`` is not "exact" or "classic".
        SceneError: the scene file is invalid.
        BackendError: a backend failed, or the two images came back in different sizes.
    """
    from .backends.povray import check_mapping

    named = {
        "width": width,
        "height": height,
        "samples": samples,
        "threads": threads,
        "time": time,
        "sample_pattern": sample_pattern,
        "aa_threshold": aa_threshold,
        "shadow_adaptive": shadow_adaptive,
    }
    if overrides is None:
        overrides = RenderOverrides(mapping=mapping, **named)
    elif any(v is not None for v in named.values()):
        raise TypeError("diff: give overrides= or the separate width ... shadow_adaptive and time, not both")
    mapping = overrides.mapping if overrides.mapping is not None else mapping
    if mapping is not None:
        check_mapping(mapping)  # before the scene is read
    reading = None
    if progress is not None and not isinstance(scene_or_path, Scene):
        reading = ProgressBar("scene", progress)
        reading.phase(f"reading {Path(scene_or_path).name}")  # a big USD file takes seconds
    start = perf_counter()
    scene, warnings = load_scene(
        scene_or_path,
        overrides.time,
        sandbox=sandbox,
        camera=overrides.camera,
        subdivision_level=overrides.subdivision_level,
    )
    if reading is not None:
        reading.done(perf_counter() - start, "read")
    if progress is not None:
        for w in warnings:
            progress.write(f"warning: {w}\n")
    if mapping is None:
        from .backends.povray import exact_mapping_obstacle

        obstacle = exact_mapping_obstacle(scene)
        mapping = "exact" if obstacle is None else "classic"
        if obstacle is not None:
            note = f"compared in the classic mapping: {obstacle}, which the exact mapping cannot render"
            warnings = [*warnings, note]
            if progress is not None:
                progress.write(f"warning: {note}\n")
    scene, settings = replace(overrides, mapping=mapping).apply(scene)

    settings = replace(settings, numerics="povray")
    if thresholds is HALF_FLOAT and mapping == "exact":
        from .backends.povray import pass_count

        thresholds = for_povray_passes(pass_count(scene, mapping))
    # POV-Ray 3.7 cannot render normal maps (the SDL leaves them out): both backends render the
    # scene without them, and the native image with them says where they change the picture.
    normal_mapped, scene = (scene, scene.without_normal_maps()) if scene.normal_mapped else (None, scene)
    images, timings = {}, {}
    for backend in LABELS:
        bar = ProgressBar(backend, progress) if progress is not None else None
        start = perf_counter()
        if backend == "native":
            images[backend] = render_native_as_povray(scene, settings, mapping, progress=bar)
        else:
            images[backend] = render(scene, backend, settings, progress=bar, timeout=timeout, explain=False)
        timings[backend] = perf_counter() - start
        if bar is not None:
            bar.done(timings[backend])
    try:
        report = compare(images["povray"], images["native"], thresholds)
    except ImageMismatchError as e:
        raise BackendError(f"the backends returned images of different sizes: {e}") from e
    explained, ill_conditioned, unexplained = _explain(scene, settings, mapping, images, report, thresholds)
    plain = render_native_as_povray(scene, replace(settings, numerics="scale-invariant"), mapping)
    numerics_differ = int(failing_mask(images["native"], plain, thresholds).sum())
    normal_map_pixels = ()
    if normal_mapped is not None:
        with_maps = render_native_as_povray(normal_mapped, settings, mapping)
        normal_map_pixels = _listed(failing_mask(with_maps, images["native"], thresholds))

    from .diagnostics import ImageChecks

    image_warnings = tuple(ImageChecks.of(scene, settings, warnings).warnings(images["native"]))
    result = DiffResult(
        report,
        None,
        timings,
        images["povray"],
        images["native"],
        settings,
        mapping,
        warnings,
        explained,
        unexplained,
        numerics_differ,
        image_warnings,
        normal_map_pixels,
        ill_conditioned,
    )
    if outdir is not None:
        from .files import atomic_folder
        from .report import write_report

        source = scene.source_file or (os.fspath(scene_or_path) if not isinstance(scene_or_path, Scene) else "")
        with atomic_folder(outdir) as tmp:  # the whole report, or none of it (a full disk)
            write_report(
                tmp,
                images["povray"],
                images["native"],
                report,
                labels=LABELS,
                title=f"phongscene diff: {Path(source).name if source else 'scene'} ({mapping} mapping)",
                timings=timings,
                # Failing pixels are classified only when the comparison fails (_explain).
                explained=None
                if report.ok
                else {
                    **dict.fromkeys(explained, SHADOW_CACHE_CAUSE),
                    **dict.fromkeys(ill_conditioned, ILL_CONDITIONED_CAUSE),
                },
                ok=result.ok,
                meta={
                    "scene": source,
                    "time": overrides.time,
                    "camera": scene.camera.source,
                    "mapping": mapping,
                    "native_specular": settings.specular,
                    "settings": _settings_dict(settings),
                    "scene_warnings": warnings,
                    "image_warnings": list(image_warnings),
                    "explained_by_povray_shadow_cache": [list(p) for p in explained],
                    "ill_conditioned_pixels": [list(p) for p in ill_conditioned],
                    "unexplained_failing_pixels": [list(p) for p in unexplained],
                    "native_numerics_differ_pixels": numerics_differ,
                    "normal_map_pixels": [list(p) for p in normal_map_pixels],
                },
            )
        result = replace(result, outdir=Path(outdir))
    return result


def render_native_as_povray(scene: Scene, settings: RenderSettings, mapping: str, progress=None) -> np.ndarray:
    """The native image of what POV-Ray renders for ``mapping``. The same as a plain native render
    except for adaptive anti-aliasing (a threshold > 0) under the exact mapping with several
    lights: POV-Ray renders one pass per light and decides which pixels to supersample in each
    pass from that pass's colours, so the native tracer renders the same passes and sums them."""
    from .backends.povray import pass_scenes

    adaptive_aa = settings.aa_threshold > 0 and settings.sample_pattern in ("povray-am1", "povray-am2")
    passes = pass_scenes(scene, mapping) if adaptive_aa else (scene,)
    if len(passes) == 1:
        return render(scene, "native", settings, progress=progress, explain=False)
    total = np.zeros((settings.height, settings.width, 3), np.float64)
    for i, one in enumerate(passes):
        background = settings.background if i == 0 else (0.0, 0.0, 0.0)
        total += render(one, "native", replace(settings, background=background), progress=progress, explain=False)
    return total.astype(np.float32)


def _explain(
    scene: Scene, settings: RenderSettings, mapping: str, images: dict, report: Report, thresholds: Thresholds
):
    """(by the shadow cache, ill-conditioned, unexplained) failing pixels: a failing pixel where
    POV-Ray agrees with a native render in its shadow cache's window is explained by the cache;
    of the rest, those ``phongscene.conditioning`` finds ill-conditioned (four more native
    renders, only when such pixels remain and are few enough for ``diff`` to pass)."""
    if report.ok or not report.failing_pixels:
        return (), (), ()
    failing = failing_mask(images["povray"], images["native"], thresholds)
    cached = render_native_as_povray(scene, replace(settings, numerics="povray-shadow-cache"), mapping)
    by_cache = failing & ~failing_mask(images["povray"], cached, thresholds)
    rest = failing & ~by_cache
    # The probe only where it can change the verdict: more failing pixels than diff allows fail
    # it whatever explains them, and four renders of a big image cost minutes.
    if rest.any() and failing.sum() <= POVRAY_SHADOW_CACHE.fail_percent / 100 * report.pixels:
        tilted = _native_from_cameras(scene, settings, mapping, tilted_cameras(scene.camera))
        by_conditioning = ill_conditioned(images["povray"], images["native"], tilted, rest, thresholds)
        rest &= ~by_conditioning
    else:
        by_conditioning = np.zeros_like(rest)
    return _listed(by_cache), _listed(by_conditioning), _listed(rest)


def _native_from_cameras(scene: Scene, settings: RenderSettings, mapping: str, cameras) -> list[np.ndarray]:
    """``render_native_as_povray``'s image from each of ``cameras``, each pass's C++ scene built
    once (a big mesh's BVH takes longer than a small image's render)."""
    from .backends import native
    from .backends.povray import pass_scenes

    adaptive_aa = settings.aa_threshold > 0 and settings.sample_pattern in ("povray-am1", "povray-am2")
    passes = pass_scenes(scene, mapping) if adaptive_aa else (scene,)
    totals = [np.zeros((settings.height, settings.width, 3), np.float64) for _ in cameras]
    for i, one in enumerate(passes):
        background = settings.background if i == 0 else (0.0, 0.0, 0.0)
        prepared = native.prepare(one, replace(settings, background=background))
        for total, camera in zip(totals, cameras):
            total += prepared(camera)
    return [total.astype(np.float32) for total in totals]


def _listed(mask: np.ndarray) -> tuple[tuple[int, int], ...]:
    """The (x, y) of a mask's set pixels, row by row."""
    return tuple((int(x), int(y)) for y, x in np.argwhere(mask))


def _settings_dict(settings: RenderSettings) -> dict:
    out = {}
    for f in fields(RenderSettings):
        name, value = f.name, getattr(settings, f.name)
        out[name] = list(value) if isinstance(value, tuple) else value
        if isinstance(value, float) and not math.isfinite(value):
            out[name] = str(value)
    return out
