# SPDX-License-Identifier: Apache-2.0
"""The seed examples: each .usda loads with what its script says, and the script regenerates it."""

from __future__ import annotations

import filecmp
import runpy
import subprocess
import sys

import pytest

from phongscene.usd import read_usd
from support.paths import EXAMPLES

SEED = ("seed_exponents", "seed_lobe", "seed_specular_color", "seed_buildup")


def exponents_by_sphere(scene):
    return {s.source.rsplit("/", 1)[1]: s.material for s in scene.spheres}


def test_seed_exponents():
    result = read_usd(EXAMPLES / "seed_exponents.usda")
    materials = exponents_by_sphere(result.scene)
    assert sorted(m.exponent for m in materials.values()) == [5.0, 20.0, 100.0, 1000.0]
    for m in materials.values():
        assert (m.ka, m.kd, m.ks) == pytest.approx((0.25, 0.6, 0.2))
    assert len(result.scene.meshes) == 1 and 1 <= len(result.scene.lights) <= 2 and any(result.scene.ambient.color)
    assert result.warnings == []  # camera, lights and settings are all in the file
    assert (result.scene.settings.width, result.scene.settings.height) == (320, 240)


def test_seed_lobe_specular_color_and_buildup():
    lobe = exponents_by_sphere(read_usd(EXAMPLES / "seed_lobe.usda").scene)
    assert sorted(m.exponent for m in lobe.values()) == [2.0, 20.0]
    colour = exponents_by_sphere(read_usd(EXAMPLES / "seed_specular_color.usda").scene)
    assert colour["WhiteHighlight"].specular_color == (1.0, 1.0, 1.0)
    assert colour["DiffuseColoredHighlight"].specular_color == colour["DiffuseColoredHighlight"].diffuse_color
    build = exponents_by_sphere(read_usd(EXAMPLES / "seed_buildup.usda").scene)
    assert [
        (m.kd > 0, m.ks > 0) for m in (build["Ambient"], build["AmbientDiffuse"], build["AmbientDiffuseSpecular"])
    ] == [
        (False, False),
        (True, False),
        (True, True),
    ]


@pytest.mark.parametrize("name", SEED)
def test_script_regenerates_its_usda(name, tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(EXAMPLES))
    module = runpy.run_path(str(EXAMPLES / f"{name}.py"))
    from phongscene.usd import write_usd

    fresh = write_usd(module["build"](), tmp_path / f"{name}.usda")
    assert filecmp.cmp(fresh, EXAMPLES / f"{name}.usda", shallow=False), f"run examples/{name}.py and commit"


@pytest.mark.subprocess
@pytest.mark.povray  # the demo cross-validates with POV-Ray
def test_demo_lists_every_example(tmp_path):
    outdir = tmp_path / "demo"
    run = subprocess.run(
        [sys.executable, str(EXAMPLES / "demo.py"), "-o", str(outdir)], capture_output=True, text=True, check=True
    )
    for name in SEED:
        assert f"{name}.usda:" in run.stdout
    assert (outdir / "index.html").is_file()


def test_screen_and_water_regenerates_and_holds_nested_glass_and_a_cut_out_screen(tmp_path, monkeypatch):
    from phongscene.containment import containing_interiors
    from phongscene.usd import write_usd

    monkeypatch.syspath_prepend(str(EXAMPLES))
    module = runpy.run_path(str(EXAMPLES / "screen_and_water.py"))
    fresh = write_usd(module["build"](), tmp_path / "screen_and_water.usda")
    assert filecmp.cmp(fresh, EXAMPLES / "screen_and_water.usda", shallow=False), "run examples/screen_and_water.py"
    scene = read_usd(EXAMPLES / "screen_and_water.usda").scene
    glass, water = scene.spheres[:2]
    assert scene.settings.transmission == "povray"  # where media nest
    centre = water.world_from_object[:3, 3]
    assert containing_interiors(scene, centre) == [(0, glass.material), (1, water.material)]
    (screen,) = [m for m in scene.meshes if m.material.cut_out]
    assert screen.material.opacity_threshold == 0.5
    mask = screen.material.opacity_texture.image[..., 0]
    assert mask.min() == 0.0 and mask.max() == 1.0  # holes and screen
