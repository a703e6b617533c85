# SPDX-License-Identifier: Apache-2.0
"""Outputs and their wording (issue 10, item 7): a bad output path is found before the render,
no missing folder is created, errors name the user's file (not the hidden temporary one), a
full disk leaves no half-written report or .pov without its .ini, and ``compile`` prints a
povray command that POV-Ray accepts for a name with spaces.

A full disk is simulated with RLIMIT_FSIZE in a child process (a write beyond it fails with
EFBIG, as a full disk fails with ENOSPC)."""

from __future__ import annotations

import shlex
import subprocess
import sys

import pytest

import phongscene.crossvalidation
import phongscene.rendering
from phongscene.cli import main
from support.paths import EXAMPLES

SCENE = EXAMPLES / "seed_lobe.usda"
# Bytes a child may write per file: the .ini (~300 bytes) and small SDL fit, an image or a
# report's EXR does not.
SMALL_FILE_LIMIT = 4096


def _refuse_to_render(*args, **kwargs):
    raise AssertionError("rendered although the output cannot be written")


@pytest.mark.parametrize(("command", "name"), [("render", "x.png"), ("compile", "x.pov"), ("diff", "report")])
def test_a_missing_output_folder_is_found_before_rendering_and_not_created(
    command, name, tmp_path, capsys, monkeypatch
):
    monkeypatch.setattr(phongscene.rendering, "render", _refuse_to_render)
    monkeypatch.setattr(phongscene.crossvalidation, "render", _refuse_to_render)
    missing = tmp_path / "no-such-folder"
    assert main([command, str(SCENE), "-o", str(missing / name), "--width", "8"]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line == f"error: {missing / name}: the folder {missing} does not exist (create it first)"
    assert not missing.exists()


def _child(args: list[str], cwd) -> subprocess.CompletedProcess:
    """The CLI in a child whose files may not grow beyond SMALL_FILE_LIMIT bytes (SIGXFSZ
    ignored, so the write fails with EFBIG instead of killing the child)."""
    code = (
        "import resource, signal, sys\n"
        "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
        f"resource.setrlimit(resource.RLIMIT_FSIZE, ({SMALL_FILE_LIMIT}, {SMALL_FILE_LIMIT}))\n"
        "from phongscene.cli import main\n"
        "sys.exit(main(sys.argv[1:]))\n"
    )
    return subprocess.run([sys.executable, "-c", code, *args], cwd=cwd, capture_output=True, text=True, timeout=300)


@pytest.mark.subprocess
def test_a_full_disk_names_the_users_file_and_leaves_nothing(tmp_path):
    out = tmp_path / "image.exr"
    result = _child(["render", str(SCENE), "-o", str(out), "--width", "64"], tmp_path)
    assert result.returncode == 2, result.stderr
    (line,) = [x for x in result.stderr.splitlines() if x.startswith("error: ")]  # after the progress line
    assert line.startswith(f"error: {out}: ") and "/." not in line  # no hidden temporary name
    assert list(tmp_path.iterdir()) == []


@pytest.mark.povray
def test_a_full_disk_during_diff_leaves_no_report(tmp_path, capsys, monkeypatch):
    import phongscene.report
    from phongscene.errors import PhongSceneError

    written = []
    real = phongscene.report.write_image

    def fill_up(path, *args, **kwargs):  # the disk is full after three images
        if len(written) == 3:
            raise PhongSceneError(f"{path}: cannot write image: no space left on device")
        written.append(path)
        return real(path, *args, **kwargs)

    monkeypatch.setattr(phongscene.report, "write_image", fill_up)
    outdir = tmp_path / "report"
    assert main(["diff", str(SCENE), "-o", str(outdir), "--width", "16", "--no-sandbox"]) == 2
    assert capsys.readouterr().err.strip().splitlines()[-1].endswith("no space left on device")
    assert len(written) == 3 and list(tmp_path.iterdir()) == []  # no report folder, no temporary one


def test_compile_writes_pov_and_ini_together_or_neither(tmp_path, capsys):
    (tmp_path / "c.ini").mkdir()  # the .ini cannot be written
    assert main(["compile", str(SCENE), "-o", str(tmp_path / "c.pov"), "--width", "8"]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith(f"error: {tmp_path / 'c.ini'}: ")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.ini"]  # no c.pov, no temporary file


@pytest.mark.subprocess
@pytest.mark.povray
def test_compile_prints_a_povray_command_that_works_with_spaces(tmp_path, capsys):
    out = tmp_path / "my scene.pov"
    assert main(["compile", str(SCENE), "-o", str(out), "--width", "8", "--mapping", "classic"]) == 0
    printed = capsys.readouterr().out.splitlines()
    command = next(line.strip() for line in printed if line.strip().startswith("povray '+I"))
    ini_command = printed[1].split(" with: ", 1)[1]
    for run, image in ((command, "my scene.exr"), (ini_command, "my scene.exr")):
        result = subprocess.run(shlex.split(run), cwd=tmp_path, capture_output=True, text=True, timeout=120)
        assert result.returncode == 0 and (tmp_path / image).is_file(), result.stderr[-500:]
        (tmp_path / image).unlink()
