# SPDX-License-Identifier: Apache-2.0
"""Shadows as UsdLux says them (model ``Linking``): a light's shadow switch (ShadowAPI
``inputs:shadow:enable``), its light link (``collection:lightLink``: which geometry it
illuminates) and shadow link (``collection:shadowLink``: which geometry casts its shadows). The
native tracer against the independent oracle (tests/oracle.py), POV-Ray's exact mapping (one pass
per light: ``no_shadow`` and an ambient-only texture per pass) against the native tracer, and the
classic mapping's errors where one pass cannot say it."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from phongscene import compile_pov, render
from phongscene.comparison import compare
from phongscene.errors import SceneError
from phongscene.rendering import settings_for
from phongscene.scene import Linking, PointLight, RectAreaLight
from support import oracle
from support.calibration import GOLD, _sphere_on_ground, classic_variant

# As tests/test_native_render.py: the native tracer against the float64 oracle.
ORACLE_RELATIVE_TOLERANCE = 1e-6
ORACLE_ABSOLUTE_FLOOR = 1e-30

BALL, GROUND = "/World/Ball", "/World/Ground"


def linked_scene(*linkings: Linking, area: bool = False):
    """The sphere on the ground (named BALL and GROUND) with one light per linking: a point light
    up and to the right, the second one to the left (each casts the ball's shadow onto the
    ground), or a rect area light for the first with ``area``."""
    positions = [(3.41, 5.07, 2.93), (-3.7, 4.3, 1.9)]
    colours = [(2.2, 1.3, 0.7), (0.6, 1.1, 2.1)]
    lights = []
    for i, linking in enumerate(linkings):
        if area and i == 0:
            lights.append(RectAreaLight(positions[i], (1.2, 0, 0), (0, 0, 0.9), colours[i], samples=5, linking=linking))
        else:
            lights.append(PointLight(positions[i], colours[i], linking=linking))
    scene = _sphere_on_ground(lights[0], material=GOLD)
    return dataclasses.replace(
        scene,
        lights=tuple(lights),
        spheres=tuple(dataclasses.replace(s, source=BALL) for s in scene.spheres),
        meshes=tuple(dataclasses.replace(m, source=GROUND) for m in scene.meshes),
    )


CASES = {
    "shadows off": (Linking(shadows=False),),
    "shadow link without the ball": (Linking(shadowed_by=frozenset({GROUND})),),
    "light link without the ground": (Linking(illuminates=frozenset({BALL})),),
    "light link without the ball": (Linking(illuminates=frozenset({GROUND})),),
    "two lights, one without shadows": (Linking(shadows=False), Linking()),
    "two lights, linked apart": (Linking(illuminates=frozenset({BALL})), Linking(shadowed_by=frozenset())),
}


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("convention", ["seed", "povray-classic"])
def test_native_links_lights_as_the_oracle(case, convention):
    scene = linked_scene(*CASES[case])
    if convention != "seed":
        scene = classic_variant(scene)
    got = render(scene, "native")
    np.testing.assert_allclose(got, oracle.render(scene), rtol=ORACLE_RELATIVE_TOLERANCE, atol=ORACLE_ABSOLUTE_FLOOR)
    # The linking changes the picture (else this test proves nothing).
    default = dataclasses.replace(scene, lights=tuple(dataclasses.replace(l, linking=Linking()) for l in scene.lights))
    assert not np.allclose(render(default, "native"), got, rtol=1e-3)


@pytest.mark.parametrize("linking", [Linking(shadows=False), Linking(shadowed_by=frozenset({GROUND}))])
def test_an_area_lights_grid_follows_its_linking(linking):
    scene = linked_scene(linking, area=True)
    got = render(scene, "native")
    np.testing.assert_allclose(got, oracle.render(scene), rtol=ORACLE_RELATIVE_TOLERANCE, atol=ORACLE_ABSOLUTE_FLOOR)
    assert not np.allclose(render(linked_scene(Linking(), area=True), "native"), got, rtol=1e-3)


def test_shadows_off_lights_the_ground_under_the_ball_as_if_it_were_not_there():
    """Independent of the oracle: without shadows, wherever the ball is not in view, the picture
    is the scene without the ball; with shadows it is not (the ball's shadow is in view)."""
    scene = linked_scene(Linking(shadows=False))
    ball_only = render(dataclasses.replace(scene, meshes=()), "native")
    ground_seen = np.all(ball_only == np.asarray(scene.settings.background, dtype=np.float32), axis=2)
    assert ground_seen.sum() > 100
    without_ball = render(dataclasses.replace(scene, spheres=()), "native")
    np.testing.assert_array_equal(render(scene, "native")[ground_seen], without_ball[ground_seen])
    shadowed = render(linked_scene(Linking()), "native")
    assert not np.array_equal(shadowed[ground_seen], without_ball[ground_seen])


def glass_linked_scene(linking: Linking):
    """linked_scene with a tinted glass ball: its shadow is the light filtered through it (kt per
    crossing, Beer-Lambert inside), the path a shadow link and the shadow switch must also govern."""
    scene = linked_scene(linking)
    # No highlight: the exact mapping refuses one on a transmissive material (its average texture).
    glass = dataclasses.replace(GOLD, ks=0.0, kt=0.7, ior=1.3, interior_filter=(0.8, 0.9, 0.6), source="/World/Glass")
    return dataclasses.replace(scene, spheres=tuple(dataclasses.replace(s, material=glass) for s in scene.spheres))


GLASS_CASES = {
    "shadows off": Linking(shadows=False),
    "shadow link without the glass ball": Linking(shadowed_by=frozenset({GROUND})),
}


@pytest.mark.parametrize("case", GLASS_CASES)
def test_a_filtered_shadow_follows_the_lights_linking(case):
    scene = glass_linked_scene(GLASS_CASES[case])
    got = render(scene, "native")
    np.testing.assert_allclose(got, oracle.render(scene), rtol=ORACLE_RELATIVE_TOLERANCE, atol=ORACLE_ABSOLUTE_FLOOR)
    # Without the link the ball's filtered shadow darkens the ground: the link must change that.
    filtered = render(glass_linked_scene(Linking()), "native")
    assert np.sum(np.any(filtered < got - 1e-3, axis=2)) > 50


@pytest.mark.povray
@pytest.mark.parametrize("case", GLASS_CASES)
def test_povrays_exact_mapping_links_a_filtered_shadow_as_the_native_tracer(case):
    scene = glass_linked_scene(GLASS_CASES[case])
    scene = dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, numerics="povray"))
    # Like with like: POV-Ray's refracted rays carry no 1/η² (the "povray" transmission
    # convention), which the glass's own diffuse term seen from inside shows.
    native = render(scene, "native", settings=settings_for(scene, mapping="exact"))
    result = compare(render(scene, "povray", mapping="exact"), native)
    assert result.ok, result


@pytest.mark.povray
@pytest.mark.parametrize("case", CASES)
def test_povrays_exact_mapping_links_lights_as_the_native_tracer(case):
    scene = linked_scene(*CASES[case])
    scene = dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, numerics="povray"))
    result = compare(render(scene, "povray", mapping="exact"), render(scene, "native"))
    assert result.ok, result


@pytest.mark.povray
def test_povrays_classic_mapping_makes_every_object_no_shadow_when_no_light_shadows():
    scene = classic_variant(linked_scene(Linking(shadows=False), Linking(shadows=False)))
    scene = dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, numerics="povray"))
    sdl = compile_pov(scene, mapping="classic")
    assert sdl.count("no_shadow") == 2 and "shadowless" not in sdl
    result = compare(render(scene, "povray", mapping="classic"), render(scene, "native"))
    assert result.ok, result


def test_the_sdl_is_unchanged_without_linking():
    plain = linked_scene(Linking(), Linking())
    for mapping in ("exact", "classic"):
        sdl = compile_pov(plain, mapping=mapping)
        assert "no_shadow" not in sdl and "_Unlit" not in sdl


def test_the_exact_mapping_switches_per_pass():
    sdl = compile_pov(
        linked_scene(Linking(illuminates=frozenset({BALL})), Linking(shadowed_by=frozenset())), mapping="exact"
    )
    assert "#if (Pass = 0) Material_1_Unlit #else Material_1 #end" in sdl  # the ground, unlit by light 0
    assert sdl.count("#if (Pass = 1) no_shadow #end") == 2  # light 1: nothing casts its shadows


@pytest.mark.parametrize(
    ("linkings", "attribute"),
    [
        ((Linking(illuminates=frozenset({BALL})), Linking()), "collection:lightLink"),
        ((Linking(shadows=False), Linking()), "inputs:shadow:enable"),
        ((Linking(), Linking(shadowed_by=frozenset({GROUND}))), "collection:shadowLink"),
    ],
)
def test_the_classic_mapping_names_the_light_and_collection_it_cannot_express(linkings, attribute):
    scene = classic_variant(linked_scene(*linkings))
    scene = dataclasses.replace(
        scene, lights=tuple(dataclasses.replace(l, source=f"/World/Light{i}") for i, l in enumerate(scene.lights))
    )
    with pytest.raises(SceneError, match=attribute) as error:
        compile_pov(scene, mapping="classic")
    assert "/World/Light" in str(error.value)


def test_validation_rejects_a_linking_that_is_not_one():
    from phongscene.validate import validate

    scene = linked_scene(Linking(illuminates={BALL}))  # a set, not a frozenset
    problems = validate(scene)
    assert any(p.attribute == "linking.illuminates" for p in problems)
