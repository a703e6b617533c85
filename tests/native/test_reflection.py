# SPDX-License-Identifier: Apache-2.0
"""Mirror reflection (Suffern ch. 24, PerfectSpecular on top of Phong) in the native tracer and the
oracle, against closed forms: a mirror plane doubles a scene; a mirror sphere shows a ball where
the mirror law puts it; rays trapped between two mirrors add up a geometric series cut off at
max_depth; a grazing reflection shows the background without acne at any scale. Plus: kr = 0
and max_depth = 0 leave images bit-identical, thread-count determinism, validation, and the
POV-Ray SDL (only reflective scenes get the depth settings). POV-Ray's own images of reflective
scenes: tests/test_povray_reflection.py and the calibration scenes in tests/test_cross_backend.py.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from phongscene.backends import native
from phongscene.backends.povray import compile_pov
from phongscene.comparison import compare
from phongscene.errors import SceneError
from phongscene.scene import (
    AmbientLight,
    Camera,
    Instances,
    PhongMaterial,
    PointLight,
    Prototype,
    RenderSettings,
    Scene,
    Sphere,
    TriangleMesh,
)
from phongscene.validate import check
from support import calibration, oracle

# The two paths of a closed-form comparison (a reflected ray from the mirror point, or the
# straight ray of the mirrored scene) round differently in float64 (~1e-15 relative); the images
# are stored as float32, so the two may differ by rounding to neighbouring floats: two float32
# ulps (2^-22 relative) and no more. A changed hit, shadow or highlight decision is far larger.
FLOAT32_TWO_ULPS = 2.0**-22
# Pure mirror: no Phong terms of its own, kr = 1, white cr: the reflected radiance, unchanged.
PURE_MIRROR = PhongMaterial(ka=0.0, kd=0.0, ks=0.0, exponent=1.0, diffuse_color=(0.0, 0.0, 0.0), kr=1.0)
BACKGROUND = (0.11, 0.23, 0.37)


def _oracle_image(scene: Scene) -> np.ndarray:
    """The oracle's image stored as the native tracer stores its own (float32)."""
    return oracle.render(scene).astype(np.float32)


def _renderers():
    return [pytest.param(native.render, id="native"), pytest.param(_oracle_image, id="oracle")]


def _quad(y: float, half: float, material: PhongMaterial) -> TriangleMesh:
    """A horizontal square at height y, side 2·half, centred on the y axis."""
    corners = [(-half, y, -half), (half, y, -half), (half, y, half), (-half, y, half)]
    return TriangleMesh(points=corners, triangles=[(0, 2, 1), (0, 3, 2)], material=material)


def _close(image, expected, relative: float) -> bool:
    image, expected = np.asarray(image, np.float64), np.asarray(expected, np.float64)
    return bool(np.all(np.abs(image - expected) <= relative * np.abs(expected)))


# ---------------------------------------------------------------------------------------------
# Defaults: no secondary ray, every existing image unchanged


def test_kr_zero_or_max_depth_zero_renders_bit_identical_images():
    scene = calibration.mirror_floor()
    plain = dataclasses.replace(
        scene,
        spheres=tuple(dataclasses.replace(s, material=dataclasses.replace(s.material, kr=0.0)) for s in scene.spheres),
        meshes=tuple(dataclasses.replace(m, material=dataclasses.replace(m.material, kr=0.0)) for m in scene.meshes),
    )
    reference = native.render(plain)
    no_depth = dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, max_depth=0))
    assert np.array_equal(native.render(no_depth), reference)
    assert np.array_equal(native.render(dataclasses.replace(plain, settings=no_depth.settings)), reference)
    # and the reflection is really there when allowed
    assert np.abs(native.render(scene) - reference).max() > 0.1


def test_reflective_render_is_identical_for_any_thread_count():
    scene = calibration.mirror_floor()
    one = native.render(dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, threads=1)))
    two = native.render(dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, threads=2)))
    five = native.render(dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, threads=5)))
    assert np.array_equal(one, two) and np.array_equal(one, five)


# ---------------------------------------------------------------------------------------------
# A mirror plane doubles the scene


def _objects_above() -> tuple[tuple[Sphere, ...], PointLight]:
    return (
        (Sphere.at((0.2, 1.1, -0.4), 0.9, calibration.RED), Sphere.at((-1.5, 0.6, 0.7), 0.55, calibration.GOLD)),
        PointLight((2.9, 4.7, 3.1), (2.6, 2.5, 2.3)),
    )


@pytest.mark.parametrize("render", _renderers())
def test_mirror_plane_shows_the_mirrored_scene_exactly(render):
    """Where a camera ray meets the pure mirror y = 0 first, it sees what the straight ray sees in
    the scene mirrored through y = 0 (objects and light) with no mirror: the image doubles."""
    spheres, light = _objects_above()
    camera = Camera.look_at((0.4, 2.6, 6.3), (-0.2, 0.2, -0.5), 55.0)
    settings = RenderSettings(width=64, height=48, background=BACKGROUND)
    ambient = AmbientLight((0.15, 0.16, 0.18))
    with_mirror = Scene(
        camera=camera,
        ambient=ambient,
        lights=(light,),
        spheres=spheres,
        meshes=(_quad(0.0, 1e3, PURE_MIRROR),),
        settings=settings,
    )

    def flipped(p):
        return (p[0], -p[1], p[2])

    mirrored_spheres = tuple(
        dataclasses.replace(s, world_from_object=np.diag([1.0, -1.0, 1.0, 1.0]) @ s.world_from_object) for s in spheres
    )
    mirrored = Scene(
        camera=camera,
        ambient=ambient,
        lights=(dataclasses.replace(light, position=flipped(light.position)),),
        spheres=mirrored_spheres,
        settings=settings,
    )
    # The camera rays that reach the mirror first: downward, and not stopped by an object (the
    # objects alone leave the background there; BACKGROUND is no colour an object shows).
    alone = render(dataclasses.replace(with_mirror, meshes=()))
    sx, sy = np.meshgrid(np.arange(64) + 0.5, np.arange(48) + 0.5)
    _, d = oracle.camera_rays(camera, 64, 48, sx, sy)
    to_mirror = (d[:, 1].reshape(48, 64) < 0) & np.all(alone == np.float32(BACKGROUND), axis=2)
    assert to_mirror.sum() > 500  # most of the lower image
    image, expected = render(with_mirror), render(mirrored)
    assert _close(image[to_mirror], expected[to_mirror], FLOAT32_TWO_ULPS)
    # the mirrored spheres are really in view there (not just background on both sides)
    assert np.any(np.abs(expected[to_mirror] - np.float32(BACKGROUND)) > 0.1)


# ---------------------------------------------------------------------------------------------
# A mirror sphere shows a ball where the mirror law puts it


def _mirror_point(camera_position, ball, radius: float) -> np.ndarray:
    """The point q on the sphere |q| = radius where a ray from the camera is reflected to the
    ball's centre (Alhazen's problem): in the plane of the centre, camera and ball, q = radius·n(θ)
    with n bisecting the unit directions from q to the camera and to the ball. Found by bisection
    between θ = 0 (towards the camera) and the ball's direction, where the bisector's tangential
    component changes sign."""
    c, b = np.asarray(camera_position, float), np.asarray(ball, float)
    e1 = c / np.linalg.norm(c)
    e2 = b - e1 * (b @ e1)
    e2 /= np.linalg.norm(e2)
    theta_ball = math.atan2(b @ e2, b @ e1)

    def tangential(theta):
        n = math.cos(theta) * e1 + math.sin(theta) * e2
        q = radius * n
        bisector = (c - q) / np.linalg.norm(c - q) + (b - q) / np.linalg.norm(b - q)
        return bisector @ (-math.sin(theta) * e1 + math.cos(theta) * e2)

    lo, hi = 0.0, theta_ball
    assert tangential(lo) * tangential(hi) < 0
    for _ in range(100):
        mid = (lo + hi) / 2
        if tangential(lo) * tangential(mid) <= 0:
            hi = mid
        else:
            lo = mid
    theta = (lo + hi) / 2
    return radius * (math.cos(theta) * e1 + math.sin(theta) * e2)


def _pixel_of(camera: Camera, width: int, height: int, point) -> tuple[float, float]:
    """The continuous image position (sx, sy) whose camera ray passes through ``point``."""
    r, u, d = oracle.camera_vectors(camera, width, height)
    v = np.asarray(point, float) - np.asarray(camera.position, float)
    lam = (v @ d) / (d @ d)
    return ((v @ r) / (lam * (r @ r)) + 0.5) * width, (0.5 - (v @ u) / (lam * (u @ u))) * height


@pytest.mark.parametrize("render", _renderers())
def test_mirror_sphere_shows_a_ball_where_the_mirror_law_puts_it(render):
    """A unit mirror sphere at the origin and a self-lit ball (ambient only: it shows exactly its
    colour): the pixel through the mirror point of the ball's centre shows the ball's colour
    exactly, and the ball's image in the mirror is centred there."""
    ball_colour = (0.2, 0.9, 0.3)
    ball_centre = (2.3, 1.4, 1.1)
    ball = PhongMaterial(ka=1.0, kd=0.0, ks=0.0, exponent=1.0, diffuse_color=ball_colour)
    camera = Camera.look_at((0.0, 0.3, 4.0), (0.0, 0.0, 0.0), 34.0)
    width, height = 120, 90
    scene = Scene(
        camera=camera,
        ambient=AmbientLight((1.0, 1.0, 1.0)),
        spheres=(Sphere.at((0.0, 0.0, 0.0), 1.0, PURE_MIRROR), Sphere.at(ball_centre, 0.5, ball)),
        settings=RenderSettings(width=width, height=height),
    )
    image = render(scene)
    q = _mirror_point(camera.position, ball_centre, 1.0)
    sx, sy = _pixel_of(camera, width, height, q)
    assert np.array_equal(image[int(sy), int(sx)], np.float32(ball_colour))
    # Points inside the ball (half its radius from the centre) are seen through their own mirror
    # points, where the ball is shown; points beside it (two radii off the line from the mirror
    # point to the centre) are not. The margins (half a radius, a radius) are ~2 pixels in this
    # image, more than the half pixel between a mirror point and its pixel's centre.
    direction = np.asarray(ball_centre) - q
    direction /= np.linalg.norm(direction)
    side = np.cross(direction, (0.0, 1.0, 0.0))
    side /= np.linalg.norm(side)
    up = np.cross(side, direction)
    for axis in (side, up, -side, -up):
        inner = _pixel_of(
            camera, width, height, _mirror_point(camera.position, np.asarray(ball_centre) + 0.25 * axis, 1.0)
        )
        outer = _pixel_of(
            camera, width, height, _mirror_point(camera.position, np.asarray(ball_centre) + 1.0 * axis, 1.0)
        )
        assert np.array_equal(image[int(inner[1]), int(inner[0])], np.float32(ball_colour))
        assert not np.array_equal(image[int(outer[1]), int(outer[0])], np.float32(ball_colour))


# ---------------------------------------------------------------------------------------------
# Rays trapped between two mirrors stop at max_depth


@pytest.mark.parametrize("render", _renderers())
@pytest.mark.parametrize("max_depth", [0, 1, 2, 5, 12])
def test_rays_between_two_mirrors_sum_a_geometric_series_up_to_max_depth(render, max_depth):
    """An orthographic camera at z = 5 looking down −z between a mirror at z = 0 (colour a) and
    one at z = 10 (colour b), each ambient-only (ka = 1, La = 1) with kr: the k-th surface on the
    path is a, b, a, ... weighted kr^k, and the ray of depth max_depth + 1 returns black (not the
    background): L = Σ_{k=0}^{max_depth} kr^k·c_k."""
    kr = 0.6
    a, b = (0.9, 0.2, 0.1), (0.1, 0.3, 0.8)

    def wall(z, colour):
        corners = [(-1e3, -1e3, z), (1e3, -1e3, z), (1e3, 1e3, z), (-1e3, 1e3, z)]
        material = PhongMaterial(ka=1.0, kd=0.0, ks=0.0, exponent=1.0, diffuse_color=colour, kr=kr)
        return TriangleMesh(points=corners, triangles=[(0, 1, 2), (0, 2, 3)], material=material)

    camera = Camera(position=(0.0, 0.0, 5.0), forward=(0.0, 0.0, -1.0), projection="orthographic", ortho_width=2.0)
    scene = Scene(
        camera=camera,
        ambient=AmbientLight((1.0, 1.0, 1.0)),
        meshes=(wall(0.0, a), wall(10.0, b)),
        settings=RenderSettings(width=8, height=6, background=BACKGROUND, max_depth=max_depth),
    )
    expected = sum(kr**k * np.asarray(a if k % 2 == 0 else b) for k in range(max_depth + 1))
    image = render(scene)
    assert _close(image, np.broadcast_to(expected, image.shape), FLOAT32_TWO_ULPS)


def _instanced_mirrors(max_depth: int) -> tuple[Scene, np.ndarray]:
    """The two mirrors above, each a copy of one mirror prototype (z = 0 and z = 10), both
    ambient-only in one colour; and the series the path sums."""
    kr, colour = 0.6, (0.9, 0.2, 0.1)
    corners = [(-1e3, -1e3, 0.0), (1e3, -1e3, 0.0), (1e3, 1e3, 0.0), (-1e3, 1e3, 0.0)]
    material = PhongMaterial(ka=1.0, kd=0.0, ks=0.0, exponent=1.0, diffuse_color=colour, kr=kr)
    wall = Prototype((TriangleMesh(points=corners, triangles=[(0, 1, 2), (0, 2, 3)], material=material),))
    places = np.stack([np.eye(4), np.eye(4)])
    places[1, 2, 3] = 10.0
    camera = Camera(position=(0.0, 0.0, 5.0), forward=(0.0, 0.0, -1.0), projection="orthographic", ortho_width=2.0)
    scene = Scene(
        camera=camera,
        ambient=AmbientLight((1.0, 1.0, 1.0)),
        instances=(Instances(wall, places),),
        settings=RenderSettings(width=8, height=6, background=BACKGROUND, max_depth=max_depth),
    )
    return scene, sum(kr**k * np.asarray(colour) for k in range(max_depth + 1))


def test_a_mirror_only_in_instances_gets_the_depth_limit_in_the_sdl():
    """The SDL's max_trace_level and adc_bailout 0 follow a reflective material wherever it is: on
    an instance's prototype too (without them POV-Ray stops at its default 5 levels and 1/255)."""
    scene, _ = _instanced_mirrors(12)
    for mapping in ("exact", "classic"):
        assert "adc_bailout 0 max_trace_level 13" in compile_pov(scene, mapping=mapping)


@pytest.mark.povray
def test_povray_sums_the_instanced_mirrors_series_as_native():
    from phongscene import render

    scene, expected = _instanced_mirrors(12)
    image = native.render(scene)
    assert _close(image, np.broadcast_to(expected, image.shape), FLOAT32_TWO_ULPS)
    assert compare(render(scene, "povray"), image).ok


# ---------------------------------------------------------------------------------------------
# Grazing reflection


@pytest.mark.parametrize("scale", [1e-6, 1.0, 1e6])
def test_grazing_reflection_shows_the_background_without_acne_at_any_scale(scale):
    """A pure mirror floor (cr tinted) seen from height 1 down to 0.2° above the horizon: every
    pixel below the horizon shows cr·background exactly (a reflected ray that re-hit its own floor
    would show black or a darker tint), every pixel above it the background, from 1e-6 to 1e6
    units (the secondary rays' offsets are relative to the scene, math.hpp)."""
    cr = (0.7, 0.8, 0.9)
    floor = dataclasses.replace(PURE_MIRROR, reflective_color=cr)
    half = 1e4
    camera = Camera.look_at((0.0, scale, 0.0), (0.0, scale * (1 - 0.03 * 180 / math.pi), -scale * 180 / math.pi), 20.0)
    width, height = 48, 36
    scene = Scene(
        camera=camera,
        meshes=(_quad(0.0, half * scale, floor),),
        settings=RenderSettings(width=width, height=height, background=BACKGROUND),
    )
    sx, sy = np.meshgrid(np.arange(width) + 0.5, np.arange(height) + 0.5)
    _, d = oracle.camera_rays(camera, width, height, sx, sy)
    dy = d[:, 1].reshape(height, width)
    down = dy < 0
    # every downward ray meets the floor inside the quad, some of them at grazing angles
    assert down.any() and (~down).any() and np.all(-dy[down] * half > 1.0)
    assert -dy[down].max() < math.sin(math.radians(0.3))
    expected = np.where(down[..., None], np.float32(np.float64(cr) * np.float64(BACKGROUND)), np.float32(BACKGROUND))
    assert np.array_equal(native.render(scene), expected)
    if scale == 1.0:
        assert np.array_equal(oracle.render(scene).astype(np.float32), expected)


# ---------------------------------------------------------------------------------------------
# Validation and the POV-Ray SDL


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"kr": 1.5}, "kr"),
        ({"kr": -0.1}, "kr"),
        ({"kr": float("nan")}, "kr"),
        ({"reflective_color": (1.0, -0.2, 0.0)}, "reflective_color"),
    ],
)
def test_reflective_material_out_of_range_is_a_scene_error(change, field):
    scene = calibration.mirror_floor()
    bad = dataclasses.replace(scene.spheres[1], material=dataclasses.replace(scene.spheres[1].material, **change))
    with pytest.raises(SceneError) as error:
        check(dataclasses.replace(scene, spheres=(scene.spheres[0], bad)))
    assert any(p.attribute == field for p in error.value.problems)


@pytest.mark.parametrize("depth", [-1, 256, 2.5, True])
def test_max_depth_out_of_range_is_a_scene_error(depth):
    scene = calibration.mirror_floor()
    with pytest.raises(SceneError) as error:
        check(dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, max_depth=depth)))
    assert [p.attribute for p in error.value.problems] == ["max_depth"]


def test_only_reflective_scenes_get_secondary_ray_settings_in_the_sdl():
    plain = calibration.point_light()
    for mapping in ("exact", "classic"):
        sdl = compile_pov(plain, mapping=mapping)
        assert "reflection" not in sdl and "max_trace_level" not in sdl
    scene = calibration.mirror_floor()  # max_depth 3
    classic = compile_pov(scene, mapping="classic")
    assert "adc_bailout 0 max_trace_level 4" in classic
    assert "reflection rgb <0.54, 0.48, 0.6>" in classic  # kr·cr of the floor
    assert "reflection rgb <0.8, 0.72, 0.56>" in classic  # and of the chrome sphere
    exact = compile_pov(scene, mapping="exact")
    assert "adc_bailout 0 max_trace_level 4" in exact
    # the floor (no highlight) has one plain texture; the chrome sphere's average texture carries
    # the mirror term on its doubled diffuse half
    assert "reflection rgb <0.54, 0.48, 0.6>" in exact and "reflection rgb <1.6, 1.44, 1.12>" in exact


# ---------------------------------------------------------------------------------------------
# From USD


@pytest.mark.slow  # writes and reads two stages: ~1.3 s on 2 cores
def test_phong_shader_inputs_round_trip_and_are_written_only_when_used(tmp_path):
    from phongscene.usd import load_usd, write_usd

    scene = calibration.dielectric_sphere()
    back = load_usd(write_usd(scene, tmp_path / "dielectric.usda"))
    for a, b in zip((*scene.spheres, *scene.meshes), (*back.spheres, *back.meshes)):
        assert (b.material.kr, b.material.kt, b.material.ior, b.material.fresnel) == pytest.approx(
            (a.material.kr, a.material.kt, a.material.ior, a.material.fresnel)
        )
        assert b.material.reflective_color == pytest.approx(a.material.reflective_color)
    text = (tmp_path / "dielectric.usda").read_text()
    assert "bool inputs:fresnel = 1" in text and "float inputs:kt = 1" in text
    plain = tmp_path / "plain.usda"
    write_usd(calibration.point_light(), plain)
    assert not any(f"inputs:{name}" in plain.read_text() for name in ("kr", "reflectiveColor", "kt", "ior", "fresnel"))


def test_a_smooth_metal_preview_surface_is_a_mirror_tinted_by_its_f0():
    from phongscene.usd import preview_to_phong
    from phongscene.usd.materials import PREVIEW_MIRROR_MAX_ROUGHNESS

    gold = preview_to_phong((1.0, 0.77, 0.34), 0.1, metallic=1.0)
    assert gold.kr == 1.0 and gold.reflective_color == (1.0, 0.77, 0.34)
    half = preview_to_phong((0.8, 0.8, 0.8), 0.0, metallic=0.5)
    assert half.reflective_color == pytest.approx((0.4, 0.4, 0.4))
    # rough metals, dielectrics and the specular workflow keep no mirror term
    assert preview_to_phong((1.0, 0.77, 0.34), PREVIEW_MIRROR_MAX_ROUGHNESS + 0.01, metallic=1.0).kr == 0.0
    assert preview_to_phong((0.8, 0.1, 0.1), 0.0).kr == 0.0
    assert preview_to_phong((0.8, 0.1, 0.1), 0.0, specular_color=(1, 1, 1), use_specular_workflow=1).kr == 0.0


def test_info_says_which_materials_reflect_or_refract(tmp_path, capsys):
    from phongscene.cli import main
    from phongscene.usd import write_usd

    path = write_usd(calibration.dielectric_sphere(), tmp_path / "dielectric.usda")
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "reflect or refract" in out and "refracts kt 1 ior 1.5, fresnel" in out and "reflects kr 1" in out
    plain = write_usd(calibration.point_light(), tmp_path / "plain.usda")
    assert main(["info", str(plain)]) == 0
    assert "reflect or refract" not in capsys.readouterr().out


def test_render_settings_max_depth_and_transmission_round_trip(tmp_path):
    from phongscene.usd import load_usd, write_usd

    scene = calibration.mirror_floor()  # max_depth 3
    scene = dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, transmission="povray"))
    back = load_usd(write_usd(scene, tmp_path / "mirror.usda"))
    assert (back.settings.max_depth, back.settings.transmission) == (3, "povray")
    text = (tmp_path / "mirror.usda").read_text()
    assert "int phong:maxDepth = 3" in text and 'phong:transmissionConvention = "povray"' in text


def test_a_dome_light_is_what_mirrors_see_at_infinity(tmp_path):
    """A scene with a reflective material and a DomeLight (its ambient light) but a black
    background: the reader makes the dome's radiance the background (what a mirror, and a camera
    ray that misses, sees there, as USD renderers show it). Scenes without secondary rays keep
    theirs."""
    from phongscene.usd import load_usd, write_usd

    black = dict(background=(0.0, 0.0, 0.0))
    mirror = calibration.mirror_floor()
    mirror = dataclasses.replace(mirror, settings=dataclasses.replace(mirror.settings, **black))
    back = load_usd(write_usd(mirror, tmp_path / "mirror.usda"))
    assert back.settings.background == pytest.approx(mirror.ambient.color)
    plain = calibration.point_light()
    plain = dataclasses.replace(plain, settings=dataclasses.replace(plain.settings, **black))
    assert load_usd(write_usd(plain, tmp_path / "plain.usda")).settings.background == (0.0, 0.0, 0.0)
