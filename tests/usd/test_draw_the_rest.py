# SPDX-License-Identifier: Apache-2.0
"""One bad value on one prim does not refuse the scene (as USD and usdview draw the rest): a
warning naming prim and attribute, the prim skipped or repaired; `validate --strict` (warnings
as errors) still refuses it. And warnings that read: no "animated" for a stage whose time range
animates nothing, no "None" for a texture without a file."""

from __future__ import annotations

import numpy as np
import pytest
from usda import read

from phongscene.cli import main

CAMERA_AND_LIGHT = """
def Camera "Cam" { double3 xformOp:translate = (0, 0, 5)
    uniform token[] xformOpOrder = ["xformOp:translate"] }
def DistantLight "Sun" { float inputs:intensity = 1 }
"""

QUAD = """
def Mesh "{name}" {{
    int[] faceVertexCounts = [3, 3]
    int[] faceVertexIndices = [0, 1, 2, 0, 2, 3]
    {points} points = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
    uniform token subdivisionScheme = "none"
    {normals}
}}
"""


def _quad(name: str, points: str = "point3f[]", normals: str = "") -> str:
    return QUAD.format(name=name, points=points, normals=normals)


def test_a_mesh_with_wrong_typed_points_is_skipped_and_the_rest_drawn(tmp_path):
    result = read(tmp_path, CAMERA_AND_LIGHT + _quad("Good") + _quad("Bad", points="int3[]"))
    assert [m.source for m in result.scene.meshes] == ["/Good"]
    (warning,) = [w for w in result.warnings if "/Bad.points" in w]
    assert "int3[]" in warning and "skipped" in warning


def test_a_zero_length_normal_takes_its_triangles_geometric_normal(tmp_path):
    normals = 'normal3f[] normals = [(0, 0, 1), (0, 0, 1), (0, 0, 0), (0, 0, 1)] (interpolation = "vertex")'
    result = read(tmp_path, CAMERA_AND_LIGHT + _quad("Q", normals=normals))
    (mesh,) = result.scene.meshes
    # Vertex 2 is a corner of both triangles: each of those corners now has the geometric
    # normal (+z for this counter-clockwise quad), every other corner its authored normal.
    corner_normals = np.asarray(mesh.normals)[np.asarray(mesh.normal_indices)]
    np.testing.assert_allclose(corner_normals, np.broadcast_to([0.0, 0.0, 1.0], corner_normals.shape), atol=1e-12)
    assert np.all(np.linalg.norm(np.asarray(mesh.normals), axis=1) > 0)
    (warning,) = [w for w in result.warnings if "zero-length normals" in w]
    assert "/Q.normals" in warning and "element 2" in warning


def test_a_repaired_scene_still_fails_validate_strict(tmp_path, capsys):
    scene = tmp_path / "scene.usda"
    normals = 'normal3f[] normals = [(0, 0, 1), (0, 0, 1), (0, 0, 0), (0, 0, 1)] (interpolation = "vertex")'
    scene.write_text(
        "#usda 1.0\n" + (CAMERA_AND_LIGHT + _quad("Q", normals=normals)).replace("{ ", "{\n").replace(" }", "\n}")
    )
    assert main(["validate", "--no-sandbox", str(scene)]) == 0
    capsys.readouterr()
    assert main(["validate", "--no-sandbox", "--strict", str(scene)]) == 2
    said = capsys.readouterr()
    assert "zero-length normals" in said.out + said.err


@pytest.mark.parametrize("texture", ["missing.exr", "corrupt.exr"])
def test_an_unreadable_dome_texture_lights_as_an_untextured_dome(tmp_path, texture):
    # (A FIFO, device or folder stays an error: reading it could block; tests/usd/test_usd_hangs.py.)
    (tmp_path / "corrupt.exr").write_bytes(b"not an image at all")
    dome = f"""
def DomeLight "Dome" {{
    float inputs:intensity = 0.5
    asset inputs:texture:file = @{texture}@
}}
def Sphere "S" {{
}}
"""
    result = read(tmp_path, CAMERA_AND_LIGHT + dome)
    untextured = read(tmp_path, CAMERA_AND_LIGHT + dome.replace(f"asset inputs:texture:file = @{texture}@", ""))
    assert result.scene.ambient == untextured.scene.ambient
    assert max(result.scene.ambient.color) > 0
    assert any("/Dome.inputs:texture:file" in w and "untextured" in w for w in result.warnings)


def test_a_time_range_without_samples_is_not_called_animated(tmp_path):
    path = tmp_path / "ranged.usda"
    path.write_text('#usda 1.0\n(\n    startTimeCode = 1\n    endTimeCode = 24\n)\ndef Sphere "S" {\n}\n')
    from phongscene.usd import read_usd

    assert not [w for w in read_usd(path).warnings if "animated" in w]
    sampled = tmp_path / "sampled.usda"
    sampled.write_text(
        '#usda 1.0\n(\n    startTimeCode = 1\n    endTimeCode = 24\n)\ndef Sphere "S" {\n'
        "    double radius.timeSamples = { 1: 1, 24: 2 }\n}\n"
    )
    assert [w for w in read_usd(sampled).warnings if "animated" in w]


def test_a_texture_without_a_file_says_so(tmp_path):
    material = """
def Material "M" {
    token outputs:surface.connect = </M/P.outputs:surface>
    def Shader "P" { uniform token info:id = "UsdPreviewSurface"
        color3f inputs:diffuseColor.connect = </M/T.outputs:rgb>
        token outputs:surface }
    def Shader "T" { uniform token info:id = "UsdUVTexture"
        float3 outputs:rgb }
}
def Sphere "S" (prepend apiSchemas = ["MaterialBindingAPI"]) { rel material:binding = </M> }
"""
    warnings = read(tmp_path, CAMERA_AND_LIGHT + material).warnings
    assert any("/M/T.inputs:file: not authored" in w for w in warnings)
    assert not [w for w in warnings if "None" in w]
