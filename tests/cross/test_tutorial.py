# SPDX-License-Identifier: Apache-2.0
"""The first-scene tutorial (docs/tutorial/first-scene.md) stays true: its two scene files read
as the page says, the image centre has the radiance the page computes from UsdLux's units, and
both backends agree on them."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

import phongscene as ps
from phongscene.scene import SphereAreaLight
from phongscene.usd import read_usd
from support.paths import EXAMPLES, REPO

HAND_WRITTEN = EXAMPLES / "first_scene.usda"
FROM_BLENDER = EXAMPLES / "first_scene_blender.usda"
PAGE = REPO / "docs" / "tutorial" / "first-scene.md"

# What the page says the hand-written file holds.
INTENSITY, RADIUS = 3000.0, 0.1  # SphereLight inputs:intensity (luminance L) and inputs:radius
RADIANT_INTENSITY = INTENSITY * math.pi * RADIUS**2  # I = L·πr² = 30π W/sr
LIGHT_AT = (0.0, 4.0, 5.0)
BALL_FRONT, BALL_NORMAL = np.array([0.0, 1.0, 1.0]), np.array([0.0, 0.0, 1.0])  # what the centre pixel sees
CAMERA_AT = np.array([0.0, 1.0, 6.0])

# An odd size puts a pixel centre on the camera's axis, which meets the ball at BALL_FRONT.
WIDTH, HEIGHT = 161, 107
CENTRE = (HEIGHT // 2, WIDTH // 2)
# The hand-written file is exact; Blender's stores the sphere's points and normals and the
# camera's 89.99999° rotation in float32 (relative errors ~1e-7, which move the centre pixel's
# radiance by as much, times the exponent 17.5 on the highlight), well inside this.
CENTRE_RTOL = 1e-5
# USD's blackbody colour is normalised to Rec. 709 luminance 1 (UsdLuxBlackbodyTemperatureAsRgb),
# to about 1e-4 at 6500 K.
BLACKBODY_LUMINANCE_RTOL = 1e-4
REC709_LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
# The page shows numpy's print of float32 pixels (8 significant digits).
PRINTED_RTOL = 1e-6


def printed_on_the_page() -> list[tuple[float, ...]]:
    """The centre pixels the page shows, hand-written first, then Blender's."""
    found = re.findall(r"\[(\d\.\d+)\s+(\d\.\d+)\s+(\d\.\d+)\]", PAGE.read_text(encoding="utf-8"))
    return [tuple(float(v) for v in triple) for triple in found]


def the_light(path) -> SphereAreaLight:
    result = read_usd(path)
    assert result.warnings == [], result.warnings  # the page promises a clean read
    (light,) = result.scene.lights
    assert isinstance(light, SphereAreaLight) and light.falloff == "inverse-square"
    return light


def the_ball_material(path):
    scene = read_usd(path).scene
    balls = [s.material for s in scene.spheres] + [m.material for m in scene.meshes if "Ball" in m.source]
    (material,) = balls
    return material


def expected_centre(light: SphereAreaLight, material) -> np.ndarray:
    """The page's formula: L = [kd·cd/π + ks·cs·(r·wo)^e] · I·(n·l)/d² at the ball's front."""
    to_light = np.array(light.center) - BALL_FRONT
    d = np.linalg.norm(to_light)
    towards_light = to_light / d
    n_dot_l = float(BALL_NORMAL @ towards_light)
    wo = (CAMERA_AT - BALL_FRONT) / np.linalg.norm(CAMERA_AT - BALL_FRONT)
    r = 2 * n_dot_l * BALL_NORMAL - towards_light
    irradiance = np.array(light.color) * n_dot_l / d**2
    brdf = (
        material.kd * np.array(material.diffuse_color) / math.pi
        + material.ks * np.array(material.specular_color) * max(0.0, float(r @ wo)) ** material.exponent
    )
    return brdf * irradiance


def test_hand_written_light_is_I_equals_L_pi_r_squared():
    light = the_light(HAND_WRITTEN)
    assert light.radius == pytest.approx(RADIUS) and light.center == pytest.approx(LIGHT_AT)
    assert light.color == pytest.approx((RADIANT_INTENSITY,) * 3, rel=1e-6)


def test_blender_light_is_the_same_light():
    """Blender's export (intensity P/π, normalize: I = P/(4π)) of P = 120π² W is I = 30π, tinted
    by the 6500 K blackbody its exporter enables, which keeps the luminance."""
    light = the_light(FROM_BLENDER)
    assert light.center == pytest.approx(LIGHT_AT, abs=1e-5)  # Z up in the file, Y up in the model
    assert light.radius == pytest.approx(RADIUS)
    assert float(REC709_LUMINANCE @ light.color) == pytest.approx(RADIANT_INTENSITY, rel=BLACKBODY_LUMINANCE_RTOL)
    assert light.color[0] != pytest.approx(light.color[1], rel=1e-2)  # the tint the page warns about


def test_blender_diffuse_is_the_hand_written_diffuse():
    hand, blender = the_ball_material(HAND_WRITTEN), the_ball_material(FROM_BLENDER)
    assert blender.kd * np.array(blender.diffuse_color) == pytest.approx(
        hand.kd * np.array(hand.diffuse_color), rel=1e-6
    )


def test_the_page_prints_both_centre_pixels():
    assert len(printed_on_the_page()) == 2


@pytest.mark.parametrize("index, path", [(0, HAND_WRITTEN), (1, FROM_BLENDER)], ids=["hand-written", "blender"])
def test_centre_pixel_is_the_formula_and_the_page(index, path):
    image = ps.render(path, width=WIDTH, height=HEIGHT)
    expected = expected_centre(the_light(path), the_ball_material(path))
    assert image[CENTRE] == pytest.approx(expected, rel=CENTRE_RTOL)
    assert image[CENTRE] == pytest.approx(printed_on_the_page()[index], rel=PRINTED_RTOL)


@pytest.mark.parametrize("path", [HAND_WRITTEN, FROM_BLENDER], ids=["hand-written", "blender"])
def test_the_image_is_a_ball_on_a_lit_floor(path):
    """Not black, not empty: the ball fills the centre, the floor below it is lit, the sky is the
    background (black)."""
    image = ps.render(path, width=80, height=53)
    luminance = image @ REC709_LUMINANCE
    assert luminance[26, 40] > 0.1  # the ball
    assert luminance[50, 10] > 0.1  # the floor, near the camera
    assert luminance[2, 40] == 0.0  # above the horizon: the black background


@pytest.mark.povray
@pytest.mark.slow
@pytest.mark.parametrize("path", [HAND_WRITTEN, FROM_BLENDER], ids=["hand-written", "blender"])
def test_both_backends_agree_on_the_tutorial(path, tmp_path):
    result = ps.diff(path, tmp_path / "report", width=81, height=54)
    assert result.ok, result.report
