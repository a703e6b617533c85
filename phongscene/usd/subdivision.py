# SPDX-License-Identifier: Apache-2.0
"""Subdivision surfaces: a USD ``Mesh`` whose ``subdivisionScheme`` is ``catmullClark`` (USD's
fallback: every Mesh that does not say ``none``), ``loop`` or ``bilinear`` is refined by
OpenSubdiv (the library usdview, Storm, Cycles and Karma refine with) into the triangles both
backends trace. The refinement is uniform, ``phong:subdivisionLevel`` times (``DEFAULT_LEVEL``
when the prim does not say; 0: the control cage), with every refined vertex moved onto the limit
surface and smooth-shaded by the limit surface's normal there. USD's
``interpolateBoundary``, ``faceVaryingLinearInterpolation`` (the ``st`` coordinates of a
textured mesh are refined as OpenSubdiv's face-varying channel), ``triangleSubdivisionRule``,
creases (``creaseIndices``/``Lengths``/``Sharpnesses``), corners and ``holeIndices`` are
OpenSubdiv's own options, passed through. Authored normals do not apply (USD: a subdivided mesh's
normals are its surface's)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pxr import Usd, UsdGeom

from ..limits import MAX_SUBDIVISION_LEVEL
from .context import ReadContext
from .names import INT_TYPES, SUBDIVISION_LEVEL

# Two refinements: each cage quad becomes 16 smooth-shaded quads (32 triangles) with its
# vertices on the limit surface. Measured on a Catmull-Clark cube of size 2 (tests/usd/
# test_subdivision.py, edge midpoints against the limit): largest distance 0.12 at level 1,
# 0.038 at 2 (1.9 % of the size), 0.014 at 3, 0.0056 at 4, at the valence-3 corners. Blender's
# render default is 2 as well; a scene asks for more with phong:subdivisionLevel.
DEFAULT_LEVEL = 2
MAX_LEVEL = MAX_SUBDIVISION_LEVEL

SCHEMES = {
    UsdGeom.Tokens.catmullClark: "catmull_clark",
    UsdGeom.Tokens.loop: "loop",
    UsdGeom.Tokens.bilinear: "bilinear",
}
BOUNDARIES = {
    UsdGeom.Tokens.none: "none",
    UsdGeom.Tokens.edgeOnly: "edge_only",
    UsdGeom.Tokens.edgeAndCorner: "edge_and_corner",
}
FACE_VARYING = {
    UsdGeom.Tokens.none: "none",
    UsdGeom.Tokens.cornersOnly: "corners_only",
    UsdGeom.Tokens.cornersPlus1: "corners_plus1",
    UsdGeom.Tokens.cornersPlus2: "corners_plus2",
    UsdGeom.Tokens.boundaries: "boundaries",
    UsdGeom.Tokens.all: "all",
}
TRIANGLE_RULES = (UsdGeom.Tokens.catmullClark, UsdGeom.Tokens.smooth)


@dataclass(frozen=True)
class Refined:
    """A refined surface in the prim's own space: points on the limit surface (V, 3), their unit
    limit normals (V, 3), triangles (T, 3) wound as the cage, the cage face of each triangle
    (T,), and the refined st (uvs (U, 2), uv_triangles (T, 3)) when the cage had them."""

    points: np.ndarray
    normals: np.ndarray
    triangles: np.ndarray
    base_face: np.ndarray
    uvs: np.ndarray | None
    uv_triangles: np.ndarray | None


def level_of(ctx: ReadContext, prim: Usd.Prim) -> int | None:
    """The prim's refinement level (``phong:subdivisionLevel``, else the reader's override, else
    DEFAULT_LEVEL); None after a problem."""
    authored = ctx.get(prim, SUBDIVISION_LEVEL, INT_TYPES, None)
    level = ctx.subdivision_level if ctx.subdivision_level is not None else authored
    if level is None:
        return DEFAULT_LEVEL
    if not 0 <= int(level) <= MAX_LEVEL:
        ctx.problem(prim, SUBDIVISION_LEVEL, f"must be in 0..{MAX_LEVEL}, got {int(level)}")
        return None
    return int(level)


def _int_array(ctx: ReadContext, prim: Usd.Prim, name: str) -> np.ndarray:
    value = ctx.get(prim, name, ("int[]",), None)
    return np.zeros(0, dtype=np.int32) if value is None else np.asarray(value, dtype=np.int32)


def _sharpness(ctx: ReadContext, prim: Usd.Prim, name: str) -> np.ndarray | None:
    value = ctx.get(prim, name, ("float[]",), None)
    values = np.zeros(0, dtype=np.float32) if value is None else np.asarray(value, dtype=np.float32)
    if not np.all(np.isfinite(values)):
        ctx.problem(prim, name, "values must be finite")
        return None
    return values


def _token(ctx: ReadContext, prim: Usd.Prim, name: str, allowed, default: str) -> str | None:
    value = ctx.get(prim, name, ("token",), default)
    if value not in allowed:
        ctx.problem(prim, name, f"must be one of {', '.join(allowed)}, got {value!r}")
        return None
    return value


def _creases(ctx: ReadContext, prim: Usd.Prim, n_points: int):
    """USD's crease chains as (edge vertex pairs (E, 2), one sharpness per edge), or None."""
    indices = _int_array(ctx, prim, "creaseIndices")
    lengths = _int_array(ctx, prim, "creaseLengths")
    sharpness = _sharpness(ctx, prim, "creaseSharpnesses")
    if sharpness is None:
        return None
    if (lengths < 2).any():
        ctx.problem(prim, "creaseLengths", "every crease needs at least 2 vertices")
        return None
    if int(lengths.sum()) != len(indices):
        ctx.problem(
            prim, "creaseLengths", f"sums to {int(lengths.sum())}, but creaseIndices has {len(indices)} entries"
        )
        return None
    if ((indices < 0) | (indices >= n_points)).any():
        ctx.problem(prim, "creaseIndices", f"indices out of range [0, {n_points})")
        return None
    edges_per_crease = lengths - 1
    n_edges = int(edges_per_crease.sum())
    # One sharpness per crease, or one per edge of the chains (USD allows both).
    if len(sharpness) == len(lengths):
        per_edge = np.repeat(sharpness, edges_per_crease)
    elif len(sharpness) == n_edges:
        per_edge = sharpness
    else:
        ctx.problem(
            prim,
            "creaseSharpnesses",
            f"has {len(sharpness)} values, expected {len(lengths)} (one per crease) or {n_edges} (one per edge)",
        )
        return None
    # Edge k of a chain joins its vertices k and k + 1: every chain index but each chain's last.
    last = np.cumsum(lengths) - 1
    first_of_edge = np.setdiff1d(np.arange(len(indices)), last)
    pairs = np.stack([indices[first_of_edge], indices[first_of_edge + 1]], axis=1).astype(np.int32)
    return pairs.reshape(-1, 2), per_edge.astype(np.float32)


def refine(
    ctx: ReadContext,
    prim: Usd.Prim,
    scheme: str,
    points: np.ndarray,
    counts: np.ndarray,
    indices: np.ndarray,
    holes: np.ndarray,
    level: int,
    uv_values: np.ndarray | None,
    uv_of_corner: np.ndarray | None,
) -> Refined | None:
    """The cage (points (N, 3), faceVertexCounts, faceVertexIndices, already checked; faces of
    fewer than 3 vertices dropped by the caller) refined ``level`` (>= 1) times; None after a
    problem, or (with a warning naming the prim) where OpenSubdiv cannot refine it."""
    from phongscene.backends.native import _native  # the extension holds OpenSubdiv

    path = str(prim.GetPath())
    n_problems = len(ctx.problems)
    boundary = _token(ctx, prim, "interpolateBoundary", BOUNDARIES, UsdGeom.Tokens.edgeAndCorner)
    face_varying = _token(ctx, prim, "faceVaryingLinearInterpolation", FACE_VARYING, UsdGeom.Tokens.cornersPlus1)
    triangle_rule = _token(ctx, prim, "triangleSubdivisionRule", TRIANGLE_RULES, UsdGeom.Tokens.catmullClark)
    creases = _creases(ctx, prim, len(points))
    corners = _int_array(ctx, prim, "cornerIndices")
    corner_sharpness = _sharpness(ctx, prim, "cornerSharpnesses")
    if corner_sharpness is not None and len(corner_sharpness) != len(corners):
        ctx.problem(prim, "cornerSharpnesses", f"has {len(corner_sharpness)} values, expected {len(corners)}")
    if ((corners < 0) | (corners >= len(points))).any():
        ctx.problem(prim, "cornerIndices", f"indices out of range [0, {len(points)})")
    if len(ctx.problems) > n_problems:
        return None
    if scheme == UsdGeom.Tokens.loop and (counts != 3).any():
        ctx.unsupported["Loop subdivision of faces that are not triangles (the control cage is rendered)"].append(path)
        return None
    pairs, crease_sharpness = creases
    has_uv = uv_values is not None
    try:
        out = _native.refine_subdivision(
            np.ascontiguousarray(points, dtype=np.float64),
            np.ascontiguousarray(counts, dtype=np.int32),
            np.ascontiguousarray(indices, dtype=np.int32),
            getattr(_native.SubdivisionScheme, SCHEMES[scheme]),
            getattr(_native.BoundaryInterpolation, BOUNDARIES[boundary]),
            getattr(_native.FaceVaryingInterpolation, FACE_VARYING[face_varying]),
            triangle_rule == UsdGeom.Tokens.smooth,
            pairs,
            crease_sharpness,
            corners,
            corner_sharpness,
            np.ascontiguousarray(holes, dtype=np.int32),
            np.ascontiguousarray(uv_values if has_uv else np.zeros((0, 2)), dtype=np.float64),
            np.ascontiguousarray(uv_of_corner if has_uv else np.zeros(0), dtype=np.int32),
            level,
        )
    except ValueError as error:
        ctx.unsupported[
            f"subdivision surfaces OpenSubdiv cannot refine ({error}; the control cage is rendered)"
        ].append(path)
        return None
    return Refined(
        out["points"],
        out["normals"],
        out["triangles"],
        out["base_face"].astype(np.int64),
        out["uvs"] if has_uv else None,
        out["uv_triangles"] if has_uv else None,
    )
