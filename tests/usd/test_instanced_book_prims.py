# SPDX-License-Identifier: Apache-2.0
"""Where instancing meets issue 22 (docs/instancing.md): intrinsic prims in an instance's
prototype are placed in the world per copy, and instances that a light's link tells apart are
flattened, each copy named by its own prim; the native image then equals the oracle's."""

from __future__ import annotations

import numpy as np
from pxr import Gf, Usd, UsdGeom, UsdLux

from phongscene import render
from phongscene.usd import load_usd
from support import oracle
from support.instanced_stages import point_instancer_stage, reference_stage

COPIES = 4
# As the other oracle comparisons of a few-pixel render (tests/cross/test_light_linking.py).
ORACLE_RELATIVE_TOLERANCE = 1e-6
ORACLE_ABSOLUTE_FLOOR = 1e-6


def _stage_with_cube(tmp_path) -> str:
    path = reference_stage(tmp_path / "refs.usda", COPIES, rings=6, sides=4, spacing=1.5, width=24, height=14)
    stage = Usd.Stage.Open(path)
    cube = UsdGeom.Cube.Define(stage, "/Asset/Box")
    cube.CreateSizeAttr(0.2)
    cube.AddTranslateOp().Set(Gf.Vec3d(0, -0.3, 0))
    stage.GetRootLayer().Save()
    return path


def test_an_intrinsic_in_a_prototype_is_placed_per_copy(tmp_path):
    scene = load_usd(_stage_with_cube(tmp_path))
    assert sorted(i.source for i in scene.intrinsics) == [f"/World/Copy_{k}/Box" for k in range(COPIES)]
    assert scene.instance_count == COPIES  # the torus stays instanced
    centres = sorted(tuple(np.round(i.world_from_object[:3, 3], 6)) for i in scene.intrinsics)
    assert len(set(centres)) == COPIES  # each cube where its copy is, not all at the prototype's place


def test_a_light_link_that_tells_copies_apart_flattens_them(tmp_path):
    path = _stage_with_cube(tmp_path)
    stage = Usd.Stage.Open(path)
    link = UsdLux.LightAPI(stage.GetPrimAtPath("/Light")).GetLightLinkCollectionAPI()
    link.CreateExcludesRel().SetTargets(["/World/Copy_0"])
    stage.GetRootLayer().Save()
    scene = load_usd(path)
    assert not scene.instances
    torus = sorted(m.source for m in scene.meshes)
    assert torus == [f"/World/Copy_{k}/Torus" for k in range(COPIES)]
    lit = scene.lights[0].linking.illuminates
    assert lit is not None and "/World/Copy_0/Torus" not in lit and "/World/Copy_1/Torus" in lit
    assert "/World/Copy_0/Box" not in lit and "/World/Copy_2/Box" in lit
    got = render(scene, "native")
    np.testing.assert_allclose(got, oracle.render(scene), rtol=ORACLE_RELATIVE_TOLERANCE, atol=ORACLE_ABSOLUTE_FLOOR)


def test_a_link_that_names_every_copy_keeps_the_instances(tmp_path):
    path = _stage_with_cube(tmp_path)
    stage = Usd.Stage.Open(path)
    UsdLux.LightAPI(stage.GetPrimAtPath("/Light")).GetLightLinkCollectionAPI().CreateExcludesRel().SetTargets(["/Sky"])
    stage.GetRootLayer().Save()
    scene = load_usd(path)
    assert scene.instance_count == COPIES
    assert scene.lights[0].linking.illuminates is None


def test_instances_under_a_light_without_shadows_render_as_flattened(tmp_path):
    """The native links' shadow switch reaches instance hits (their copies are not numbered)."""
    import dataclasses

    path = _stage_with_cube(tmp_path)
    stage = Usd.Stage.Open(path)
    ground = UsdGeom.Cube.Define(stage, "/World/Ground")  # world geometry the copies shadow
    ground.AddTranslateOp().Set(Gf.Vec3d(0, -0.55, 0))
    ground.AddScaleOp().Set(Gf.Vec3f(10, 0.1, 10))
    stage.GetRootLayer().Save()
    scene = load_usd(path)
    assert scene.instances
    lights = tuple(
        dataclasses.replace(light, linking=dataclasses.replace(light.linking, shadows=False)) for light in scene.lights
    )
    unshadowed = dataclasses.replace(scene, lights=lights)
    got = render(unshadowed, "native")
    np.testing.assert_allclose(
        got, render(unshadowed.flattened(), "native"), rtol=ORACLE_RELATIVE_TOLERANCE, atol=ORACLE_ABSOLUTE_FLOOR
    )
    assert not np.allclose(got, render(scene, "native"), rtol=1e-3)  # the switch changes the picture


def test_point_instancer_copies_are_in_the_default_light_link(tmp_path):
    """A copy's name (/World/Scatter[3]) is no prim: membership is asked of its instancer, so the
    default collection (includeRoot) includes every copy and no light is linked."""
    from phongscene.backends.povray.compile import compile_pov

    scene = load_usd(point_instancer_stage(tmp_path / "pi.usda", 10, rings=6, sides=4, with_sphere=True))
    assert scene.instances and any("[" in s.source for s in scene.spheres)
    assert all(light.linking.default for light in scene.lights)
    assert "no_shadow" not in compile_pov(scene)
