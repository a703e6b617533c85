# SPDX-License-Identifier: Apache-2.0
"""The backends install inside the package, from an editable install and a wheel."""

from __future__ import annotations

import importlib.metadata
import importlib.resources
import subprocess
import sys
import sysconfig
import zipfile

import pytest

import phongscene
from support.paths import REPO


def test_backends_import_from_the_installed_package():
    import phongscene.backends.native as native
    import phongscene.backends.povray as povray

    assert native._native.hardware_threads() >= 1
    assert povray.__name__ == "phongscene.backends.povray"
    assert importlib.resources.files("phongscene.schemas").is_dir()


def test_the_version_is_written_once():
    # pyproject.toml takes it from phongscene/__init__.py (scikit-build-core's regex provider).
    assert importlib.metadata.version("phongscene") == phongscene.__version__
    assert "version =" not in (REPO / "pyproject.toml").read_text().split("[tool.")[0]


def test_the_package_is_typed_and_licensed():
    assert importlib.resources.files("phongscene").joinpath("py.typed").is_file()
    assert "Apache License" in (REPO / "LICENSE").read_text()


@pytest.mark.subprocess
@pytest.mark.slow
def test_wheel_contains_the_backends_the_extension_and_no_cpp(tmp_path):
    # --no-build-isolation: the build requirements are already in the test environment.
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "--no-build-isolation",
            "--no-deps",
            "-q",
            "-w",
            str(tmp_path),
            str(REPO),
        ],
        check=True,
        capture_output=True,
    )
    (wheel,) = tmp_path.glob("phongscene-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    assert "phongscene/backends/povray/__init__.py" in names
    assert "phongscene/backends/native/__init__.py" in names
    assert any(n.startswith("phongscene/backends/native/_native") and n.endswith(".so") for n in names)
    assert "phongscene/schemas/__init__.py" in names
    assert not [n for n in names if n.endswith((".cpp", ".hpp", ".c", "CMakeLists.txt"))]
    # The `phongscene` command (cli/launcher.c, compiled), installed to the scripts folder.
    (command,) = [n for n in names if n.endswith(".data/scripts/phongscene")]
    assert zipfile.ZipFile(wheel).read(command)[:4] == b"\x7fELF"
    assert "phongscene/py.typed" in names  # PEP 561: mypy reads the package's annotations
    assert "phongscene/schemas/phongscene_PhongSurface.usda" in names
    (metadata,) = [n for n in names if n.endswith(".dist-info/METADATA")]
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names), names
    meta = zipfile.ZipFile(wheel).read(metadata).decode()
    assert f"Version: {phongscene.__version__}\n" in meta
    requires = [line for line in meta.splitlines() if line.startswith("Requires-Dist:")]
    matplotlib = [line for line in requires if "matplotlib" in line]
    assert matplotlib and all("extra ==" in line for line in matplotlib), requires  # only the bench extra

    # Import from the unpacked wheel, not from the editable install: -S skips site-packages'
    # .pth files (where the editable redirect lives); the dependencies come from this
    # environment's purelib, passed in because without `site` a venv's prefix is not set.
    target = tmp_path / "site"
    zipfile.ZipFile(wheel).extractall(target)
    probe = (
        "import sys; sys.path[:0] = sys.argv[1:3];"
        "import phongscene.backends.native as n, phongscene.backends.povray as p, phongscene;"
        "assert n.__file__.startswith(sys.argv[1]) and p.__file__.startswith(sys.argv[1]), (n.__file__, p.__file__);"
        "assert n._native.hardware_threads() >= 1"
    )
    subprocess.run(
        [sys.executable, "-S", "-c", probe, str(target), sysconfig.get_paths()["purelib"]], check=True, cwd=tmp_path
    )
