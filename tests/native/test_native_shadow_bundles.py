# SPDX-License-Identifier: Apache-2.0
"""An area light's full grid is traced candidate by candidate, two rays at a time in SSE2 lanes
(native src/scene.cpp ``occluded_by_each``, shapes.hpp ``intersect_sphere_pair``). POV-Ray's
``adaptive k`` on a 2^k + 1 grid splits every region down to single cells, so it traces the same
grid points, one ray at a time (``occluded_by``), and weighs them with the same trapezoid weights.
Every ray must see the same occluders both ways: the two images then differ only by the order of
the sums, while one grid point seen differently moves its pixel by at least its weight (~1e-3).

The scenes put rays where the lanes' arithmetic is on edge: spheres under axis-aligned and general
transforms, grazing rays at penumbrae, and (``test_axis_parallel_rays_on_box_planes``) shaded
points on a candidate's box planes with rays parallel to them (direction component 0, reciprocal
inf, 0·inf = NaN in the box test)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from phongscene.backends import native
from phongscene.scene import Camera, RectAreaLight, RenderSettings, Sphere, SphereAreaLight, TriangleMesh
from support import calibration

# The two estimators add the same weights of the same visible points in different orders
# (a flat sum against nested means of quadrants): a few ulps of each pixel's value.
SUM_ORDER_RTOL = 1e-12
# ... and an absolute floor for pixels near 0 (the ambient term keeps most well above it).
SUM_ORDER_ATOL = 1e-15
NUMERICS = ("scale-invariant", "povray")


def every_point_one_at_a_time(scene):
    """The scene with each area light's grid traced through POV-Ray's recursion down to single
    cells (samples = 2^k + 1, adaptive k: every region splits, whatever its corners say)."""

    def deep(light):
        if not hasattr(light, "samples"):
            return light
        return dataclasses.replace(light, adaptive=int(np.log2(light.samples - 1)))

    return dataclasses.replace(scene, lights=tuple(deep(light) for light in scene.lights))


def assert_bundles_equal_single_rays(scene, numerics):
    settings = dataclasses.replace(scene.settings, numerics=numerics)
    bundled = native.render(scene, settings)
    single = native.render(every_point_one_at_a_time(scene), settings)
    np.testing.assert_allclose(bundled, single, rtol=SUM_ORDER_RTOL, atol=SUM_ORDER_ATOL)
    # The scene must have shadows to test: without the spheres, many pixels are brighter.
    unshadowed = native.render(dataclasses.replace(scene, spheres=(), meshes=scene.meshes[:1]), settings)
    assert (bundled < unshadowed * (1 - 1e-3)).sum() > 100


def sphere_cloud(rng, count: int):
    """Spheres, ellipsoids and rotated ellipsoids between the floor and the light."""
    spheres = []
    for i in range(count):
        m = np.diag([*rng.uniform(0.15, 0.45, 3), 1.0])
        if i % 3 == 2:  # a general linear part: the non-axis-aligned path
            m[:3, :3] = calibration.rotation(rng.normal(size=3), float(rng.uniform(10, 80)))[:3, :3] @ m[:3, :3]
        elif i % 3 == 0:  # a plain sphere
            m[:3, :3] = np.eye(3) * m[0, 0]
        m[:3, 3] = [rng.uniform(-2.5, 2.5), rng.uniform(0.4, 2.2), rng.uniform(-2.5, 2.5)]
        spheres.append(Sphere(m, calibration.RED))
    return tuple(spheres)


@pytest.mark.parametrize("numerics", NUMERICS)
@pytest.mark.parametrize("light", ["rect", "sphere"])
def test_full_grid_bundles_equal_single_rays(light, numerics):
    rng = np.random.default_rng(5)
    area = (
        RectAreaLight(
            center=(0.37, 4.6, -0.21), axis_u=(2.3, 0.0, 0.4), axis_v=(-0.3, 0.2, 1.9), color=(2.1, 2.0, 1.9), samples=9
        )
        if light == "rect"
        else SphereAreaLight(center=(-0.43, 4.2, 0.57), radius=1.1, color=(2.0, 2.1, 1.9), samples=9)
    )
    scene = dataclasses.replace(
        calibration.point_light(),
        camera=calibration.look_at((0.3, 6.5, 7.9), (0.0, 0.5, 0.0), 55.0),
        lights=(area,),
        # ... and one around the light's edge: rays to the samples inside it leave it beyond
        # their t_max (only its near root counts).
        spheres=(*sphere_cloud(rng, 14), Sphere.at(tuple(np.add(area.center, (0.9, 0.0, 0.2))), 0.5, calibration.GOLD)),
        settings=RenderSettings(width=96, height=72, threads=2),
    )
    # Triangles too (tested behind their boxes): a faceted icosphere among the spheres.
    ball = calibration.icosphere(1, (-1.3, 1.4, 0.9), 0.55, calibration.BLUE, smooth=False)
    scene = dataclasses.replace(scene, meshes=(*scene.meshes, ball))
    assert_bundles_equal_single_rays(scene, numerics)


@pytest.mark.parametrize("numerics", NUMERICS)
def test_axis_parallel_rays_on_box_planes(numerics):
    # An orthographic camera straight down: pixel (i, j)'s floor point is exactly
    # ((2i + 1)/32 − 2, 0, (2j + 1)/32 − 2), and the light's 5 × 5 samples sit at x and z in
    # 1/32 + {−1, −1/2, 0, 1/2, 1}: from pixels i, j in {16, 24, 32, 40, 48} some rays have a
    # direction component exactly 0. The spheres' boxes have planes at x = 1/32 or z = 1/32 + 1/2
    # (floats, so the boxes are exact): those rays run inside the planes.
    camera = Camera(
        position=(0.0, 10.0, 0.0),
        forward=(0.0, -1.0, 0.0),
        up=(0.0, 0.0, -1.0),
        projection="orthographic",
        ortho_width=4.0,
    )
    light = RectAreaLight(
        center=(1 / 32, 4.0, 1 / 32), axis_u=(2.0, 0.0, 0.0), axis_v=(0.0, 0.0, 2.0), color=(2.0, 2.0, 2.0), samples=5
    )
    spheres = (
        Sphere.at((1 / 32 + 0.75, 1.5, 1 / 32 + 0.25), 0.75, calibration.RED),  # box x from 1/32
        Sphere.at((-0.75, 2.0, 1 / 32 + 0.5 + 0.5), 0.5, calibration.GREEN),  # box z from 1/32 + 1/2
        Sphere(
            np.diag([0.25, 0.5, 1.0, 1.0])
            + np.array([[0, 0, 0, 1 / 32 - 0.25 - 1.0], [0, 0, 0, 1.0], [0, 0, 0, -1.0], [0, 0, 0, 0]]),
            calibration.BLUE,
        ),
    )
    # A quad at y = 2.5 whose box's planes are x = 1/32 and z = 1/32 + 1/2 (its triangles are
    # tested behind their boxes, spheres are not).
    quad = TriangleMesh(
        points=[
            (1 / 32 - 1.5, 2.5, 1 / 32 + 0.5),
            (1 / 32, 2.5, 1 / 32 + 0.5),
            (1 / 32, 2.5, 1 / 32 + 1.5),
            (1 / 32 - 1.5, 2.5, 1 / 32 + 1.5),
        ],
        triangles=[(0, 2, 1), (0, 3, 2)],
        material=calibration.GOLD,
    )
    scene = dataclasses.replace(
        calibration.point_light(),
        camera=camera,
        lights=(light,),
        spheres=spheres,
        meshes=(*calibration.point_light().meshes, quad),
        settings=RenderSettings(width=64, height=64, threads=2),
    )
    assert_bundles_equal_single_rays(scene, numerics)
