# SPDX-License-Identifier: Apache-2.0
"""Inputs the Phong model has no term for are never dropped silently: clearcoat, occlusion and
normal maps on UsdPreviewSurface, normal maps on MaterialX / OmniPBR networks, displayOpacity
below 1. One grouped warning per kind, naming the prims; the look is the one without them."""

from __future__ import annotations

import pytest
from usda import read

CAMERA_AND_LIGHT = """
def Camera "Cam" { double3 xformOp:translate = (0, 0, 5)
    uniform token[] xformOpOrder = ["xformOp:translate"] }
def DistantLight "Sun" { float inputs:intensity = 1 }
"""


def _preview(name: str, extra: str) -> str:
    return f"""
def Material "{name}" {{
    token outputs:surface.connect = </{name}/S.outputs:surface>
    def Shader "S" {{
        uniform token info:id = "UsdPreviewSurface"
        color3f inputs:diffuseColor = (0.8, 0.2, 0.1)
        {extra}
        token outputs:surface
    }}
    def Shader "Tex" {{
        uniform token info:id = "UsdUVTexture"
        float3 outputs:rgb
        float outputs:r
    }}
}}
def Sphere "Ball{name}" (prepend apiSchemas = ["MaterialBindingAPI"]) {{
    rel material:binding = </{name}>
}}
"""


@pytest.mark.parametrize(
    ("extra", "input_name"),
    [
        ("float inputs:clearcoat = 0.7", "clearcoat"),
        ("float inputs:occlusion.connect = </M/Tex.outputs:r>", "occlusion"),
        ("normal3f inputs:normal.connect = </M/Tex.outputs:rgb>", "normal"),
    ],
)
def test_an_unmodelled_preview_input_is_warned_with_its_material(tmp_path, extra, input_name):
    result = read(tmp_path, CAMERA_AND_LIGHT + _preview("M", extra))
    plain = read(tmp_path, CAMERA_AND_LIGHT + _preview("M", ""))
    (warning,) = [w for w in result.warnings if f"inputs:{input_name} " in w]
    assert "/M/S" in warning and "ignored" in warning
    assert not [w for w in plain.warnings if f"inputs:{input_name} " in w]
    assert result.scene.spheres[0].material == plain.scene.spheres[0].material


def test_neutral_preview_values_are_not_warned(tmp_path):
    extra = "float inputs:clearcoat = 0\nfloat inputs:occlusion = 1\nnormal3f inputs:normal = (0, 0, 1)"
    result = read(tmp_path, CAMERA_AND_LIGHT + _preview("M", extra))
    assert not [w for w in result.warnings if "inputs:" in w]


def test_many_clearcoated_materials_make_one_warning(tmp_path):
    text = CAMERA_AND_LIGHT + "".join(_preview(f"M{i}", "float inputs:clearcoat = 1") for i in range(5))
    (warning,) = [w for w in read(tmp_path, text).warnings if "clearcoat" in w]
    assert "(5)" in warning and all(f"/M{i}/S" in warning for i in range(5))


def test_a_materialx_normal_map_is_warned(tmp_path):
    text = (
        CAMERA_AND_LIGHT
        + """
def Material "X" {
    token outputs:mtlx:surface.connect = </X/S.outputs:out>
    def Shader "S" {
        uniform token info:id = "ND_standard_surface_surfaceshader"
        vector3f inputs:normal.connect = </X/N.outputs:out>
        token outputs:out
    }
    def Shader "N" {
        uniform token info:id = "ND_normalmap"
        vector3f outputs:out
    }
}
def Sphere "B" (prepend apiSchemas = ["MaterialBindingAPI"]) {
    rel material:binding = </X>
}
"""
    )
    (warning,) = [w for w in read(tmp_path, text).warnings if "not read as a normal map" in w]
    assert "inputs:normal" in warning and "/X" in warning


def test_display_opacity_below_one_is_warned(tmp_path):
    sphere = 'def Sphere "Glassy" {\n    float[] primvars:displayOpacity = [0.3]\n}\n'
    opaque = 'def Sphere "Solid" {\n    float[] primvars:displayOpacity = [1]\n}\n'
    warnings = read(tmp_path, CAMERA_AND_LIGHT + sphere + opaque).warnings
    (warning,) = [w for w in warnings if "displayOpacity" in w]
    assert "/Glassy" in warning and "/Solid" not in warning
