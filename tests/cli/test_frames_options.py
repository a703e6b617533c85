# SPDX-License-Identifier: Apache-2.0
"""The --frames options of issue 26.5: one check of the output before any task, the folder rules
of the single commands, a quiet Ctrl-C, --skip-existing, usdrecord's frame specs and the
contact sheet."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from phongscene.cli import main
from phongscene.images import read_image

WIDTH = 24
ANIMATED = """#usda 1.0
(
    startTimeCode = 1
    endTimeCode = 400
    upAxis = "Y"
)
def Camera "Camera"
{
    double3 xformOp:translate = (0, 2, 14)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def SphereLight "Light"
{
    float inputs:intensity = 2000
    float inputs:radius = 0.1
    double3 xformOp:translate = (2, 4, 2)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Sphere "Ball"
{
    double radius = 1
    double3 xformOp:translate.timeSamples = {1: (-2, 1, 0), 400: (2, 1, 0)}
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
"""


@pytest.fixture
def animated(tmp_path):
    path = tmp_path / "animated.usda"
    path.write_text(ANIMATED)
    return str(path)


def test_a_missing_output_folder_is_one_error_before_any_frame(animated, tmp_path, capsys):
    code = main(
        ["render", animated, "-o", str(tmp_path / "nodir" / "f.####.png"), "--width", str(WIDTH), "--frames", "1:24"]
    )
    err = capsys.readouterr().err
    assert code == 2 and err.count("error:") == 1 and "does not exist" in err and "frames rendered" not in err
    assert main(["compile", animated, "-o", str(tmp_path / "nodir" / "f.####.pov"), "--frames", "1:24"]) == 2
    assert capsys.readouterr().err.count("error:") == 1


def test_diff_frames_refuses_a_folder_whose_parent_is_missing_as_diff_does(animated, tmp_path, capsys):
    for frames in ([], ["--frames", "1:2"]):
        code = main(["diff", animated, "-o", str(tmp_path / "nodir" / "sub"), "--width", str(WIDTH), *frames])
        assert code == 2 and "does not exist" in capsys.readouterr().err
        assert not (tmp_path / "nodir").exists()


def test_skip_existing_renders_only_the_missing_frames_and_says_how_many_were_skipped(animated, tmp_path, capsys):
    out = str(tmp_path / "f.####.exr")
    assert main(["render", animated, "-o", out, "--width", str(WIDTH), "--frames", "3"]) == 0
    kept = os.stat(tmp_path / "f.0003.exr").st_mtime_ns
    capsys.readouterr()
    # One frame left to do: it runs in this process (no cluster), and frame 3 is not redone.
    assert main(["render", animated, "-o", out, "--width", str(WIDTH), "--frames", "3:4", "--skip-existing"]) == 0
    said = capsys.readouterr().out
    assert "1 of 2 frames skipped, their outputs exist (--skip-existing)" in said
    assert "1 of 1 frames rendered" in said
    assert os.stat(tmp_path / "f.0003.exr").st_mtime_ns == kept and (tmp_path / "f.0004.exr").exists()
    assert main(["render", animated, "-o", out, "--width", str(WIDTH), "--frames", "3:4", "--skip-existing"]) == 0
    assert "nothing to do" in capsys.readouterr().out


def test_usdrecords_stride_is_accepted(animated, tmp_path, capsys):
    assert (
        main(["render", animated, "-o", str(tmp_path / "s.####.exr"), "--width", str(WIDTH), "--frames", "9:9x4"]) == 0
    )
    assert sorted(p.name for p in tmp_path.glob("s.*.exr")) == ["s.0009.exr"]
    with pytest.raises(SystemExit) as exit:  # argparse's usage error
        main(["render", animated, "-o", str(tmp_path / "s.####.exr"), "--frames", "5x1"])
    assert exit.value.code == 2 and "START:ENDxSTRIDE (usdrecord's)" in capsys.readouterr().err


@pytest.mark.dask
@pytest.mark.slow
def test_a_stride_range_with_a_contact_sheet(animated, tmp_path, capsys):
    sheet = tmp_path / "sheet.png"
    assert (
        main(
            [
                "render",
                animated,
                "-o",
                str(tmp_path / "f.####.exr"),
                "--width",
                str(WIDTH),
                "--frames",
                "1:9x4",
                "--workers",
                "2",
                "--contact-sheet",
                str(sheet),
            ]
        )
        == 0
    )
    assert sorted(p.name for p in tmp_path.glob("f.*.exr")) == ["f.0001.exr", "f.0005.exr", "f.0009.exr"]
    assert "contact sheet of 3 frames" in capsys.readouterr().out
    grid = read_image(sheet)
    from phongscene.contact_sheet import GAP

    # 3 frames: 2 columns, 2 rows of WIDTH x 18 thumbnails (the frames are smaller than a thumbnail).
    assert grid.shape == (GAP + 2 * (18 + GAP), GAP + 2 * (WIDTH + GAP), 3)
    first = read_image(tmp_path / "f.0001.exr")
    cell = grid[GAP : GAP + 18, GAP : GAP + WIDTH]
    below_label = slice(16, 18)  # the label sits in the cell's top rows
    assert np.allclose(cell[below_label], np.clip(first[below_label], 0, 1), atol=1 / 255 + 1e-3)  # 8-bit sRGB


def test_the_contact_sheet_is_checked_before_the_frames(animated, tmp_path, capsys):
    code = main(
        [
            "render",
            animated,
            "-o",
            str(tmp_path / "f.####.exr"),
            "--frames",
            "1:2",
            "--contact-sheet",
            str(tmp_path / "sheet.jpg"),
        ]
    )
    assert code == 2 and "the contact sheet must end in one of" in capsys.readouterr().err


@pytest.mark.dask
@pytest.mark.subprocess
@pytest.mark.slow
def test_ctrl_c_during_frames_on_dask_is_one_line_and_exit_130(animated, tmp_path):
    out = tmp_path / "frames"
    out.mkdir()
    # A Python parent: its child starts with SIGINT at its default (a shell's background job would ignore it).
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "phongscene",
            "render",
            animated,
            "-o",
            str(out / "f.####.png"),
            "--width",
            "160",
            "--spp",
            "3",
            "--frames",
            "1:400",
            "--workers",
            "2",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    deadline = time.monotonic() + 120
    while not any(out.iterdir()) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert any(out.iterdir()), "no frame was rendered"
    os.killpg(proc.pid, signal.SIGINT)  # what Ctrl-C in a terminal does: the whole process group
    _, err = proc.communicate(timeout=120)
    lines = [line for line in err.splitlines() if line.strip()]
    assert proc.returncode == 130
    assert "Traceback" not in err and lines[-1] == "interrupted", err
    assert len(lines) <= 2, err  # the progress line (when there is one) and "interrupted"
    assert len(list(out.iterdir())) < 400
