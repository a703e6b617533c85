# SPDX-License-Identifier: Apache-2.0
"""phongscene.rendering: what every command does before it renders (load the scene, apply the
overrides); the renders themselves are tested per backend and in test_cross_backend.py."""

from __future__ import annotations

from dataclasses import replace

import pytest

from phongscene.errors import SceneError
from phongscene.rendering import BACKENDS, load_scene, render, settings_with
from phongscene.scene import PhongMaterial, RenderSettings, Scene, Sphere
from support.paths import EXAMPLES

# 320 x 240 (4:3), specular "povray-classic": every override below visibly changes it.
SCENE = Scene(settings=RenderSettings(width=320, height=240, samples=3, threads=2, specular="povray-classic"))


def test_no_overrides_keep_the_scene_settings():
    assert settings_with(SCENE) == SCENE.settings


def test_one_side_keeps_the_aspect_ratio():
    assert (settings_with(SCENE, width=40).width, settings_with(SCENE, width=40).height) == (40, 30)
    assert (settings_with(SCENE, height=30).width, settings_with(SCENE, height=30).height) == (40, 30)
    wide = Scene(settings=RenderSettings(width=400, height=100))
    assert settings_with(wide, width=1).height == 1  # 0.25 rounds to 0: a side is never empty
    both = settings_with(SCENE, width=10, height=50)
    assert (both.width, both.height) == (10, 50)


def test_samples_threads_and_mapping_are_applied():
    s = settings_with(SCENE, "exact", samples=1, threads=0)
    assert (s.samples, s.threads, s.specular) == (1, 0, "seed")
    assert settings_with(SCENE, "classic").specular == "povray-classic"
    with pytest.raises(ValueError, match="unknown POV-Ray mapping 'phong'"):
        settings_with(SCENE, "phong")


def test_load_scene_passes_a_scene_through_and_reads_a_file():
    assert load_scene(SCENE) == (SCENE, [])
    scene, warnings = load_scene(EXAMPLES / "seed_lobe.usda")
    assert scene.source_file.endswith("seed_lobe.usda") and warnings == []
    with pytest.raises(SceneError, match="nope.usda"):
        load_scene(EXAMPLES / "nope.usda")


@pytest.mark.parametrize("backend", BACKENDS)
def test_render_rejects_an_invalid_scene_before_any_backend_runs(backend):
    # A Python-built scene never went through the USD reader's validation: render() checks it,
    # so neither backend (nor the C++ code) ever sees NaN or an out-of-range setting.
    bad_material = PhongMaterial(ks=float("nan"))
    scene = Scene(spheres=(Sphere.at((0, 0, -5), 1, bad_material),), settings=RenderSettings(width=8, height=6))
    with pytest.raises(SceneError) as e:
        render(scene, backend, replace(scene.settings, samples=12))
    text = str(e.value)
    assert "ks" in text and "samples" in text  # both problems, in one error


def test_a_prepared_native_render_frees_the_model_and_renders_the_same_image():
    # The CLI drops the model once the C++ scene is built (phongscene.cli.render.run_render): the
    # prepared render must not keep it alive, and must render what render() renders.
    import gc
    import weakref

    import numpy as np

    from phongscene.rendering import prepare_render

    scene = load_scene(EXAMPLES / "seed_exponents.usda")[0]
    settings = settings_with(scene, None, width=40)
    expected = render(scene, "native", settings)
    mesh_points = weakref.finalize(
        scene.meshes[0].points.base if scene.meshes[0].points.base is not None else scene.meshes[0].points, lambda: None
    )
    prepared = prepare_render(scene, "native", settings)
    del scene
    gc.collect()
    assert not mesh_points.alive  # the model's arrays are gone before the render
    assert np.array_equal(prepared(), expected)
