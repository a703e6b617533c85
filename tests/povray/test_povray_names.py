# SPDX-License-Identifier: Apache-2.0
"""What reaches POV-Ray's command line and .ini, and what its runner keeps (issue 29, item 5): a
file name cannot inject an option (a newline in ``compile -o NAME`` was written into the .ini
unescaped: ``Pre_Scene_Command=...``); names POV-Ray reads only quoted are quoted, and both the
.ini and the printed command then render; the runner's configuration forbids shell-outs; and this
POV-Ray build does not enforce its file I/O restriction for ``#fopen`` (docs/security.md says so;
if that test fails, a build now enforces it: update the page)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from phongscene.backends.povray import PovJob, pov_quoted
from phongscene.backends.povray.run import povray_environment
from phongscene.errors import PhongSceneError
from support.paths import EXAMPLES

SCENE = EXAMPLES / "seed_exponents.usda"
TINY = ("+W8", "+H6")  # appended to a compiled .ini's options: later options win
CLI_TIMEOUT_S = 120  # a compile or a tiny POV-Ray render; generous for a loaded 2-core machine
SDL = "#version 3.7;\ncamera { location <0, 0, -3> look_at 0 }\nsphere { 0, 1 pigment { rgb 1 } }\n"


@pytest.mark.parametrize(
    "name",
    [
        "x\nPre_Scene_Command=touch pwned\n.pov",
        "a\rb.pov",
        "nul\0.pov",
        "tab\t.pov",
        'quote".pov',
        "back\\slash.pov",
        "caf\u00e9.pov",
        "del\x7f.pov",
    ],
)
def test_a_name_povray_cannot_read_or_that_would_inject_is_refused(name):
    with pytest.raises(PhongSceneError, match="POV-Ray cannot read a file name with"):
        pov_quoted(name)
    job = PovJob(SDL, 1, 8, 6, 1, ("+FE",))
    with pytest.raises(PhongSceneError):
        job.ini(name, "out.exr")
    with pytest.raises(PhongSceneError):
        job.ini("scene.pov", name)


@pytest.mark.parametrize(
    "name,expected",
    [
        ("scene.pov", "scene.pov"),
        ("a-b_c.1.pov", "a-b_c.1.pov"),
        ("my scene.pov", '"my scene.pov"'),
        ("a;b.pov", '"a;b.pov"'),
        ("a,b.pov", '"a,b.pov"'),
        ("a#b.pov", '"a#b.pov"'),
        ("it's.pov", '"it\'s.pov"'),
        ("a=b.pov", '"a=b.pov"'),
    ],
)
def test_names_povray_reads_only_quoted_are_quoted(name, expected):
    assert pov_quoted(name) == expected
    ini = PovJob(SDL, 1, 8, 6, 1, ("+FE",)).ini(name, "out.exr")
    assert f"Input_File_Name={expected}\n" in ini


@pytest.mark.subprocess
def test_compile_refuses_a_newline_in_the_output_name(tmp_path):
    out = tmp_path / "x\nPre_Scene_Command=touch pwned\n.pov"
    result = subprocess.run(
        [sys.executable, "-m", "phongscene", "compile", str(SCENE), "-o", str(out)],
        capture_output=True,
        text=True,
        timeout=CLI_TIMEOUT_S,
        cwd=tmp_path,
    )
    assert result.returncode == 2
    (line,) = result.stderr.splitlines()
    assert "POV-Ray cannot read a file name with '\\n'" in line
    assert list(tmp_path.iterdir()) == []  # no .pov, no .ini


@pytest.mark.povray
@pytest.mark.subprocess
@pytest.mark.parametrize("stem", ["a;b c", "x,y", "it's=1"])  # no #: a frame pattern in -o
def test_a_compiled_ini_and_the_printed_command_render_with_a_quoted_name(tmp_path, stem):
    out = tmp_path / f"{stem}.pov"
    result = subprocess.run(
        [sys.executable, "-m", "phongscene", "compile", str(SCENE), "-o", str(out)],
        capture_output=True,
        text=True,
        timeout=CLI_TIMEOUT_S,
    )
    assert result.returncode == 0, result.stderr
    env = povray_environment(tmp_path)
    ini = out.with_suffix(".ini")
    run = subprocess.run(
        ["povray", pov_quoted(ini.name), *TINY, "-GA"],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        timeout=CLI_TIMEOUT_S,
    )
    assert run.returncode == 0 and out.with_suffix(".exr").is_file(), run.stderr[-500:]
    out.with_suffix(".exr").unlink()
    command = [line for line in result.stdout.splitlines() if line.startswith("  povray ")]
    import shlex

    (printed,) = command
    run = subprocess.run(
        [*shlex.split(printed), *TINY, "-GA"], cwd=tmp_path, env=env, capture_output=True, timeout=CLI_TIMEOUT_S
    )
    assert run.returncode == 0 and out.with_suffix(".exr").is_file(), run.stderr[-500:]


def _povray(workdir: Path, sdl: str, *options: str) -> subprocess.CompletedProcess:
    """Run POV-Ray on ``sdl`` in ``workdir`` exactly as the runner does (its environment, no shell)."""
    (workdir / "scene.pov").write_text(sdl, encoding="ascii")
    command = PovJob(sdl, 1, 8, 6, 1, ("+FE", "+W8", "+H6", "-D", "-GA")).command("scene.pov", "scene.exr")
    return subprocess.run(
        [*command, *options],
        cwd=workdir,
        env=povray_environment(workdir),
        capture_output=True,
        timeout=CLI_TIMEOUT_S,
        stdin=subprocess.DEVNULL,
    )


@pytest.mark.povray
@pytest.mark.subprocess
def test_a_shell_out_does_not_run_under_the_runners_configuration(tmp_path):
    # (Here the system's povray.conf forbids shell-outs too; the runner's user configuration asks
    # for the same, for a system whose configuration allows them.)
    workdir = tmp_path / "work"
    workdir.mkdir()
    marker = tmp_path / "shelled-out"
    (workdir / "extra.ini").write_text(f"Pre_Scene_Command=touch {marker}\n", encoding="ascii")
    _povray(workdir, SDL, "extra.ini")
    assert not marker.exists()


@pytest.mark.povray
@pytest.mark.subprocess
def test_this_povray_does_not_enforce_its_file_io_restriction(tmp_path):
    # docs/security.md: "restricted" with read+write only in the working directory, and yet #fopen
    # writes outside it. Our protection is that no scene text reaches the SDL (test_povray_hostile).
    workdir = tmp_path / "work"
    workdir.mkdir()
    outside = tmp_path / "outside.txt"
    _povray(workdir, f'#version 3.7;\n#fopen F "{outside}" write\n#write (F, "x")\n#fclose F\n' + SDL)
    assert outside.exists(), "this POV-Ray now enforces [File I/O Security]: update docs/security.md"


@pytest.mark.povray
@pytest.mark.subprocess
def test_the_runner_starts_povray_without_a_shell_in_a_temporary_folder_it_removes(tmp_path, monkeypatch):
    import tempfile

    from phongscene import load_usd
    from phongscene.backends import povray

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))  # where mkdtemp makes its folders
    calls = []
    real = subprocess.Popen

    def popen(args, **kwargs):
        calls.append((args, kwargs, sorted(p.name for p in Path(kwargs["cwd"]).iterdir())))
        return real(args, **kwargs)

    monkeypatch.setattr(subprocess, "Popen", popen)
    scene = load_usd(SCENE)
    import dataclasses

    povray.render(scene, dataclasses.replace(scene.settings, width=8, height=6))
    ((args, kwargs, files),) = calls
    assert isinstance(args, list) and args[0] == "povray" and not kwargs.get("shell")
    assert args[1:3] == ["+Iscene.pov", "+Oscene.exr"]  # generated names only
    assert Path(kwargs["cwd"]).parent == tmp_path and Path(kwargs["cwd"]).name.startswith("phongscene-povray-")
    assert files == ["home", "scene.ini", "scene.log", "scene.pov"]
    assert kwargs["env"]["HOME"] == str(Path(kwargs["cwd"]) / "home") and "POVINI" not in kwargs["env"]
    assert list(tmp_path.iterdir()) == []  # removed after the render
