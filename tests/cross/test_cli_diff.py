# SPDX-License-Identifier: Apache-2.0
"""``phongscene diff`` and ``phongscene compare``: exit codes, output files, messages."""

from __future__ import annotations

import io
import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import phongscene
from phongscene.cli import EXIT_BACKEND, EXIT_DIFFERENT, EXIT_OK, EXIT_SCENE, main
from phongscene.images import write_image
from phongscene.progress import ProgressBar
from support.paths import EXAMPLES

# A small scene for diff runs: one sphere, one point light, a camera (48×36 keeps POV-Ray fast).
SMALL_SCENE = """#usda 1.0
(
    upAxis = "Y"
    metersPerUnit = 1
)
def Camera "Cam"
{
    float focalLength = 35
    float horizontalAperture = 36
    double3 xformOp:translate = (0, 0.3, 5)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def SphereLight "Key"
{
    float inputs:intensity = 2.5
    bool treatAsPoint = true
    double3 xformOp:translate = (3, 4, 5)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def DomeLight "Ambient"
{
    float inputs:intensity = 0.2
}
def Sphere "Ball"
{
    double radius = 1.13
    color3f[] primvars:displayColor = [(0.8, 0.3, 0.2)]
}
def RenderSettings "Settings"
{
    rel camera = </Cam>
    int2 resolution = (48, 36)
}
"""

BAD_SCENE = SMALL_SCENE.replace("double radius = 1.13", "double radius = -1.13")


def _run(*args: str) -> subprocess.CompletedProcess:
    """The real command in its own process: exit code and stderr as a user sees them."""
    return subprocess.run([sys.executable, "-m", "phongscene", *args], capture_output=True, text=True, timeout=120)


@pytest.fixture
def small_scene(tmp_path) -> Path:
    path = tmp_path / "small.usda"
    path.write_text(SMALL_SCENE, encoding="utf-8")
    return path


# ----------------------------------------------------------------------------------------------
# compare


def _pair(tmp_path, delta: float = 0.0):
    rng = np.random.default_rng(7)
    a = rng.random((10, 14, 3)).astype(np.float32)
    b = a.copy()
    b[4, 6, 1] += delta
    return write_image(tmp_path / "a.exr", a), write_image(tmp_path / "b.exr", b, half=True)


def test_cli_compare_agreeing_files_exit_0(tmp_path, capsys):
    pa, pb = _pair(tmp_path)
    assert main(["compare", str(pa), str(pb)]) == EXIT_OK
    assert "PASS" in capsys.readouterr().out


def test_cli_compare_differing_files_exit_1_and_report(tmp_path, capsys):
    pa, pb = _pair(tmp_path, delta=0.01)
    out = tmp_path / "rep"
    assert main(["compare", str(pa), str(pb), "-o", str(out)]) == EXIT_DIFFERENT
    text = capsys.readouterr().out
    assert "@ (6, 4, G)" in text and "FAILURE" in text
    metrics = json.loads((out / "metrics.json").read_text(encoding="utf-8"))
    assert metrics["report"]["failing_pixels"] == 1
    assert (out / "index.html").is_file() and (out / "diff_heat.png").is_file()


def test_cli_compare_thresholds_from_options(tmp_path):
    pa, pb = _pair(tmp_path, delta=0.01)
    assert main(["compare", str(pa), str(pb), "--fail-percent", "1"]) == EXIT_OK  # 1 of 140 px = 0.7 %
    assert main(["compare", str(pa), str(pb), "--fail-percent", "1", "--hard-fail", "0.005"]) == EXIT_DIFFERENT


def test_cli_compare_size_mismatch_exit_1(tmp_path, capsys):
    pa = write_image(tmp_path / "a.exr", np.zeros((4, 4, 3), np.float32))
    pb = write_image(tmp_path / "b.exr", np.zeros((4, 5, 3), np.float32))
    assert main(["compare", str(pa), str(pb)]) == EXIT_DIFFERENT
    assert "different sizes: 4x4" in capsys.readouterr().err


def test_cli_compare_unreadable_file_exit_2(tmp_path, capsys):
    pa, _ = _pair(tmp_path)
    missing = tmp_path / "missing.exr"
    assert main(["compare", str(pa), str(missing)]) == EXIT_SCENE
    assert "missing.exr" in capsys.readouterr().err


def test_cli_compare_bad_threshold_exit_2(tmp_path, capsys):
    pa, pb = _pair(tmp_path)
    assert main(["compare", str(pa), str(pb), "--fail", "-1"]) == EXIT_SCENE
    assert "Thresholds.fail" in capsys.readouterr().err


def test_python_api_exports_compare_and_diff():
    assert phongscene.compare is __import__("phongscene.comparison", fromlist=["compare"]).compare
    assert callable(phongscene.diff) and callable(phongscene.render)


# ----------------------------------------------------------------------------------------------
# diff


@pytest.mark.subprocess
def test_cli_diff_bad_scene_exit_2(tmp_path):
    path = tmp_path / "bad.usda"
    path.write_text(BAD_SCENE, encoding="utf-8")
    r = _run("diff", str(path), "-o", str(tmp_path / "out"))
    assert r.returncode == EXIT_SCENE, r.stderr
    assert "/Ball" in r.stderr and "radius" in r.stderr and "Traceback" not in r.stderr


def test_cli_diff_missing_scene_exit_2(tmp_path, capsys):
    assert main(["diff", str(tmp_path / "nope.usda"), "-o", str(tmp_path / "out")]) == EXIT_SCENE
    assert "nope.usda" in capsys.readouterr().err


@pytest.mark.slow
@pytest.mark.povray
def test_cli_diff_agreeing_backends_exit_0(tmp_path, small_scene, capsys):
    out = tmp_path / "out"
    assert main(["diff", str(small_scene), "-o", str(out), "--width", "40"]) == EXIT_OK
    err = capsys.readouterr().err
    metrics = json.loads((out / "metrics.json").read_text(encoding="utf-8"))
    assert metrics["report"]["ok"] is True and metrics["settings"]["width"] == 40
    assert metrics["settings"]["height"] == 30  # aspect ratio kept
    assert set(metrics["timings_seconds"]) == {"povray", "native"}
    assert "povray: rendered in" in err and "native: rendered in" in err  # progress (not a terminal)


@pytest.mark.slow
@pytest.mark.povray
def test_cli_diff_classic_mapping_exit_0(tmp_path, small_scene):
    assert (
        main(["diff", str(small_scene), "-o", str(tmp_path / "out"), "--mapping", "classic", "--width", "32"])
        == EXIT_OK
    )
    metrics = json.loads((tmp_path / "out" / "metrics.json").read_text(encoding="utf-8"))
    assert metrics["mapping"] == "classic" and metrics["native_specular"] == "povray-classic"


@pytest.mark.slow
@pytest.mark.povray
def test_cli_diff_differing_images_exit_1(tmp_path, small_scene, capsys):
    # With zero tolerance, POV-Ray's half-float rounding alone makes the images differ.
    args = [
        "diff",
        str(small_scene),
        "-o",
        str(tmp_path / "out"),
        "--width",
        "32",
        "--fail",
        "0",
        "--fail-relative",
        "0",
    ]
    assert main(args) == EXIT_DIFFERENT
    assert "FAILURE" in capsys.readouterr().out


def test_cli_diff_povray_unavailable_exit_3(tmp_path, small_scene, monkeypatch, capsys):
    bare = tmp_path / "bin"  # a PATH without povray
    bare.mkdir()
    monkeypatch.setenv("PATH", str(bare))
    assert shutil.which("povray") is None
    assert main(["diff", str(small_scene), "-o", str(tmp_path / "out"), "--width", "32"]) == EXIT_BACKEND
    assert "povray" in capsys.readouterr().err.lower()


class _FakeTerminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_bar_draws_on_a_terminal_and_stays_quiet_in_logs():
    tty = _FakeTerminal()
    bar = ProgressBar("native", tty)
    bar(0, 4)
    bar(2, 4)  # the native backend reports (tiles done, tiles total)
    bar(0.75)  # a fraction works too
    bar.done(0.5)
    text = tty.getvalue()
    assert "\r" in text and " 50%" in text and " 75%" in text and "done in 0.50 s" in text
    log = io.StringIO()
    bar = ProgressBar("povray", log)
    bar(1, 2)
    bar.done(1.25)
    assert log.getvalue() == "povray: rendered in 1.25 s\n"


def _diff_result(explained, unexplained, failing_pixels: int = 1, size: int = 32):
    from phongscene.comparison import compare
    from phongscene.crossvalidation import DiffResult
    from phongscene.scene import RenderSettings

    a = np.full((size, size, 3), 0.5, np.float32)
    b = a.copy()
    b.reshape(-1, 3)[:failing_pixels] = 0.4
    report = compare(a, b)
    return DiffResult(report, None, {}, a, b, RenderSettings(), "exact", [], tuple(explained), tuple(unexplained))


def test_diff_passes_only_when_every_failing_pixel_is_explained_and_they_are_few():
    assert not _diff_result([], []).report.ok  # the comparison itself fails
    assert _diff_result([(0, 0)], []).ok  # explained by POV-Ray's shadow cache
    assert not _diff_result([(0, 0)], [(1, 0)], failing_pixels=2).ok  # one is not explained
    # More explained pixels than the shadow-cache allowance (0.2 % of 1024 = 2) still fail.
    many = [(i, 0) for i in range(3)]
    assert not _diff_result(many, [], failing_pixels=3).ok
    assert "3 failing pixels explained by POV-Ray's shadow cache" in _diff_result(many, [], 3).explanation()


@pytest.mark.povray
def test_diff_renders_natively_in_povray_numerics(tmp_path):
    result = phongscene.diff(EXAMPLES / "seed_lobe.usda", None, width=40)
    assert result.settings.numerics == "povray" and result.ok


@pytest.mark.povray
def test_diff_without_a_mapping_compares_glass_with_a_highlight_in_the_classic_mapping():
    # The exact mapping refuses a transmissive material with a highlight (a Blender glass's
    # OpenPBR network has one); diff without --mapping compares it in the classic mapping and
    # says why, diff --mapping exact still refuses it, and a scene without one stays exact.
    import dataclasses

    from phongscene.errors import SceneError
    from support import calibration

    scene = calibration.glass_sphere()
    glass = scene.spheres[-1]
    shiny = dataclasses.replace(glass.material, ks=0.5, exponent=50.0)
    scene = dataclasses.replace(scene, spheres=(*scene.spheres[:-1], dataclasses.replace(glass, material=shiny)))
    result = phongscene.diff(scene, None, width=32)
    assert result.mapping == "classic" and result.settings.specular == "povray-classic"
    assert any("compared in the classic mapping" in w and "highlight" in w for w in result.warnings)
    assert result.ok
    with pytest.raises(SceneError, match="use the classic mapping"):
        phongscene.diff(scene, None, width=32, mapping="exact")
    plain = phongscene.diff(calibration.glass_sphere(), None, width=32)
    assert plain.mapping == "exact" and not any("classic mapping" in w for w in plain.warnings)
