# SPDX-License-Identifier: Apache-2.0
"""The reader's checks (``phongscene.usd.stage_checks``, ``typos``, ``scene_checks``): names nothing reads,
``validate --strict``, single-sided meshes the camera sees from behind, lights that clip to white."""

from __future__ import annotations

import math

import numpy as np
import pytest
from usda import read

TYPOS = """
def SphereLight "L" {
    float inputs:intensty = 3
}
def Sphre "Ball" {
}
def Sphere "S" (prepend apiSchemas = ["MaterialBindingAPI"]) {
    rel material:binding = </Looks/Missing>
}
def Material "M" {
    token outputs:surface.connect = </M/P.outputs:surface>
    def Shader "P" {
        uniform token info:id = "UsdPreviewSurfce"
        token outputs:surface
    }
}
"""


def test_typos_are_warnings_naming_prim_and_attribute_with_the_close_name(tmp_path):
    warnings = read(tmp_path, TYPOS).warnings
    expected = [
        "/L.inputs:intensty: not an input of SphereLight (ignored) (did you mean inputs:intensity?)",
        "/Ball: prim type 'Sphre' is defined by no schema (ignored) (did you mean Sphere?)",
        "/S.material:binding: targets /Looks/Missing, which does not exist",
        "/M/P.info:id: no shader 'UsdPreviewSurfce' is registered (did you mean UsdPreviewSurface?)",
    ]
    for text in expected:
        assert any(w.startswith(text) for w in warnings), (text, warnings)


def test_validate_strict_turns_warnings_into_errors(tmp_path, capsys):
    from phongscene.cli import main

    path = tmp_path / "typos.usda"
    path.write_text("#usda 1.0\n" + TYPOS)
    assert main(["validate", str(path)]) == 0
    assert main(["validate", "--strict", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"error: {path}: /L.inputs:intensty: not an input of SphereLight" in err


SHEET = """
def Camera "C" {
    double3 xformOp:translate = (0, 0, 5)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Mesh "Sheet" {
    point3f[] points = [(0, 0, 0), (0, 1, 0), (1, 1, 0), (1, 0, 0)]
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 1, 2, 3]
    uniform token subdivisionScheme = "none"
    SIDED
}
"""


@pytest.mark.parametrize(("sided", "warned"), [("", True), ("uniform bool doubleSided = 1", False)])
def test_a_single_sided_mesh_whose_back_the_camera_sees_is_said(tmp_path, sided, warned):
    # The quad is wound clockwise seen from the camera (+Z): the camera sees its back.
    warnings = read(tmp_path, SHEET.replace("SIDED", sided)).warnings
    assert any("single-sided meshes" in w and "/Sheet" in w for w in warnings) == warned


def test_a_closed_single_sided_mesh_is_not_said(tmp_path):
    # A tetrahedron (every edge shared by two faces): its back faces are hidden by its front.
    body = SHEET.replace(
        """    point3f[] points = [(0, 0, 0), (0, 1, 0), (1, 1, 0), (1, 0, 0)]
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 1, 2, 3]""",
        """    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
    int[] faceVertexCounts = [3, 3, 3, 3]
    int[] faceVertexIndices = [0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3]""",
    ).replace("SIDED", "")
    assert "(0, 0, 1)" in body
    assert not any("single-sided" in w for w in read(tmp_path, body).warnings)


def test_a_light_that_clips_most_of_the_scene_to_white_is_said_with_the_exposure_that_fits(tmp_path):
    body = """
    def DistantLight "Sun" { float inputs:intensity = 50
        bool inputs:normalize = 1 }
    def Sphere "Ball" {
    }
    """
    warnings = read(tmp_path, body).warnings
    radiance = 50 / math.pi  # a white Lambert surface under irradiance 50
    (said,) = [w for w in warnings if w.startswith("/Sun: lights a white surface")]
    assert f"radiance {radiance:.3g}" in said and f"inputs:exposure {-math.log2(radiance):+.2f}" in said
    dim = read(tmp_path, body.replace("= 50", "= 3")).warnings  # radiance 0.95: nothing to say
    assert not [w for w in dim if "lights a white surface" in w]


def test_the_closed_mesh_test_counts_each_edge_twice():
    from phongscene.usd.scene_checks import _closed

    tetrahedron = np.array([[0, 1, 2], [0, 3, 1], [1, 3, 2], [2, 3, 0]], dtype=np.int32)
    assert _closed(tetrahedron, 4)
    assert not _closed(tetrahedron[:3], 4)  # open: three edges used once
    fin = np.concatenate([tetrahedron, [[0, 1, 4]]])  # edge 0-1 used three times
    assert not _closed(fin, 5)
    doubled = np.concatenate([tetrahedron, tetrahedron])  # every edge four times
    assert not _closed(doubled, 4)
