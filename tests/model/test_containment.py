# SPDX-License-Identifier: Apache-2.0
"""phongscene.containment: the transparent object around the camera (POV-Ray's interior list
starts there), by a sphere's equation and a mesh's crossing parity, at unit, tiny and huge
scales; opaque objects never contain it; parity is all an open mesh gets."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from phongscene.containment import containing_interiors, enclosed_volume, mesh_contains
from phongscene.scene import PhongMaterial, Scene, Sphere
from support import calibration

GLASS = PhongMaterial(ka=0.0, kd=0.0, ks=0.0, kt=0.9, ior=1.5)


@pytest.mark.parametrize("scale", [1e-6, 1.0, 1e5])
def test_a_box_mesh_contains_what_is_inside_it(scale):
    box = calibration.box_mesh((-1 * scale, -2 * scale, -3 * scale), (1 * scale, 2 * scale, 3 * scale), GLASS)
    for point, inside in [((0, 0, 0), True), ((0.9, 1.9, -2.9), True), ((1.1, 0, 0), False), ((0, 0, -3.5), False)]:
        assert mesh_contains(box, np.asarray(point, dtype=np.float64) * scale) == inside, point


def test_the_camera_interiors_are_the_transparent_objects_around_it():
    ball = Sphere.at((0.0, 0.0, 0.0), 2.0, GLASS)
    opaque = Sphere.at((5.0, 0.0, 0.0), 2.0, PhongMaterial())
    box = calibration.box_mesh((9.0, -1.0, -1.0), (11.0, 1.0, 1.0), dataclasses.replace(GLASS, ior=1.33))
    scene = Scene(spheres=(ball, opaque), meshes=(box,))
    assert containing_interiors(scene, (0.5, 0.5, 0.5)) == [(0, ball.material)]
    assert containing_interiors(scene, (5.0, 0.0, 0.0)) == []  # opaque: no interior
    assert containing_interiors(scene, (10.0, 0.0, 0.0)) == [(2, box.material)]  # objects: spheres, meshes
    assert containing_interiors(scene, (3.0, 0.0, 0.0)) == []


def test_nested_objects_each_contain_the_camera():
    water = dataclasses.replace(GLASS, ior=1.33)
    glass = Sphere.at((0.0, 0.0, 0.0), 3.0, GLASS)
    drop = Sphere.at((0.0, 0.0, 0.0), 1.0, water)
    scene = Scene(spheres=(glass, drop))
    assert containing_interiors(scene, (0.1, 0.0, 0.0)) == [(0, GLASS), (1, water)]
    assert containing_interiors(scene, (2.0, 0.0, 0.0)) == [(0, GLASS)]
    # outermost first, whatever the scene's order: the larger enclosed volume first
    scene = Scene(spheres=(drop, glass))
    assert containing_interiors(scene, (0.1, 0.0, 0.0)) == [(1, GLASS), (0, water)]
    cube = calibration.box_mesh((-2.0, -2.0, -2.0), (2.0, 2.0, 2.0), GLASS)  # 64 > the drop's 4π/3
    scene = Scene(spheres=(drop,), meshes=(cube,))
    assert containing_interiors(scene, (0.1, 0.0, 0.0)) == [(1, GLASS), (0, water)]


@pytest.mark.parametrize("offset", [0.0, 1e6])
def test_the_enclosed_volume_of_a_box_mesh(offset):
    box = calibration.box_mesh((offset - 1.0, -2.0, -3.0), (offset + 1.0, 2.0, 3.0), GLASS)
    assert enclosed_volume(box) == pytest.approx(48.0, rel=1e-12)


def test_a_point_whose_ray_crosses_no_face_is_outside():
    quad = calibration.ground_quad(0.0, GLASS)
    assert not mesh_contains(quad, np.array([0.0, 1.0, 0.0]))  # above it, the ray crosses nothing
    assert mesh_contains(quad, np.array([0.0, -1.0, 0.0]))  # below, once: parity says inside


@pytest.mark.parametrize("per_slice", [1, 5])
def test_the_parity_is_counted_across_slices_of_triangles(monkeypatch, per_slice):
    # A large glass mesh is tested CONTAINMENT_TRIANGLES_PER_SLICE triangles at a time (bounded
    # memory); the crossings of every slice add up to the whole mesh's parity.
    from phongscene import containment

    box = calibration.box_mesh((-1.0, -2.0, -3.0), (1.0, 2.0, 3.0), GLASS)
    points = np.random.default_rng(7).uniform(-4.0, 4.0, size=(200, 3))
    whole = [mesh_contains(box, p) for p in points]
    assert 0 < sum(whole) < len(points)
    monkeypatch.setattr(containment, "CONTAINMENT_TRIANGLES_PER_SLICE", per_slice)
    assert [mesh_contains(box, p) for p in points] == whole
