# SPDX-License-Identifier: Apache-2.0
"""`phongscene info` and `phongscene validate` on valid scenes."""

from __future__ import annotations

import pytest

from phongscene.cli import build_parser, main
from support.paths import EXAMPLES, SCENES, SHARED_ASSETS


def test_info_lists_nodes_counts_camera_settings_and_warnings(capsys):
    assert main(["info", str(EXAMPLES / "seed_exponents.usda")]) == 0
    out = capsys.readouterr().out
    assert "/World/Geometry/Exponent5 -> Sphere" in out
    assert "/World/Lights/Key -> PointLight" in out and "/World/Lights/Ambient -> AmbientLight" in out
    assert "counts: 1 meshes, 2 triangles, 4 spheres, 1 lights (1 PointLight), 5 materials" in out
    assert "camera: /World/Camera: perspective, hfov 55 deg" in out
    assert "settings: /Render/Settings: 320x240" in out
    assert "warning:" not in out


@pytest.mark.shared_assets
def test_info_shows_warnings(capsys):
    assert main(["info", str(SHARED_ASSETS / "teapot" / "teapot.usda")]) == 0
    out = capsys.readouterr().out
    assert "25200 triangles" in out and "warning: no camera" in out


def test_validate_valid_scene(capsys):
    assert main(["validate", str(EXAMPLES / "seed_lobe.usda")]) == 0
    captured = capsys.readouterr()
    assert captured.out.strip() == f"ok: {EXAMPLES / 'seed_lobe.usda'}" and captured.err == ""


def test_help_texts():
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    for name in ("info", "validate", "import"):
        assert len(sub.choices[name].format_help()) > 200


def test_info_lists_each_materials_textures(capsys):
    scene = SCENES / "blender_textured" / "textured_glossy.usdc"
    assert main(["info", str(scene)]) == 0
    out = capsys.readouterr().out
    grid = "textures/textured_glossy_grid.png, 64x64, wrap repeat/repeat"
    assert "/root/_materials/SphereGlossy/Principled_BSDF diffuseColor <- " in out
    assert "/root/_materials/FloorTextured/Principled_BSDF diffuseColor <- " in out
    assert out.count(grid) == 2


def test_info_has_no_texture_block_without_textures(capsys):
    assert main(["info", str(EXAMPLES / "seed_exponents.usda")]) == 0
    assert "textures:" not in capsys.readouterr().out


def test_info_counts_prototypes_and_instances(tmp_path, capsys):
    from support.instanced_stages import point_instancer_stage

    assert main(["info", point_instancer_stage(tmp_path / "pi.usda", 40, rings=6, sides=4)]) == 0
    out = capsys.readouterr().out
    assert "counts: 0 meshes, 48 triangles" in out
    assert "instancing: 1 prototypes, 40 instances, 1920 triangles drawn" in out
    assert "Instances (40 copies of 48 triangles)" in out
