# SPDX-License-Identifier: Apache-2.0
"""A light's diffuse and specular multipliers (UsdLux inputs:diffuse / inputs:specular; model
fields ``diffuse`` and ``specular``): the oracle, the native tracer and POV-Ray's exact mapping
scale the two terms of that light alone; the classic mapping, one finish per material, can only
scale a light as a whole."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from phongscene import compile_pov, render
from phongscene.comparison import compare
from phongscene.errors import SceneError
from phongscene.scene import PointLight
from support import oracle
from support.calibration import GOLD, _sphere_on_ground, classic_variant

# As tests/native/test_native_render.py: the native tracer against the float64 oracle.
ORACLE_RELATIVE_TOLERANCE = 1e-6
ORACLE_ABSOLUTE_FLOOR = 1e-30


def terms_scene():
    """A gold sphere with a highlight from each of two lights: one mostly specular (diffuse 0.3,
    specular 2), one diffuse only (specular 0)."""
    scene = _sphere_on_ground(PointLight((3.41, 5.07, 2.93), (2.2, 1.3, 0.7), diffuse=0.3, specular=2.0), material=GOLD)
    return dataclasses.replace(
        scene, lights=(*scene.lights, PointLight((-3.7, 4.3, 1.9), (0.6, 1.1, 2.1), specular=0.0))
    )


def without_terms(scene):
    return dataclasses.replace(
        scene, lights=tuple(dataclasses.replace(l, diffuse=1.0, specular=1.0) for l in scene.lights)
    )


@pytest.mark.parametrize("convention", ["seed", "povray-classic"])
def test_native_scales_each_lights_terms_as_the_oracle(convention):
    scene = terms_scene()
    if convention != "seed":
        scene = classic_variant(scene)
    expected = oracle.render(scene)
    got = render(scene, "native")
    np.testing.assert_allclose(got, expected, rtol=ORACLE_RELATIVE_TOLERANCE, atol=ORACLE_ABSOLUTE_FLOOR)
    # The multipliers change the picture (else this test proves nothing).
    assert not np.allclose(render(without_terms(scene), "native"), got, rtol=1e-3)


@pytest.mark.povray
def test_povrays_exact_mapping_scales_each_lights_terms():
    scene = dataclasses.replace(terms_scene(), settings=dataclasses.replace(terms_scene().settings, numerics="povray"))
    assert compare(render(scene, "povray", mapping="exact"), render(scene, "native")).ok


def test_the_sdl_declares_multipliers_only_where_a_light_has_them():
    assert "Light_Diffuse" in compile_pov(terms_scene(), mapping="exact")
    assert "Light_Diffuse" not in compile_pov(without_terms(terms_scene()), mapping="exact")


def test_the_classic_mapping_rejects_unequal_multipliers_naming_the_light():
    with pytest.raises(SceneError, match="specular: differs from the diffuse multiplier"):
        compile_pov(terms_scene(), mapping="classic")


@pytest.mark.povray
def test_the_classic_mapping_scales_a_light_with_equal_multipliers():
    scene = classic_variant(
        _sphere_on_ground(PointLight((3.41, 5.07, 2.93), (2.2, 1.3, 0.7), diffuse=0.5, specular=0.5))
    )
    scene = dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, numerics="povray"))
    assert compare(render(scene, "povray", mapping="classic"), render(scene, "native")).ok
