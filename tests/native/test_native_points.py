# SPDX-License-Identifier: Apache-2.0
"""``Points`` (a UsdGeom.Points set of spheres, 32 bytes each) in the native tracer: each ball is
traced as ``Sphere.at(center, radius)`` with the same numbers (src/shapes.hpp: BallShape), so a
Points set and the same spheres one by one render identical images, under point lights, area
lights (the shadow-bundle path) and light linking, in both numerics; mixed with spheres, meshes
and intrinsic prims, nothing else changes."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from phongscene.backends import native
from phongscene.scene import (
    Camera,
    Intrinsic,
    Linking,
    PhongMaterial,
    PointLight,
    Points,
    RectAreaLight,
    RenderSettings,
    Scene,
    Sphere,
)
from support.calibration import ground_quad

RED = PhongMaterial(diffuse_color=(0.8, 0.25, 0.2), ks=0.4, exponent=20.0)
BLUE = PhongMaterial(diffuse_color=(0.2, 0.3, 0.8))
GREY = PhongMaterial(diffuse_color=(0.6, 0.6, 0.6))


def cloud(n: int = 200, seed: int = 5, scale: float = 1.0, offset=(0.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """Random centres in a box above the ground and radii that make the spheres overlap and
    shadow each other, at any ``scale``."""
    rng = np.random.default_rng(seed)
    centers = (rng.random((n, 3)) * (4.0, 2.0, 4.0) + (-2.0, 0.3, -2.0)) * scale + np.asarray(offset) * scale
    radii = (rng.random(n) * 0.25 + 0.05) * scale
    return centers, radii


def scene_of(geometry: dict, lights, scale: float = 1.0, numerics: str = "scale-invariant") -> Scene:
    return Scene(
        camera=Camera.look_at(np.array((0.3, 3.0, 7.5)) * scale, np.array((0.0, 0.8, 0.0)) * scale),
        lights=tuple(lights),
        settings=RenderSettings(width=96, height=72, numerics=numerics),
        **geometry,
    )


def both(centers, radii, lights, scale=1.0, extra=None, numerics="scale-invariant", material=RED, source="/Cloud"):
    """The images of a Points set and of the same spheres one by one (with ``extra`` geometry)."""
    extra = extra or {}
    as_spheres = tuple(Sphere.at(c, r, material, source) for c, r in zip(centers, radii))
    a = native.render(
        scene_of({**extra, "spheres": (*extra.get("spheres", ()), *as_spheres)}, lights, scale=scale, numerics=numerics)
    )
    b = native.render(
        scene_of({**extra, "points": (Points(centers, radii, material, source),)}, lights, scale, numerics)
    )
    return a, b


@pytest.mark.parametrize("scale", [1e-6, 1.0, 1e6])
def test_a_points_set_renders_as_its_spheres(scale):
    centers, radii = cloud(scale=scale, offset=(3.0, 0.0, -1.0))
    a, b = both(centers, radii, [PointLight(np.array((3.0, 6.0, 4.0)) * scale, (1.0, 1.0, 1.0))], scale)
    assert a.max() > 0.1  # something is lit
    assert np.array_equal(a, b)


def test_area_light_shadows_of_points_as_of_spheres():
    """Shadow-ray bundles (shadow_bundles.cpp) test balls as spheres: the same penumbrae."""
    centers, radii = cloud(60)
    light = RectAreaLight((1.0, 5.0, 2.0), (1.5, 0.0, 0.0), (0.0, 0.0, 1.5), (1.0, 1.0, 1.0), samples=5)
    ground = {"meshes": (ground_quad(0.0, GREY),)}
    a, b = both(centers, radii, [light], extra=ground)
    assert np.array_equal(a, b)


def test_points_among_every_other_kind_of_geometry():
    """Spheres, a mesh and an intrinsic prim beside a Points set: the refs of each kind (balls
    between the spheres and the intrinsic parts) name the right primitive."""
    centers, radii = cloud(80)
    box = np.array([[0.5, 0, 0, -2.5], [0, 0.5, 0, 0.5], [0, 0, 0.5, 2.0], [0, 0, 0, 1]])
    extra = {
        "spheres": (Sphere.at((0.0, 1.0, 2.5), 0.6, BLUE, "/Ball"),),
        "meshes": (ground_quad(0.0, GREY),),
        "intrinsics": (Intrinsic("cube", box, BLUE, "/Box"),),
    }
    lights = [PointLight((3.0, 6.0, 4.0), (0.7, 0.7, 0.7)), PointLight((-4.0, 3.0, 2.0), (0.4, 0.5, 0.6))]
    a, b = both(centers, radii, lights, extra=extra)
    assert np.array_equal(a, b)
    a, b = both(centers, radii, lights, extra=extra, numerics="povray")
    assert np.array_equal(a, b)


def test_light_linking_names_a_points_set_as_one_object():
    """A light that neither lights nor is shadowed by the set: the set is one object, named by its
    source, whose every ball follows the link."""
    centers, radii = cloud(50)
    ground = {"meshes": (dataclasses.replace(ground_quad(0.0, GREY), source="/Ground"),)}
    linking = Linking(illuminates=frozenset({"/Ground"}), shadowed_by=frozenset({"/Ground"}))
    lights = [PointLight((3.0, 6.0, 4.0), (0.8, 0.8, 0.8), linking=linking), PointLight((-3, 4, 5), (0.3, 0.3, 0.3))]
    a, b = both(centers, radii, lights, extra=ground)
    assert np.array_equal(a, b)
    unlinked = native.render(
        scene_of(
            {**ground, "points": (Points(centers, radii, RED, "/Cloud"),)},
            [dataclasses.replace(lights[0], linking=Linking()), lights[1]],
        )
    )
    assert not np.array_equal(b, unlinked)  # the link changed the image (it is not ignored)


def test_two_sets_keep_their_materials():
    c1, r1 = cloud(40, seed=1)
    c2, r2 = cloud(40, seed=2)
    lights = [PointLight((3.0, 6.0, 4.0), (1.0, 1.0, 1.0))]
    spheres = tuple(Sphere.at(c, r, RED, "/A") for c, r in zip(c1, r1)) + tuple(
        Sphere.at(c, r, BLUE, "/B") for c, r in zip(c2, r2)
    )
    a = native.render(scene_of({"spheres": spheres}, lights))
    b = native.render(scene_of({"points": (Points(c1, r1, RED, "/A"), Points(c2, r2, BLUE, "/B"))}, lights))
    assert np.array_equal(a, b)


def test_ray_hits_name_balls_after_every_other_primitive():
    """primitive ids (closest_hits): spheres, triangles, intrinsic parts, then the balls by row."""
    points = Points([[0.0, 0.0, -5.0], [2.0, 0.0, -5.0]], [0.5, 0.5], RED)
    scene = scene_of({"spheres": (Sphere.at((-2.0, 0.0, -5.0), 0.5, RED),), "points": (points,)}, [])
    built = native.build(dataclasses.replace(scene, lights=(PointLight((0, 0, 0), (1, 1, 1)),)))
    origins = np.zeros((3, 3))
    dirs = np.array([[0.0, 0.0, -1.0], [2.0, 0.0, -5.0], [-2.0, 0.0, -5.0]])
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    t, ids = built.intersect(origins, dirs)
    assert list(ids) == [1, 2, 0]
    assert t[0] == pytest.approx(4.5, rel=1e-15)
    counts, closest = built.count_hits(origins, dirs)
    assert list(counts) == [1, 1, 1] and np.array_equal(closest, t)


def test_bad_arrays_are_refused_not_crashed_on():
    """Python validates scenes; the extension still refuses a radius that is not positive."""
    arrays = native.scene_arrays(scene_of({"points": (Points([[0.0, 0.0, 0.0]], [1.0], RED),)}, []))
    with pytest.raises(ValueError, match="radius"):
        native._native.Scene(**dict(arrays, ball_radii=[np.array([-1.0])]))
    with pytest.raises(ValueError, match="differ in length"):
        native._native.Scene(**dict(arrays, ball_radii=[np.array([1.0, 2.0])]))
