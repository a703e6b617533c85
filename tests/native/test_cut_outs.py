# SPDX-License-Identifier: Apache-2.0
"""Cut-out masks (UsdPreviewSurface's masked mode with a textured opacity): where the mask's
opacity at a hit's uv is below the threshold the surface is not there. Camera and secondary rays
go on unchanged at their depth, shadow rays pass; the rest of the surface is opaque. The native
tracer and the oracle against the mask's own bilinear lookup (oracle.sample_texture), in both
transmission conventions; POV-Ray (a texture_map over the mask as an image_pattern) against the
native tracer in POV-Ray's numerics, as `diff` renders."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from phongscene.backends import native
from phongscene.errors import SceneError
from phongscene.scene import (
    AmbientLight,
    Camera,
    DirectionalLight,
    PhongMaterial,
    RectAreaLight,
    RenderSettings,
    Scene,
    Texture,
    TriangleMesh,
)
from phongscene.validate import check
from support import oracle

RED, BACKDROP = (0.9, 0.2, 0.1), (0.1, 0.3, 0.8)
THRESHOLD = 0.5
# A 4 x 4 mask: a checker of opacities 0.9 and 0.1 (repeat), bilinear between texel centres.
MASK = Texture(np.repeat(np.where((np.add.outer(np.arange(4), np.arange(4)) % 2)[..., None] == 0, 0.9, 0.1), 3, axis=2))


def _self_lit(colour, **masked) -> PhongMaterial:
    return PhongMaterial(ka=1.0, kd=0.0, ks=0.0, exponent=1.0, diffuse_color=colour, **masked)


def _quad(z: float, material: PhongMaterial, size: float = 1.0) -> TriangleMesh:
    """The square [0, size]² at height z facing +z, its uvs the unit square."""
    return TriangleMesh(
        points=[(0, 0, z), (size, 0, z), (size, size, z), (0, size, z)],
        triangles=[(0, 1, 2), (0, 2, 3)],
        uvs=[(0, 0), (1, 0), (1, 1), (0, 1)],
        uv_indices=[(0, 1, 2), (0, 2, 3)],
        material=material,
    )


def _looking_down(width: int, **settings) -> Scene:
    camera = Camera(position=(0.5, 0.5, 5.0), forward=(0, 0, -1), projection="orthographic", ortho_width=1.0)
    return Scene(
        camera=camera,
        ambient=AmbientLight((1.0, 1.0, 1.0)),
        settings=RenderSettings(width=width, height=width, background=(0, 0, 0), **settings),
    )


def _renderers():
    return [
        pytest.param(native.render, id="native"),
        pytest.param(lambda s: oracle.render(s).astype(np.float32), id="oracle"),
    ]


def _opacity_at_pixels(width: int) -> np.ndarray:
    centres = (np.arange(width) + 0.5) / width
    u, v = np.meshgrid(centres, centres[::-1])  # row 0 at the top: v high
    return oracle.sample_texture(MASK, u.ravel(), v.ravel())[:, 0].reshape(width, width)


@pytest.mark.parametrize("render", _renderers())
@pytest.mark.parametrize("convention", ["book", "povray"])
def test_the_backdrop_shows_where_the_mask_is_below_the_threshold(render, convention):
    width = 12
    masked = _self_lit(RED, opacity_texture=MASK, opacity_threshold=THRESHOLD)
    scene = dataclasses.replace(
        _looking_down(width, transmission=convention),
        meshes=(_quad(0.0, masked), _quad(-5.0, _self_lit(BACKDROP), size=1.0)),
    )
    opacity = _opacity_at_pixels(width)
    assert np.abs(opacity - THRESHOLD).min() > 1e-3  # no pixel centre on the mask's edge
    expected = np.where((opacity < THRESHOLD)[..., None], BACKDROP, RED)
    image = render(scene)
    assert (opacity < THRESHOLD).any() and (opacity >= THRESHOLD).any()
    assert np.array_equal(image, expected.astype(np.float32))


@pytest.mark.parametrize("render", _renderers())
def test_a_cut_out_texel_uses_no_depth(render):
    """Five masked quads over the backdrop at max_depth 0: a ray through their cut-out texels is
    continued, not traced anew, so the backdrop shows (as POV-Ray's continued ray)."""
    width = 8
    masked = _self_lit(RED, opacity_texture=MASK, opacity_threshold=THRESHOLD)
    scene = dataclasses.replace(
        _looking_down(width, max_depth=0),
        meshes=(*(_quad(-k * 0.5, masked) for k in range(5)), _quad(-5.0, _self_lit(BACKDROP))),
    )
    opacity = _opacity_at_pixels(width)
    expected = np.where((opacity < THRESHOLD)[..., None], BACKDROP, RED)
    assert np.array_equal(render(scene), expected.astype(np.float32))


@pytest.mark.parametrize("render", _renderers())
@pytest.mark.parametrize("convention", ["book", "povray"])
def test_light_passes_the_cut_out_texels_and_nothing_else(render, convention):
    """A floor under a masked quad, lit straight down by a directional light: each floor point is
    lit where the quad above it is cut out, in shadow elsewhere (the shadow ray meets the quad at
    the point's own (x, y))."""
    width = 12
    floor = PhongMaterial(ka=0.0, kd=1.0, ks=0.0, exponent=1.0, diffuse_color=(1.0, 1.0, 1.0))
    masked = PhongMaterial(ka=0.0, kd=1.0, ks=0.0, opacity_texture=MASK, opacity_threshold=THRESHOLD)
    # The camera sits between the quad (z = 1) and the floor (z = 0): it sees the floor only.
    scene = Scene(
        camera=Camera(position=(0.5, 0.5, 0.5), forward=(0, 0, -1), projection="orthographic", ortho_width=1.0),
        lights=(DirectionalLight((0.0, 0.0, -1.0), (math.pi, math.pi, math.pi)),),
        meshes=(_quad(0.0, floor, size=1.0), _quad(1.0, masked)),
        settings=RenderSettings(width=width, height=width, transmission=convention),
    )
    lit = np.where((_opacity_at_pixels(width) < THRESHOLD)[..., None], 1.0, 0.0) * np.ones(3)
    assert np.array_equal(render(scene), lit.astype(np.float32))


def test_a_threshold_needs_a_mask_and_a_mask_needs_an_opaque_material():
    with pytest.raises(SceneError, match="opacity_threshold"):
        check(Scene(meshes=(_quad(0.0, PhongMaterial(opacity_threshold=0.5)),)))
    with pytest.raises(SceneError, match="opacity_threshold"):
        check(Scene(meshes=(_quad(0.0, PhongMaterial(opacity_texture=MASK, opacity_threshold=0.0)),)))
    glass = PhongMaterial(ka=0.0, kd=0.0, ks=0.0, kt=0.8, ior=1.5, opacity_texture=MASK, opacity_threshold=0.5)
    with pytest.raises(SceneError, match="transmissive"):
        check(Scene(meshes=(_quad(0.0, glass),)))


def test_the_cells_estimator_is_refused_with_cut_outs():
    light = RectAreaLight(center=(0.5, 0.5, 3.0), axis_u=(1, 0, 0), axis_v=(0, 1, 0), color=(1, 1, 1), samples=3)
    masked = PhongMaterial(opacity_texture=MASK, opacity_threshold=THRESHOLD)
    check(Scene(lights=(light,), meshes=(_quad(0.0, masked),)))  # the grid: fine
    cells = dataclasses.replace(light, cell_samples=2)
    check(Scene(lights=(cells,), meshes=(_quad(0.0, masked.without_textures()),)))  # no mask: fine
    with pytest.raises(SceneError, match="cut-out") as error:
        check(Scene(lights=(cells,), meshes=(_quad(0.0, masked),)))
    assert any(p.attribute == "cell_samples" for p in error.value.problems)


def _lit_scene() -> Scene:
    """A masked, lit, highlighted quad over a lit floor, seen at a slant: its holes show the floor,
    its shadow on the floor has holes."""
    floor = PhongMaterial(ka=0.1, kd=0.8, ks=0.0, diffuse_color=(0.8, 0.7, 0.5))
    masked = PhongMaterial(
        ka=0.1, kd=0.6, ks=0.4, exponent=20.0, diffuse_color=RED, opacity_texture=MASK, opacity_threshold=THRESHOLD
    )
    from support import calibration

    return Scene(
        camera=calibration.look_at((0.5, -1.2, 2.2), (0.5, 0.5, 0.2)),
        ambient=AmbientLight((0.3, 0.3, 0.3)),
        lights=(DirectionalLight(tuple(np.array([-0.3, 0.2, -1.0]) / math.sqrt(1.13)), (2.0, 2.0, 2.0)),),
        meshes=(_quad(0.0, floor, size=1.0), _quad(0.4, masked)),
        settings=RenderSettings(width=40, height=30, background=(0.05, 0.05, 0.1), numerics="povray"),
    )


@pytest.mark.povray
@pytest.mark.parametrize("mapping", ["exact", "classic"])
def test_povray_cuts_out_what_the_native_tracer_does(mapping):
    from phongscene import render
    from phongscene.comparison import compare
    from phongscene.rendering import settings_for

    scene = _lit_scene()
    settings = settings_for(scene, mapping=mapping)
    image = native.render(dataclasses.replace(scene, settings=settings))
    povray = render(scene, "povray", settings, mapping=mapping)
    assert compare(povray, image).ok
    # the mask matters: the uncut quad differs
    solid = dataclasses.replace(
        scene,
        meshes=(
            scene.meshes[0],
            dataclasses.replace(scene.meshes[1], material=scene.meshes[1].material.without_textures()),
        ),
    )
    assert np.abs(native.render(dataclasses.replace(solid, settings=settings)) - image).max() > 0.1
