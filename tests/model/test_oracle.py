# SPDX-License-Identifier: Apache-2.0
"""Checks of the oracle (tests/support/oracle.py) against closed forms, and of the calibration catalogue.

Each test states its closed form in a comment (pbrt's habit). The closed forms come from
the shading model in docs/concepts/phong-model.md and the POV-Ray reference (ref §n: docs/povray-3.7-semantics.md), never from the oracle's own output.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from phongscene.scene import (
    AmbientLight,
    Camera,
    DirectionalLight,
    PhongMaterial,
    PointLight,
    RectAreaLight,
    RenderSettings,
    Scene,
    Sphere,
    SphereAreaLight,
    TriangleMesh,
)
from phongscene.validate import validate
from support import calibration, oracle

# Closed forms are evaluated in float64 like the oracle; only the order of operations differs.
EXACT = 1e-12
# Reference §15 prints its expected values with 5 decimals (rounding ≤ 5e-6); allow 2× that.
GOLDEN_TABLE_TOLERANCE = 1e-5
# A pixel whose value jumps by more than this when every sample moves by COINCIDENCE_SHIFT_PX has
# a discontinuity (silhouette, shadow or highlight edge) within that distance of a sample point.
COINCIDENCE_JUMP = 1e-3
# 1e-4 px: far below any real sampling difference, far above double round-off, and wider than the
# silhouette shifts from POV-Ray's float32 mesh vertices at these scene scales (~1e-6 px).
COINCIDENCE_SHIFT_PX = 1e-4
# Every calibration pixel must stay below this (POV-Ray's half-float EXR keeps ~3 digits there).
CALIBRATION_MAX_VALUE = 4.0


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


def _tup(v) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


def _quad(corners, material) -> TriangleMesh:
    return TriangleMesh(points=corners, triangles=[(0, 1, 2), (0, 2, 3)], material=material)


def _one_ray(scene: Scene, origin, target) -> np.ndarray:
    """Radiance of the single ray from ``origin`` through ``target``."""
    o = np.asarray([origin], dtype=np.float64)
    return oracle.trace_rays(scene, o, np.asarray([target], dtype=np.float64) - o)[0]


# ---------------------------------------------------------------------------------------------
# Camera and sampling


def test_camera_perspective_centre_ray_is_forward_and_plus_x_is_right():
    # Closed form (ref §3): u = v = 0 at (W/2, H/2) gives dir = D̂ = forward; sx > W/2 gives u > 0,
    # i.e. +right = forward × up = +X for a camera looking down −Z with +Y up.
    camera = Camera(position=(1.0, 2.0, 3.0), forward=(0, 0, -1), up=(0, 1, 0), horizontal_fov_deg=60.0)
    origins, dirs = oracle.camera_rays(camera, 64, 48, np.array([32.0, 60.0, 32.0]), np.array([24.0, 24.0, 2.0]))
    np.testing.assert_allclose(origins, [[1.0, 2.0, 3.0]] * 3)
    np.testing.assert_allclose(dirs[0], [0, 0, -1], atol=EXACT)
    assert dirs[1, 0] > 0.3 and abs(dirs[1, 1]) < EXACT  # right of centre → +X
    assert dirs[2, 1] > 0.2  # top row → +Y
    # The image's right edge is at half the horizontal FOV: x/−z = tan(30°).
    _, edge = oracle.camera_rays(camera, 64, 48, np.array([64.0]), np.array([24.0]))
    assert edge[0, 0] / -edge[0, 2] == pytest.approx(math.tan(math.radians(30.0)), abs=EXACT)


def test_camera_orthographic_origins_span_ortho_width():
    # Closed form (ref §3): origin = position + u·R + v·U with |R| = ortho_width, |U| = ortho_width·H/W;
    # the corner (0, 0) has u = −½, v = +½.
    camera = Camera(position=(0, 0, 5), forward=(0, 0, -1), up=(0, 1, 0), projection="orthographic", ortho_width=8.0)
    origins, dirs = oracle.camera_rays(camera, 64, 48, np.array([0.0, 64.0]), np.array([0.0, 48.0]))
    np.testing.assert_allclose(origins, [[-4.0, 3.0, 5.0], [4.0, -3.0, 5.0]], atol=EXACT)
    np.testing.assert_allclose(dirs, [[0, 0, -1], [0, 0, -1]], atol=EXACT)


def test_pixel_sample_weights():
    # ref §8: n = 1 → the centre; grid → n² cell centres (a+½)/n, weight 1/n²;
    # povray-am1 → centre + grid, each 1/(n²+1) (for odd n the centre is listed twice: weight 2/(n²+1)).
    offsets, weights = oracle.pixel_samples(1, "povray-am1")
    np.testing.assert_array_equal(offsets, [[0.5, 0.5]])
    np.testing.assert_array_equal(weights, [1.0])
    offsets, weights = oracle.pixel_samples(3, "grid")
    assert sorted(set(offsets[:, 0])) == pytest.approx([1 / 6, 1 / 2, 5 / 6])
    np.testing.assert_allclose(weights, np.full(9, 1 / 9))
    offsets, weights = oracle.pixel_samples(3, "povray-am1")
    np.testing.assert_allclose(weights, np.full(10, 1 / 10))
    at_centre = np.all(np.isclose(offsets, 0.5), axis=1)
    assert weights[at_centre].sum() == pytest.approx(2 / 10)
    offsets, weights = oracle.pixel_samples(2, "povray-am1")
    np.testing.assert_allclose(weights, np.full(5, 1 / 5))


@pytest.mark.parametrize(
    ("samples", "pattern", "fraction"),
    [
        (1, "grid", 1.0),  # the centre (offset ½) lies right of the edge at offset 0.4
        (3, "grid", 2 / 3),  # offsets 1/6 | 1/2, 5/6: two of three columns covered
        (3, "povray-am1", 7 / 10),  # (centre + 6 of 9 grid samples) / 10
        (2, "povray-am1", 3 / 5),  # offsets 1/4 | 3/4: (centre + 2 of 4) / 5
    ],
)
def test_antialiasing_of_an_edge_inside_a_pixel(samples, pattern, fraction):
    # Closed form: an orthographic camera with 1 world unit per pixel sees a constant-radiance
    # (ambient-only) triangle whose vertical edge lies 0.4 px into column 3; that pixel =
    # c·(weighted fraction of its samples right of the edge), column 2 = background 0, column 4 = c.
    c = 0.5
    material = PhongMaterial(ka=1.0, kd=0.0, ks=0.0, diffuse_color=(c, c, c))
    x_edge = 3.4 - 4.0  # image x = sx maps to world x = sx − W/2
    tri = TriangleMesh(
        points=[(x_edge, -500, 0), (x_edge, 500, 0), (1000, 0, 0)], triangles=[(0, 1, 2)], material=material
    )
    scene = Scene(
        camera=Camera(position=(0, 0, 5), forward=(0, 0, -1), up=(0, 1, 0), projection="orthographic", ortho_width=8.0),
        ambient=AmbientLight((1.0, 1.0, 1.0)),
        meshes=(tri,),
        settings=RenderSettings(width=8, height=6, samples=samples, sample_pattern=pattern),
    )
    image = oracle.render(scene)
    np.testing.assert_allclose(image[:, 2], 0.0, atol=EXACT)
    np.testing.assert_allclose(image[:, 3], c * fraction, atol=EXACT)
    np.testing.assert_allclose(image[:, 4], c, atol=EXACT)


def test_area_light_subdivision_weights():
    # ref §5: full recursive 4-corner subdivision; for n = 2^k + 1 the trapezoid rule
    # (½, 1, …, 1, ½)/(n − 1); always summing to 1. For n = 4 the halves [0,1], [2,3] give ¼ each.
    for n in (2, 3, 5, 9, 17):
        expected = np.ones(n)
        expected[[0, -1]] = 0.5
        np.testing.assert_allclose(oracle.subdivision_weights(n), expected / (n - 1), atol=EXACT)
    np.testing.assert_allclose(oracle.subdivision_weights(4), [0.25] * 4, atol=EXACT)
    for n in range(2, 12):
        assert oracle.subdivision_weights(n).sum() == pytest.approx(1.0, abs=EXACT)


# ---------------------------------------------------------------------------------------------
# Shading closed forms


HEAD_ON = PhongMaterial(
    ka=0.2, kd=0.7, ks=0.4, exponent=15.0, diffuse_color=(0.8, 0.5, 0.3), specular_color=(0.3, 0.6, 0.9)
)
HEAD_ON_LA = np.array([0.5, 0.4, 0.3])
HEAD_ON_L = np.array([2.0, 2.5, 3.0])


def _head_on_scene(specular: str) -> Scene:
    return Scene(
        camera=Camera(position=(0, 0, 5), forward=(0, 0, -1), up=(0, 1, 0), horizontal_fov_deg=30.0),
        ambient=AmbientLight(_tup(HEAD_ON_LA)),
        lights=(DirectionalLight((0.0, 0.0, -1.0), _tup(HEAD_ON_L)),),
        spheres=(Sphere.at((0, 0, 0), 1.0, HEAD_ON),),
        settings=RenderSettings(width=33, height=25, specular=specular),
    )


def test_head_on_directional_light_centre_pixel_seed():
    # Centre pixel of an odd image looks along −Z at the sphere's pole: n = l = wo = +Z, so
    # n·l = 1 and r·wo = 1: L = ka·cd·La + (kd·cd/π + ks·cs)·L (docs/concepts/phong-model.md).
    m = HEAD_ON
    expected = (
        m.ka * np.array(m.diffuse_color) * HEAD_ON_LA
        + (m.kd * np.array(m.diffuse_color) / math.pi + m.ks * np.array(m.specular_color)) * HEAD_ON_L
    )
    np.testing.assert_allclose(oracle.render(_head_on_scene("seed"))[12, 16], expected, atol=EXACT)


def test_head_on_directional_light_centre_pixel_classic():
    # Same pole, povray-classic: L = ka·cd·La + kd/π·cd·L + ks·L (white highlight, no cs).
    m = HEAD_ON
    expected = (
        m.ka * np.array(m.diffuse_color) * HEAD_ON_LA + (m.kd * np.array(m.diffuse_color) / math.pi + m.ks) * HEAD_ON_L
    )
    np.testing.assert_allclose(oracle.render(_head_on_scene("povray-classic"))[12, 16], expected, atol=EXACT)


def test_seed_and_classic_differ_by_n_dot_l_on_a_phong_only_sphere():
    # Phong-only material (ka = kd = 0, ks = 1, cs = 1), directional light l:
    # seed = (r_l·wo)^e·(n·l), classic = (r_v·l)^e with r_v·l = r_l·wo (ref §4), so seed = classic·(n·l)
    # wherever n·l ≥ EPSILON; n from the analytic unit-sphere hit t = −o·d − √((o·d)² − |o|² + 1).
    light_l = _unit([0.5, 0.4, 1.0])
    material = PhongMaterial(ka=0.0, kd=0.0, ks=1.0, exponent=8.0, diffuse_color=(1, 1, 1), specular_color=(1, 1, 1))
    scene = Scene(
        camera=Camera(position=(0, 0, 4), forward=(0, 0, -1), up=(0, 1, 0), horizontal_fov_deg=40.0),
        lights=(DirectionalLight(_tup(-light_l), (1.0, 1.0, 1.0)),),
        spheres=(Sphere.at((0, 0, 0), 1.0, material),),
        settings=RenderSettings(width=48, height=36),
    )
    seed = oracle.render(scene)[..., 0]
    classic = oracle.render(calibration.classic_variant(scene))[..., 0]
    cols, rows = np.meshgrid(np.arange(48) + 0.5, np.arange(36) + 0.5)
    o, d = oracle.camera_rays(scene.camera, 48, 36, cols, rows)
    b = np.einsum("ij,ij->i", o, d)
    disc = b * b - np.einsum("ij,ij->i", o, o) + 1.0
    hit = disc > 0
    t = -b - np.sqrt(np.where(hit, disc, 0.0))
    n_dot_l = ((o + t[:, None] * d) @ light_l).reshape(36, 48)
    lit = hit.reshape(36, 48) & (n_dot_l >= oracle.EPSILON)
    np.testing.assert_allclose(seed[lit], classic[lit] * n_dot_l[lit], atol=EXACT)
    np.testing.assert_allclose(seed[~lit], 0.0, atol=EXACT)
    np.testing.assert_allclose(classic[~lit], 0.0, atol=EXACT)
    assert classic.max() > 0.5 and np.abs(seed - classic).max() > 0.05  # the test can tell them apart


def test_classic_phong_cutoff():
    # ref §4: POV-Ray sets the phong term to 0 when phong_size >= 60 and k <= 0.0008, else k^e (k > 0).
    assert oracle.classic_phong_factor(np.array([0.0008]), 60.0)[0] == 0.0
    assert oracle.classic_phong_factor(np.array([0.0008]), 59.0)[0] == pytest.approx(0.0008**59, rel=1e-12)
    assert oracle.classic_phong_factor(np.array([0.0009]), 60.0)[0] == pytest.approx(0.0009**60, rel=1e-12)
    assert oracle.classic_phong_factor(np.array([0.5, 0.0, -0.5]), 0.0).tolist() == [1.0, 0.0, 0.0]


GROUND_MAT = PhongMaterial(ka=0.1, kd=0.9, ks=0.0, exponent=1.0, diffuse_color=(0.6, 0.5, 0.4))
GROUND_LA = np.array([0.3, 0.3, 0.3])


def _ground_scene(lights, *, spheres=(), meshes=()) -> Scene:
    ground = _quad([(-10, 0, -10), (-10, 0, 10), (10, 0, 10), (10, 0, -10)], GROUND_MAT)
    return Scene(ambient=AmbientLight(_tup(GROUND_LA)), lights=tuple(lights), spheres=spheres, meshes=(ground, *meshes))


def _ground_value(light_colour, n_dot_l, fraction=1.0) -> np.ndarray:
    """Closed form on the ground: ka·cd·La + kd·cd/π·L·(n·l)·fraction (ks = 0)."""
    cd = np.array(GROUND_MAT.diffuse_color)
    return GROUND_MAT.ka * cd * GROUND_LA + GROUND_MAT.kd * cd / math.pi * np.asarray(light_colour) * n_dot_l * fraction


def test_shadowed_point_gets_ambient_only():
    # Directional light straight down, occluder sphere above: under it L = ka·cd·La; in the open,
    # L = ka·cd·La + kd·cd/π·L (n·l = 1).
    light = DirectionalLight((0.0, -1.0, 0.0), (2.0, 2.0, 2.0))
    scene = _ground_scene([light], spheres=(Sphere.at((0, 2, 0), 0.5, HEAD_ON),))
    np.testing.assert_allclose(_one_ray(scene, (0, 5, 3), (0, 0, 0.1)), _ground_value((2, 2, 2), 0.0), atol=EXACT)
    np.testing.assert_allclose(_one_ray(scene, (0, 5, 3), (0, 0, 2.0)), _ground_value((2, 2, 2), 1.0), atol=EXACT)


def test_directional_shadow_reaches_far_occluders():
    # A directional light's shadow ray runs to MAX_DISTANCE: an occluder 1000 units up still shadows.
    light = DirectionalLight((0.0, -1.0, 0.0), (2.0, 2.0, 2.0))
    scene = _ground_scene([light], spheres=(Sphere.at((0, 1000, 0), 0.5, HEAD_ON),))
    np.testing.assert_allclose(_one_ray(scene, (0, 5, 3), (0, 0, 0.1)), _ground_value((2, 2, 2), 0.0), atol=EXACT)


def test_n_dot_l_gate():
    # ref §4, §6: a light with n·l < 1e-10 contributes nothing (neither a tiny positive nor a negative
    # amount: kd·cd/π·L·5e-11 ≈ 1.7e-11 would exceed the absolute tolerance); above it kd·cd/π·L·(n·l).
    for height, n_dot_l in ((0.0, 0.0), (-1.0, 0.0), (-1e-4, 0.0), (5e-11, 0.0)):
        scene = _ground_scene([PointLight((1.0, height, 0.0), (2, 2, 2))])
        got = _one_ray(scene, (0, 1, 1), (0, 0, 0))
        np.testing.assert_allclose(got, _ground_value((2, 2, 2), n_dot_l), rtol=0.0, atol=EXACT)
    scene = _ground_scene([PointLight((1.0, 0.01, 0.0), (2, 2, 2))])
    n_dot_l = 0.01 / math.hypot(1.0, 0.01)
    np.testing.assert_allclose(_one_ray(scene, (0, 1, 1), (0, 0, 0)), _ground_value((2, 2, 2), n_dot_l), atol=1e-9)


def test_point_light_fade():
    # ref §5: Lc = c·2/(1 + (d/fade_distance)^fade_power); P = origin, light 3 up: d = 3, n·l = 1.
    for fade_distance, fade_power in ((2.0, 2.0), (4.5, 1.0)):
        light = PointLight((0, 3, 0), (1.5, 1.5, 1.5), fade_distance=fade_distance, fade_power=fade_power)
        factor = 2.0 / (1.0 + (3.0 / fade_distance) ** fade_power)
        got = _one_ray(_ground_scene([light]), (0.5, 1, 1), (0, 0, 0))
        np.testing.assert_allclose(got, _ground_value(np.full(3, 1.5 * factor), 1.0), atol=1e-9)


def test_usdlux_inverse_square_point_and_lambertian_rect_light():
    # UsdLux: a point light of intensity I, 3 above P = origin, gives I/9 (n·l = 1); a rect light
    # centred at (4, 3, 0) emitting straight down gives I·cos θ/d² with cos θ = 3/5, d = 5, and
    # n·l = 3/5 at P; turned to emit upwards (its back to P) it gives nothing.
    point = PointLight((0, 3, 0), (18.0, 18.0, 18.0), falloff="inverse-square")
    got = _one_ray(_ground_scene([point]), (0.5, 1, 1), (0, 0, 0))
    np.testing.assert_allclose(got, _ground_value(np.full(3, 2.0), 1.0), atol=1e-9)
    down = RectAreaLight(
        (4, 3, 0), axis_u=(0, 0, 0.1), axis_v=(0.1, 0, 0), color=(50.0, 50.0, 50.0), samples=3, falloff="inverse-square"
    )  # emits along −(u × v) = −y
    got = _one_ray(_ground_scene([down]), (0.5, 1, 1), (0, 0, 0))
    np.testing.assert_allclose(got, _ground_value(np.full(3, 50.0 * 0.6 / 25.0), 0.6), atol=1e-9)
    up = dataclasses.replace(down, axis_u=down.axis_v, axis_v=down.axis_u)
    np.testing.assert_allclose(
        _one_ray(_ground_scene([up]), (0.5, 1, 1), (0, 0, 0)), _ground_value((0, 0, 0), 0.6), atol=1e-9
    )


@pytest.mark.parametrize(("samples", "fraction"), [(3, 1 / 4), (5, 3 / 8), (9, 5 / 16)])
def test_rect_area_light_shades_from_centre_and_shadows_from_trapezoid_grid(samples, fraction):
    # Light centre (0,4,0) straight above P = origin: shading n·l = 1 from the centre (ref §5).
    # A half-plane occluder at y = 2 covers x < 0.15, so a sample at x_s is blocked iff x_s/2 < 0.15,
    # i.e. x_s < 0.3 (x_s = −1 … 1). Visible fraction = Σ trapezoid weights of columns x_s > 0.3:
    # n = 3 {1}: ¼; n = 5 {0.5, 1}: ¼ + ⅛; n = 9 {0.5, 0.75, 1}: ⅛ + ⅛ + 1/16. The centre itself is
    # blocked, which a point light would turn into full shadow.
    light = RectAreaLight(center=(0, 4, 0), axis_u=(2, 0, 0), axis_v=(0, 0, 2), color=(2, 2, 2), samples=samples)
    occluder = _quad([(-10, 2, -10), (-10, 2, 10), (0.15, 2, 10), (0.15, 2, -10)], GROUND_MAT)
    scene = _ground_scene([light], meshes=(occluder,))
    np.testing.assert_allclose(
        _one_ray(scene, (0.05, 1, 1), (0, 0, 0)), _ground_value((2, 2, 2), 1.0, fraction), atol=EXACT
    )


def test_sphere_area_light_samples_form_an_oriented_disc():
    # ref §5 circular + orient: offsets ⟂ l, |offset| = 2r·max(|ju|, |jv|) with ju = u/(n−1) − ½ + 0.001;
    # the farthest samples sit at 2r·0.501 = 1.002·r. With l = ±Z the helper axis is Y: A1 ∥ l × Y.
    radius, n = 0.7, 5
    light = SphereAreaLight(center=(0, 0, 0), radius=radius, color=(1, 1, 1), samples=n)
    to_light = np.array([_unit([0.3, -0.5, 0.8]), [0.0, 0.0, 1.0]])
    offsets, weights = oracle.area_light_offsets(light, to_light)
    assert offsets.shape == (2, n * n, 3) and weights.sum() == pytest.approx(1.0, abs=EXACT)
    j = np.arange(n) / (n - 1) - 0.5 + 0.001
    ju, jv = np.meshgrid(j, j, indexing="ij")
    expected_radius = 2 * radius * np.maximum(np.abs(ju), np.abs(jv)).ravel()
    for k in range(2):
        np.testing.assert_allclose(offsets[k] @ to_light[k], 0.0, atol=EXACT)
        np.testing.assert_allclose(np.linalg.norm(offsets[k], axis=1), expected_radius, atol=EXACT)
    assert np.linalg.norm(offsets, axis=2).max() == pytest.approx(1.002 * radius, abs=EXACT)
    # l = +Z: A1 = normalise(l × (0,1,0))·2r = −X·2r, so ju (the first index) moves samples along −X.
    corner = offsets[1, 0]  # u = v = 0: ju = jv = −0.499 before the disc scaling
    assert corner[0] > 0 and corner[1] != 0.0


def test_unoccluded_sphere_area_light_equals_a_point_light():
    # Shading from the centre (ref §5) and shadow fraction 1 when nothing blocks: exactly a point light.
    area = SphereAreaLight(center=(0.7, 3.0, -0.4), radius=0.5, color=(2, 2, 2), samples=5)
    point = PointLight((0.7, 3.0, -0.4), (2, 2, 2))
    a = _one_ray(_ground_scene([area]), (0.5, 1, 1), (0.1, 0, 0.2))
    p = _one_ray(_ground_scene([point]), (0.5, 1, 1), (0.1, 0, 0.2))
    np.testing.assert_allclose(a, p, atol=EXACT)
    n_dot_l = _unit(np.array([0.7, 3.0, -0.4]) - [0.1, 0, 0.2])[1]
    np.testing.assert_allclose(p, _ground_value((2, 2, 2), n_dot_l), atol=1e-9)


# ---------------------------------------------------------------------------------------------
# Tolerances (ref §6)


def test_primary_hit_needs_min_isect_depth_and_max_distance():
    # ref §6: a primary hit counts for 1e-4 <= t < 1e7. Ambient-only quad: a hit is ka·cd·La = 0.25.
    material = PhongMaterial(ka=0.5, kd=0.0, ks=0.0, diffuse_color=(0.5, 0.5, 0.5))

    def value(z_quad, origin_z, half=1.0):
        quad = _quad(
            [(-half, -half, z_quad), (half, -half, z_quad), (half, half, z_quad), (-half, half, z_quad)], material
        )
        scene = Scene(
            ambient=AmbientLight((1, 1, 1)), meshes=(quad,), settings=RenderSettings(background=(0.0, 0.0, 0.0))
        )
        return _one_ray(scene, (0.1, 0.2, origin_z), (0.1, 0.2, origin_z - 1.0))[0]

    assert value(0.0, 5e-5) == 0.0
    assert value(0.0, 2e-4) == pytest.approx(0.25, abs=EXACT)
    assert value(-1.2e7, 0.0, half=1e8) == 0.0
    assert value(-9e6, 0.0, half=1e8) == pytest.approx(0.25, abs=EXACT)


@pytest.mark.parametrize(
    ("distance_along_l", "shadowed"),
    [
        (5e-4, False),
        (2e-3, True),
        (2 * math.sqrt(2) - 5e-4, False),
        (2 * math.sqrt(2) - 2e-3, True),
        (2 * math.sqrt(2) + 0.5, False),
    ],
)
def test_shadow_window(distance_along_l, shadowed):
    # ref §6: a shadow ray starts exactly at P; an occluder counts for 1e-3 < t < dist − 1e-3.
    # P = origin, light at (2,2,0): dist = 2√2, n·l = 1/√2. A tiny triangle ⟂ l centred at P + t·l.
    l = _unit([1.0, 1.0, 0.0])
    centre = l * distance_along_l
    side = np.array([1.0, -1.0, 0.0]) / math.sqrt(2)
    z = np.array([0.0, 0.0, 1.0])
    s = 2e-4  # small enough that the primary ray (arriving from (−1,1,0)) passes beside it
    occluder = TriangleMesh(
        points=[centre + s * z, centre + s * (-0.5 * z + 0.866 * side), centre + s * (-0.5 * z - 0.866 * side)],
        triangles=[(0, 1, 2)],
        material=GROUND_MAT,
    )
    scene = _ground_scene([PointLight((2, 2, 0), (2, 2, 2))], meshes=(occluder,))
    expected = _ground_value((2, 2, 2), 0.0 if shadowed else 1 / math.sqrt(2))
    np.testing.assert_allclose(_one_ray(scene, (-1, 1, 0), (0, 0, 0)), expected, atol=1e-9)


# ---------------------------------------------------------------------------------------------
# Geometry


def test_sphere_and_ellipsoid_coverage_orthographic():
    # Closed form: orthographic view, s = W/ortho_width px per unit. A sphere covers π(r·s)² px and an
    # ellipsoid with in-view semi-axes a, b covers π·a·b·s² px (rotation about the view axis keeps the
    # area), to within the area of a ring of width √2/2 px around the outline.
    width, height, ortho = 64, 48, 4.0
    s = width / ortho
    ellipsoid = (
        calibration.translation((0.9, -0.3, 0))
        @ calibration.rotation((0, 0, 1), 30.0)
        @ calibration.scaling((0.6, 0.35, 2.0))
    )
    cases = [(Sphere.at((-0.2, 0.1, 0.0), 1.1), 1.1 * 1.1, 1.1), (Sphere(ellipsoid), 0.6 * 0.35, 0.6)]
    for sphere, ab, largest in cases:
        scene = Scene(
            camera=Camera(
                position=(0, 0, 10), forward=(0, 0, -1), up=(0, 1, 0), projection="orthographic", ortho_width=ortho
            ),
            ambient=AmbientLight((1, 1, 1)),
            spheres=(sphere,),
            settings=RenderSettings(width=width, height=height, background=(-1.0, -1.0, -1.0)),
        )
        covered = int((oracle.render(scene)[..., 0] >= 0.0).sum())
        rho = math.sqrt(2) / 2
        ring = math.pi * (2 * largest * s * rho + rho * rho)
        assert abs(covered - math.pi * ab * s * s) <= ring, (covered, math.pi * ab * s * s, ring)


def test_transformed_sphere_normal_is_inverse_transpose():
    # Ellipsoid M = T·R·S(a,b,c): at the object point q on the unit-scaled surface, the world normal is
    # R·(x/a², y/b², z/c²) normalised; diffuse only: L = kd·cd/π·Lc·(n·l).
    a, b, c = 2.0, 1.0, 0.5
    rot = calibration.rotation((0.2, 0.9, 0.4), 40.0)
    m = calibration.translation((0.3, -0.2, 0.5)) @ rot @ calibration.scaling((a, b, c))
    material = PhongMaterial(ka=0.0, kd=0.8, ks=0.0, diffuse_color=(0.5, 0.6, 0.7))
    light_l = _unit([0.2, 0.3, 1.0])
    local = np.array([1.0, 0.5, c * math.sqrt(0.5)])  # in the scaled frame: x²/a² + y²/b² + z²/c² = 1, z > 0
    world = (m @ [*(local / np.array([a, b, c])), 1.0])[:3]  # its unit-sphere point mapped by M
    up_axis = rot[:3, :3] @ [0, 0, 1.0]
    normal = _unit(rot[:3, :3] @ (local / np.array([a * a, b * b, c * c])))
    light_l = _unit(normal + 0.3 * light_l)  # keep n·l comfortably positive
    scene = Scene(lights=(DirectionalLight(_tup(-light_l), (2, 2, 2)),), spheres=(Sphere(m, material),))
    got = _one_ray(scene, world + 5 * up_axis, world)
    expected = 0.8 * np.array([0.5, 0.6, 0.7]) / math.pi * 2.0 * (normal @ light_l)
    np.testing.assert_allclose(got, expected, atol=1e-9)


def test_smooth_mesh_normal_is_barycentric_interpolation_and_two_sided():
    # ref §7: n = normalise(w0·n0 + w1·n1 + w2·n2) at barycentrics (w0, w1, w2) = (0.5, 0.2, 0.3);
    # diffuse only, L = kd·cd/π·Lc·(n·l). Negating every vertex normal changes nothing (flip, ref §7).
    corners = np.array([(-1.0, -1.0, 0.0), (1.0, -1.0, 0.0), (0.0, 1.0, 0.0)])
    normals = np.array([_unit([-0.3, 0.0, 1.0]), _unit([0.3, 0.1, 1.0]), _unit([0.0, 0.4, 1.0])])
    weights = np.array([0.5, 0.2, 0.3])
    hit = weights @ corners
    n = _unit(weights @ normals)
    light_l = _unit([0.2, 0.3, 1.0])
    material = PhongMaterial(ka=0.0, kd=0.9, ks=0.0, diffuse_color=(0.4, 0.5, 0.6))
    expected = 0.9 * np.array([0.4, 0.5, 0.6]) / math.pi * 1.5 * (n @ light_l)
    for sign in (1.0, -1.0):
        mesh = TriangleMesh(
            points=corners, triangles=[(0, 1, 2)], normals=sign * normals, normal_indices=[(0, 1, 2)], material=material
        )
        scene = Scene(lights=(DirectionalLight(_tup(-light_l), (1.5, 1.5, 1.5)),), meshes=(mesh,))
        np.testing.assert_allclose(_one_ray(scene, hit + [0.0, 0.0, 3.0], hit), expected, atol=1e-9)


# ---------------------------------------------------------------------------------------------
# Reference §15 golden example and calibration scenes with closed forms


GOLDEN_PIXELS = {  # (col, row): ref §15 "expected (numpy)" column
    (32, 24): (0.39576, 0.18253, 0.09459),
    (27, 18): (0.87979, 0.59849, 0.48447),
    (26, 18): (0.69496, 0.41236, 0.29811),
    (40, 29): (0.17239, 0.08577, 0.04746),
    (10, 40): (0.10201, 0.11001, 0.11802),
    (0, 0): (0.1, 0.2, 0.3),
}


def test_povray_golden_example():
    # Reference §15 in model terms (see calibration.povray_golden for the camera conversion).
    image = oracle.render(calibration.povray_golden())
    for (col, row), expected in GOLDEN_PIXELS.items():
        np.testing.assert_allclose(
            image[row, col], expected, atol=GOLDEN_TABLE_TOLERANCE, err_msg=f"pixel {(col, row)}"
        )


def test_handedness_red_right_green_top():
    # Closed form: the red sphere's centre (1.5, 0, −5) projects to column W/2 + (1.5/5)·W/(2·tan 30°)
    # = 48.6 and row H/2 = 24; green (0, 1.5, −5) to row 24 − 0.3·W/(2·tan 30°) = 7.4. The centroid of a
    # projected sphere differs from the projected centre by well under a pixel here.
    image = oracle.render(calibration.handedness())
    r, g, b = image[..., 0], image[..., 1], image[..., 2]
    rows, cols = np.indices(r.shape) + 0.5
    red = r > 1.5 * (g + b)
    green = g > 1.5 * (r + b)
    scale = 64 / (2 * math.tan(math.radians(30)))
    assert red.sum() > 30 and green.sum() > 30
    assert cols[red].mean() == pytest.approx(32 + 0.3 * scale, abs=1.0)
    assert rows[red].mean() == pytest.approx(24, abs=1.0)
    assert rows[green].mean() == pytest.approx(24 - 0.3 * scale, abs=1.0)
    assert cols[green].mean() == pytest.approx(32, abs=1.0)


def test_pixel_centres_scene_needs_centre_sampling():
    # At pixel centres every pixel of the chosen columns/rows sees a strip (not the background);
    # at pixel corners (offset ½ px from the centres, the strips being 0.3 px wide) nothing is hit.
    scene = calibration.pixel_centres()
    width, height = calibration.PIXEL_CENTRES_SIZE
    background = np.array(scene.settings.background)
    image = oracle.render(scene)
    is_background = np.all(np.isclose(image, background, atol=EXACT), axis=2)
    covered = np.zeros((height, width), dtype=bool)
    covered[:, list(calibration.PIXEL_CENTRES_COLUMNS)] = True
    covered[list(calibration.PIXEL_CENTRES_ROWS), :] = True
    np.testing.assert_array_equal(~is_background, covered)
    cols, rows = np.meshgrid(np.arange(width, dtype=np.float64), np.arange(height, dtype=np.float64))
    o, d = oracle.camera_rays(scene.camera, width, height, cols, rows)
    corners = oracle.trace_rays(scene, o, d)
    np.testing.assert_allclose(corners, np.broadcast_to(background, corners.shape), atol=EXACT)


def test_back_faces_scene_is_ambient_only():
    # Light behind an open patch seen from its back: viewer-facing n has n·l < 0, so every patch pixel
    # is exactly ka·cd·La (no diffuse, no highlight).
    scene = calibration.back_faces()
    material = scene.meshes[0].material
    expected = material.ka * np.array(material.diffuse_color) * np.array(scene.ambient.color)
    for variant in (scene, calibration.classic_variant(scene)):
        image = oracle.render(variant)
        patch = ~np.all(np.isclose(image, scene.settings.background, atol=EXACT), axis=2)
        assert patch.sum() > 500
        np.testing.assert_allclose(image[patch], np.broadcast_to(expected, image[patch].shape), atol=EXACT)


def test_ambient_only_scene():
    # No lights: every hit pixel is ka·cd·La for its material; the set of values is exactly those.
    scene = calibration.ambient_only()
    la = np.array(scene.ambient.color)
    materials = [s.material for s in scene.spheres] + [m.material for m in scene.meshes]
    allowed = [m.ka * np.array(m.diffuse_color) * la for m in materials] + [np.array(scene.settings.background)]
    pixels = oracle.render(scene).reshape(-1, 3)
    distance = np.min([np.abs(pixels - a).max(axis=1) for a in allowed], axis=0)
    assert distance.max() < EXACT


def test_huge_exponent_peak_pixel():
    # Light at the eye, sphere on the axis of an odd image: the centre pixel sees n = l = wo, so
    # L = ka·cd·La + (kd·cd/π + ks·cs)·L in both conventions ((r·wo)^1e4 = 1 at the peak).
    scene = calibration.huge_exponent()
    m = scene.spheres[0].material
    cd, cs = np.array(m.diffuse_color), np.array(m.specular_color)
    light = np.array(scene.lights[0].color)
    expected = m.ka * cd * np.array(scene.ambient.color) + (m.kd * cd / math.pi + m.ks * cs) * light
    for variant in (scene, calibration.classic_variant(scene)):
        image = oracle.render(variant)
        assert np.isfinite(image).all()
        np.testing.assert_allclose(image[18, 24], expected, atol=1e-9)
        # One pixel off the peak the highlight is gone: (r·wo)^1e4 < 1e-6.
        neighbour_without_highlight = image[18, 25] - m.ks * cs * light
        assert np.all(neighbour_without_highlight < 0)


# ---------------------------------------------------------------------------------------------
# The catalogue as a whole


def _render_shifted(scene: Scene, dx: float, dy: float) -> np.ndarray:
    """The oracle's image with every sample position moved by (dx, dy) pixels."""
    st = scene.settings
    offsets, weights = oracle.pixel_samples(st.samples, st.sample_pattern)
    cols, rows = np.meshgrid(np.arange(st.width, dtype=np.float64), np.arange(st.height, dtype=np.float64))
    sx = cols[..., None] + offsets[:, 0] + dx
    sy = rows[..., None] + offsets[:, 1] + dy
    o, d = oracle.camera_rays(scene.camera, st.width, st.height, sx, sy)
    radiance = oracle.trace_rays(scene, o, d).reshape(st.height, st.width, len(weights), 3)
    return np.einsum("hwkc,k->hwc", radiance, weights)


REQUIRED_SCENES = {
    "handedness", "pixel_centres", "point_light", "directional_light", "rect_area_light", "sphere_area_light",
    "ambient_only", "transformed_spheres", "smooth_mesh", "flat_mesh", "back_faces", "shadows_two_lights",
    "coloured_specular", "fade", "orthographic", "aa_grid", "aa_povray", "classic_convention", "exponent_zero",
    "huge_exponent",
}  # fmt: skip


def test_catalogue_has_required_scenes():
    assert REQUIRED_SCENES <= set(calibration.SCENES)
    assert calibration.SCENES["classic_convention"]().settings.specular == "povray-classic"
    assert calibration.SCENES["aa_grid"]().settings.sample_pattern == "grid"
    assert calibration.SCENES["aa_povray"]().settings.sample_pattern == "povray-am1"


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(calibration.SCENES))
def test_calibration_scene_is_well_posed(name):
    # Small, deterministic, finite, bounded (< 4, ≥ 0) in both conventions, and — except for the scene
    # built on pixel centres — no discontinuity within COINCIDENCE_SHIFT_PX of any sample position.
    build = calibration.SCENES[name]
    scene = build()
    assert scene == build()
    assert 48 <= scene.settings.width <= 96 and 36 <= scene.settings.height <= 72
    for variant in (scene, calibration.classic_variant(scene)):
        assert variant.settings.specular in ("seed", "povray-classic")
        image = oracle.render(variant)
        assert np.isfinite(image).all()
        assert image.min() >= 0.0 and image.max() < CALIBRATION_MAX_VALUE
        assert (np.ptp(image.reshape(-1, 3), axis=0) > 0.05).any()  # not a blank picture
        if name == "pixel_centres":
            continue
        for dx, dy in ((COINCIDENCE_SHIFT_PX, COINCIDENCE_SHIFT_PX), (-COINCIDENCE_SHIFT_PX, COINCIDENCE_SHIFT_PX)):
            jump = np.abs(_render_shifted(variant, dx, dy) - image).max(axis=2)
            assert jump.max() <= COINCIDENCE_JUMP, (
                f"{name}: discontinuity near a sample at pixels {np.argwhere(jump > COINCIDENCE_JUMP)}"
            )


@pytest.mark.parametrize("name", sorted(calibration.SCENES))
def test_calibration_scene_is_a_valid_model_scene(name):
    # The backends' public render() validates its input; every calibration scene must pass.
    assert validate(calibration.SCENES[name]()) == []
