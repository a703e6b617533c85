# SPDX-License-Identifier: Apache-2.0
"""The USD reader's camera and render settings (``phongscene.usd.camera``): projection, Z-up, resolution,
the image aspect against the apertures. Each expected value is derived from the USD text in the test."""

from __future__ import annotations

import math

import numpy as np
import pytest
from usda import EXACT, read


def test_z_up_light_and_camera(tmp_path):
    body = """
    def SphereLight "L" { float inputs:radius = 0
        double3 xformOp:translate = (0, 0, 10)
        uniform token[] xformOpOrder = ["xformOp:translate"] }
    def Camera "C" {
        double3 xformOp:translate = (0, -10, 0)
        float3 xformOp:rotateXYZ = (90, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateXYZ"] }
    """
    scene = read(tmp_path, body, up="Z").scene
    assert np.allclose(scene.lights[0].position, (0, 10, 0), atol=EXACT)  # Z-up "above" → +Y
    assert np.allclose(scene.camera.position, (0, 0, 10), atol=EXACT)
    assert np.allclose(scene.camera.forward, (0, 0, -1), atol=1e-7)
    assert np.allclose(scene.camera.up, (0, 1, 0), atol=1e-7)


def test_camera_and_render_settings(tmp_path):
    body = """
    def Camera "First" { float focalLength = 10
        float horizontalAperture = 20 }
    def Camera "Ortho" { token projection = "orthographic"
        float horizontalAperture = 40 }
    def Scope "Render" { def RenderSettings "S" {
        int2 resolution = (64, 48)
        rel camera = </Ortho>
        int phong:samples = 3
        token phong:samplePattern = "povray-am1"
        token phong:specularConvention = "povray-classic"
        color3f phong:background = (0.5, 0.25, 0)
    } }
    def Sphere "B" {}
    """
    scene = read(tmp_path, body).scene
    assert scene.camera.projection == "orthographic" and scene.camera.ortho_width == pytest.approx(4.0)
    s = scene.settings
    assert (s.width, s.height, s.samples, s.sample_pattern, s.specular) == (64, 48, 3, "povray-am1", "povray-classic")
    assert s.background == (0.5, 0.25, 0.0)
    first = read(tmp_path, body.replace("rel camera = </Ortho>", "")).scene.camera
    assert first.source == "/First"
    assert first.horizontal_fov_deg == pytest.approx(2 * math.degrees(math.atan(0.5 * 20 / 10)))


def test_image_aspect_follows_the_camera_apertures_without_a_resolution(tmp_path):
    body = """
    def Camera "Wide" { float horizontalAperture = 36
        float verticalAperture = 20.25 }
    """
    settings = read(tmp_path, body).scene.settings
    assert (settings.width, settings.height) == (320, 180)  # 16:9 at the default width


def test_a_resolution_that_disagrees_with_the_apertures_fits_horizontally_with_a_warning(tmp_path):
    body = """
    def Camera "Wide" { float horizontalAperture = 36
        float verticalAperture = 20.25 }
    def RenderSettings "S" { int2 resolution = (400, 300)
        rel camera = </Wide> }
    """
    result = read(tmp_path, body)
    assert (result.scene.settings.width, result.scene.settings.height) == (400, 300)
    assert result.scene.camera.horizontal_fov_deg == pytest.approx(2 * math.degrees(math.atan(18 / 50)))
    assert any("fitting horizontally" in w and "/Wide" in w for w in result.warnings)
