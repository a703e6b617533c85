# SPDX-License-Identifier: Apache-2.0
"""Shared test set-up: the ``povray`` marker skips without POV-Ray, except in CI
(PHONGSCENE_REQUIRE_POVRAY=1), where a missing POV-Ray is a failure, never a skip; likewise the
``chromium`` marker (the report's screenshot, PHONGSCENE_REQUIRE_CHROMIUM=1) and the
``shared_assets`` marker without the third-party scenes beside the repository (a user's clone
has none), except with PHONGSCENE_REQUIRE_ASSETS=1 (CI)."""

from __future__ import annotations

import os
import shutil

import pytest

# Re-exported for tests that still write ``from conftest import REPO``; new tests import
# ``support.paths`` (see tests/README.md).
from support.paths import EXAMPLES, REPO, SHARED_ASSETS, chromium  # noqa: F401


def _required(variable: str) -> bool:
    return os.environ.get(variable, "") not in ("", "0")


def povray_required() -> bool:
    return _required("PHONGSCENE_REQUIRE_POVRAY")


def pytest_configure(config):
    config.addinivalue_line(
        "markers", "chromium: needs a headless Chromium (skipped without it, unless PHONGSCENE_REQUIRE_CHROMIUM=1)"
    )


def pytest_runtest_setup(item):
    if item.get_closest_marker("chromium") and chromium() is None:
        if _required("PHONGSCENE_REQUIRE_CHROMIUM"):
            pytest.fail("PHONGSCENE_REQUIRE_CHROMIUM=1 but chromium is not on PATH", pytrace=False)
        pytest.skip("chromium not installed (apt-get install chromium)")
    if item.get_closest_marker("povray") and shutil.which("povray") is None:
        if povray_required():
            pytest.fail("PHONGSCENE_REQUIRE_POVRAY=1 but povray is not on PATH", pytrace=False)
        pytest.skip("povray not installed (apt-get install povray)")
    if item.get_closest_marker("shared_assets") and not SHARED_ASSETS.is_dir():
        if _required("PHONGSCENE_REQUIRE_ASSETS"):
            pytest.fail(f"PHONGSCENE_REQUIRE_ASSETS=1 but {SHARED_ASSETS} is missing", pytrace=False)
        pytest.skip(f"third-party scenes not present ({SHARED_ASSETS})")
