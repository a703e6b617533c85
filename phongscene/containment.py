# SPDX-License-Identifier: Apache-2.0
"""Which transparent objects a point (the camera) is inside, as POV-Ray decides it: POV-Ray keeps
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


def containing_interiors(scene: Scene, point) -> list[tuple[int, PhongMaterial]]:
    """The transparent (kt > 0) spheres and meshes that contain ``point``, as (object, material)
    with objects numbered as ``Scene.objects`` (spheres, then meshes): the interiors a camera ray
    starts in, outermost first (the larger enclosed volume first; equal volumes in object order).
    POV-Ray orders a camera's interiors by its bounding tree instead (measured: a water ball in a
    glass ball, in either order in the SDL, gives one image, which changes when the water moves
    along z), so the two agree on one containing object, or on nested ones where its tree
    happens to list the outer first."""
    p = np.asarray(point, dtype=np.float64)
    found = []
    for k, sphere in enumerate(scene.spheres):
        if sphere.material.kt > 0:
            q = np.linalg.solve(sphere.world_from_object[:3, :3], p - sphere.world_from_object[:3, 3])
            if float(q @ q) < 1.0:
                volume = abs(np.linalg.det(sphere.world_from_object[:3, :3])) * 4.0 * np.pi / 3.0
                found.append((volume, k, sphere.material))
    for k, mesh in enumerate(scene.meshes):
        if mesh.material.kt > 0 and mesh_contains(mesh, p):
            found.append((enclosed_volume(mesh), len(scene.spheres) + k, mesh.material))
    found.sort(key=lambda entry: (-entry[0], entry[1]))
    return [(k, material) for _, k, material in found]


def enclosed_volume(mesh: TriangleMesh) -> float:
    """The volume a closed mesh encloses: |sum of its triangles' signed tetrahedra with the
    origin|, taken about the mesh's first point so that far-off meshes keep their precision."""
    total = 0.0
    origin = mesh.points[0]
    for start in range(0, len(mesh.triangles), CONTAINMENT_TRIANGLES_PER_SLICE):
        t = mesh.triangles[start : start + CONTAINMENT_TRIANGLES_PER_SLICE]
        a, b, c = (mesh.points[t[:, k]] - origin for k in range(3))
        total += float(np.einsum("ij,ij->", a, np.cross(b, c)))
    return abs(total) / 6.0


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
