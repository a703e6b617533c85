# SPDX-License-Identifier: Apache-2.0
"""Transparency (Suffern ch. 27, PerfectTransmitter; POV-Ray's transmit + interior ior, ref §18)
in the native tracer and the oracle, against closed forms: refraction through a slab shifts a ray
sideways by T·(tan θi − tan θt); total internal reflection beyond the critical angle returns the
mirror ray at full weight, below it kr and kt/η² (book) or kt (povray); shadows through a
transmissive box are the light × kt per crossing. POV-Ray's images of transmissive scenes: the
glass calibration scenes in tests/test_cross_backend.py and the SDL checks below."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from phongscene.backends import native
from phongscene.backends.povray import compile_pov
from phongscene.errors import SceneError
from phongscene.rendering import settings_for
from phongscene.scene import (
    AmbientLight,
    Camera,
    Linking,
    PhongMaterial,
    PointLight,
    RectAreaLight,
    RenderSettings,
    Scene,
    Sphere,
    TriangleMesh,
)
from phongscene.validate import check
from support import calibration, oracle

# As in tests/test_reflection.py: two float32 ulps between two equally exact float64 paths (here
# the η factors of entry and exit, 1/η² and η², whose product rounds near 1).
FLOAT32_TWO_ULPS = 2.0**-22
GLASS_ONLY = PhongMaterial(ka=0.0, kd=0.0, ks=0.0, exponent=1.0, diffuse_color=(1.0, 1.0, 1.0), kt=0.8, ior=1.5)
BACKGROUND = (0.11, 0.23, 0.37)


def _oracle_image(scene: Scene) -> np.ndarray:
    return oracle.render(scene).astype(np.float32)


def _renderers():
    return [pytest.param(native.render, id="native"), pytest.param(_oracle_image, id="oracle")]


def _self_lit(colour) -> PhongMaterial:
    """Ambient only (ka = 1 under La = 1): the surface shows exactly its colour."""
    return PhongMaterial(ka=1.0, kd=0.0, ks=0.0, exponent=1.0, diffuse_color=colour)


def _rect_z(x0, x1, y0, y1, z, material) -> TriangleMesh:
    corners = [(x0, y0, z), (x1, y0, z), (x1, y1, z), (x0, y1, z)]
    return TriangleMesh(points=corners, triangles=[(0, 1, 2), (0, 2, 3)], material=material)


# ---------------------------------------------------------------------------------------------
# Refraction through a slab


@pytest.mark.parametrize("render", _renderers())
@pytest.mark.parametrize("convention", ["book", "povray"])
def test_slab_shifts_the_view_by_snells_law(render, convention):
    """An orthographic camera looks at θ = 35° through a slab of thickness T = 2 (ior 1.5) at a
    backdrop with a colour edge at x = 0: a ray leaves the slab parallel to itself, shifted by
    T·(tan θ − tan θt) along x, so every pixel shows the colour at x − that shift, times kt² (two
    crossings; in the book's convention 1/η² on entry and η² on exit cancel)."""
    theta = math.radians(35.0)
    ior, kt, thickness = 1.5, GLASS_ONLY.kt, 2.0
    left, right = (0.9, 0.3, 0.1), (0.1, 0.4, 0.9)
    slab = calibration.box_mesh((-50.0, -50.0, -3.0), (50.0, 50.0, -3.0 + thickness), GLASS_ONLY)
    forward = (math.sin(theta), 0.0, -math.cos(theta))
    camera = Camera(
        position=(-8.5, 0.0, 3.0), forward=forward, up=(0.0, 1.0, 0.0), projection="orthographic", ortho_width=6.0
    )
    width, height = 48, 4
    scene = Scene(
        camera=camera,
        ambient=AmbientLight((1.0, 1.0, 1.0)),
        meshes=(
            slab,
            _rect_z(-60, 0, -60, 60, -10.0, _self_lit(left)),
            _rect_z(0, 60, -60, 60, -10.0, _self_lit(right)),
        ),
        settings=RenderSettings(
            width=width, height=height, background=BACKGROUND, max_depth=3, transmission=convention
        ),
    )
    image = render(scene)
    sx, sy = np.meshgrid(np.arange(width) + 0.5, np.arange(height) + 0.5)
    o, d = oracle.camera_rays(camera, width, height, sx, sy)
    theta_t = math.asin(math.sin(theta) / ior)
    x_straight = o[:, 0] + (o[:, 2] + 10.0) * math.tan(theta)
    x = (x_straight - thickness * (math.tan(theta) - math.tan(theta_t))).reshape(height, width)
    expected = np.where((x < 0)[..., None], kt * kt * np.asarray(left), kt * kt * np.asarray(right))
    assert np.abs(x).min() > 1e-3  # no pixel centre on the edge
    assert (x < 0).any() and (x > 0).any()
    assert np.all(np.abs(image - expected) <= FLOAT32_TWO_ULPS * np.abs(expected))
    # the shift is visible: without refraction (ior 1) some pixels change colour
    straight = render(
        dataclasses.replace(
            scene,
            meshes=(dataclasses.replace(slab, material=dataclasses.replace(GLASS_ONLY, ior=1.0)), *scene.meshes[1:]),
        )
    )
    assert np.any(np.abs(straight - image) > 0.1)


@pytest.mark.parametrize("render", _renderers())
@pytest.mark.parametrize("slabs", [1, 3])
def test_povray_continues_a_ray_between_equal_indices_without_using_a_depth(render, slabs):
    """Slabs of ior 1 (kt 0.8) before a self-lit backdrop, at max_depth 1: in POV-Ray's
    convention every crossing between equal indices is a continued ray at the same depth (POV-Ray's
    trace.cpp; ref §18), so the backdrop shows through all of them, kt per crossing; the book counts
    each crossing as a level, so the first slab's far side, at depth 1, traces nothing (black)."""
    colour = np.array([0.9, 0.3, 0.1])
    air_glass = dataclasses.replace(GLASS_ONLY, ior=1.0)
    meshes = [
        calibration.box_mesh((-50.0, -50.0, -3.0 * k - 2.0), (50.0, 50.0, -3.0 * k - 1.0), air_glass)
        for k in range(slabs)
    ]
    camera = Camera(
        position=(0.0, 0.0, 3.0),
        forward=(0.0, 0.0, -1.0),
        up=(0.0, 1.0, 0.0),
        projection="orthographic",
        ortho_width=4.0,
    )
    scene = Scene(
        camera=camera,
        ambient=AmbientLight((1.0, 1.0, 1.0)),
        meshes=(*meshes, _rect_z(-60, 60, -60, 60, -20.0, _self_lit(tuple(colour)))),
        settings=RenderSettings(width=8, height=6, background=BACKGROUND, max_depth=1, transmission="povray"),
    )
    expected = colour * GLASS_ONLY.kt ** (2 * slabs)
    image = render(scene)
    assert np.all(np.abs(image - expected) <= FLOAT32_TWO_ULPS * expected)
    book = render(dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, transmission="book")))
    assert np.all(book == 0.0)


@pytest.mark.parametrize("render", _renderers())
def test_the_book_lights_glass_seen_from_inside_with_its_outward_normal(render):
    """A camera at the centre of a glass ball (kd 0.6, ka 0, kt 0.5) looks at its inner surface,
    behind which a shadowless point light sits on the axis, at depth 0 (no secondary rays): the
    book's Phong::shade takes the unflipped normal, n·l = 1, so the centre pixel is kd·cd/π·L
    (Suffern's figure 27.23 shows this highlight); POV-Ray's convention faces the normal to the
    ray, n·l = −1, and the pixel is black."""
    cd, light = np.array([0.9, 0.6, 0.3]), 2.0
    glass = PhongMaterial(ka=0.0, kd=0.6, ks=0.0, exponent=1.0, diffuse_color=tuple(cd), kt=0.5, ior=1.5)
    scene = Scene(
        camera=Camera(position=(0.0, 0.0, 0.0), forward=(0.0, 0.0, -1.0), up=(0.0, 1.0, 0.0), horizontal_fov_deg=1.0),
        ambient=AmbientLight((0.0, 0.0, 0.0)),
        lights=(PointLight((0.0, 0.0, -10.0), (light,) * 3, linking=Linking(shadows=False)),),
        spheres=(Sphere.at((0.0, 0.0, 0.0), 2.0, glass),),
        settings=RenderSettings(width=3, height=3, background=BACKGROUND, max_depth=0, transmission="book"),
    )
    centre = render(scene)[1, 1]
    expected = 0.6 * cd / math.pi * light
    assert np.all(np.abs(centre - expected) <= FLOAT32_TWO_ULPS * expected)  # the centre ray is the axis
    povray = render(dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, transmission="povray")))
    assert np.all(povray[1, 1] == 0.0)


@pytest.mark.povray
def test_povray_renders_the_continued_ray_as_native():
    from phongscene import render
    from phongscene.comparison import compare

    air_glass = dataclasses.replace(GLASS_ONLY, ior=1.0)
    scene = Scene(
        camera=calibration.look_at((0.0, 0.0, 6.0), (0.0, 0.0, 0.0)),
        ambient=AmbientLight((1.0, 1.0, 1.0)),
        spheres=(
            Sphere.at((0.0, 0.0, 0.0), 1.5, air_glass),
            Sphere.at((0.4, 0.3, -4.0), 2.0, _self_lit((0.9, 0.3, 0.1))),
        ),
        settings=RenderSettings(width=32, height=24, background=BACKGROUND, max_depth=1, transmission="povray"),
    )
    image = native.render(scene)
    assert image.max() > 0.5 * 0.9 * GLASS_ONLY.kt**2  # the red ball shows through the ior-1 ball
    assert compare(render(scene, "povray"), image).ok


# ---------------------------------------------------------------------------------------------
# Total internal reflection


def _inside_glass(ior: float, convention: str, kr: float = 0.3, kt: float = 0.5) -> Scene:
    """A camera inside a big glass box (ior) looking up at 60° from the normal of its top face;
    a self-lit floor K inside the box at y = −5; the background beyond the top face."""
    glass = dataclasses.replace(GLASS_ONLY, kr=kr, kt=kt, ior=ior)
    box = calibration.box_mesh((-1e3, -10.0, -1e3), (1e3, 10.0, 1e3), glass)
    floor = TriangleMesh(
        points=[(-900, -5, -900), (900, -5, -900), (900, -5, 900), (-900, -5, 900)],
        triangles=[(0, 2, 1), (0, 3, 2)],
        material=_self_lit((0.8, 0.6, 0.4)),
    )
    s, c = math.sin(math.radians(60.0)), math.cos(math.radians(60.0))
    camera = Camera(
        position=(0.0, 0.0, 0.0), forward=(s, c, 0.0), up=(-c, s, 0.0), projection="orthographic", ortho_width=0.01
    )
    return Scene(
        camera=camera,
        ambient=AmbientLight((1.0, 1.0, 1.0)),
        meshes=(box, floor),
        settings=RenderSettings(width=2, height=2, background=BACKGROUND, max_depth=5, transmission=convention),
    )


def _fresnel_free_leaving(ior: float, kr: float, kt: float, convention: str) -> np.ndarray:
    eta = 1.0 / ior  # leaving the glass
    weight = kt / eta**2 if convention == "book" else kt
    return kr * np.array([0.8, 0.6, 0.4]) + weight * np.asarray(BACKGROUND)


@pytest.mark.parametrize("render", _renderers())
@pytest.mark.parametrize("convention", ["book", "povray"])
def test_total_internal_reflection_returns_the_mirror_ray_at_full_weight(render, convention):
    # beyond the critical angle (asin(1/1.5) = 41.8° < 60°): the floor K, unweighted, no kr term
    image = render(_inside_glass(1.5, convention))
    assert np.array_equal(image, np.broadcast_to(np.float32((0.8, 0.6, 0.4)), image.shape))
    # below it (asin(1/1.1) = 65.4° > 60°): kr·K + the refracted ray (the background) × kt/η²
    # (η = 1/1.1 leaving: × 1.21 in the book's convention) or × kt (POV-Ray's)
    image = render(_inside_glass(1.1, convention))
    expected = _fresnel_free_leaving(1.1, 0.3, 0.5, convention)
    assert np.all(np.abs(image - expected) <= FLOAT32_TWO_ULPS * expected)


# ---------------------------------------------------------------------------------------------
# Shadows through transmissive objects


@pytest.mark.parametrize("render", _renderers())
@pytest.mark.parametrize("convention", ["book", "povray"])
def test_shadow_through_a_transmissive_box_is_the_light_times_kt_per_crossing(render, convention):
    """A floor lit from straight above through a transmissive box (kt 0.6, ior 1.5, not
    refracting the shadow ray): in the "povray" convention the floor under it is lit × 0.6² (two
    crossings, POV-Ray's filtered shadows); in the "book" one it is in the box's shadow, as under
    an opaque box (Suffern's Whitted tracer blocks shadow rays at every object). The box is out
    of the camera's view."""
    kt = 0.6
    floor = PhongMaterial(ka=0.0, kd=1.0, ks=0.0, exponent=1.0, diffuse_color=(0.7, 0.8, 0.9))
    quad = TriangleMesh(
        points=[(-50, 0, -50), (50, 0, -50), (50, 0, 50), (-50, 0, 50)],
        triangles=[(0, 2, 1), (0, 3, 2)],
        material=floor,
    )
    camera = Camera(
        position=(0.0, 3.0, 0.0),
        forward=(0.0, -1.0, 0.0),
        up=(0.0, 0.0, -1.0),
        projection="orthographic",
        ortho_width=1.0,
    )

    def scene(box_material):
        box = calibration.box_mesh((-2.0, 4.0, -2.0), (2.0, 6.0, 2.0), box_material)  # above the camera
        return Scene(
            camera=camera,
            lights=(PointLight((0.0, 10.0, 0.0), (math.pi, math.pi, math.pi)),),
            meshes=(quad, box),
            settings=RenderSettings(width=4, height=4, transmission=convention),
        )

    lit = render(
        Scene(
            camera=camera, lights=scene(GLASS_ONLY).lights, meshes=(quad,), settings=RenderSettings(width=4, height=4)
        )
    )
    filtered = render(scene(dataclasses.replace(GLASS_ONLY, kt=kt)))
    blocked = render(scene(dataclasses.replace(GLASS_ONLY, kt=0.0)))
    assert np.all(lit > 0.5)
    if convention == "povray":
        assert np.all(np.abs(filtered - kt * kt * lit) <= FLOAT32_TWO_ULPS * lit)
    else:
        assert np.array_equal(filtered, np.zeros_like(filtered))
    assert np.array_equal(blocked, np.zeros_like(blocked))


# ---------------------------------------------------------------------------------------------
# Conventions, validation, the SDL


def test_povray_mappings_render_the_native_image_in_povrays_convention():
    scene = calibration.glass_sphere()
    assert scene.settings.transmission == "book"
    # an ambient term on the glass: seen from inside (after entering), the book scales it by 1/η²
    glass = scene.spheres[-1]
    scene = dataclasses.replace(
        scene,
        spheres=(*scene.spheres[:-1], dataclasses.replace(glass, material=dataclasses.replace(glass.material, ka=0.2))),
    )
    for mapping in ("exact", "classic"):
        assert settings_for(scene, mapping=mapping).transmission == "povray"
    book = native.render(scene)
    povray = native.render(
        dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, transmission="povray"))
    )
    assert np.abs(book - povray).max() > 1e-3  # the paths that end inside the glass


@pytest.mark.parametrize(
    ("change", "field"),
    [({"kt": 1.2}, "kt"), ({"kt": -0.5}, "kt"), ({"ior": 0.0}, "ior"), ({"ior": float("inf")}, "ior")],
)
def test_transmissive_material_out_of_range_is_a_scene_error(change, field):
    scene = calibration.glass_sphere()
    glass = scene.spheres[-1]
    bad = dataclasses.replace(glass, material=dataclasses.replace(glass.material, **change))
    with pytest.raises(SceneError) as error:
        check(dataclasses.replace(scene, spheres=(*scene.spheres[:-1], bad)))
    assert any(p.attribute == field for p in error.value.problems)


def test_area_lights_with_transmissive_materials_take_the_grid_or_adaptive_not_cells():
    """In POV-Ray's convention grid samples' shadow rays are filtered (all of them, or POV-Ray's
    adaptive recursion on their colours: calibration glass_under_*_light and adaptive_glass_*
    against POV-Ray); the cells estimator, which answers visibility only, is a clear error there.
    In the book's convention glass casts opaque shadows, and the cells estimator applies."""
    scene = calibration.glass_sphere()
    povray = dataclasses.replace(scene.settings, transmission="povray")
    light = RectAreaLight(
        center=(3.0, 5.0, 3.0), axis_u=(1.0, 0.0, 0.0), axis_v=(0.0, 0.0, 1.0), color=(3.0, 3.0, 3.0), samples=3
    )
    for settings in (scene.settings, povray):
        check(dataclasses.replace(scene, lights=(light,), settings=settings))
        check(dataclasses.replace(scene, lights=(dataclasses.replace(light, adaptive=1),), settings=settings))
    cells = dataclasses.replace(light, cell_samples=2)
    with pytest.raises(SceneError, match="which the cells estimator does not do") as error:
        check(dataclasses.replace(scene, lights=(cells,), settings=povray))
    assert any(p.attribute == "cell_samples" for p in error.value.problems)
    assert scene.settings.transmission == "book"
    check(dataclasses.replace(scene, lights=(cells,)))


def test_in_the_book_convention_the_cells_estimator_sees_glass_as_an_opaque_occluder():
    """A glass ball between a rect area light and the floor, out of the camera's view (the camera
    looks down from below it): with the cells estimator the floor's soft shadow is exactly that of
    an opaque ball in the same place (the book's shadow rays stop at glass), and it is a partial
    shadow, so the cells' inner points were traced."""
    glass = dataclasses.replace(GLASS_ONLY, kd=0.5)
    floor = PhongMaterial(ka=0.1, kd=0.8, ks=0.0, exponent=1.0, diffuse_color=(0.8, 0.8, 0.8))
    light = RectAreaLight(
        center=(0.0, 6.0, 0.0),
        axis_u=(2.0, 0.0, 0.0),
        axis_v=(0.0, 0.0, 2.0),
        color=(4.0, 4.0, 4.0),
        samples=5,
        cell_samples=4,
    )
    camera = Camera(
        position=(0.0, 1.0, 0.0),
        forward=(0.0, -1.0, 0.0),
        up=(0.0, 0.0, -1.0),
        projection="orthographic",
        ortho_width=8.0,
    )
    scene = Scene(
        camera=camera,
        ambient=AmbientLight((1.0, 1.0, 1.0)),
        lights=(light,),
        spheres=(Sphere.at((0.0, 3.0, 0.0), 1.0, glass),),
        meshes=(calibration.ground_quad(0.0, floor),),
        settings=RenderSettings(width=24, height=24, background=BACKGROUND, max_depth=2, transmission="book"),
    )
    image = native.render(check(scene))
    opaque = native.render(
        dataclasses.replace(scene, spheres=(Sphere.at((0.0, 3.0, 0.0), 1.0, dataclasses.replace(glass, kt=0.0)),))
    )
    assert np.array_equal(image, opaque)
    lit = native.render(dataclasses.replace(scene, spheres=()))
    darker = image.mean(axis=2) < lit.mean(axis=2)
    assert darker.any() and not darker.all()
    full_shadow = image.mean(axis=2) <= 0.1 * 0.8 + 1e-6  # the ambient term only
    assert (darker & ~full_shadow).any()  # a penumbra: partial cells


def test_transmissive_sdl_compensates_povrays_att_and_declares_the_interior():
    glass = PhongMaterial(ka=0.1, kd=0.5, ks=0.4, exponent=30.0, diffuse_color=(0.9, 0.95, 1.0), kt=0.75, ior=1.33)
    scene = calibration.glass_sphere()
    scene = dataclasses.replace(
        scene, spheres=(*scene.spheres[:-1], dataclasses.replace(scene.spheres[-1], material=glass))
    )
    classic = compile_pov(scene, mapping="classic")
    # POV-Ray scales ambient and diffuse by att = 1 − kt: the finish divides it back out
    assert "pigment { rgbt <0.9, 0.95, 1.0, 0.75> } finish { ambient 0.4 diffuse 0.63661975" in classic
    assert "interior { ior 1.33 }" in classic and "max_trace_level 7" in classic
    with pytest.raises(SceneError, match="exact mapping"):
        compile_pov(scene, mapping="exact")
    with pytest.raises(SceneError, match="kt = 1 with ambient or diffuse"):
        compile_pov(
            dataclasses.replace(
                scene,
                spheres=(
                    *scene.spheres[:-1],
                    dataclasses.replace(scene.spheres[-1], material=dataclasses.replace(glass, kt=1.0)),
                ),
            ),
            mapping="classic",
        )
    mesh_sdl = compile_pov(calibration.glass_slab(), mapping="classic")
    assert "inside_vector" in mesh_sdl and "interior { ior 1.5 }" in mesh_sdl


# ---------------------------------------------------------------------------------------------
# The dielectric (Suffern ch. 28): Fresnel


@pytest.mark.parametrize("render", _renderers())
@pytest.mark.parametrize("ior", [1.33, 1.5, 2.0])
def test_fresnel_at_normal_incidence_reflects_the_closed_form(render, ior):
    """An opaque fresnel mirror (kr = 1, ior n) seen head-on reflects ((n − 1)/(n + 1))² of the
    background; a dielectric slab (kr = kt = 1) transmits (1 − F)² of a self-lit backdrop, plus
    the echoes between its faces, F² each, as deep as max_depth lets them (the backdrop is met at
    depth 2, 4, 6)."""
    f = ((ior - 1) / (ior + 1)) ** 2
    camera = Camera(position=(0.0, 0.0, 5.0), forward=(0.0, 0.0, -1.0), projection="orthographic", ortho_width=1.0)
    mirror = PhongMaterial(
        ka=0.0, kd=0.0, ks=0.0, exponent=1.0, diffuse_color=(0.0, 0.0, 0.0), kr=1.0, ior=ior, fresnel=True
    )
    settings = RenderSettings(width=2, height=2, background=BACKGROUND, max_depth=6)
    image = render(Scene(camera=camera, meshes=(_rect_z(-9, 9, -9, 9, 0.0, mirror),), settings=settings))
    expected = f * np.asarray(BACKGROUND)
    assert np.all(np.abs(image - expected) <= FLOAT32_TWO_ULPS * expected)
    dielectric = dataclasses.replace(GLASS_ONLY, kr=1.0, kt=1.0, ior=ior, fresnel=True)
    slab = calibration.box_mesh((-50.0, -50.0, -2.0), (50.0, 50.0, 0.0), dielectric)
    backdrop = (0.8, 0.6, 0.4)
    scene = Scene(
        camera=camera,
        ambient=AmbientLight((1.0, 1.0, 1.0)),
        meshes=(slab, _rect_z(-60, 60, -60, 60, -5.0, _self_lit(backdrop))),
        settings=dataclasses.replace(settings, background=(0.0, 0.0, 0.0)),
    )
    expected = np.asarray(backdrop) * (1 - f) ** 2 * sum(f ** (2 * j) for j in range(3))
    image = render(scene)
    assert np.all(np.abs(image - expected) <= FLOAT32_TWO_ULPS * expected)


# ---------------------------------------------------------------------------------------------
# Beer-Lambert (Suffern ch. 28's cf_in; POV-Ray's exponential interior fade)


@pytest.mark.parametrize("render", _renderers())
@pytest.mark.parametrize("convention", ["book", "povray"])
def test_beer_lambert_through_a_slab_and_in_its_shadow(render, convention):
    """Head-on through a slab of thickness 2 with interior_filter cf: the backdrop shows
    kt²·cf² (both conventions filter the path through the slab); the floor under a filtered box
    (2 units thick) is lit × kt²·cf^d, d the shadow ray's path inside the box, in the "povray"
    convention (in the book's the box's shadow is opaque)."""
    cf = np.array([0.3, 0.6, 0.9])
    glass = dataclasses.replace(GLASS_ONLY, interior_filter=tuple(cf))
    camera = Camera(position=(0.0, 0.0, 5.0), forward=(0.0, 0.0, -1.0), projection="orthographic", ortho_width=1.0)
    backdrop = np.array([0.8, 0.6, 0.4])
    scene = Scene(
        camera=camera,
        ambient=AmbientLight((1.0, 1.0, 1.0)),
        meshes=(
            calibration.box_mesh((-50, -50, -2), (50, 50, 0), glass),
            _rect_z(-60, 60, -60, 60, -5.0, _self_lit(tuple(backdrop))),
        ),
        settings=RenderSettings(width=2, height=2, max_depth=4, transmission=convention),
    )
    expected = backdrop * glass.kt**2 * cf**2
    assert np.all(np.abs(render(scene) - expected) <= FLOAT32_TWO_ULPS * expected)
    floor = PhongMaterial(ka=0.0, kd=1.0, ks=0.0, exponent=1.0, diffuse_color=(1.0, 1.0, 1.0))
    quad = TriangleMesh(
        points=[(-50, 0, -50), (50, 0, -50), (50, 0, 50), (-50, 0, 50)],
        triangles=[(0, 2, 1), (0, 3, 2)],
        material=floor,
    )
    down = Camera(
        position=(0.0, 3.0, 0.0),
        forward=(0.0, -1.0, 0.0),
        up=(0.0, 0.0, -1.0),
        projection="orthographic",
        ortho_width=1.0,
    )
    light = PointLight((0.0, 10.0, 0.0), (math.pi, math.pi, math.pi))
    lit = render(Scene(camera=down, lights=(light,), meshes=(quad,), settings=RenderSettings(width=2, height=2)))
    shadowed = render(
        Scene(
            camera=down,
            lights=(light,),
            meshes=(quad, calibration.box_mesh((-2, 4, -2), (2, 6, 2), glass)),
            settings=RenderSettings(width=2, height=2, transmission=convention),
        )
    )
    # the shadow ray from floor point q to the light crosses the 2 units of box along a slant:
    # 2·|light − q|/10 inside
    sx, sy = np.meshgrid(np.arange(2) + 0.5, np.arange(2) + 0.5)
    o, _ = oracle.camera_rays(down, 2, 2, sx, sy)
    q = o * np.array([1.0, 0.0, 1.0])
    inside = (2.0 * np.linalg.norm(np.asarray(light.position) - q, axis=1) / 10.0).reshape(2, 2, 1)
    expected = lit * glass.kt**2 * cf**inside
    if convention == "book":  # the book's shadow rays stop at the box: its shadow is opaque
        expected = np.zeros_like(expected)
    assert np.all(np.abs(shadowed - expected) <= FLOAT32_TWO_ULPS * expected)


def test_beer_lambert_conventions_differ_on_internal_reflections_only():
    """POV-Ray fades only what a transparent surface transmits (ref §18): an internally reflected
    ray is not filtered on its way, the book filters it. The native tracer matches the oracle in
    both conventions on the tinted glass scene, and they differ there."""
    scene = calibration.tinted_glass()
    images = {}
    for convention in ("book", "povray"):
        s = dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, transmission=convention))
        images[convention] = native.render(s)
        expected = oracle.render(s)
        assert np.all(np.abs(images[convention] - expected) <= 1e-6 * np.abs(expected) + 1e-30)
    assert np.abs(images["book"] - images["povray"]).max() > 1e-3
