# SPDX-License-Identifier: Apache-2.0
"""USD schema files shipped with phongscene (data only; phongscene registers them from Python in
``phongscene.usd``).

Other USD tools (usdview, USD's validators) find the Phong surface through Sdr's filesystem
discovery, pointed at this folder::

    export PXR_SDR_FS_PLUGIN_SEARCH_PATHS="$(phongscene info --usd-plugin-path)"
    export PXR_SDR_FS_PLUGIN_ALLOWED_EXTS=usda

That discovery names a node after its file, so the definition file is named after the node
identifier, and it must be the only ``.usda`` file here. (A ``plugInfo.json`` cannot do this: USD
finds Sdr nodes only through discovery plugins, which are C++ libraries; the two that read
``.usda`` definitions read only USD's own shaders.)
"""

from __future__ import annotations

from pathlib import Path

# Sdr's filesystem discovery turns <identifier>.usda into the node <identifier>.
DEFINITIONS_FILE = "phongscene_PhongSurface.usda"


def folder() -> Path:
    """This folder on disk: the value for ``PXR_SDR_FS_PLUGIN_SEARCH_PATHS``."""
    # The package is always a folder on disk (a wheel installs unpacked, an editable install is
    # the source tree; Sdr's discovery needs a real folder anyway), so ``__file__`` is enough:
    # importlib.resources would add ~25 ms to every start-up that reads a scene (issue 15).
    return Path(__file__).resolve().parent
