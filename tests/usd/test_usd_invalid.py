# SPDX-License-Identifier: Apache-2.0
"""Each scene in tests/scenes/invalid/ has one error, described in its header comment
(expected-prim / expected-attribute / expected-message); the API and `phongscene validate`
both report exactly that, without a traceback."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest

from phongscene.cli import main
from phongscene.errors import SceneError
from phongscene.usd import load_usd
from support.paths import REPO

INVALID = sorted((REPO / "tests" / "scenes" / "invalid").glob("*.usda"))


def expected(path):
    header = path.read_text().split("(", 1)[0]
    fields = dict(re.findall(r"expected-(prim|attribute|message): (.*)", header))
    return fields["prim"], fields["attribute"], fields["message"].strip()


def test_there_is_an_invalid_scene_for_each_required_error():
    names = {p.stem for p in INVALID}
    for required in ("nan_kd", "negative_ks", "negative_exponent", "index_out_of_range", "unknown_phong_attribute"):
        assert required in names


@pytest.mark.parametrize("path", INVALID, ids=lambda p: p.stem)
def test_api_reports_the_one_expected_problem(path):
    prim, attribute, message = expected(path)
    with pytest.raises(SceneError) as info:
        load_usd(path)
    (problem,) = info.value.problems
    assert (problem.prim, problem.attribute) == (prim, attribute)
    assert message in problem.message
    assert problem.file == str(path)


@pytest.mark.slow
@pytest.mark.parametrize("path", INVALID, ids=lambda p: p.stem)
def test_cli_validate_exits_2_with_one_line(path, capsys):
    prim, attribute, message = expected(path)
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0].startswith(f"error: {path}: {prim}.{attribute}: ") and message in err[0]


@pytest.mark.subprocess
def test_cli_in_a_subprocess_prints_no_traceback():
    path = REPO / "tests" / "scenes" / "invalid" / "negative_ks.usda"
    run = subprocess.run([sys.executable, "-m", "phongscene", "validate", str(path)], capture_output=True, text=True)
    assert run.returncode == 2
    assert "Traceback" not in run.stderr and "/Looks/M/Phong.inputs:ks: must be in [0, 1], got -0.5" in run.stderr


def test_missing_scene_file(tmp_path, capsys):
    missing = tmp_path / "nope.usda"
    with pytest.raises(SceneError, match="file not found"):
        load_usd(missing)
    assert main(["validate", str(missing)]) == 2
    assert capsys.readouterr().err.strip() == f"error: {missing}: file not found"


# Scenes that USD and usdview draw with a warning (a reference that does not resolve, normals of
# the wrong type): phongscene warns and draws the rest too; `validate --strict` rejects them.
WARNED = sorted((REPO / "tests" / "scenes" / "warned").glob("*.usda"))


def _warned_expectation(path):
    header = path.read_text().split("(", 1)[0]
    fields = dict(re.findall(r"expected-(warning|drawn): (.*)", header))
    return fields["warning"].strip(), fields["drawn"].strip()


def test_there_is_a_warned_scene_for_each_required_case():
    assert {p.stem for p in WARNED} >= {"missing_reference", "wrong_type_normals"}


@pytest.mark.slow
@pytest.mark.parametrize("path", WARNED, ids=lambda p: p.stem)
def test_warned_scene_is_drawn_with_its_warning(path, capsys):
    from phongscene.usd import read_usd

    warning, drawn = _warned_expectation(path)
    result = read_usd(path)
    assert any(w.startswith(warning) for w in result.warnings), result.warnings
    assert drawn in {node.source for node in (*result.scene.spheres, *result.scene.meshes)}
    assert main(["validate", str(path)]) == 0
    assert main(["validate", "--strict", str(path)]) == 2
    assert warning in capsys.readouterr().err
