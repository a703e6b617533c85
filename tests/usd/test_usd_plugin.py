# SPDX-License-Identifier: Apache-2.0
"""Other USD tools know the Phong surface: with Sdr's filesystem discovery pointed at the folder
``phongscene info --usd-plugin-path`` prints, USD's own validators (run in a fresh process that
never imports phongscene) report nothing on the examples and on ``phongscene import`` output;
without it they report ``MissingShaderIdInRegistry`` (so the check can fail)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from support.paths import EXAMPLES

# Runs in a fresh interpreter: USD only, no phongscene. Prints the identifiers of every
# validation error per file, and whether Sdr knows the shader and its inputs.
VALIDATE = r"""
import json, sys
from pxr import Sdr, Usd, UsdValidation
assert "phongscene" not in sys.modules
node = Sdr.Registry().GetShaderNodeByIdentifier("phongscene_PhongSurface")
validators = UsdValidation.ValidationRegistry().GetOrLoadAllValidators()
errors = {}
for path in sys.argv[1:]:
    found = UsdValidation.ValidationContext(validators).Validate(Usd.Stage.Open(path))
    errors[path] = [str(e.GetIdentifier()) + ": " + e.GetMessage() for e in found]
print(json.dumps({
    "known": node is not None,
    "inputs": sorted(node.GetShaderInputNames()) if node else [],
    "errors": errors,
    "loaded_phongscene": "phongscene" in sys.modules,
}))
"""


def _plugin_folder() -> Path:
    out = subprocess.run(
        [sys.executable, "-m", "phongscene", "info", "--usd-plugin-path"], capture_output=True, text=True, check=True
    )
    return Path(out.stdout.strip())


def _validate(files: list[Path], folder: Path | None) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith("PXR_SDR_FS_PLUGIN")}
    if folder is not None:
        env.update(PXR_SDR_FS_PLUGIN_SEARCH_PATHS=str(folder), PXR_SDR_FS_PLUGIN_ALLOWED_EXTS="usda")
    out = subprocess.run(
        [sys.executable, "-c", VALIDATE, *map(str, files)], capture_output=True, text=True, env=env, check=True
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def usd_files(tmp_path_factory) -> list[Path]:
    import trimesh

    tmp = tmp_path_factory.mktemp("plugin")
    trimesh.creation.box().export(tmp / "box.stl")
    subprocess.run(
        [sys.executable, "-m", "phongscene", "import", str(tmp / "box.stl"), "-o", str(tmp / "box.usda")],
        check=True,
        capture_output=True,
    )
    return [*sorted(EXAMPLES.glob("*.usda")), tmp / "box.usda"]


@pytest.mark.subprocess
def test_the_plugin_folder_holds_the_definition_as_its_only_usda_file():
    folder = _plugin_folder()
    # The filesystem discovery takes every .usda file in the folder as one node named after it.
    assert [p.name for p in folder.rglob("*.usda")] == ["phongscene_PhongSurface.usda"]


@pytest.mark.subprocess
def test_usd_validators_report_nothing_with_the_plugin_folder(usd_files):
    result = _validate(usd_files, _plugin_folder())
    assert not result["loaded_phongscene"]
    assert result["known"]
    assert result["inputs"] == [
        "checkerColor",
        "checkerOutlineColor",
        "checkerOutlineWidth",
        "checkerPlane",
        "checkerSize",
        "diffuseColor",
        "emissiveColor",
        "exponent",
        "fresnel",
        "interiorFilter",
        "ior",
        "ka",
        "kd",
        "kr",
        "ks",
        "kt",
        "normal",
        "opacity",
        "opacityThreshold",
        "reflectiveColor",
        "specularColor",
    ]
    assert result["errors"] == {str(p): [] for p in usd_files}


@pytest.mark.subprocess
def test_without_the_plugin_folder_usd_reports_the_shader_missing(usd_files):
    result = _validate(usd_files[:1], None)
    assert not result["known"]
    (errors,) = result["errors"].values()
    assert errors and all("MissingShaderIdInRegistry" in e for e in errors), errors


@pytest.mark.subprocess
def test_phongscene_registers_the_shader_also_when_usd_already_discovered_it(tmp_path):
    # Both ways at once (the environment set and phongscene imported): one node, same defaults.
    probe = (
        "from pxr import Sdr\n"
        "import phongscene.usd as u\n"
        "from phongscene.usd.shader_defs import phong_input_defaults\n"
        "assert Sdr.Registry().GetShaderNodeIdentifiers().count('phongscene_PhongSurface') == 1\n"
        "print(phong_input_defaults()['exponent'])\n"
    )
    env = dict(os.environ, PXR_SDR_FS_PLUGIN_SEARCH_PATHS=str(_plugin_folder()), PXR_SDR_FS_PLUGIN_ALLOWED_EXTS="usda")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, env=env, check=True)
    assert out.stdout.strip() == "32.0"


@pytest.mark.subprocess
def test_info_without_a_scene_or_the_flag_is_a_usage_error():
    out = subprocess.run([sys.executable, "-m", "phongscene", "info"], capture_output=True, text=True)
    assert out.returncode == 2
    assert "--usd-plugin-path" in out.stderr
