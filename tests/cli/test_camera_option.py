# SPDX-License-Identifier: Apache-2.0
"""--camera PATH (a RenderOverrides field) for render, compile, diff and frames; `info` lists
every camera; a stage with two cameras and none chosen says which it used (issue 26.6)."""

from __future__ import annotations

import numpy as np
import pytest

import phongscene as ps
from phongscene.cli import main
from phongscene.images import read_image

TWO_CAMERAS = """#usda 1.0
(
    upAxis = "Y"
)
def Camera "Front"
{
    double3 xformOp:translate = (0, 2, 14)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Camera "Side"
{
    double3 xformOp:translate = (14, 2, 0)
    float xformOp:rotateY = 90
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateY"]
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
    double3 xformOp:translate = (0, 1, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Cube "Box"
{
    double size = 1
    double3 xformOp:translate = (0, 0.5, 2.5)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
"""
SMALL = ps.RenderOverrides(width=32)


@pytest.fixture
def two(tmp_path):
    path = tmp_path / "two.usda"
    path.write_text(TWO_CAMERAS)
    return str(path)


def test_two_cameras_and_none_chosen_warns_naming_the_one_used(two):
    result = ps.read_usd(two)
    assert result.cameras == ["/Front", "/Side"]
    assert result.scene.camera.source == "/Front"
    assert any(
        "has 2 cameras (/Front, /Side) and none is chosen: using the first, /Front" in w for w in result.warnings
    )
    chosen = ps.read_usd(two, camera="/Side")
    assert chosen.scene.camera.source == "/Side" and not any("none is chosen" in w for w in chosen.warnings)
    assert chosen.scene.camera.position == pytest.approx((14, 2, 0))


def test_a_camera_that_is_not_one_is_an_error_naming_the_cameras(two):
    for path, what in (("/Nope", "no such prim"), ("/Ball", "is a Sphere, not a Camera")):
        with pytest.raises(ps.SceneError) as e:
            ps.read_usd(two, camera=path)
        assert f"{path}: the camera asked for (--camera): {what}; the stage's cameras: /Front, /Side" in str(e.value)


def test_render_through_the_chosen_camera(two, tmp_path, capsys):
    out = tmp_path / "side.exr"
    assert main(["render", two, "-o", str(out), "--width", "32", "--camera", "/Side"]) == 0
    assert "none is chosen" not in capsys.readouterr().err
    side = ps.render(two, overrides=ps.RenderOverrides(width=32, camera="/Side"))
    np.testing.assert_array_equal(read_image(out), side)
    with pytest.warns(ps.SceneWarning, match="none is chosen"):
        front = ps.render(two, overrides=SMALL)
    assert not np.array_equal(front, side)  # the box hides part of the ball from the front, not from the side
    assert main(["render", two, "-o", str(tmp_path / "x.exr"), "--camera", "/Nope"]) == 2
    assert "/Nope: the camera asked for" in capsys.readouterr().err


def test_compile_and_frames_use_the_chosen_camera(two, tmp_path):
    assert main(["compile", two, "-o", str(tmp_path / "side.pov"), "--camera", "/Side"]) == 0
    sdl = (tmp_path / "side.pov").read_text()
    assert "/Side" in sdl and "/Front" not in sdl
    assert (
        main(["render", two, "-o", str(tmp_path / "f.####.exr"), "--width", "32", "--camera", "/Side", "--frames", "1"])
        == 0
    )
    np.testing.assert_array_equal(
        read_image(tmp_path / "f.0001.exr"), ps.render(two, overrides=ps.RenderOverrides(width=32, camera="/Side"))
    )


def test_info_lists_every_camera(two, capsys):
    assert main(["info", two, "--camera", "/Side"]) == 0
    out = capsys.readouterr().out
    assert "cameras (2; --camera PATH chooses one):\n  /Front\n  /Side  (used)\n" in out


@pytest.mark.povray
def test_diff_through_the_chosen_camera(two, tmp_path, capsys):
    assert main(["diff", two, "-o", str(tmp_path / "report"), "--width", "32", "--camera", "/Side"]) == 0
    import json

    assert json.loads((tmp_path / "report" / "metrics.json").read_text())["camera"] == "/Side"
