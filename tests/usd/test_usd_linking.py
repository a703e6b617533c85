# SPDX-License-Identifier: Apache-2.0
"""UsdLux shadows and linking read into the model's ``Linking`` (phongscene.usd.linking): the
ShadowAPI switch, collection:lightLink and collection:shadowLink resolved by usd-core's
UsdCollectionAPI (includeRoot, includes, excludes, expansion rule), and a warning for every
ShadowAPI / ShapingAPI input the model cannot render. Expected values come from the USD text."""

from __future__ import annotations

import pytest
from usda import read

GEOMETRY = """
def Xform "World" {
    def Sphere "Ball" { double radius = 1 }
    def Xform "Group" {
        def Sphere "Inner" { double radius = 0.5 }
    }
    def Cube "Box" { double size = 1 }
}
"""


def light(body: str, schemas: str = "") -> str:
    api = f"(\n    prepend apiSchemas = [{schemas}]\n)" if schemas else ""
    return (
        GEOMETRY
        + f"""
def SphereLight "Key" {api}
{{
    uniform token phong:lightModel = "seed"
    bool treatAsPoint = 1
    double3 xformOp:translate = (0, 5, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
{body}
}}
"""
    )


def linking_of(tmp_path, body: str, schemas: str = ""):
    result = read(tmp_path, light(body, schemas))
    (key,) = result.scene.lights
    return key.linking, result.warnings


def test_a_light_without_linking_lights_everything(tmp_path):
    linking, _ = linking_of(tmp_path, "")
    assert linking.default


def test_shadow_enable_off(tmp_path):
    linking, warnings = linking_of(tmp_path, "    bool inputs:shadow:enable = 0", '"ShadowAPI"')
    assert not linking.shadows and linking.illuminates is None and linking.shadowed_by is None
    assert not [w for w in warnings if "shadow" in w]


def test_shadow_enable_without_the_api_is_ignored_and_said_so(tmp_path):
    linking, warnings = linking_of(tmp_path, "    bool inputs:shadow:enable = 0")
    assert linking.shadows
    assert any("inputs:shadow:enable" in w and "ignored" in w for w in warnings)


def test_a_light_link_includes_only_what_it_names(tmp_path):
    body = """
    uniform bool collection:lightLink:includeRoot = 0
    rel collection:lightLink:includes = [</World/Ball>, </World/Group>]
    """
    linking, _ = linking_of(tmp_path, body, '"CollectionAPI:lightLink"')
    # expandPrims (the default rule): the group's child is included.
    assert linking.illuminates == {"/World/Ball", "/World/Group/Inner"} and linking.shadowed_by is None


def test_a_shadow_link_excludes_what_it_names(tmp_path):
    body = """
    rel collection:shadowLink:excludes = [</World/Group>]
    """
    linking, _ = linking_of(tmp_path, body, '"CollectionAPI:shadowLink"')
    assert linking.shadowed_by == {"/World/Ball", "/World/Box"} and linking.illuminates is None


def test_explicit_only_does_not_expand_to_children(tmp_path):
    body = """
    uniform bool collection:lightLink:includeRoot = 0
    uniform token collection:lightLink:expansionRule = "explicitOnly"
    rel collection:lightLink:includes = [</World/Group>, </World/Box>]
    """
    linking, _ = linking_of(tmp_path, body, '"CollectionAPI:lightLink"')
    assert linking.illuminates == {"/World/Box"}


@pytest.mark.parametrize(
    "attribute, value",
    [
        ("inputs:shadow:color", "color3f inputs:shadow:color = (0.2, 0, 0)"),
        ("inputs:shadow:distance", "float inputs:shadow:distance = 3"),
        ("inputs:shadow:falloff", "float inputs:shadow:falloff = 2"),
        ("inputs:shaping:ies:file", "asset inputs:shaping:ies:file = @light.ies@"),
    ],
)
def test_inputs_the_model_cannot_render_are_a_warning_naming_prim_and_attribute(tmp_path, attribute, value):
    _, warnings = linking_of(tmp_path, "    " + value, '"ShadowAPI", "ShapingAPI"')
    assert any(attribute in w and "/Key" in w for w in warnings), warnings


def test_their_fallback_values_are_no_warning(tmp_path):
    _, warnings = linking_of(
        tmp_path, "    color3f inputs:shadow:color = (0, 0, 0)\n    float inputs:shadow:distance = -1", '"ShadowAPI"'
    )
    assert not [w for w in warnings if "shadow" in w]


def test_write_usd_round_trips_linking_intrinsics_and_emission(tmp_path):
    import dataclasses

    import numpy as np

    from phongscene.scene import Intrinsic, Linking, PhongMaterial, PointLight, Scene, Sphere
    from phongscene.usd import write_usd

    glow = PhongMaterial(emission=(0.5, 0.25, 0.0), source="/World/Looks/Glow/Phong")
    shapes = (
        Intrinsic("cube", np.diag([1.0, 2.0, 0.5, 1.0]), source="/World/Geometry/Box"),
        Intrinsic("cylinder", np.eye(4), radius_bottom=0.5, radius_top=0.25, source="/World/Geometry/Frustum"),
        Intrinsic("cylinder", np.eye(4), radius_top=0.0, source="/World/Geometry/Cone"),
        Intrinsic(
            "capsule", np.eye(4), radius_bottom=0.5, radius_top=0.5, half_height=0.75, source="/World/Geometry/Pill"
        ),
        Intrinsic(
            "capsule", np.eye(4), radius_bottom=0.5, radius_top=0.2, half_height=0.75, source="/World/Geometry/Drop"
        ),
        Intrinsic("plane", np.eye(4), glow, infinite=True, source="/World/Geometry/Ground"),
    )
    linking = Linking(
        shadows=False,
        illuminates=frozenset({"/World/Geometry/Ball", "/World/Geometry/Box"}),
        shadowed_by=frozenset({"/World/Geometry/Cone"}),
    )
    scene = Scene(
        lights=(PointLight((0, 5, 0), (1, 1, 1), source="/World/Lights/Key", linking=linking),),
        spheres=(Sphere.at((0, 0, 0), 1.0, glow, "/World/Geometry/Ball"),),
        intrinsics=shapes,
    )
    back = read_usd_scene(write_usd(scene, tmp_path / "out.usda"))
    assert back.lights[0].linking == linking
    assert [
        dataclasses.replace(i, material=scene.intrinsics[0].material)
        == dataclasses.replace(j, material=scene.intrinsics[0].material)
        for i, j in zip(back.intrinsics, shapes)
    ] == [True] * len(shapes)
    assert back.spheres[0].material.emission == (0.5, 0.25, 0.0)


def read_usd_scene(path):
    from phongscene.usd import read_usd

    return read_usd(path).scene
