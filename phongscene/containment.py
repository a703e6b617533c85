# SPDX-License-Identifier: Apache-2.0
"""Which transparent object a point (the camera) is inside, as POV-Ray decides it: POV-Ray keeps
the list of interiors each ray is in, and a camera ray starts in those of the objects containing
the camera. The native tracer's "povray" transmission convention starts its camera rays there
too (the "book" convention has no such list: it decides by the normal at each hit).

A sphere contains the points within it; a mesh those from which a ray along ``INSIDE_VECTOR``
crosses its triangles an odd number of times (POV-Ray's mesh ``inside_vector`` test: the POV-Ray
compiler writes the same vector). Exact shapes (Cube, Cylinder ...), instances and points are
never taken to contain the camera (POV-Ray's scenes here do not place a camera inside them)."""

from __future__ import annotations

import numpy as np

from .scene import PhongMaterial, Scene, TriangleMesh

# The direction of the crossing-parity test (POV-Ray's mesh2 inside_vector, as compile.py writes
# it): irrational components, so that no axis-aligned edge or face of a modelled mesh is met edge-on.
INSIDE_VECTOR = (0.2718281828, 0.5772156649, 0.7853981634)

# The parity test's triangles at a time: its numpy temporaries take ~230 bytes a triangle, which
# over a whole 12.8M-triangle glass mesh was 2.6 GB on top of the native scene (the chess set's
# `diff` peak); 65,536 at a time take ~15 MB, as fast.
CONTAINMENT_TRIANGLES_PER_SLICE = 1 << 16


def containing_interior(scene: Scene, point) -> PhongMaterial | None:
    """The material of the first transparent (kt > 0) sphere or mesh that contains ``point``, or
    None (media are not nested: one interior at a time)."""
    p = np.asarray(point, dtype=np.float64)
    for sphere in scene.spheres:
        if sphere.material.kt > 0:
            q = np.linalg.solve(sphere.world_from_object[:3, :3], p - sphere.world_from_object[:3, 3])
            if float(q @ q) < 1.0:
                return sphere.material
    for mesh in scene.meshes:
        if mesh.material.kt > 0 and mesh_contains(mesh, p):
            return mesh.material
    return None


def mesh_contains(mesh: TriangleMesh, point: np.ndarray) -> bool:
    """Whether a ray from ``point`` along INSIDE_VECTOR crosses the mesh an odd number of times
    (Möller-Trumbore against every triangle, vectorised over CONTAINMENT_TRIANGLES_PER_SLICE
    triangles at a time; t > 0)."""
    d = np.asarray(INSIDE_VECTOR) / np.linalg.norm(INSIDE_VECTOR)
    crossings = 0
    for start in range(0, len(mesh.triangles), CONTAINMENT_TRIANGLES_PER_SLICE):
        corners = mesh.points[mesh.triangles[start : start + CONTAINMENT_TRIANGLES_PER_SLICE]]
        e1, e2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
        pvec = np.cross(d, e2)
        det = np.einsum("ij,ij->i", e1, pvec)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / det
            tvec = point - corners[:, 0]
            u = np.einsum("ij,ij->i", tvec, pvec) * inv
            qvec = np.cross(tvec, e1)
            v = (qvec @ d) * inv
            t = np.einsum("ij,ij->i", e2, qvec) * inv
        crossings += int(np.count_nonzero((det != 0) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)))
    return bool(crossings % 2)
