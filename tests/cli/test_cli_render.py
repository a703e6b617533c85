# SPDX-License-Identifier: Apache-2.0
"""``phongscene render``: USD in, image out, through the native backend by default."""

from __future__ import annotations

import dataclasses

import numpy as np

from phongscene.backends import native
from phongscene.cli import EXIT_OK, EXIT_SCENE, main
from phongscene.images import read_image
from phongscene.usd import load_usd, write_usd
from support import calibration


def test_render_writes_the_native_image_as_float_exr(tmp_path, capsys):
    scene_path = write_usd(calibration.SCENES["point_light"](), tmp_path / "scene.usda")
    out = tmp_path / "out" / "image.exr"
    out.parent.mkdir()  # phongscene creates no missing folder (issue 10)
    assert main(["render", str(scene_path), "-o", str(out), "--width", "32", "--threads", "1"]) == EXIT_OK
    image = read_image(out)
    scene = load_usd(scene_path)
    expected = native.render(scene, dataclasses.replace(scene.settings, width=32, height=24))
    assert image.shape == (24, 32, 3)
    assert np.array_equal(image, expected)  # float EXR keeps float32 exactly
    assert "32 x 24, native, specular seed" in capsys.readouterr().out


def test_render_classic_mapping_selects_the_povray_classic_convention(tmp_path, capsys):
    scene_path = write_usd(calibration.SCENES["coloured_specular"](), tmp_path / "scene.usda")
    seed, classic = tmp_path / "seed.exr", tmp_path / "classic.exr"
    assert main(["render", str(scene_path), "-o", str(seed)]) == EXIT_OK
    assert main(["render", str(scene_path), "-o", str(classic), "--mapping", "classic"]) == EXIT_OK
    assert "specular povray-classic" in capsys.readouterr().out
    scene = calibration.classic_variant(load_usd(scene_path))
    assert np.array_equal(read_image(classic), native.render(scene))
    assert not np.array_equal(read_image(seed), read_image(classic))


def test_render_rejects_an_unknown_image_extension(tmp_path, capsys):
    scene_path = write_usd(calibration.SCENES["point_light"](), tmp_path / "scene.usda")
    assert main(["render", str(scene_path), "-o", str(tmp_path / "image.jpg")]) == EXIT_SCENE
    assert "image.jpg" in capsys.readouterr().err
    assert not (tmp_path / "image.jpg").exists()
