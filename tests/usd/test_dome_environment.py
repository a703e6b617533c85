# SPDX-License-Identifier: Apache-2.0
"""A textured DomeLight as the environment (model ``Environment``): in a scene with a mirror and
no background of its own, the reader hands the dome's lat-long image, its colour · intensity ·
2^exposure and its frame to the model, and camera rays that miss see the texel UsdLux's layout
puts along their direction (the dome's transform turning it); the lighting stays the mean.
Scenes without secondary rays, with another dome beside it, or with a dome this cannot model
keep the mean as before (with a warning). The lookup itself: tests/native/test_environment.py."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from phongscene.backends import native
from phongscene.images import write_image
from phongscene.scene import Camera, DirectionalLight, PhongMaterial, RenderSettings, Scene, Sphere
from phongscene.usd import write_usd
from phongscene.usd.reader import read_usd

W, H = 16, 8
# Texel (i, j) holds (i, j, 1): small integers, exact in the float EXR written below.
IMAGE = np.stack(
    np.broadcast_arrays(
        np.arange(W, dtype=np.float32)[None, :], np.arange(H, dtype=np.float32)[:, None], np.float32(1.0)
    ),
    axis=-1,
).astype(np.float32)
MIRROR = PhongMaterial(ka=0.0, kd=0.0, ks=0.0, exponent=1.0, diffuse_color=(0.0, 0.0, 0.0), kr=1.0)
MATTE = PhongMaterial()
# Texel centres seen through a 1-pixel camera: weights 1 and 0 up to ~1e-15, stored in float32.
TEXEL_TOLERANCE = 1e-5
DOME = """
def DomeLight "Sky" (
    prepend apiSchemas = ["LightAPI"]
)
{{
    float inputs:intensity = 2
    float inputs:exposure = 1
    color3f inputs:color = (1, 0.5, 0.25)
    asset inputs:texture:file = @sky.exr@
    {extra}
}}
"""


def _stage(tmp_path, material=MIRROR, extra: str = "", more: str = "", image=IMAGE, name="scene.usda"):
    write_image(tmp_path / "sky.exr", image)
    scene = Scene(
        camera=Camera(position=(0.0, 0.0, 5.0)),
        spheres=(Sphere.at((0.0, 0.0, 0.0), 1.0, material, "/World/Ball"),),
        lights=(DirectionalLight(direction=(0.0, -1.0, 0.0), color=(1.0, 1.0, 1.0)),),
        settings=RenderSettings(width=8, height=6),
    )
    path = write_usd(scene, tmp_path / name)
    with open(path, "a", encoding="utf-8") as out:
        out.write(DOME.format(extra=extra) + more)
    return read_usd(str(path))


def _look(scene: Scene, direction) -> np.ndarray:
    """The pixel a narrow camera at (0, 0, 50) sees along ``direction`` (away from the ball)."""
    camera = Camera(position=(0.0, 0.0, 50.0), forward=direction, up=(0.0, 1.0, 0.0), horizontal_fov_deg=1e-3)
    one = dataclasses.replace(scene, camera=camera, settings=dataclasses.replace(scene.settings, width=1, height=1))
    return native.render(one)[0, 0]


def test_textured_dome_is_the_environment_of_a_mirror_scene(tmp_path):
    result = _stage(tmp_path)
    e = result.scene.environment
    assert e is not None and e.source == "/Sky"
    np.testing.assert_array_equal(e.texture.image, IMAGE)
    assert e.scale == pytest.approx((4.0, 2.0, 1.0))  # colour · 2 · 2^1
    np.testing.assert_allclose(e.dome_from_world, np.eye(3), atol=1e-15)
    assert result.scene.settings.background == (0.0, 0.0, 0.0)
    # The lighting is still the dome's mean (its ambient light), as before.
    mean = IMAGE.mean(axis=(0, 1)) * np.array([4.0, 2.0, 1.0])  # each column: the same weights
    assert result.scene.ambient.color == pytest.approx(tuple(mean), rel=1e-6)


@pytest.mark.parametrize(
    ("direction", "texel"),
    [((0.0, 0.0, 1.0), (7.5, 3.5)), ((1.0, 0.0, 0.0), (3.5, 3.5)), ((-1.0, 0.0, 0.0), (11.5, 3.5))],
    ids=["+Z-centre", "+X-quarter", "-X-three-quarters"],
)
def test_camera_rays_see_usdlux_latlong_layout(tmp_path, direction, texel):
    """OpenEXR's lat-long layout, which UsdLux adopts: longitude 0 (+Z) the image's centre,
    +π/2 (+X) a quarter from its left edge; latitude 0 between rows 3 and 4; × the scale."""
    scene = _stage(tmp_path).scene
    np.testing.assert_allclose(_look(scene, direction), (texel[0] * 4.0, texel[1] * 2.0, 1.0), atol=TEXEL_TOLERANCE * 4)


def test_the_dome_transform_turns_the_environment(tmp_path):
    """rotateY 90 takes the dome's +Z (the image's centre) to world +X."""
    extra = 'float xformOp:rotateY = 90\n    uniform token[] xformOpOrder = ["xformOp:rotateY"]'
    scene = _stage(tmp_path, extra=extra).scene
    np.testing.assert_allclose(_look(scene, (1.0, 0.0, 0.0)), (7.5 * 4.0, 3.5 * 2.0, 1.0), atol=TEXEL_TOLERANCE * 4)
    # A scaled dome turns the same (a dome at infinity has no size).
    scaled = 'float xformOp:rotateY = 90\n    float3 xformOp:scale = (3, 1, 2)\n    uniform token[] xformOpOrder = ["xformOp:rotateY", "xformOp:scale"]'
    again = _stage(tmp_path, extra=scaled, name="scaled.usda").scene
    np.testing.assert_allclose(again.environment.dome_from_world, scene.environment.dome_from_world, atol=1e-12)


def test_the_top_row_is_up(tmp_path):
    """The top row's centre latitude, π/2 − π/(2H), sees row 0."""
    scene = _stage(tmp_path).scene
    theta = math.pi / 2 - math.pi / (2 * H)
    d = (0.0, math.sin(theta), math.cos(theta))  # longitude 0: column 7.5
    np.testing.assert_allclose(_look(scene, d)[:2], (7.5 * 4.0, 0.0), atol=TEXEL_TOLERANCE * 4)


def test_scenes_without_secondary_rays_keep_their_background(tmp_path):
    result = _stage(tmp_path, material=MATTE)
    assert result.scene.environment is None and result.scene.settings.background == (0.0, 0.0, 0.0)


def test_a_dome_beside_another_dome_is_its_mean(tmp_path):
    other = 'def DomeLight "Fill" {\n    float inputs:intensity = 0.25\n}\n'
    result = _stage(tmp_path, more=other)
    assert result.scene.environment is None
    assert result.scene.settings.background == pytest.approx(result.scene.ambient.color)
    assert any("beside other DomeLights" in w and "/Sky" in w for w in result.warnings)


def test_domes_it_cannot_model_are_their_mean(tmp_path):
    """Texels a half-float EXR (POV-Ray's) cannot hold, and a DomeLight_1 whose pole is on Z."""
    bright = IMAGE.copy()
    bright[0, 0] = 1e6
    result = _stage(tmp_path, image=bright)
    assert result.scene.environment is None and max(result.scene.settings.background) > 0
    assert any("texels outside" in w and "/Sky" in w for w in result.warnings)
    path = tmp_path / "pole.usda"
    write_image(tmp_path / "sky.exr", IMAGE)
    scene = Scene(
        camera=Camera(position=(0.0, 0.0, 5.0)),
        spheres=(Sphere.at((0.0, 0.0, 0.0), 1.0, MIRROR),),
        lights=(DirectionalLight(direction=(0.0, -1.0, 0.0), color=(1.0, 1.0, 1.0)),),
    )
    write_usd(scene, path)
    with open(path, "a", encoding="utf-8") as out:
        out.write('def DomeLight_1 "Sky" {\n    asset inputs:texture:file = @sky.exr@\n    token poleAxis = "Z"\n}\n')
    result = read_usd(str(path))
    assert result.scene.environment is None
    assert any("pole on Z" in w for w in result.warnings)
    path.write_text(path.read_text().replace('"Z"', '"Y"'))
    assert read_usd(str(path)).scene.environment is not None


def test_info_shows_the_environment(tmp_path, capsys):
    from phongscene.cli import main

    _stage(tmp_path)
    assert main(["info", "--no-sandbox", str(tmp_path / "scene.usda")]) == 0
    out = capsys.readouterr().out
    assert "environment: /Sky: 16x8 lat-long, scale (4, 2, 1)" in out
