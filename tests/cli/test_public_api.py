# SPDX-License-Identifier: Apache-2.0
"""The package's public names: each resolves to a function or class, and ``import phongscene``
(or ``phongscene.cli``, for a fast ``--help``) stays light: the heavy modules load on first use."""

from __future__ import annotations

import inspect
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest

import phongscene
from support.paths import EXAMPLES

# numpy too: before main() installs its Ctrl-C handling, an import is a window for a traceback.
HEAVY_MODULES = ("numpy", "pxr", "OpenImageIO", "phongscene.backends.native", "phongscene.backends.povray")


def test_every_public_name_resolves_to_a_function_or_class():
    for name in phongscene.__all__:
        value = getattr(phongscene, name)
        assert inspect.isclass(value) or inspect.isfunction(value), (name, value)
        assert value.__name__ == name, (name, value)


def test_functions_share_names_with_no_module():
    # The modules are comparison, crossvalidation and rendering, so nothing shadows the functions.
    from phongscene.comparison import compare
    from phongscene.crossvalidation import diff
    from phongscene.rendering import render

    assert (phongscene.compare, phongscene.diff, phongscene.render) == (compare, diff, render)


def test_unknown_names_raise_attribute_error():
    assert not hasattr(phongscene, "no_such_name")


@pytest.mark.subprocess
@pytest.mark.parametrize("module", ["phongscene", "phongscene.cli"])
def test_importing_the_package_or_the_cli_loads_no_heavy_module(module):
    probe = (
        f"import sys, {module}\nheavy = [m for m in {HEAVY_MODULES!r} if m in sys.modules]\nassert not heavy, heavy\n"
    )
    subprocess.run([sys.executable, "-c", probe], check=True)


# ----------------------------------------------------------------------------------------------
# What a Mitsuba 3 or trimesh user tries first (issue 11)

EXAMPLE = EXAMPLES / "seed_exponents.usda"


def test_render_takes_a_path_and_size_overrides_keeping_the_aspect_ratio():
    image = phongscene.render(EXAMPLE, width=32)  # the file is 320 x 240
    assert isinstance(image, np.ndarray) and isinstance(image, phongscene.Image)
    assert image.shape == (24, 32, 3) and image.dtype == np.float32
    scene = phongscene.load_usd(EXAMPLE)
    same = phongscene.render(scene, "native", replace(scene.settings, width=32, height=24))  # the old form
    np.testing.assert_array_equal(image, same)


def test_render_overrides_apply_to_given_settings_and_spp_is_samples_per_axis():
    scene = phongscene.load_usd(EXAMPLE)
    small = replace(scene.settings, width=16, height=12)
    image = phongscene.render(scene, settings=small, spp=2)
    np.testing.assert_array_equal(image, phongscene.render(scene, settings=replace(small, samples=2)))
    assert not np.array_equal(image, phongscene.render(scene, settings=small))  # anti-aliasing changed it
    classic = phongscene.render(scene, settings=small, mapping="classic")
    np.testing.assert_array_equal(classic, phongscene.render(scene, settings=replace(small, specular="povray-classic")))


def test_an_image_displays_in_jupyter_as_the_png_write_image_writes(tmp_path):
    image = phongscene.render(EXAMPLE, width=16)
    png = image._repr_png_()
    assert png.startswith(b"\x89PNG\r\n\x1a\n")
    phongscene.write_image(tmp_path / "same.png", image)
    assert png == (tmp_path / "same.png").read_bytes()
    assert phongscene.read_image(tmp_path / "same.png").shape == image.shape
    assert image[0, 0]._repr_png_() is None  # a pixel is not an image
    # numpy works as on any array: an image stays an Image, a reduction is a plain number/array.
    assert isinstance(image * 2, phongscene.Image) and isinstance(np.sqrt(image), phongscene.Image)
    assert type(image.max()) is np.float32 and type(image.mean(axis=2)) is np.ndarray


def test_look_at_is_public_and_builds_a_camera():
    cam = phongscene.look_at((0.0, 0.0, 5.0), (0.0, 0.0, 0.0), 45.0)
    assert isinstance(cam, phongscene.Camera)
    assert cam.forward == (0.0, 0.0, -1.0) and cam.up == (0.0, 1.0, 0.0) and cam.horizontal_fov_deg == 45.0


def test_a_missing_file_is_file_not_found_and_a_scene_error(tmp_path):
    missing = tmp_path / "nope.usda"
    for call in (phongscene.load_usd, phongscene.render):
        with pytest.raises(FileNotFoundError) as caught:
            call(missing)
        assert isinstance(caught.value, phongscene.SceneError)
        assert str(caught.value) == f"{missing}: file not found"


def test_render_of_a_path_issues_the_readers_warnings(tmp_path):
    scene = phongscene.load_usd(EXAMPLE)
    lonely = tmp_path / "no_lights.usda"
    phongscene.write_usd(replace(scene, lights=(), ambient=phongscene.AmbientLight((0.0, 0.0, 0.0))), lonely)
    with pytest.warns(phongscene.SceneWarning, match="head light"):
        phongscene.render(lonely, width=8)


def test_public_compile_pov_validates_first():
    """An invalid scene is a SceneError naming the problem, not an arithmetic error in the compiler."""
    scene = phongscene.Scene(
        camera=phongscene.look_at((0.0, 0.0, 5.0), (0.0, 0.0, 0.0)),
        spheres=(phongscene.Sphere(world_from_object=np.diag([0.0, 1.0, 1.0, 1.0])),),
    )
    with pytest.raises(phongscene.SceneError, match="singular"):
        phongscene.compile_pov(scene)
