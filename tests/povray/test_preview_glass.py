# SPDX-License-Identifier: Apache-2.0
"""A UsdPreviewSurface glass sphere (opacity 0, ior 1.5) in front of a red sphere: ``diff``
passes between the native tracer and POV-Ray (the classic mapping: the exact one refuses a
transmissive material with a highlight)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.povray

SCENE = Path(__file__).parent.parent / "scenes" / "preview_glass.usda"


def test_diff_passes_on_a_preview_surface_glass_sphere(tmp_path):
    out = tmp_path / "out"
    args = [sys.executable, "-m", "phongscene", "diff", str(SCENE), "-o", str(out), "--mapping", "classic"]
    run = subprocess.run([*args, "--width", "40", "--height", "30", "--threads", "1"], capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "PASS" in run.stdout
