# SPDX-License-Identifier: Apache-2.0
"""``UsdGeom.Points`` with ``widths`` read as analytic spheres (both backends draw spheres)."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, Vt

from phongscene.errors import SceneError
from phongscene.usd import read_usd
from phongscene.usd.geometry import DEFAULT_POINT_WIDTH


def _points_stage(path, widths=None, interpolation=None) -> str:
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    xform = UsdGeom.Xform.Define(stage, "/World")
    xform.AddTranslateOp().Set(Gf.Vec3d(0, 1, 0))
    points = UsdGeom.Points.Define(stage, "/World/Dots")
    points.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(-1, 0, 0), Gf.Vec3f(0, 0, 0), Gf.Vec3f(1.5, 0, 0)]))
    if widths is not None:
        points.CreateWidthsAttr(Vt.FloatArray(widths))
        if interpolation:
            points.SetWidthsInterpolation(interpolation)
    stage.GetRootLayer().Save()
    return str(path)


def test_points_are_spheres_of_their_widths(tmp_path):
    result = read_usd(_points_stage(tmp_path / "p.usda", [0.5, 1.0, 0.0], UsdGeom.Tokens.vertex))
    spheres = result.scene.spheres
    assert len(spheres) == 2  # a zero width draws nothing
    assert np.allclose(spheres[0].world_from_object, [[0.25, 0, 0, -1], [0, 0.25, 0, 1], [0, 0, 0.25, 0], [0, 0, 0, 1]])
    assert np.allclose(spheres[1].world_from_object[:3, 3], [0, 1, 0]) and spheres[1].world_from_object[0, 0] == 0.5
    assert spheres[0].source == "/World/Dots"
    assert ("/World/Dots", "Points (2 spheres)") in result.nodes
    assert not any("unsupported geometry" in w for w in result.warnings)


def test_constant_width_and_missing_widths(tmp_path):
    spheres = read_usd(_points_stage(tmp_path / "c.usda", [0.2], UsdGeom.Tokens.constant)).scene.spheres
    assert len(spheres) == 3 and all(s.world_from_object[1, 1] == pytest.approx(0.1) for s in spheres)
    result = read_usd(_points_stage(tmp_path / "none.usda"))
    assert [s.world_from_object[0, 0] for s in result.scene.spheres] == [DEFAULT_POINT_WIDTH / 2] * 3
    assert any("Points without widths" in w and "/World/Dots" in w for w in result.warnings)


def test_widths_of_the_wrong_count_are_a_problem(tmp_path):
    with pytest.raises(SceneError) as raised:
        read_usd(_points_stage(tmp_path / "bad.usda", [0.1, 0.2]))
    problem = raised.value.problems[0]
    assert problem.prim == "/World/Dots" and problem.attribute == "widths" and "expected 1" in problem.message
