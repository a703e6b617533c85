# SPDX-License-Identifier: Apache-2.0
"""Emission (Suffern's Emissive material; model ``PhongMaterial.emission``, USD emissiveColor):
Le is added wherever the surface is seen, lit, shadowed or unlit, and lights nothing else. The
native tracer against the oracle, POV-Ray's ``finish { emission }`` (counted once, in pass 0 of
the exact mapping) against the native tracer."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from phongscene import compile_pov, render
from phongscene.comparison import compare
from phongscene.scene import PointLight
from support import oracle
from support.calibration import GOLD, _sphere_on_ground, classic_variant

# As tests/test_native_render.py: the native tracer against the float64 oracle.
ORACLE_RELATIVE_TOLERANCE = 1e-6
ORACLE_ABSOLUTE_FLOOR = 1e-30
LE = (0.35, 0.0, 0.8)  # a zero channel: POV-Ray's pigment·emission cannot take Le / cd


def emissive_scene(ks: float = 0.5, lights: int = 2):
    material = dataclasses.replace(GOLD, emission=LE, ks=ks, diffuse_color=(0.8, 0.6, 0.0))
    scene = _sphere_on_ground(PointLight((3.41, 5.07, 2.93), (2.2, 1.3, 0.7)), material=material)
    extra = (PointLight((-3.7, 4.3, 1.9), (0.6, 1.1, 2.1)),) if lights == 2 else ()
    return dataclasses.replace(scene, lights=scene.lights[:lights] + extra)


@pytest.mark.parametrize("convention", ["seed", "povray-classic"])
def test_native_adds_le_as_the_oracle(convention):
    scene = emissive_scene()
    if convention != "seed":
        scene = classic_variant(scene)
    got = render(scene, "native")
    np.testing.assert_allclose(got, oracle.render(scene), rtol=ORACLE_RELATIVE_TOLERANCE, atol=ORACLE_ABSOLUTE_FLOOR)


def test_le_is_added_and_lights_nothing_else():
    scene = emissive_scene()
    plain = dataclasses.replace(
        scene,
        spheres=tuple(
            dataclasses.replace(s, material=dataclasses.replace(s.material, emission=(0, 0, 0))) for s in scene.spheres
        ),
    )
    got, without = render(scene, "native"), render(plain, "native")
    ball = np.any(
        render(dataclasses.replace(scene, meshes=()), "native") != np.float32(scene.settings.background), axis=2
    )
    np.testing.assert_allclose(got[ball] - without[ball], np.broadcast_to(LE, got[ball].shape), rtol=0, atol=1e-6)
    np.testing.assert_array_equal(got[~ball], without[~ball])  # the ground is not lit by it


@pytest.mark.povray
@pytest.mark.parametrize("mapping", ["exact", "classic"])
@pytest.mark.parametrize("ks", [0.0, 0.5])
def test_povrays_emission_is_the_native_tracers(mapping, ks):
    scene = emissive_scene(ks)
    if mapping == "classic":
        scene = classic_variant(scene)
    scene = dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, numerics="povray"))
    assert "emission" in compile_pov(scene, mapping=mapping)
    result = compare(render(scene, "povray", mapping=mapping), render(scene, "native"))
    assert result.ok, result


def test_the_sdl_has_no_emission_without_it():
    scene = _sphere_on_ground(PointLight((3.41, 5.07, 2.93), (2.2, 1.3, 0.7)), material=GOLD)
    for mapping in ("exact", "classic"):
        assert "emission" not in compile_pov(scene, mapping=mapping)
