# SPDX-License-Identifier: Apache-2.0
"""Speed against error for any scene (``phongscene bench``): every estimator of both backends,
timed in wall and CPU seconds, judged against a reference whose own error is measured.

Two families of estimators, each varied with the other held fixed:

* anti-aliasing (every scene): the n×n ``grid``, POV-Ray's ``povray-am1`` and ``povray-am2``
  with thresholds (ref §8), and the native tracer's ``stratified`` and ``adaptive`` estimators;
  the scene's lights as they are. Reference: the stratified estimator without early stop at
  k× the resolution (``reference_resolution``, default REFERENCE_RESOLUTION) with
  REFERENCE_SAMPLES² points per (small) pixel, box-filtered down: (16k)² points per pixel.
* area-light shadows (scenes with area lights): the shadow grid at 3…33 points per axis, in
  full and with POV-Ray's ``adaptive n``, and the native tracer's ``cells`` estimator (alone and
  on top of ``adaptive n``), at one sample per pixel (the same primary rays as the reference, so
  anti-aliasing error cancels). Reference: the full grid at ``reference_shadow_samples`` points
  per axis (default REFERENCE_SHADOW_SAMPLES).

The reference's own error is measured, not assumed: it is rendered a second time with a coarser
setting (half the samples per axis, resp. half the grid intervals) and, for an estimator whose
error falls as h^p with p >= 1 (h: the sample spacing), its error is at most
|reference − coarser| / ((h_coarse / h_ref)^p − 1) <= |reference − coarser| / (ratio − 1).
Rows whose error is not at least REFERENCE_MARGIN× that bound are flagged.

Times: wall (perf_counter) and CPU (this process's CPU time plus that of the child processes it
waited for: POV-Ray's), best of ``repeat`` runs each, both backends back to back at every setting
so that they see the same machine load. POV-Ray's times include its fixed start-up.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import math
import resource
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from .scene import RectAreaLight, RenderSettings, Scene, SphereAreaLight

AA, AREA = "anti-aliasing", "area-light shadows"
BACKEND_NAMES = ("native", "povray")

# The anti-aliasing reference: REFERENCE_SAMPLES² points of the stratified (0,2)-sequence (the
# most RenderSettings allows, no early stop) at REFERENCE_RESOLUTION× the size: 48² samples per
# pixel; its twin with half the points per axis measures its error.
REFERENCE_RESOLUTION = 3
REFERENCE_PATTERN = "stratified"
REFERENCE_SAMPLES = 16
REFERENCE_COARSE_SAMPLES = 8
# The area-light reference grid (2^7 + 1: its trapezoid rule contains every coarser 2^k + 1 grid);
# its coarser twin has half the intervals.
REFERENCE_SHADOW_SAMPLES = 129
# The requirement: the reference's own error at least 10× below every error reported.
REFERENCE_MARGIN = 10.0

# The estimators studied (family, label, how it changes the scene). POV-Ray's thresholds are
# those of its documentation's range (default 0.3) down to where AM2 stops saving rays.
AA_GRID = (1, 2, 3, 4, 6)
AA_AM1 = ((3, 0.3), (3, 0.1), (3, 0.03), (4, 0.03), (4, 0.01))
AA_AM2 = ((2, 0.1), (3, 0.1), (3, 0.03), (4, 0.03), (4, 0.01))
# The native stratified estimator: (n, threshold): up to n² points, stop when settled within t.
AA_STRATIFIED = ((2, 0.0), (4, 0.0), (4, 0.03), (8, 0.03), (8, 0.01), (8, 0.003), (16, 0.01), (16, 0.003))
# The native adaptive quadtree: (n, threshold): cells down to 1/n pixel, split while spread·s^1.5 >= t.
AA_ADAPTIVE = ((4, 0.1), (4, 0.03), (8, 0.03), (8, 0.01), (16, 0.01), (16, 0.003), (16, 0.001))
AREA_GRID = (3, 5, 9, 17, 33)
AREA_ADAPTIVE = ((9, 1), (17, 1), (17, 2), (33, 1), (33, 2))
# The native cells estimator: (grid, POV-Ray's adaptive level or None, points per partial cell per axis).
AREA_CELLS = ((5, None, 8), (9, None, 4), (9, None, 8), (17, 2, 2), (17, 2, 4), (33, 2, 2), (33, 2, 4))


@dataclasses.dataclass(frozen=True)
class Estimator:
    """One setting of one family: how to change the scene and its settings, and which backends
    implement it."""

    family: str
    label: str
    settings: dict  # RenderSettings overrides
    light: dict  # overrides for every area light
    backends: tuple[str, ...] = BACKEND_NAMES
    spacing: float = 1.0  # the sample spacing h (fraction of a pixel / of the light's edge)

    def apply(self, scene: Scene, settings: RenderSettings) -> tuple[Scene, RenderSettings]:
        if self.light:
            lights = tuple(
                dataclasses.replace(light, **self.light) if _is_area(light) else light for light in scene.lights
            )
            scene = dataclasses.replace(scene, lights=lights)
        return scene, dataclasses.replace(settings, **self.settings)


def _is_area(light) -> bool:
    return isinstance(light, (RectAreaLight, SphereAreaLight))


def estimators(scene: Scene, quick: bool = False) -> list[Estimator]:
    """Every estimator of both backends that applies to ``scene`` (``quick``: a few of each)."""
    grid = AA_GRID[:3] if quick else AA_GRID
    am1 = AA_AM1[1:3] if quick else AA_AM1
    am2 = AA_AM2[1:3] if quick else AA_AM2
    out = [
        Estimator(AA, f"grid {n}", {"samples": n, "sample_pattern": "grid", "aa_threshold": 0.0}, {}, spacing=1 / n)
        for n in grid
    ]
    out += [
        Estimator(
            AA, f"am1 R{n} A{t:g}", {"samples": n, "sample_pattern": "povray-am1", "aa_threshold": t}, {}, spacing=1 / n
        )
        for n, t in am1
    ]
    out += [
        Estimator(
            AA,
            f"am2 R{n} A{t:g}",
            {"samples": n, "sample_pattern": "povray-am2", "aa_threshold": t},
            {},
            spacing=1 / 2 ** (n - 1),
        )
        for n, t in am2
    ]
    stratified = AA_STRATIFIED[2:4] if quick else AA_STRATIFIED
    out += [
        Estimator(
            AA,
            f"stratified {n} t{t:g}",
            {"samples": n, "sample_pattern": "stratified", "aa_threshold": t},
            {},
            backends=("native",),
            spacing=1 / n,
        )
        for n, t in stratified
    ]
    adaptive_aa = AA_ADAPTIVE[1:3] if quick else AA_ADAPTIVE
    out += [
        Estimator(
            AA,
            f"adaptive {n} t{t:g}",
            {"samples": n, "sample_pattern": "adaptive", "aa_threshold": t},
            {},
            backends=("native",),
            spacing=1 / n,
        )
        for n, t in adaptive_aa
    ]
    if any(_is_area(light) for light in scene.lights):
        one = {"samples": 1, "sample_pattern": "grid", "aa_threshold": 0.0}
        shadow = AREA_GRID[:3] if quick else AREA_GRID
        adaptive = AREA_ADAPTIVE[:2] if quick else AREA_ADAPTIVE
        out += [
            Estimator(
                AREA, f"area {s}", one, {"samples": s, "adaptive": None, "cell_samples": None}, spacing=1 / (s - 1)
            )
            for s in shadow
        ]
        out += [
            Estimator(
                AREA,
                f"area {s} adaptive {a}",
                one,
                {"samples": s, "adaptive": a, "cell_samples": None},
                spacing=1 / (s - 1),
            )
            for s, a in adaptive
        ]
        cells = AREA_CELLS[1:2] if quick else AREA_CELLS
        out += [
            Estimator(
                AREA,
                f"area {s}{'' if a is None else f' adaptive {a}'} cells {k}",
                one,
                {"samples": s, "adaptive": a, "cell_samples": k},
                backends=("native",),
                spacing=1 / ((s - 1) * k),
            )
            for s, a, k in cells
        ]
    return out


# --------------------------------------------------------------------------------------------
# Measuring


def cpu_seconds() -> float:
    """CPU time of this process (all its threads) and of its waited-for children (POV-Ray)."""
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + children.ru_utime + children.ru_stime


def timed(fn: Callable[[], np.ndarray], repeat: int) -> tuple[float, float, np.ndarray]:
    """(best wall seconds, best CPU seconds, the last result) of ``repeat`` calls of ``fn``."""
    wall, cpu, result = math.inf, math.inf, None
    for _ in range(repeat):
        c0, w0 = cpu_seconds(), time.perf_counter()
        result = fn()
        wall = min(wall, time.perf_counter() - w0)
        cpu = min(cpu, cpu_seconds() - c0)
    return wall, cpu, result


def rms(a: np.ndarray, b: np.ndarray) -> float:
    """RMS over every channel value, in float64."""
    return float(np.sqrt(np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2)))


def max_error(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a.astype(np.float64) - b.astype(np.float64))))


def box_down(image: np.ndarray, k: int) -> np.ndarray:
    """Average k×k pixel blocks (a render at k× the size → the pixel's box-filtered value)."""
    h, w, c = image.shape
    return image.reshape(h // k, k, w // k, k, c).astype(np.float64).mean(axis=(1, 3))


def reference(
    family: str,
    scene: Scene,
    settings: RenderSettings,
    render: Callable,
    resolution: int = REFERENCE_RESOLUTION,
    shadow_samples: int = REFERENCE_SHADOW_SAMPLES,
) -> dict:
    """The family's reference image and a bound on its own RMS error (module docstring); the
    anti-aliasing reference at ``resolution``× the size, the shadow one a grid of
    ``shadow_samples`` (2^k + 1) per axis."""
    if family == AA:
        k = resolution
        big = dataclasses.replace(
            settings,
            width=settings.width * k,
            height=settings.height * k,
            sample_pattern=REFERENCE_PATTERN,
            aa_threshold=0.0,
        )
        start = time.perf_counter()
        fine = box_down(render(scene, dataclasses.replace(big, samples=REFERENCE_SAMPLES)), k)
        seconds = time.perf_counter() - start
        coarse = box_down(render(scene, dataclasses.replace(big, samples=REFERENCE_COARSE_SAMPLES)), k)
        ratio = REFERENCE_SAMPLES / REFERENCE_COARSE_SAMPLES
        what = (
            f"{REFERENCE_PATTERN} {REFERENCE_SAMPLES}x{REFERENCE_SAMPLES} points at {k}x the resolution "
            f"({(REFERENCE_SAMPLES * k) ** 2} per pixel)"
        )
    else:
        one = dataclasses.replace(settings, samples=1, sample_pattern="grid", aa_threshold=0.0)

        def at(samples: int) -> np.ndarray:
            lights = tuple(
                dataclasses.replace(light, samples=samples, adaptive=None, cell_samples=None)
                if _is_area(light)
                else light
                for light in scene.lights
            )
            return render(dataclasses.replace(scene, lights=lights), one).astype(np.float64)

        start = time.perf_counter()
        coarse_samples = (shadow_samples - 1) // 2 + 1  # half the intervals
        fine = at(shadow_samples)
        seconds = time.perf_counter() - start
        coarse = at(coarse_samples)
        ratio = (shadow_samples - 1) / (coarse_samples - 1)
        what = f"shadow grid {shadow_samples}x{shadow_samples}, 1 sample per pixel"
    return {"image": fine, "what": what, "seconds": seconds, "rms_error_bound": rms(fine, coarse) / (ratio - 1.0)}


def pareto_front(points: Sequence[tuple[float, float]]) -> list[int]:
    """Indices of the points (cost, error) no other point beats in both (cheaper or as cheap
    and at least as accurate), by increasing cost."""
    order = sorted(range(len(points)), key=lambda i: (points[i][0], points[i][1]))
    front, best = [], math.inf
    for i in order:
        if points[i][1] < best:
            front.append(i)
            best = points[i][1]
    return front


def cheapest_at(rows: list[dict], backend: str, family: str, error: float, cost: str) -> dict | None:
    """The row of ``backend`` in ``family`` with RMS error <= ``error`` at the least ``cost``."""
    ok = [r for r in rows if r["backend"] == backend and r["family"] == family and r["rms"] <= error]
    return min(ok, key=lambda r: r[cost]) if ok else None


def dominance(rows: list[dict], family: str, cost: str) -> dict:
    """How much cheaper native reaches every error level POV-Ray reaches: for each POV-Ray row on
    its Pareto front, POV-Ray's cost over native's cheapest cost at that error or better. Only
    levels the reference resolves (row["resolved"], absent: resolved) count in ``min_ratio``; the
    others are listed with ``resolved`` false."""
    pov = [r for r in rows if r["backend"] == "povray" and r["family"] == family]
    front = [pov[i] for i in pareto_front([(r[cost], r["rms"]) for r in pov])]
    ratios = []
    for r in front:
        native = cheapest_at(rows, "native", family, r["rms"], cost)
        ratios.append(
            {
                "povray": r["label"],
                "rms": r["rms"],
                "native": native["label"] if native else None,
                "ratio": (r[cost] / native[cost]) if native else 0.0,
                "resolved": r.get("resolved", True),
            }
        )
    counted = [x["ratio"] for x in ratios if x["resolved"]]
    return {"cost": cost, "min_ratio": min(counted, default=None), "levels": ratios}


def run(
    scene: Scene,
    settings: RenderSettings,
    *,
    repeat: int = 3,
    quick: bool = False,
    backends: Sequence[str] = BACKEND_NAMES,
    log: Callable[[str], None] = print,
    families: Sequence[str] | None = None,
    reference_resolution: int = REFERENCE_RESOLUTION,
    reference_shadow_samples: int = REFERENCE_SHADOW_SAMPLES,
) -> dict:
    """Measure every estimator of ``scene`` (see the module docstring). Returns a JSON-able dict:
    ``rows`` (one per backend and estimator), ``references``, ``dominance``."""
    rows: list[dict] = []
    references: dict = {}
    chosen = estimators(scene, quick)
    wanted = families_of(chosen, families)
    for family in wanted:
        ref = reference(family, scene, settings, render_native, reference_resolution, reference_shadow_samples)
        references[family] = {k: v for k, v in ref.items() if k != "image"}
        log(reference_line(family, ref))
        for est in (e for e in chosen if e.family == family):
            for backend in (b for b in backends if b in est.backends):
                rows.append(measure(scene, settings, est, backend, ref, repeat))
                log(row_line(rows[-1]))
    return result_of(settings, repeat, references, rows, backends, wanted)


def render_native(scene: Scene, settings: RenderSettings) -> np.ndarray:
    from .rendering import render

    return render(scene, "native", settings, explain=False)  # timed: no image checks


def families_of(chosen: list[Estimator], families: Sequence[str] | None) -> list[str]:
    """The families of ``chosen`` to study (those in ``families``, default all), in table order."""
    available = sorted({e.family for e in chosen}, key=[AA, AREA].index)
    return [f for f in available if f in families] if families else available


def measure(scene: Scene, settings: RenderSettings, est: Estimator, backend: str, ref: dict, repeat: int) -> dict:
    """One row: ``est`` rendered by ``backend``, timed (best of ``repeat``), its errors against
    the family's reference (``reference``)."""
    from .rendering import render as render_backend

    s_scene, s_settings = est.apply(scene, settings)
    wall, cpu, image = timed(lambda: render_backend(s_scene, backend, s_settings, explain=False), repeat)
    row = {
        "family": est.family,
        "label": est.label,
        "backend": backend,
        "wall": wall,
        "cpu": cpu,
        "rms": rms(ref["image"], image),
        "max": max_error(ref["image"], image),
        "bias": float(np.mean(image.astype(np.float64) - ref["image"])),
        "spacing": est.spacing,
    }
    row["resolved"] = row["rms"] >= REFERENCE_MARGIN * ref["rms_error_bound"]
    return row


def reference_line(family: str, ref: dict) -> str:
    return f"{family}: reference {ref['what']} in {ref['seconds']:.2f} s, its RMS error <= {ref['rms_error_bound']:.2e}"


def row_line(row: dict) -> str:
    return (
        f"  {row['label']:<22} {row['backend']:<7} wall {row['wall']:7.3f} s  cpu {row['cpu']:7.3f} s  "
        f"rms {row['rms']:.2e}  max {row['max']:.3f}{'' if row['resolved'] else '  (within 10x of the reference error)'}"
    )


def result_of(
    settings: RenderSettings,
    repeat: int,
    references: dict,
    rows: list[dict],
    backends: Sequence[str],
    families: list[str],
) -> dict:
    """``run``'s JSON-able result from its rows (in table order) and references."""
    result = {
        "width": settings.width,
        "height": settings.height,
        "threads": settings.threads,
        "repeat": repeat,
        "specular": settings.specular,
        "references": references,
        "rows": rows,
        "dominance": {},
    }
    if set(backends) >= set(BACKEND_NAMES):
        for family in families:
            result["dominance"][family] = {c: dominance(rows, family, c) for c in ("cpu", "wall")}
    return result


def target(result: dict, rms_target: float) -> list[str]:
    """Lines saying which setting of each backend reaches ``rms_target`` fastest, per family."""
    lines = []
    families = sorted({r["family"] for r in result["rows"]}, key=[AA, AREA].index)
    for family in families:
        for backend in BACKEND_NAMES:
            for cost in ("cpu", "wall"):
                row = cheapest_at(result["rows"], backend, family, rms_target, cost)
                where = f"{family}, {backend}, by {cost} time"
                lines.append(
                    f"target RMS {rms_target:.2e}: {where}: "
                    + (f"{row['label']} ({row[cost]:.3f} s, RMS {row['rms']:.2e})" if row else "no setting reaches it")
                )
    return lines


# --------------------------------------------------------------------------------------------
# Output


def table(result: dict) -> str:
    """A plain-text table of every row (bias: the mean signed error over every channel value, an
    estimate of the estimator's bias on this scene), and the dominance summary."""
    out = io.StringIO()
    out.write(
        f"{'family':<19} {'estimator':<22} {'backend':<7} {'wall s':>8} {'CPU s':>8} {'RMS':>9} {'max':>7} "
        f"{'bias':>9}\n"
    )
    for r in result["rows"]:
        flag = "" if r["resolved"] else "  *"
        out.write(
            f"{r['family']:<19} {r['label']:<22} {r['backend']:<7} {r['wall']:8.3f} {r['cpu']:8.3f} "
            f"{r['rms']:9.2e} {r['max']:7.3f} {r['bias']:+9.1e}{flag}\n"
        )
    if any(not r["resolved"] for r in result["rows"]):
        out.write(f"* RMS error within {REFERENCE_MARGIN:g}x of the reference's own error bound\n")
    for family, d in result["dominance"].items():
        for cost, info in d.items():
            if info["min_ratio"] is None:
                continue
            unresolved = sum(not x["resolved"] for x in info["levels"])
            out.write(
                f"{family}: at every RMS level POV-Ray's Pareto front reaches, native is >= "
                f"{info['min_ratio']:.2f}x cheaper in {cost} time"
                + (f" ({unresolved} level(s) below what the reference resolves not counted)" if unresolved else "")
                + "\n"
            )
    return out.getvalue()


def write_csv(result: dict, path: Path) -> None:
    from .files import write_text_atomic

    out = io.StringIO()
    fields = ("family", "label", "backend", "wall", "cpu", "rms", "max", "bias", "spacing", "resolved")
    writer = csv.DictWriter(out, fieldnames=fields, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    writer.writerows(result["rows"])
    write_text_atomic(path, out.getvalue())


def draw(ax, result: dict, cost: str) -> None:
    """One panel: RMS error against ``cost`` ("cpu" or "wall") time, log-log; every estimator a
    faint point, each backend's Pareto front (per family) a labelled line."""
    colours = {"native": "tab:blue", "povray": "tab:red"}
    markers = {AA: "o", AREA: "s"}
    rows = result["rows"]
    for family in sorted({r["family"] for r in rows}, key=[AA, AREA].index):
        for backend in BACKEND_NAMES:
            mine = [r for r in rows if r["family"] == family and r["backend"] == backend]
            if not mine:
                continue
            ax.scatter(
                [r[cost] for r in mine],
                [r["rms"] for r in mine],
                color=colours[backend],
                marker=markers[family],
                alpha=0.35,
                s=20,
            )
            front = [mine[i] for i in pareto_front([(r[cost], r["rms"]) for r in mine])]
            ax.plot(
                [r[cost] for r in front],
                [r["rms"] for r in front],
                color=colours[backend],
                marker=markers[family],
                linestyle="-" if family == AA else "--",
                label=f"{'POV-Ray' if backend == 'povray' else 'native'} Pareto front, {family}",
            )
            for r in front:
                ax.annotate(
                    r["label"],
                    (r[cost], r["rms"]),
                    textcoords="offset points",
                    xytext=(4, 3),
                    fontsize=6,
                    color=colours[backend],
                )
        bound = result["references"][family]["rms_error_bound"]
        ax.axhline(
            bound,
            color="grey",
            linestyle=":" if family == AA else "-.",
            linewidth=1,
            label=f"reference's own RMS error (bound), {family}",
        )
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(f"{'CPU' if cost == 'cpu' else 'wall'} time per image, end to end (s)")
    ax.set_ylabel("RMS error against the reference")
    ax.grid(True, which="both", alpha=0.3)


def plot(result: dict, path: Path, title: str = "") -> None:
    """Log-log RMS error against CPU and wall time, one panel each (``draw``)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .files import atomic_path

    fig, axes = plt.subplots(1, 2, figsize=(13, 6), layout="constrained")
    for ax, cost in zip(axes, ("cpu", "wall")):
        draw(ax, result, cost)
        ax.set_title(f"RMS error against {'CPU' if cost == 'cpu' else 'wall'} time")
    fig.legend(*axes[0].get_legend_handles_labels(), loc="outside lower center", ncol=3, fontsize=8)
    fig.suptitle(title or f"Speed against error, {result['width']}x{result['height']}")
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=100)
    plt.close(fig)


def write_all(result: dict, outdir: Path, stem: str, title: str = "") -> list[Path]:
    """``stem``.csv, .json and .png in ``outdir`` (atomically); their paths."""
    from .files import write_text_atomic

    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    paths = [outdir / f"{stem}.csv", outdir / f"{stem}.json", outdir / f"{stem}.png"]
    write_csv(result, paths[0])
    write_text_atomic(paths[1], json.dumps(result, indent=1, default=_json_default) + "\n")
    plot(result, paths[2], title)
    return paths


def _json_default(value):
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    raise TypeError(f"not JSON: {type(value).__name__}")
