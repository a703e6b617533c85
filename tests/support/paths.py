# SPDX-License-Identifier: Apache-2.0
"""Where the tests find their files: one place, so a moved test needs no path arithmetic."""

from __future__ import annotations

import shutil
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
EXAMPLES = REPO / "examples"
# Scenes written for the tests (valid, warned, invalid, corrupt, Blender exports).
SCENES = REPO / "tests" / "scenes"
# Golden files a test compares its output with (PHONGSCENE_UPDATE_GOLDEN=1 rewrites them).
GOLDEN = REPO / "tests" / "golden"
# Third-party scenes beside the repository (../shared); a user's clone has none.
SHARED_ASSETS = REPO.parent / "shared" / "assets" / "usd"


def chromium() -> str | None:
    """The Chromium binary (Debian's package is ``chromium``), or None."""
    return shutil.which("chromium") or shutil.which("chromium-browser")
