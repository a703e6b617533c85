# SPDX-License-Identifier: Apache-2.0
"""Nested and overlapping transparent objects in the "povray" transmission convention: each ray
keeps the list of interiors it is in (POV-Ray's, trace.cpp ComputeRefraction; ref §18), so a
ray refracts by the ratio of the indices on the two sides of each surface. Closed forms (Snell's
law through nested slabs; overlapping slabs of one index act as one slab, its inner crossings
continued rays at no depth), then the native tracer against POV-Ray on a glass of water, two
overlapping glasses, a light inside tinted glass and a camera inside glass, in POV-Ray's
numerics (as `diff` renders them)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from phongscene.backends import native
from phongscene.scene import (
    AmbientLight,
    Camera,
    PhongMaterial,
    PointLight,
    RenderSettings,
    Scene,
    Sphere,
    TriangleMesh,
)
from support import calibration, oracle

# Two float32 ulps between two equally exact float64 paths (as tests/native/test_transmission.py).
FLOAT32_TWO_ULPS = 2.0**-22
GLASS = PhongMaterial(ka=0.0, kd=0.0, ks=0.0, exponent=1.0, diffuse_color=(1.0, 1.0, 1.0), kt=0.8, ior=1.5)
WATER = dataclasses.replace(GLASS, kt=0.9, ior=1.33)
BACKGROUND = (0.11, 0.23, 0.37)
LEFT, RIGHT = (0.9, 0.3, 0.1), (0.1, 0.4, 0.9)


def _oracle_image(scene: Scene) -> np.ndarray:
    return oracle.render(scene).astype(np.float32)


def _renderers():
    return [pytest.param(native.render, id="native"), pytest.param(_oracle_image, id="oracle")]


def _self_lit(colour) -> PhongMaterial:
    return PhongMaterial(ka=1.0, kd=0.0, ks=0.0, exponent=1.0, diffuse_color=colour)


def _rect_z(x0, x1, y0, y1, z, material) -> TriangleMesh:
    corners = [(x0, y0, z), (x1, y0, z), (x1, y1, z), (x0, y1, z)]
    return TriangleMesh(points=corners, triangles=[(0, 1, 2), (0, 2, 3)], material=material)


def _through_slabs(slabs, max_depth: int, theta_deg: float = 35.0) -> tuple[Scene, np.ndarray]:
    """An orthographic camera looking down at θ through horizontal slabs at a backdrop (z = −10)
    with a colour edge at x = 0; the scene and each pixel's x on the backdrop had it gone straight."""
    theta = math.radians(theta_deg)
    camera = Camera(
        position=(-8.5, 0.0, 3.0),
        forward=(math.sin(theta), 0.0, -math.cos(theta)),
        up=(0.0, 1.0, 0.0),
        projection="orthographic",
        ortho_width=6.0,
    )
    width, height = 48, 4
    scene = Scene(
        camera=camera,
        ambient=AmbientLight((1.0, 1.0, 1.0)),
        meshes=(
            *slabs,
            _rect_z(-60, 0, -60, 60, -10.0, _self_lit(LEFT)),
            _rect_z(0, 60, -60, 60, -10.0, _self_lit(RIGHT)),
        ),
        settings=RenderSettings(
            width=width, height=height, background=BACKGROUND, max_depth=max_depth, transmission="povray"
        ),
    )
    sx, sy = np.meshgrid(np.arange(width) + 0.5, np.arange(height) + 0.5)
    o, _ = oracle.camera_rays(camera, width, height, sx, sy)
    return scene, (o[:, 0] + (o[:, 2] + 10.0) * math.tan(theta)).reshape(height, width)


def _edge_seen(x: np.ndarray, weight: float) -> np.ndarray:
    assert np.abs(x).min() > 1e-3  # no pixel centre on the edge
    assert (x < 0).any() and (x > 0).any()
    return np.where((x < 0)[..., None], weight * np.asarray(LEFT), weight * np.asarray(RIGHT))


@pytest.mark.parametrize("render", _renderers())
def test_a_water_slab_inside_a_glass_slab_refracts_by_the_ratio_of_their_indices(render):
    """Glass z ∈ [−3, 1] (ior 1.5) around water z ∈ [−2, 0] (ior 1.33): 1 + 1 units of glass and 2
    of water. Between the two the ray refracts by 1.33/1.5 (not 1.33 from air), so inside each
    medium sin θ = sin θ₀/n and the view shifts by Σ T·(tan θ₀ − tan θ); kt at each of the four
    crossings."""
    theta = math.radians(35.0)
    glass = calibration.box_mesh((-50.0, -50.0, -3.0), (50.0, 50.0, 1.0), GLASS)
    water = calibration.box_mesh((-45.0, -45.0, -2.0), (45.0, 45.0, 0.0), WATER)
    scene, x_straight = _through_slabs((glass, water), max_depth=4)
    shift = sum(
        thickness * (math.tan(theta) - math.tan(math.asin(math.sin(theta) / n)))
        for thickness, n in ((2.0, GLASS.ior), (2.0, WATER.ior))
    )
    expected = _edge_seen(x_straight - shift, GLASS.kt**2 * WATER.kt**2)
    image = render(scene)
    assert np.all(np.abs(image - expected) <= FLOAT32_TWO_ULPS * np.abs(expected))
    # the ratio matters: water entered as from the air (ior 1.33 relative to 1) is seen elsewhere
    wrong = x_straight - 2.0 * (math.tan(theta) - math.tan(math.asin(math.sin(theta) / 1.5)))
    wrong -= 2.0 * (math.tan(theta) - math.tan(math.asin(math.sin(math.asin(math.sin(theta) / 1.5)) / 1.33)))
    assert np.any((wrong < 0) != (x_straight - shift < 0))


@pytest.mark.parametrize("render", _renderers())
def test_overlapping_slabs_of_one_glass_refract_as_one_slab_at_no_extra_depth(render):
    """Two glass slabs of one material overlap: B z ∈ [−2, 0] is entered first, A z ∈ [−3, −1] from
    inside B (ratio 1: a continued ray), B is left from inside A (not the innermost: continued),
    A is left for the air. The view is that through one slab of thickness 3, kt per crossing
    (four), and at max_depth 2 the backdrop shows: the two inner crossings use no depth."""
    theta = math.radians(35.0)
    a = calibration.box_mesh((-50.0, -50.0, -3.0), (50.0, 50.0, -1.0), GLASS)
    b = calibration.box_mesh((-50.0, -50.0, -2.0), (50.0, 50.0, 0.0), GLASS)
    scene, x_straight = _through_slabs((a, b), max_depth=2)
    shift = 3.0 * (math.tan(theta) - math.tan(math.asin(math.sin(theta) / GLASS.ior)))
    expected = _edge_seen(x_straight - shift, GLASS.kt**4)
    image = render(scene)
    assert np.all(np.abs(image - expected) <= FLOAT32_TWO_ULPS * np.abs(expected))


@pytest.mark.parametrize("render", _renderers())
def test_a_shadow_ray_fades_only_where_it_crosses_the_surface_of_the_interior_it_is_in(render):
    """A floor lit through a tinted glass box (cf_g) holding a tinted water box (cf_w), head-on
    from a light above: the shadow ray crosses glass, water, water, glass (kt each), fading by the
    water over its 2 units inside, and by the glass only over the stretch from the water to the
    glass's far side (POV-Ray's fade at the surface of the interior the ray is in, ref §18),
    1 unit; the 1 unit of glass before the water is not faded."""
    cf_g, cf_w = np.array([0.5, 0.8, 0.9]), np.array([0.9, 0.6, 0.7])
    glass = calibration.box_mesh((-20, 2, -20), (20, 6, 20), dataclasses.replace(GLASS, interior_filter=tuple(cf_g)))
    water = calibration.box_mesh((-10, 3, -10), (10, 5, 10), dataclasses.replace(WATER, interior_filter=tuple(cf_w)))
    floor = PhongMaterial(ka=0.0, kd=1.0, ks=0.0, exponent=1.0, diffuse_color=(1.0, 1.0, 1.0))
    quad = TriangleMesh(
        points=[(-50, 0, -50), (50, 0, -50), (50, 0, 50), (-50, 0, 50)],
        triangles=[(0, 2, 1), (0, 3, 2)],
        material=floor,
    )
    down = Camera(
        position=(0.0, 1.0, 0.0),
        forward=(0.0, -1.0, 0.0),
        up=(0.0, 0.0, -1.0),
        projection="orthographic",
        ortho_width=1e-3,
    )
    light = PointLight((0.0, 10.0, 0.0), (math.pi, math.pi, math.pi))
    settings = RenderSettings(width=1, height=1, transmission="povray")
    lit = render(Scene(camera=down, lights=(light,), meshes=(quad,), settings=settings))
    shadowed = render(Scene(camera=down, lights=(light,), meshes=(quad, glass, water), settings=settings))
    expected = lit * GLASS.kt**2 * WATER.kt**2 * cf_w**2 * cf_g**1
    assert np.all(np.abs(shadowed - expected) <= 4 * FLOAT32_TWO_ULPS * expected)


def _looking_at_glass(spheres, *, camera=None, light=(3.0, 5.0, 6.0)) -> Scene:
    backdrop = dataclasses.replace(
        PhongMaterial(ka=0.3, kd=0.7, ks=0.0, diffuse_color=(0.9, 0.7, 0.3)),
        checker_size=0.7,
        checker_color=(0.1, 0.3, 0.8),
    )
    return Scene(
        camera=camera or calibration.look_at((0.5, 0.8, 6.0), (0.0, 0.0, 0.0)),
        ambient=AmbientLight((1.0, 1.0, 1.0)),
        lights=(PointLight(light, (60.0, 60.0, 60.0)),),
        spheres=tuple(spheres),
        meshes=(_rect_z(-20, 20, -20, 20, -6.0, backdrop),),
        settings=RenderSettings(
            width=48, height=36, background=BACKGROUND, max_depth=6, transmission="povray", numerics="povray"
        ),
    )


def _dielectric(m: PhongMaterial) -> PhongMaterial:
    return dataclasses.replace(m, fresnel=True, kr=1.0, kt=1.0)


TINTED_GLASS = dataclasses.replace(GLASS, interior_filter=(0.7, 0.9, 0.8))
TINTED_WATER = dataclasses.replace(WATER, interior_filter=(0.9, 0.8, 0.6))
SCENES = {
    "a glass of water": lambda: _looking_at_glass(
        (Sphere.at((0, 0, 0), 2.0, TINTED_GLASS), Sphere.at((0, 0, 0), 1.3, TINTED_WATER))
    ),
    "a glass of water, Fresnel": lambda: _looking_at_glass(
        (Sphere.at((0, 0, 0), 2.0, _dielectric(GLASS)), Sphere.at((0.2, 0, 0), 1.3, _dielectric(WATER)))
    ),
    "two overlapping glasses of one material": lambda: _looking_at_glass(
        (Sphere.at((-0.6, 0, 0), 1.3, GLASS), Sphere.at((0.6, 0, 0), 1.3, GLASS))
    ),
    "overlapping glass and water, Fresnel": lambda: _looking_at_glass(
        (Sphere.at((-0.6, 0, 0), 1.3, _dielectric(GLASS)), Sphere.at((0.6, 0, 0), 1.3, _dielectric(WATER)))
    ),
    "a light inside tinted glass": lambda: _looking_at_glass(
        (Sphere.at((0, 0, 0), 2.0, dataclasses.replace(TINTED_GLASS, ka=0.05, kd=0.6)),), light=(0.3, 0.2, 0.5)
    ),
    "a camera inside glass, looking at water in it": lambda: _looking_at_glass(
        (Sphere.at((0, 0, 0), 4.0, TINTED_GLASS), Sphere.at((0, 0, -2.0), 1.2, TINTED_WATER)),
        camera=calibration.look_at((0.2, 0.1, 1.5), (0.0, 0.0, -6.0)),
    ),
}


@pytest.mark.povray
@pytest.mark.parametrize("name", list(SCENES))
def test_nested_and_overlapping_media_render_as_povray_does(name):
    from phongscene import render
    from phongscene.comparison import compare

    scene = SCENES[name]()
    image = native.render(scene)
    assert compare(render(scene, "povray"), image).ok
    # the oracle follows the same rules independently
    assert np.array_equal(image, _oracle_image(scene))
