# SPDX-License-Identifier: Apache-2.0
"""``diff`` passes on a ``UsdGeom.Points`` cloud (analytic spheres in both backends)."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, UsdLux, Vt

from phongscene import diff

pytestmark = [pytest.mark.povray]


def test_diff_passes_on_points(tmp_path):
    stage = Usd.Stage.CreateNew(str(tmp_path / "cloud.usda"))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    rng = np.random.default_rng(5)
    points = UsdGeom.Points.Define(stage, "/Cloud")
    points.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(rng.uniform(-2, 2, (60, 3)).astype(np.float32)))
    points.CreateWidthsAttr(Vt.FloatArray.FromNumpy(rng.uniform(0.1, 0.6, 60).astype(np.float32)))
    points.CreateDisplayColorAttr(Vt.Vec3fArray([Gf.Vec3f(0.2, 0.6, 0.9)]))
    light = UsdLux.DistantLight.Define(stage, "/Sun")
    light.AddRotateXYZOp().Set(Gf.Vec3f(-50, 20, 0))
    stage.GetRootLayer().Save()
    result = diff(tmp_path / "cloud.usda", width=64, height=48)
    assert result.native.max() > 0.05
    assert result.report.ok, result.report.summary()
