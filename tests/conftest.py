# SPDX-License-Identifier: Apache-2.0
"""Shared test set-up: the ``povray`` marker skips without POV-Ray, except in CI
(PHONGSCENE_REQUIRE_POVRAY=1), where a missing POV-Ray is a failure, never a skip."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED_ASSETS = REPO.parent / "shared" / "assets" / "usd"
EXAMPLES = REPO / "examples"


def povray_required() -> bool:
    return os.environ.get("PHONGSCENE_REQUIRE_POVRAY", "") not in ("", "0")


def pytest_runtest_setup(item):
    if item.get_closest_marker("povray") and shutil.which("povray") is None:
        if povray_required():
            pytest.fail("PHONGSCENE_REQUIRE_POVRAY=1 but povray is not on PATH", pytrace=False)
        pytest.skip("povray not installed (apt-get install povray)")
