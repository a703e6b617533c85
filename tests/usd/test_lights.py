# SPDX-License-Identifier: Apache-2.0
"""The USD reader's UsdLux lights (``phongscene.usd.lights``): the seed's lights and UsdLux's units,
multipliers, light models, shaping cones. Each expected value is derived from the USD text in the test,
not from the reader."""

from __future__ import annotations

import math

import numpy as np
import pytest
from usda import FLOAT32, read

from phongscene.errors import SceneError

LIGHTS = """
def DomeLight "Dome" { float inputs:intensity = 0.5 }
def DomeLight "Dome2" { color3f inputs:color = (0.1, 0.2, 0.3) }
def SphereLight "Point" {
    uniform token phong:lightModel = "seed"
    float inputs:intensity = 2
    float inputs:exposure = 1
    color3f inputs:color = (1, 0.5, 0.25)
    bool treatAsPoint = 1
    double phong:fadeDistance = 4
    double phong:fadePower = 2
    double3 xformOp:translate = (1, 2, 3)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def SphereLight "Ball" {
    uniform token phong:lightModel = "seed"
    float inputs:radius = 0.5
    int phong:shadowSamples = 5
    double3 xformOp:translate = (0, 5, 0)
    double3 xformOp:scale = (2, 2, 2)
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale"]
}
def DistantLight "Sun" {
    uniform token phong:lightModel = "seed"
    float inputs:intensity = 3
    float3 xformOp:rotateXYZ = (-90, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:rotateXYZ"]
}
def RectLight "Panel" {
    uniform token phong:lightModel = "seed"
    float inputs:width = 2
    float inputs:height = 4
    double3 xformOp:translate = (0, 6, 0)
    float3 xformOp:rotateXYZ = (90, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateXYZ"]
}
def DiskLight "Disk" {}
def CylinderLight "Tube" { uniform token phong:lightModel = "seed"
    float inputs:intensity = 1.5
    double3 xformOp:translate = (4, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"] }
def CylinderLight "Tube2" { float inputs:radius = 0.25
    float inputs:length = 2
    double3 xformOp:scale = (3, 2, 2)
    uniform token[] xformOpOrder = ["xformOp:scale"] }
def PortalLight "Portal" {}
def Sphere "Target" {}
"""


def test_lights(tmp_path):
    # The seed's constant lights (phong:lightModel = "seed"): strength = intensity · 2^exposure · color.
    result = read(tmp_path, LIGHTS)
    scene = result.scene
    assert scene.ambient.color == pytest.approx((0.6, 0.7, 0.8), abs=FLOAT32)  # DomeLights add up
    point, ball, sun, panel, disk, tube, tube2 = scene.lights
    assert point.position == (1, 2, 3) and point.color == (4.0, 2.0, 1.0)  # 2·2^1·color
    assert (point.fade_distance, point.fade_power) == (4.0, 2.0)
    assert ball.center == (0, 5, 0) and ball.radius == 1.0 and ball.samples == 5  # radius × scale
    assert ball.color == (1.0, 1.0, 1.0)
    assert np.allclose(sun.direction, (0, -1, 0), atol=1e-7)  # −Z rotated −90° about X points down
    assert sun.color == (3.0, 3.0, 3.0)
    assert np.allclose(panel.axis_u, (2, 0, 0), atol=1e-7) and np.allclose(panel.axis_v, (0, 0, 4), atol=1e-6)
    assert panel.samples == 9
    # A DiskLight of radius r is lit as the square of its area (side r·√π), UsdLux units.
    side = 0.5 * math.sqrt(math.pi)
    assert np.linalg.norm(disk.axis_u) == pytest.approx(side) and np.linalg.norm(disk.axis_v) == pytest.approx(side)
    assert disk.falloff == "inverse-square" and any("DiskLights" in w and "/Disk" in w for w in result.warnings)
    # A CylinderLight is a point light of the same power at its centre (UsdLux: I = L·π·r·l/2).
    assert tube.position == (4, 0, 0) and tube.color == (1.5, 1.5, 1.5) and tube.falloff == "none"
    assert tube2.falloff == "inverse-square"
    assert tube2.color == pytest.approx((math.pi / 2 * (0.25 * 2) * (2 * 3),) * 3)
    assert any("CylinderLights" in w and "/Tube2" in w for w in result.warnings)
    unsupported = [w for w in result.warnings if "unsupported lights" in w]
    assert len(unsupported) == 1 and "/Tube" not in unsupported[0] and "/Portal" in unsupported[0]


# Each light alone, in UsdLux's units (the default): L = intensity · 2^exposure · color.
USDLUX_LIGHTS = """
def SphereLight "Bulb" { float inputs:intensity = 8
    bool inputs:normalize = 1
    bool treatAsPoint = 1 }
def SphereLight "Globe" { float inputs:intensity = 2
    float inputs:radius = 0.5
    double3 xformOp:scale = (2, 2, 2)
    uniform token[] xformOpOrder = ["xformOp:scale"] }
def SphereLight "Unlit" { float inputs:intensity = 5
    float inputs:radius = 0 }
def RectLight "Panel" { float inputs:intensity = 3
    float inputs:width = 2
    float inputs:height = 4 }
def RectLight "Normalized" { float inputs:intensity = 3
    bool inputs:normalize = 1
    float inputs:width = 2 }
def DistantLight "Sun" { float inputs:intensity = 50000 }
def DistantLight "Lux" { float inputs:intensity = 7
    bool inputs:normalize = 1 }
"""


def test_usdlux_lights_in_usdlux_units(tmp_path):
    bulb, globe, unlit, panel, normalized, sun, lux = read(tmp_path, USDLUX_LIGHTS).scene.lights
    # A sphere light of world radius r radiates I = L·πr² (L/4 when normalized, whatever r).
    assert bulb.falloff == "inverse-square" and bulb.color == (2.0, 2.0, 2.0)
    assert globe.falloff == "inverse-square" and globe.radius == 1.0
    assert globe.color == pytest.approx((2 * math.pi,) * 3)
    assert unlit.color == (0.0, 0.0, 0.0)  # radius 0, not normalized: no power by the letter of UsdLux
    # A rect light of area A radiates I = L·A along its normal (L when normalized).
    assert panel.falloff == "inverse-square" and panel.color == (24.0, 24.0, 24.0)
    assert normalized.color == (3.0, 3.0, 3.0)
    # A distant light's irradiance is L·π·sin²(angle/2) (angle 0.53° by default), L when normalized.
    assert sun.color == pytest.approx((50000 * math.pi * math.sin(math.radians(0.53) / 2) ** 2,) * 3)
    assert lux.color == (7.0, 7.0, 7.0)


def test_light_diffuse_and_specular_multipliers(tmp_path):
    body = """
    def DistantLight "Plain" { float inputs:intensity = 2
        bool inputs:normalize = 1 }
    def DistantLight "Split" { float inputs:intensity = 2
        bool inputs:normalize = 1
        float inputs:diffuse = 0.7
        float inputs:specular = 0.25 }
    def DomeLight "Sky" { float inputs:intensity = 0.5
        float inputs:diffuse = 0.5 }
    """
    result = read(tmp_path, body)
    plain, split = result.scene.lights
    assert (plain.diffuse, plain.specular) == (1.0, 1.0)
    # The multipliers are the light's own fields; its strength stays as authored.
    assert split.color == (2.0, 2.0, 2.0)
    assert split.diffuse == pytest.approx(0.7) and split.specular == 0.25
    assert not [w for w in result.warnings if "inputs:diffuse" in w or "inputs:specular" in w]
    # The ambient term is diffuse light: a dome's diffuse multiplier scales it.
    assert result.scene.ambient.color == (0.25, 0.25, 0.25)


def test_negative_light_multiplier_is_an_error(tmp_path):
    with pytest.raises(SceneError, match=r"/L\.inputs:diffuse: must be >= 0, got -1"):
        read(tmp_path, 'def SphereLight "L" { float inputs:diffuse = -1 }')


def test_unknown_light_model_is_an_error(tmp_path):
    with pytest.raises(SceneError, match=r"/L\.phong:lightModel: must be one of usdlux, seed"):
        read(tmp_path, 'def SphereLight "L" { token phong:lightModel = "suffern" }')


def test_shaping_cone_on_a_point_light(tmp_path):
    body = """
    def SphereLight "Spot" (prepend apiSchemas = ["ShapingAPI"]) { float inputs:radius = 0
        bool inputs:normalize = 1
        float inputs:shaping:cone:angle = 30
        float inputs:shaping:cone:softness = 0.5 }
    def SphereLight "Wide" (prepend apiSchemas = ["ShapingAPI"]) { float inputs:radius = 0
        bool inputs:normalize = 1
        float inputs:shaping:cone:angle = 180 }
    """
    result = read(tmp_path, body)
    spot, wide = result.scene.lights
    assert spot.cone.axis == (0.0, 0.0, -1.0)
    assert spot.cone.cos_outer == pytest.approx(math.cos(math.radians(30)))
    assert spot.cone.cos_inner == pytest.approx(math.cos(math.radians(15)))  # smooth start θc·(1 − softness)
    assert wide.cone is None  # a hard 180° cone restricts nothing, and is not warned about
    assert not [w for w in result.warnings if "cone" in w]


def test_shaping_focus_is_a_cosine_power_inside_the_cone(tmp_path):
    body = """
    def SphereLight "Focused" (prepend apiSchemas = ["ShapingAPI"]) { float inputs:radius = 0
        bool inputs:normalize = 1
        float inputs:shaping:cone:angle = 40
        float inputs:shaping:focus = 6 }
    def SphereLight "Tinted" (prepend apiSchemas = ["ShapingAPI"]) { float inputs:radius = 0
        bool inputs:normalize = 1
        float inputs:shaping:cone:angle = 40
        float inputs:shaping:focus = 2
        color3f inputs:shaping:focusTint = (0.2, 0.1, 0) }
    def SphereLight "Everywhere" (prepend apiSchemas = ["ShapingAPI"]) { float inputs:radius = 0
        bool inputs:normalize = 1
        float inputs:shaping:cone:angle = 180
        float inputs:shaping:focus = 3 }
    """
    result = read(tmp_path, body)
    focused, tinted, everywhere = result.scene.lights
    assert focused.cone.focus == 6.0 and tinted.cone.focus == 2.0
    assert everywhere.cone is None
    assert any("focusTint" in w and "/Tinted" in w and "/Focused" not in w for w in result.warnings)
    assert any("focus but no cone" in w and "/Everywhere" in w for w in result.warnings)
