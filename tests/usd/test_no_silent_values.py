# SPDX-License-Identifier: Apache-2.0
"""Values a renderer cannot honour are errors naming prim and attribute, not exit 0 (issue 27.3):
each case of the issue's table, read from usda text."""

from __future__ import annotations

import pytest
from usda import read

from phongscene.errors import SceneError
from phongscene.usd.lights import MAX_KELVIN, MIN_KELVIN

SPHERE = 'def Sphere "s" { }\n'
INSTANCER = """
def PointInstancer "pi" {{
    rel prototypes = </pi/P>
    int[] protoIndices = [0, 0, 0]
    {arrays}
    def Scope "P" {{
        def Sphere "ball" {{ }}
    }}
}}
"""
THREE = "point3f[] positions = [(0, 0, 0), (3, 0, 0), (6, 0, 0)]"


def _error(tmp_path, body: str) -> str:
    with pytest.raises(SceneError) as info:
        read(tmp_path, body)
    return str(info.value)


@pytest.mark.parametrize("radius", ["", "float inputs:radius = 0"])  # radius 0 used to hide it (a factor 0)
def test_a_negative_light_colour(tmp_path, radius):
    body = f'def SphereLight "l" {{\n color3f inputs:color = (-1, 1, 1)\n {radius}\n}}\n' + SPHERE
    assert "/l.inputs:color: must be >= 0 in every channel" in _error(tmp_path, body)


@pytest.mark.parametrize("kelvin", ["1e38", "999", "10001", "-5"])
def test_a_colour_temperature_outside_usdlux_table(tmp_path, kelvin):
    body = (
        f'def DistantLight "l" {{\n bool inputs:enableColorTemperature = 1\n float inputs:colorTemperature = {kelvin}\n}}\n'
        + SPHERE
    )
    assert "/l.inputs:colorTemperature: must be" in _error(tmp_path, body)


@pytest.mark.parametrize("kelvin", [MIN_KELVIN, 6500.0, MAX_KELVIN])
def test_colour_temperatures_inside_the_table_are_read(tmp_path, kelvin):
    body = (
        f'def DistantLight "l" {{\n bool inputs:enableColorTemperature = 1\n float inputs:colorTemperature = {kelvin}\n}}\n'
        + SPHERE
    )
    (light,) = read(tmp_path, body).scene.lights
    assert max(light.color) > 0


@pytest.mark.parametrize("aperture", ["1e38", "1e20"])
def test_an_absurd_orthographic_aperture(tmp_path, aperture):
    body = (
        f'def Camera "cam" {{\n token projection = "orthographic"\n float horizontalAperture = {aperture}\n'
        f" float verticalAperture = {aperture}\n}}\n" + SPHERE
    )
    assert "/cam.horizontalAperture: the orthographic view window must be" in _error(tmp_path, body)


def test_a_mesh_under_a_projective_transform(tmp_path):
    body = """
def Mesh "m" {
    matrix4d xformOp:transform = ((1, 0, 0, 0.5), (0, 1, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1))
    uniform token[] xformOpOrder = ["xformOp:transform"]
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
}
"""
    assert "/m.xformOpOrder: the world transform is projective" in _error(tmp_path, body)


@pytest.mark.parametrize(
    ("arrays", "attribute"),
    [
        ("point3f[] positions = [(0, 0, 0)]", "positions"),
        (THREE + "\n quath[] orientations = [(1, 0, 0, 0)]", "orientations"),
        (THREE + "\n float3[] scales = [(1, 1, 1), (1, 1, 1)]", "scales"),
        ("", "positions"),
    ],
)
def test_point_instancer_arrays_shorter_than_proto_indices(tmp_path, arrays, attribute):
    message = _error(tmp_path, INSTANCER.format(arrays=arrays))
    assert f"/pi.{attribute}: must have one entry per instance (3 protoIndices)" in message


def test_matching_point_instancer_arrays_are_read(tmp_path):
    arrays = THREE + "\n quath[] orientations = [(1, 0, 0, 0), (1, 0, 0, 0), (1, 0, 0, 0)]"
    assert len(read(tmp_path, INSTANCER.format(arrays=arrays)).scene.spheres) == 3


def test_an_unknown_sample_pattern_on_the_render_settings(tmp_path):
    body = (
        """
def RenderSettings "S" {
    uniform int2 resolution = (8, 8)
    uniform token phong:samplePattern = "bogus"
}
"""
        + SPHERE
    )
    assert "/S.phong:samplePattern: must be one of grid," in _error(tmp_path, body)
