# SPDX-License-Identifier: Apache-2.0
"""USD's own diagnostics (its "Warning: in ..." lines on file descriptor 2) become phongscene
warnings (issue 10, item 7): the fuzzer found them on stderr for a .usdz whose reference is
missing, and a corrupt file printed 548 of them."""

from __future__ import annotations

import subprocess
import sys

import pytest
from pxr import Sdf, UsdUtils

from phongscene.usd.diagnostics import MAX_USD_WARNINGS, as_warnings
from support.paths import REPO

USD_LINE = (
    "Warning: in _ReadPaths at line 2261 of /opt/USD/pxr/usd/sdf/crateFile.cpp -- "
    "Corrupt path index in crate file ({i} repeated)"
)


def test_repeated_diagnostics_are_one_warning_each_at_most_ten():
    text = "\n".join(USD_LINE.format(i=0) for _ in range(548)) + "\n"
    assert as_warnings(text) == ["USD: Corrupt path index in crate file (0 repeated) (548 times)"]
    many = as_warnings("\n".join(USD_LINE.format(i=i) for i in range(30)))
    assert len(many) == MAX_USD_WARNINGS + 1 and many[-1] == "USD: 20 more distinct diagnostics not shown"
    assert not any("crateFile.cpp" in w for w in many)  # no C++ source location


@pytest.mark.subprocess
def test_a_usdz_with_a_missing_reference_prints_only_phongscene_lines(tmp_path):
    crate = tmp_path / "scene.usdc"
    Sdf.Layer.FindOrOpen(str(REPO / "tests" / "scenes" / "warned" / "missing_reference.usda")).Export(str(crate))
    package = tmp_path / "scene.usdz"
    assert UsdUtils.CreateNewUsdzPackage(str(crate), str(package))
    result = subprocess.run(
        [sys.executable, "-m", "phongscene", "validate", "--no-sandbox", str(package)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0
    lines = result.stderr.splitlines()
    assert lines and all(line.startswith("warning: ") for line in lines), result.stderr
    assert any("references" in line and "not composed" in line for line in lines)
