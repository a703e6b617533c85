# SPDX-License-Identifier: Apache-2.0
"""A packet's primary hits are lit in AVX double lanes (backends/native/src/lane_shading.hpp)
where every light is a point light without fade or cone and the material has no texture,
checker, mirror or transmission. The lanes run shade_hit's and shade_phong's IEEE operations in
the same order, so every pixel must be the one-by-one shading's to the bit: the SSE2 path
(PHONGSCENE_NATIVE_SIMD=sse2) never takes the lanes, and the two images are compared exactly, on
every calibration scene and on random scenes that mix lanes and fallbacks in one packet (plain
and textured, mirror or checkered materials; lights inside objects, on surfaces and behind them;
huge, zero and fractional exponents; both specular conventions; partial packets).

A float32 pixel hides a last-bit difference of its double colour. The lanes were also checked
with a build that stores each colour's low 32 bits in place of the float (these tests at 200
random scenes: equal; a dot product summed in another order: caught)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_native_simd_dispatch import built_with, needs_avx2, render_with

from phongscene.scene import Cone, Intrinsic, PhongMaterial, PointLight, Points, Sphere
from support import calibration

pytestmark = needs_avx2


def both_paths(monkeypatch, scene):
    return render_with(monkeypatch, scene, "avx2"), render_with(monkeypatch, scene, "sse2")


@pytest.mark.parametrize("name", sorted(calibration.SCENES))
@pytest.mark.parametrize("convention", ["seed", "povray-classic"])
def test_every_calibration_scene_shades_as_one_by_one(monkeypatch, name, convention):
    scene = calibration.SCENES[name]()
    scene = dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, specular=convention))
    lanes, one_by_one = both_paths(monkeypatch, scene)
    assert lanes.tobytes() == one_by_one.tobytes()


@pytest.mark.parametrize(
    ("name", "expected"),
    [
        ("point_light", True),
        ("shadows_two_lights", True),
        ("inverse_square_lights", False),  # beside its inverse-square point light, area lights
        ("mirror_floor", True),  # the floor falls back, the spheres take the lanes
        ("directional_light", False),
        ("rect_area_light", False),
        ("fade", False),
    ],
)
def test_which_lights_the_lanes_take(monkeypatch, name, expected):
    scene = calibration.SCENES[name]()
    assert built_with(monkeypatch, scene, "avx2").lane_lights is expected
    assert built_with(monkeypatch, scene, "sse2").lane_lights is False  # the lanes need AVX2


def test_an_inverse_square_light_is_a_lane_light_and_a_spot_light_is_not(monkeypatch):
    scene = calibration.point_light()
    inverse_square = dataclasses.replace(scene.lights[0], falloff="inverse-square")
    spot = dataclasses.replace(inverse_square, cone=Cone((0.0, -1.0, 0.0), math.cos(0.5), math.cos(0.3)))
    assert built_with(monkeypatch, dataclasses.replace(scene, lights=(inverse_square,)), "avx2").lane_lights
    assert not built_with(monkeypatch, dataclasses.replace(scene, lights=(inverse_square, spot)), "avx2").lane_lights


# Materials a packet mixes: plain ones (lanes) of every exponent regime, and the fallbacks.
PLAIN = [
    calibration.RED,
    calibration.GROUND,  # ks = 0
    PhongMaterial(ka=0.0, kd=0.9, ks=0.8, exponent=0.0, diffuse_color=(0.3, 0.6, 0.9)),
    PhongMaterial(ka=0.2, kd=0.5, ks=0.9, exponent=1e6, specular_color=(0.9, 0.7, 0.2)),
    PhongMaterial(ka=0.1, kd=0.4, ks=0.6, exponent=61.5, emission=(0.05, 0.0, 0.1)),  # past the classic cut-off
    PhongMaterial(ka=0.3, kd=0.0, ks=0.7, exponent=2.25),
    # A needle highlight: (r·wo)^1e12 turns r·wo's last double bits (n, l and wo's) into visible
    # ones in a float32 pixel (1 ulp of r·wo near 1 moves it by ~1e-4), where a rounding
    # difference of the lanes would otherwise vanish.
    PhongMaterial(ka=0.0, kd=0.1, ks=1.0, exponent=1e12),
    PhongMaterial(ka=0.0, kd=0.1, ks=1.0, exponent=1e12),
]
FALLBACK = [
    calibration.MIRROR_FLOOR,
    dataclasses.replace(calibration.RED, kt=0.5, ior=1.3),
    calibration.checker().meshes[0].material,
    calibration.texture_specular().meshes[0].material,
]


@st.composite
def mixed_scenes(draw):
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    materials = PLAIN + FALLBACK
    pick = lambda: materials[int(rng.integers(len(materials)))]  # noqa: E731
    spheres = [
        Sphere.at(tuple(rng.uniform(-2.0, 2.0, 3) + [0.0, 0.8, 0.0]), float(rng.uniform(0.2, 0.9)), pick())
        for _ in range(draw(st.integers(1, 5)))
    ]
    # A small scene (small_scene.hpp: a few axis-aligned spheres on a ground quad) asks its shadow
    # rays together, up to 64 (Scene.occluded_each); any other walks its tree.
    small = draw(st.booleans())
    spheres.append(
        Sphere(
            calibration.translation(rng.uniform(-1.5, 1.5, 3) + [0.0, 1.0, 0.0])
            @ calibration.rotation(rng.normal(size=3), 0.0 if small else float(rng.uniform(0, 180)))
            @ calibration.scaling(rng.uniform(0.2, 0.8, 3)),
            pick(),
        )
    )
    ground = calibration.ground_quad(0.0, pick())
    ball = calibration.icosphere(1, tuple(rng.uniform(-1.5, 1.5, 3) + [0.0, 1.0, 0.0]), 0.5, pick(), smooth=True)
    box = Intrinsic(
        "cube", calibration.translation(rng.uniform(-2, 2, 3)) @ calibration.scaling([0.3, 0.5, 0.3]), pick()
    )
    points = Points(rng.uniform(-2.5, 2.5, (6, 3)) + [0.0, 1.0, 0.0], rng.uniform(0.05, 0.3, 6), pick())
    lights = []
    for _ in range(draw(st.integers(1, 4))):
        # Some lights sit on a sphere's surface or inside it (n·l NaN, negative or shadowed).
        where = draw(st.sampled_from(["free", "surface", "inside"]))
        if where == "free":
            position = rng.uniform(-4.0, 4.0, 3) + [0.0, 3.0, 0.0]
        else:
            sphere = np.asarray(spheres[0].world_from_object)
            position = sphere[:3, 3] + (sphere[:3, 0] if where == "surface" else 0.3 * sphere[:3, 0])
        lights.append(
            PointLight(
                tuple(float(x) for x in position),
                tuple(float(x) for x in rng.uniform(0.2, 1.5, 3)),
                falloff=draw(st.sampled_from(["none", "inverse-square"])),
                diffuse=draw(st.sampled_from([1.0, 0.5])),
                specular=draw(st.sampled_from([1.0, 1.7, 0.0])),
            )
        )
    width = draw(st.integers(5, 23))  # partial packets at the right edge and bottom
    height = draw(st.integers(3, 17))
    scene = calibration.mirror_floor()
    return dataclasses.replace(
        scene,
        camera=calibration.look_at(rng.uniform([-3, 1, 5], [3, 4, 8]), (0.0, 0.7, 0.0)),
        ambient=dataclasses.replace(scene.ambient, color=(0.2, 0.25, 0.3)),
        lights=tuple(lights),
        spheres=tuple(spheres),
        meshes=(ground,) if small else (ground, ball),
        intrinsics=() if small else (box,),
        points=() if small else (points,),
        settings=dataclasses.replace(
            scene.settings,
            width=width,
            height=height,
            samples=draw(st.sampled_from([1, 2])),
            specular=draw(st.sampled_from(["seed", "povray-classic"])),
            numerics=draw(st.sampled_from(["scale-invariant", "povray"])),
            max_depth=2,
        ),
    )


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(scene=mixed_scenes())
def test_random_scenes_shade_as_one_by_one(monkeypatch, scene):
    built = built_with(monkeypatch, scene, "avx2")
    assert built.lane_lights
    assert built.small_scene == (not scene.intrinsics)
    lanes, one_by_one = both_paths(monkeypatch, scene)
    assert lanes.tobytes() == one_by_one.tobytes()
