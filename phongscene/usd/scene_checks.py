# SPDX-License-Identifier: Apache-2.0
"""Checks of the scene as read, where another renderer or the image would show it otherwise:
single-sided meshes whose back the camera may see (drawn from both sides here), and lights
alone brighter than an sRGB image holds. Each is a warning; nothing is changed."""

from __future__ import annotations

import math

import numpy as np
from pxr import Usd, UsdGeom

from ..scene import DirectionalLight, Scene
from .context import ReadContext

# A light is said to clip when the median radiance it gives a white surface exceeds this: one
# stop above what an sRGB image holds (1), so a light that brings white to exactly white (our
# head light and seed examples) or a little above is left alone.
CLIP_RADIANCE = 2.0
# Points of the geometry sampled to judge how bright a light makes the scene (a fixed, evenly
# spaced selection: deterministic).
CLIP_SAMPLE_POINTS = 1024


def _median(values: np.ndarray) -> float:
    """np.median of finite ``values``, the same value: np.median imports numpy.ma for its NaN
    check, ~40 ms of every render's start-up (issue 15); these values are finite."""
    n = len(values)
    middle = np.partition(values, [(n - 1) // 2, n // 2])
    return float((middle[(n - 1) // 2] + middle[n // 2]) / 2)


def warn_clipping_lights(ctx: ReadContext, scene: Scene) -> None:
    """A light alone brighter than an sRGB image holds: where the median of the radiance it gives a
    white Lambert surface facing it, over points of the geometry (shadows ignored), exceeds
    CLIP_RADIANCE, a PNG clips most of what it lights to white. Said per light, with the exposure change that
    brings that median to 1 (UsdLux ``inputs:exposure``)."""
    points = [
        m.points[:: max(1, len(m.points) * max(1, len(scene.meshes)) // CLIP_SAMPLE_POINTS)] for m in scene.meshes
    ]
    points += [s.world_from_object[:3, 3][None, :] for s in scene.spheres]
    points += [g.centers[:: max(1, len(g) // CLIP_SAMPLE_POINTS)] for g in scene.points]
    if not points:
        return
    p = np.concatenate(points)
    for light in scene.lights:
        colour = float(np.max(light.color))
        if isinstance(light, DirectionalLight) or light.falloff == "none":
            irradiance = np.full(len(p), colour)
        else:
            centre = np.asarray(getattr(light, "position", getattr(light, "center", None)), dtype=np.float64)
            d2 = np.maximum(((p - centre) ** 2).sum(axis=1), 1e-300)
            with np.errstate(over="ignore"):  # a light at a point of the geometry: inf, said as such
                irradiance = colour / d2
        radiance = _median(irradiance) / math.pi
        if radiance > CLIP_RADIANCE:
            ctx.warn(
                f"{light.source}: lights a white surface to radiance {radiance:.3g} at the median point of the "
                f"geometry, which an sRGB image clips to white; inputs:exposure {-math.log2(radiance):+.2f} would bring it to 1"
            )


# Triangles per block of the facing test: its temporaries (corners, edges, normals: ~200 B a
# triangle) stay ~100 MiB however big the mesh (10M triangles at once peaked at 2.7 GiB).
FACING_BLOCK = 500_000


def _faces_away(points: np.ndarray, triangles: np.ndarray, eye: np.ndarray) -> bool:
    """Whether any triangle faces away from the eye (block by block; stops at the first)."""
    for start in range(0, len(triangles), FACING_BLOCK):
        p = points[triangles[start : start + FACING_BLOCK]]
        facing = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 0] - eye)
        if np.any(facing > 0):
            return True
    return False


def _closed(triangles: np.ndarray, n_points: int) -> bool:
    """Whether every edge is used by exactly two triangles. Each edge is one int64 key
    (lo·n + hi), sorted in place: closed when the sorted keys come in equal pairs, each pair
    unlike the next (8 bytes an edge, no (E, 2) pair arrays or np.unique's copies)."""
    keys = np.empty(3 * len(triangles), dtype=np.int64)
    for k, (i, j) in enumerate(((0, 1), (1, 2), (2, 0))):
        a, b = triangles[:, i], triangles[:, j]
        lo = np.minimum(a, b).astype(np.int64)
        lo *= n_points
        lo += np.maximum(a, b)
        keys[k * len(triangles) : (k + 1) * len(triangles)] = lo
    keys.sort()
    if len(keys) % 2:
        return False
    first, second = keys[0::2], keys[1::2]
    return bool(np.array_equal(first, second) and np.all(second[:-1] != first[1:]))


def warn_single_sided(ctx: ReadContext, stage: Usd.Stage, scene: Scene) -> None:
    """phongscene shades every surface from both sides (Suffern's model, and POV-Ray, which has no
    back-face culling for mesh2, so both backends agree); USD renderers cull the back of a mesh
    with ``doubleSided = false`` (USD's fallback). Said once, listing the single-sided meshes whose
    back the camera may see: open ones (a closed mesh hides its back faces) with a triangle facing
    away from the camera."""
    eye = np.asarray(scene.camera.position, dtype=np.float64)
    seen = []
    for mesh in scene.meshes:
        prim = stage.GetPrimAtPath(mesh.source)
        if not prim or not prim.IsA(UsdGeom.Mesh) or UsdGeom.Mesh(prim).GetDoubleSidedAttr().Get(ctx.time):
            continue
        if _faces_away(mesh.points, mesh.triangles, eye) and not _closed(mesh.triangles, len(mesh.points)):
            seen.append(mesh.source)
    if seen:
        ctx.unsupported[
            "single-sided meshes (doubleSided = false) whose back the camera may see, shaded from both "
            "sides as POV-Ray does (USD renderers would not draw the back)"
        ].extend(seen)
