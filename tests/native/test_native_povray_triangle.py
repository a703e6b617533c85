# SPDX-License-Identifier: Apache-2.0
"""POV-Ray's mesh2 triangle test is not watertight, and the native tracer in POV-Ray's numerics
reproduces it (backends/native/src/povray_triangle.hpp).

POV-Ray stores each triangle's plane as a float32 normal and a float32 distance, so the plane is
slightly off the triangle's (float32) vertices; a ray grazing a quad near its diagonal can find
the two triangles' rounded planes on either side of the edge and miss both. The scene: a flat
parallelogram split along its diagonal, seen by an orthographic camera 6e-9 wide at 1.7° from
the plane, straddling the diagonal: POV-Ray sees background through the crack.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from phongscene import render
from phongscene.scene import AmbientLight, Camera, PhongMaterial, RenderSettings, Scene, TriangleMesh
from support import oracle

# A parallelogram A, B, C, D = A + C − B (float32 values), split along A–C.
A = (0.18905338644981384, -0.5227484703063965, -0.41306355595588684)
B = (-2.44146728515625, 1.7997074127197266, 1.1441658735275269)
C = (-0.32542282342910767, 0.7738065719604492, 0.28121066093444824)
D = (2.305097818374634, -1.5486491918563843, -1.276018738746643)
# The view: rays at this slope to the plane, across the diagonal at this fraction of A–C.
GRAZING_SLOPE = 0.03
DIAGONAL_FRACTION = 0.6
VIEW_WIDTH = 6e-9


def quad_scene() -> Scene:
    a, b, c = (np.array(p) for p in (A, B, C))
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n)
    e = (c - a) / np.linalg.norm(c - a)
    forward = np.cross(n, e) - GRAZING_SLOPE * n
    forward /= np.linalg.norm(forward)
    up = e - forward * (e @ forward)
    centre = a + (c - a) * DIAGONAL_FRACTION
    camera = Camera(
        position=tuple(centre - 2.0 * forward),
        forward=tuple(forward),
        up=tuple(up / np.linalg.norm(up)),
        projection="orthographic",
        ortho_width=VIEW_WIDTH,
    )
    white = PhongMaterial(ka=1.0, kd=0.0, ks=0.0, exponent=1.0, diffuse_color=(1.0, 1.0, 1.0))
    mesh = TriangleMesh(
        points=np.array([A, B, C, A, C, D]), triangles=np.arange(6, dtype=np.int32).reshape(2, 3), material=white
    )
    return Scene(
        camera=camera,
        meshes=(mesh,),
        lights=(),
        ambient=AmbientLight(color=(1.0, 1.0, 1.0)),
        settings=RenderSettings(width=64, height=16, numerics="povray"),
    )


def _f32(x) -> np.ndarray:
    return np.asarray(x, dtype=np.float32).astype(np.float64)


def povray_rule_hits(p1, p2, p3, origins: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """POV-Ray's mesh triangle test, written here from docs/povray-3.7-semantics.md §7 (the
    independent reference for the C++ one): plane of float32 normal and distance, depth cut
    1e-6, inside test of the projection along the dominant axis after POV-Ray's reordering."""
    p1, p2, p3 = _f32(p1), _f32(p2), _f32(p3)
    normal = np.cross(p3 - p1, p2 - p1)
    normal /= np.linalg.norm(normal)
    distance = float(np.float32(-normal @ p1))
    x, y, z = np.abs(normal)
    dominant = (0 if x > z else 2) if x > y else (1 if y > z else 2)
    a, b = {0: (1, 2), 1: (0, 2), 2: (0, 1)}[dominant]
    if (p2[a] - p3[a]) * (p2[b] - p1[b]) < (p2[b] - p3[b]) * (p2[a] - p1[a]):
        p1, p2 = p2, p1
    nf = _f32(normal)
    n_dot_d = directions @ nf
    depth = -(distance + origins @ nf) / n_dot_d
    s = origins[:, a] + depth * directions[:, a]
    t = origins[:, b] + depth * directions[:, b]
    hit = (np.abs(n_dot_d) >= 1e-10) & (depth >= 1e-6)
    for q, r in ((p2, p1), (p3, p2), (p1, p3)):
        hit &= ~((q[a] - s) * (q[b] - r[b]) < (q[b] - t) * (q[a] - r[a]))
    return hit


def _background(image: np.ndarray) -> np.ndarray:
    return image[..., 0] == 0.0


def test_native_povray_numerics_follow_povrays_rule_through_the_crack():
    scene = quad_scene()
    w, h = scene.settings.width, scene.settings.height
    cols, rows = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    origins, directions = oracle.camera_rays(scene.camera, w, h, cols.ravel(), rows.ravel())
    missed = ~povray_rule_hits(A, B, C, origins, directions) & ~povray_rule_hits(A, C, D, origins, directions)
    expected = missed.reshape(h, w)
    assert 0 < expected.sum() < expected.size  # a crack, inside the view
    np.testing.assert_array_equal(_background(render(scene, "native")), expected)
    # The default (watertight) test has no crack.
    watertight = render(scene, "native", dataclasses.replace(scene.settings, numerics="scale-invariant"))
    assert not _background(watertight).any()


@pytest.mark.povray
def test_povray_sees_through_the_crack_where_native_does():
    scene = quad_scene()
    pov = render(scene, "povray")
    assert _background(pov).any()
    np.testing.assert_array_equal(_background(pov), _background(render(scene, "native")))
