# SPDX-License-Identifier: Apache-2.0
"""``diff`` passes on instanced scenes: 100 PointInstancer copies (rotated, non-uniformly
scaled) and 100 instanceable references with a material override, nested instancing; native's
two-level BVH against POV-Ray's declared mesh2 and objects."""

from __future__ import annotations

import pytest

from phongscene import diff
from support.instanced_stages import nested_stage, point_instancer_stage, reference_stage

pytestmark = [pytest.mark.povray, pytest.mark.slow]


@pytest.mark.parametrize("kind", ["point_instancer", "references", "nested"])
def test_diff_passes_on_instances(tmp_path, kind):
    if kind == "point_instancer":
        path = point_instancer_stage(tmp_path / "pi.usda", 100, rings=12, sides=8, with_sphere=True)
    elif kind == "references":
        path = reference_stage(tmp_path / "refs.usda", 100, rings=12, sides=8, red_every=3)
    else:
        path = nested_stage(tmp_path / "nested.usda", outer=3, inner=4)
    result = diff(path)
    assert result.native.max() > 0.01  # a picture, not black
    assert result.report.ok, result.report.summary()
