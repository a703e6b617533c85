# SPDX-License-Identifier: Apache-2.0
"""Values beyond what the renderers hold are errors naming the prim and the attribute (issue 29,
item 3): a light whose float32 radiance would overflow (``inputs:exposure = 1000``: validate was
ok and the native EXR held inf pixels, exit 0), and a ``resolution`` of (0, 0) with authored
apertures (a ZeroDivisionError traceback in ``render`` and ``info``: the conform divided by it
before the bounds check)."""

from __future__ import annotations

import subprocess
import sys

import pytest
from usda import read

from phongscene.errors import SceneError
from phongscene.limits import MAX_IMAGE_SIDE, MAX_RADIANCE

CLI_TIMEOUT_S = 120  # reading a one-prim scene; generous for a loaded 2-core machine
CAMERA = 'def Camera "Cam" { float horizontalAperture = 36\n float verticalAperture = 24 }\n'


def _settings(resolution: str) -> str:
    return f'def RenderSettings "Settings" {{ int2 resolution = {resolution}\n rel camera = </Cam> }}\n'


@pytest.mark.parametrize(
    "light,attribute",
    [
        (
            'def SphereLight "L" { float inputs:exposure = 1000\n bool treatAsPoint = 1\n bool inputs:normalize = 1 }',
            "inputs:exposure",
        ),
        (
            'def SphereLight "L" { float inputs:intensity = 3.4e38\n bool treatAsPoint = 1\n bool inputs:normalize = 1 }',
            "inputs:intensity",
        ),
        ('def DistantLight "L" { float inputs:intensity = 1e30\n float inputs:exposure = 30 }', "inputs:exposure"),
        ('def DomeLight "L" { float inputs:exposure = 127 }', "inputs:exposure"),
    ],
)
def test_a_light_beyond_float32_radiance_is_an_error_naming_it(tmp_path, light, attribute):
    with pytest.raises(SceneError) as info:
        read(tmp_path, light + "\n" + 'def Sphere "Ball" { }\n')
    (problem,) = info.value.problems
    assert (problem.prim, problem.attribute) == ("/L", attribute)
    assert f"beyond the {MAX_RADIANCE:.4g}" in problem.message


def test_a_bright_light_within_float32_is_read(tmp_path):
    result = read(
        tmp_path,
        'def SphereLight "L" { float inputs:exposure = 90\n bool treatAsPoint = 1\n '
        'bool inputs:normalize = 1 }\ndef Sphere "Ball" { }\n',
    )
    (light,) = result.scene.lights
    assert max(light.color) == 2.0**90 / 4  # L/4 for a normalized point light


@pytest.mark.parametrize("resolution", ["(0, 0)", "(0, 480)", "(640, -1)", f"({MAX_IMAGE_SIDE + 1}, 100)"])
def test_a_resolution_out_of_bounds_is_an_error_before_the_aperture_conform(tmp_path, resolution):
    with pytest.raises(SceneError) as info:
        read(tmp_path, CAMERA + _settings(resolution) + 'def Sphere "Ball" { }\n')
    (problem,) = info.value.problems
    assert (problem.prim, problem.attribute) == ("/Settings", "resolution")
    assert f"got {resolution}" in problem.message


@pytest.mark.subprocess
@pytest.mark.parametrize("command", ["info", "render"])
def test_a_zero_resolution_is_one_line_not_a_traceback(tmp_path, command):
    scene = tmp_path / "scene.usda"
    scene.write_text(
        "#usda 1.0\n"
        + (CAMERA + _settings("(0, 0)") + 'def Sphere "Ball" { }\n').replace("{ ", "{\n").replace(" }", "\n}")
    )
    args = [command, str(scene)] + (["-o", str(tmp_path / "out.exr")] if command == "render" else [])
    result = subprocess.run(
        [sys.executable, "-m", "phongscene", *args], capture_output=True, text=True, timeout=CLI_TIMEOUT_S
    )
    assert result.returncode == 2 and "Traceback" not in result.stderr, result.stderr
    (line,) = [line for line in result.stderr.splitlines() if line.startswith("error")]
    assert "/Settings.resolution: must be two integers" in line
    assert not (tmp_path / "out.exr").exists()
