# SPDX-License-Identifier: Apache-2.0
"""A Scene keeps the flat normals of its small meshes without vertex normals, up to
MAX_CACHED_FLAT_NORMALS triangles, instead of computing each at every hit (native
src/scene.hpp, kMaxCachedFlatNormals). Both come from one expression (flat_triangle_normal, on
the corners as stored), so a kept normal is the number the hit would compute; what can go wrong
is which triangle's normal a hit reads, and which meshes are kept: the same mesh must render
the same image whether its normals are kept or computed."""

from __future__ import annotations

import numpy as np
import pytest
from test_native_intersect import jittered_grid

from phongscene.backends import native
from phongscene.backends.native import _native
from phongscene.scene import AmbientLight, PhongMaterial, PointLight, RenderSettings, Scene, TriangleMesh
from support import calibration


def tilted_bumpy_grid(n: int, float_corners: bool) -> TriangleMesh:
    """A jittered n×n grid, its vertices also jittered in depth and the whole turned about an
    oblique axis: flat triangles whose normals are none of the axes (normalising them rounds)."""
    grid = jittered_grid(n, seed=3)
    rng = np.random.default_rng(5)
    points = grid.points - n / 2.0
    points[:, 2] += rng.uniform(-0.2, 0.2, size=len(points))
    axis = np.array([1.0, 2.0, 0.5]) / np.linalg.norm([1.0, 2.0, 0.5])
    angle = 0.7
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    rotation = np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k
    points = points @ rotation.T
    if float_corners:  # float-exact corners: the store keeps them as floats
        points = points.astype(np.float32).astype(np.float64)
    material = PhongMaterial(ka=0.1, kd=0.6, ks=0.5, exponent=30.0, diffuse_color=(0.7, 0.6, 0.4))
    return TriangleMesh(points=points, triangles=grid.triangles, material=material)


def far_flat_mesh(triangles: int) -> TriangleMesh:
    """``triangles`` flat triangles far behind the camera and the light: no ray of the image
    reaches them, so they change which normals are kept and nothing else."""
    corners = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    offsets = np.zeros((triangles, 1, 3))
    offsets[:, 0, 0] = 2.0 * np.arange(triangles)
    points = (corners + offsets + np.array([0.0, 0.0, 1e3])).reshape(-1, 3)
    return TriangleMesh(points=points, triangles=np.arange(3 * triangles).reshape(-1, 3))


def scene_of(*meshes: TriangleMesh) -> Scene:
    return Scene(
        camera=calibration.look_at((0.0, 0.0, -9.0), (0.0, 0.0, 0.0), horizontal_fov_deg=45.0),
        ambient=AmbientLight((0.1, 0.1, 0.1)),
        lights=(PointLight((-6.0, 8.0, -10.0), (1.2, 1.2, 1.2)),),
        meshes=meshes,
        settings=RenderSettings(width=48, height=36),
    )


@pytest.mark.parametrize("float_corners", [False, True])
def test_a_mesh_renders_the_same_with_its_flat_normals_kept_or_computed(float_corners):
    grid = tilted_bumpy_grid(6, float_corners)
    kept = native.render(scene_of(grid))  # 72 triangles: kept
    # A far mesh first that takes every kept row: the grid's normals are computed at each hit.
    computed = native.render(scene_of(far_flat_mesh(_native.MAX_CACHED_FLAT_NORMALS), grid))
    # ... and one just too big to keep, after which the grid's are kept again.
    kept_after = native.render(scene_of(far_flat_mesh(_native.MAX_CACHED_FLAT_NORMALS + 1), grid))
    assert (kept > 0.0).any(axis=2).mean() > 0.5  # the grid fills most of the image
    np.testing.assert_array_equal(kept, computed)
    np.testing.assert_array_equal(kept, kept_after)
