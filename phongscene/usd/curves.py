# SPDX-License-Identifier: Apache-2.0
"""``UsdGeom.BasisCurves`` as tubes: the surface a sphere of diameter ``widths`` sweeps along the
curve (POV-Ray's ``sphere_sweep``, as renderers draw curves of "tube" type). A linear curve is
that sweep exactly: per segment, the two spheres at its ends and the cone tangent to both, which
is a two-radius ``capsule`` ``Intrinsic`` (traced exactly in both backends). A cubic curve
(``bezier``, ``bspline``, ``catmullRom``; ``wrap`` nonperiodic, periodic or pinned) is evaluated
at ``SAMPLES_PER_SEGMENT`` steps per segment and swept along that polyline. The tube lies in the
prim's space: ``world_from_object`` is the prim's transform times the segment's frame, so any
affine transform is carried exactly."""

from __future__ import annotations

import math

import numpy as np
from pxr import Usd, UsdGeom

from ..scene import Intrinsic, PhongMaterial
from ..tolerances import is_singular
from .context import ReadContext

# Steps per cubic segment. The chord of a cubic over 1/n of its parameter deviates from it by
# ~max|P''|/(8n²): 1/512 of the segment's curvature term at n = 8 (a quarter-circle Bezier of
# radius 1 stays within 2e-3 of its arc's sweep).
SAMPLES_PER_SEGMENT = 8
# USD gives BasisCurves without widths no width; Hydra draws them 1 unit wide, as we do.
DEFAULT_CURVE_WIDTH = 1.0

# point(t) = [t³ t² t 1] · M · [P0 P1 P2 P3]ᵀ
BASIS_MATRICES = {
    UsdGeom.Tokens.bezier: np.array([[-1, 3, -3, 1], [3, -6, 3, 0], [-3, 3, 0, 0], [1, 0, 0, 0]], dtype=np.float64),
    UsdGeom.Tokens.bspline: np.array([[-1, 3, -3, 1], [3, -6, 3, 0], [-3, 0, 3, 0], [1, 4, 1, 0]], dtype=np.float64)
    / 6.0,
    UsdGeom.Tokens.catmullRom: np.array([[-1, 3, -3, 1], [2, -5, 4, -1], [-1, 0, 1, 0], [0, 2, 0, 0]], dtype=np.float64)
    / 2.0,
}
WRAPS = (UsdGeom.Tokens.nonperiodic, UsdGeom.Tokens.periodic, UsdGeom.Tokens.pinned)


def _segments(kind: str, basis: str, wrap: str, n: int) -> list[tuple[int, ...]] | None:
    """The vertex indices of each segment of a curve of n vertices (2 linear, 4 cubic; a pinned
    curve's indices count from its phantom first vertex), or None when n does not fit."""
    if kind == UsdGeom.Tokens.linear:
        if wrap == UsdGeom.Tokens.periodic:
            return [(i, (i + 1) % n) for i in range(n)] if n >= 3 else None
        return [(i, i + 1) for i in range(n - 1)] if n >= 2 else None
    if basis == UsdGeom.Tokens.bezier:
        if wrap == UsdGeom.Tokens.periodic:
            return [tuple((3 * k + j) % n for j in range(4)) for k in range(n // 3)] if n >= 3 and n % 3 == 0 else None
        return (
            [tuple(3 * k + j for j in range(4)) for k in range((n - 1) // 3)] if n >= 4 and (n - 4) % 3 == 0 else None
        )
    if wrap == UsdGeom.Tokens.periodic:
        return [tuple((k + j) % n for j in range(4)) for k in range(n)] if n >= 3 else None
    if wrap == UsdGeom.Tokens.pinned:
        return [tuple(k + j for j in range(4)) for k in range(n - 1)] if n >= 2 else None  # with 2 phantoms
    return [tuple(k + j for j in range(4)) for k in range(n - 3)] if n >= 4 else None


def _pin(values: np.ndarray) -> np.ndarray:
    """A pinned bspline / catmullRom curve's vertices with the phantom ends USD defines
    (2·P0 − P1 before, 2·Pn−1 − Pn−2 after), so the curve starts and ends at its end vertices."""
    return np.concatenate([2 * values[:1] - values[1:2], values, 2 * values[-1:] - values[-2:-1]])


def _polyline(kind, basis, wrap, p, r_vertex, r_varying, segments):
    """The curve sampled: points (M, 3) and radii (M,), from per-vertex radii (cubic-interpolated
    like the points) or per segment-end radii (linear along each segment)."""
    if kind == UsdGeom.Tokens.linear:
        pts = np.array([p[a] for a, _ in segments] + [p[segments[-1][1]]])
        if r_vertex is not None:
            radii = np.array([r_vertex[a] for a, _ in segments] + [r_vertex[segments[-1][1]]])
        else:
            radii = r_varying
        return pts, radii
    m = BASIS_MATRICES[basis]
    t = np.arange(SAMPLES_PER_SEGMENT) / SAMPLES_PER_SEGMENT
    powers = np.stack([t**3, t**2, t, np.ones_like(t)], axis=1) @ m  # (S, 4) weights
    last = np.array([[1.0, 1.0, 1.0, 1.0]]) @ m  # t = 1
    pts, radii = [], []
    for k, seg in enumerate(segments):
        idx = list(seg)
        pts.append(powers @ p[idx])
        if r_vertex is not None:
            radii.append(powers @ r_vertex[idx])
        else:
            radii.append(r_varying[k] + t * (r_varying[k + 1] - r_varying[k]))
    idx = list(segments[-1])
    pts.append(last @ p[idx])
    radii.append(last @ r_vertex[idx] if r_vertex is not None else r_varying[-1:])
    return np.concatenate(pts), np.concatenate(radii)


def _frame(c0: np.ndarray, c1: np.ndarray) -> tuple[np.ndarray, float]:
    """An orthonormal frame (4, 4) with +Z along c1 − c0 and its origin at c0, and |c1 − c0|."""
    d = c1 - c0
    length = float(np.linalg.norm(d))
    z = d / length
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    frame = np.eye(4)
    frame[:3, 0], frame[:3, 1], frame[:3, 2], frame[:3, 3] = x, np.cross(z, x), z, c0
    return frame, length


def swept_segment(c0, r0: float, c1, r1: float, world: np.ndarray, material: PhongMaterial, source: str) -> Intrinsic:
    """The hull of the spheres (c0, r0) and (c1, r1) (object space) as a capsule Intrinsic.

    The capsule convention (Intrinsic.capsule_ends) puts its end spheres at z = −h − s·r_b and
    h − s·r_t with radii r·g, g = √(1 + s²), s = (r_b − r_t)/2h: their distance is 2h·g². For
    end spheres a distance D apart, σ = (r0 − r1)/D (the sine of the tangent cone's half angle)
    gives g² = 1/(1 − σ²), s = σ·g, r_b = r0/g, r_t = r1/g and h = D(1 − σ²)/2; the capsule's
    centre then sits h + s·r_b above c0. Where one sphere holds the other (|r0 − r1| >= D, D = 0
    included) the hull is the larger sphere."""
    c0, c1 = np.asarray(c0, dtype=np.float64), np.asarray(c1, dtype=np.float64)
    distance = float(np.linalg.norm(c1 - c0))
    if distance == 0.0 or abs(r0 - r1) >= distance:
        centre, radius = (c0, r0) if r0 >= r1 else (c1, r1)
        local = np.eye(4)
        local[:3, 3] = centre
        return Intrinsic("capsule", world @ local, material, source, radius, radius, 0.0)
    frame, _ = _frame(c0, c1)
    sigma = (r0 - r1) / distance
    g = 1.0 / math.sqrt((1.0 - sigma) * (1.0 + sigma))  # (1 − σ)(1 + σ): no cancellation near |σ| = 1
    s = sigma * g
    rb, rt = r0 / g, r1 / g
    h = 0.5 * distance * (1.0 - sigma) * (1.0 + sigma)
    # The bottom sphere's centre, −h − s·r_b in the capsule's frame, must be c0 (z = 0 here).
    shift = np.eye(4)
    shift[2, 3] = h + s * rb
    return Intrinsic("capsule", world @ frame @ shift, material, source, rb, rt, h)


def basis_curves(ctx: ReadContext, prim: Usd.Prim, world: np.ndarray, material: PhongMaterial) -> list[Intrinsic]:
    """A BasisCurves prim's tube segments (empty after a problem, or for no curves)."""
    path = str(prim.GetPath())
    n_problems = len(ctx.problems)
    points = ctx.get(prim, "points", ("point3f[]", "point3d[]", "float3[]", "double3[]"))
    counts = ctx.get(prim, "curveVertexCounts", ("int[]",))
    if points is None or counts is None or not len(points) or not len(counts):
        return []
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    counts = np.asarray(counts, dtype=np.int64)
    kind = ctx.get(prim, "type", ("token",), UsdGeom.Tokens.cubic)
    basis = ctx.get(prim, "basis", ("token",), UsdGeom.Tokens.bezier)
    wrap = ctx.get(prim, "wrap", ("token",), UsdGeom.Tokens.nonperiodic)
    if kind not in (UsdGeom.Tokens.linear, UsdGeom.Tokens.cubic):
        ctx.problem(prim, "type", f"must be linear or cubic, got {kind!r}")
    if kind == UsdGeom.Tokens.cubic and basis not in BASIS_MATRICES:
        ctx.problem(prim, "basis", f"must be one of {', '.join(BASIS_MATRICES)}, got {basis!r}")
    if wrap not in WRAPS:
        ctx.problem(prim, "wrap", f"must be one of {', '.join(WRAPS)}, got {wrap!r}")
    if not np.isfinite(p).all():
        ctx.problem(prim, "points", f"{int(np.count_nonzero(~np.isfinite(p).all(axis=1)))} points are not finite")
    if (counts < 0).any() or int(counts.sum()) != len(p):
        ctx.problem(
            prim, "curveVertexCounts", f"must be >= 0 and sum to the {len(p)} points, got sum {int(counts.sum())}"
        )
    if not np.all(np.isfinite(world)) or is_singular(world[:3, :3]):
        ctx.problem(prim, "xformOpOrder", "the transform is not finite or singular")
    if len(ctx.problems) > n_problems:
        return []
    pinned = wrap == UsdGeom.Tokens.pinned and kind == UsdGeom.Tokens.cubic and basis != UsdGeom.Tokens.bezier
    starts = np.cumsum(counts) - counts
    per_curve = []
    for c, n in enumerate(counts):
        segments = _segments(kind, basis, wrap, int(n))
        if segments is None or not segments:
            ctx.problem(
                prim, "curveVertexCounts", f"curve {c} has {int(n)} vertices: too few for a {kind} {basis} {wrap} curve"
            )
            return []
        per_curve.append(segments)
    periodic = wrap == UsdGeom.Tokens.periodic
    varying_counts = [len(s) + (0 if periodic else 1) for s in per_curve]

    widths = ctx.get(prim, "widths", ("float[]", "double[]", "half[]"))
    interpolation = UsdGeom.BasisCurves(prim).GetWidthsInterpolation()
    if widths is None or not len(widths):
        ctx.unsupported[f"BasisCurves without widths (tubes {DEFAULT_CURVE_WIDTH:g} wide)"].append(path)
        w, interpolation = np.array([DEFAULT_CURVE_WIDTH]), UsdGeom.Tokens.constant
    else:
        w = np.asarray(widths, dtype=np.float64)
        if not (np.isfinite(w).all() and (w >= 0).all()):
            ctx.problem(prim, "widths", "values must be finite and >= 0")
            return []
    expected = {
        UsdGeom.Tokens.constant: 1,
        UsdGeom.Tokens.uniform: len(counts),
        UsdGeom.Tokens.varying: sum(varying_counts),
        UsdGeom.Tokens.faceVarying: sum(varying_counts),
        UsdGeom.Tokens.vertex: len(p),
    }.get(interpolation)
    if len(w) == 1 and interpolation != UsdGeom.Tokens.constant:
        interpolation, expected = UsdGeom.Tokens.constant, 1  # one value: the same everywhere
    if expected is None or len(w) != expected:
        ctx.problem(prim, "widths", f"has {len(w)} values, expected {expected} for {interpolation} interpolation")
        return []
    out: list[Intrinsic] = []
    varying_start = np.cumsum(varying_counts) - varying_counts
    for c, (start, n, segments) in enumerate(zip(starts, counts, per_curve)):
        cp = p[start : start + n]
        r_vertex = r_varying = None
        if interpolation == UsdGeom.Tokens.vertex:
            r_vertex = w[start : start + n] / 2
        elif interpolation in (UsdGeom.Tokens.varying, UsdGeom.Tokens.faceVarying):
            r_varying = w[varying_start[c] : varying_start[c] + varying_counts[c]] / 2
            if periodic:
                r_varying = np.append(r_varying, r_varying[0])
        else:
            r_vertex = np.full(len(cp), (w[c] if interpolation == UsdGeom.Tokens.uniform else w[0]) / 2)
        if pinned:
            cp = _pin(cp)
            r_vertex = None if r_vertex is None else _pin(r_vertex)
        pts, radii = _polyline(kind, basis, wrap, cp, r_vertex, r_varying, segments)
        radii = np.maximum(radii, 0.0)  # a cubic's overshoot below 0 draws nothing there
        for k in range(len(pts) - 1):
            if radii[k] > 0 or radii[k + 1] > 0:
                out.append(swept_segment(pts[k], radii[k], pts[k + 1], radii[k + 1], world, material, path))
    return out
