# SPDX-License-Identifier: Apache-2.0
"""The environment (a textured DomeLight, ``phongscene.scene.Environment``) in the native tracer:
camera rays that miss see the lat-long texel UsdLux's layout puts along their direction (+Z the
centre column, +X a quarter from the left, +Y the top row), in both numerics; the dome's frame
turns it; a mirror sphere shows it where the mirror law says; validation. POV-Ray's image of the
same: tests/cross/test_cross_environment.py."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from phongscene.backends import native
from phongscene.scene import Camera, Environment, PhongMaterial, RenderSettings, Scene, Sphere, Texture
from phongscene.validate import validate

W, H = 16, 8
# Texel (column i, row j) holds (i, j, 1 + i + W·j): every texel tells where it is, and every
# value is a small integer, exact in float32 and in half floats (POV-Ray numerics).
IMAGE = np.stack(
    np.broadcast_arrays(
        np.arange(W, dtype=np.float32)[None, :],
        np.arange(H, dtype=np.float32)[:, None],
        1.0 + np.arange(W, dtype=np.float32)[None, :] + W * np.arange(H, dtype=np.float32)[:, None],
    ),
    axis=-1,
).astype(np.float32)
NUMERICS = ("scale-invariant", "povray")
# A texel centre seen through a 1-pixel camera: the lookup's weights are 1 and 0 up to the
# rounding of atan2/asin and the direction (~1e-15 relative), far below float32's 2^-24 of the
# stored pixel; 1e-5 on values up to 129 is a few float32 ulps.
TEXEL_TOLERANCE = 1e-5
PURE_MIRROR = PhongMaterial(ka=0.0, kd=0.0, ks=0.0, exponent=1.0, diffuse_color=(0.0, 0.0, 0.0), kr=1.0)


def _direction(u: float, v: float) -> np.ndarray:
    """The world direction of lat-long coordinates (u, v) (v = 1 the top edge): longitude
    φ = π(1 − 2u) from +Z towards +X, latitude θ = π(v − ½)."""
    phi, theta = math.pi * (1.0 - 2.0 * u), math.pi * (v - 0.5)
    return np.array([math.cos(theta) * math.sin(phi), math.sin(theta), math.cos(theta) * math.cos(phi)])


def _texel_direction(i: int, j: int) -> np.ndarray:
    return _direction((i + 0.5) / W, 1.0 - (j + 0.5) / H)


def _reference(d: np.ndarray, image: np.ndarray = IMAGE) -> np.ndarray:
    """The lat-long lookup written out: u = ½ − atan2(x, z)/2π, v = ½ + asin(y)/π, bilinear between
    texel centres, repeating around the longitude, clamped at the poles."""
    d = d / np.linalg.norm(d)
    h, w = image.shape[:2]
    u = 0.5 - math.atan2(d[0], d[2]) / (2 * math.pi)
    v = 0.5 + math.asin(d[1]) / math.pi
    x, y = u * w - 0.5, (1 - v) * h - 0.5
    x0, y0 = math.floor(x), math.floor(y)
    fx, fy = x - x0, y - y0

    def texel(i, j):
        return image[min(max(j, 0), h - 1), i % w].astype(np.float64)

    top = texel(x0, y0) * (1 - fx) + texel(x0 + 1, y0) * fx
    bottom = texel(x0, y0 + 1) * (1 - fx) + texel(x0 + 1, y0 + 1) * fx
    return top * (1 - fy) + bottom * fy


def _look(direction, environment: Environment, numerics: str, up=(0.0, 1.0, 0.0)) -> np.ndarray:
    """The one pixel a narrow camera at the origin sees along ``direction`` (nothing to hit)."""
    d = np.asarray(direction, dtype=np.float64)
    up = np.asarray(up, dtype=np.float64)
    if abs(np.dot(d, up)) > 0.9:
        up = np.array([1.0, 0.0, 0.0])
    up = up - np.dot(up, d) * d
    camera = Camera(
        position=(0.0, 0.0, 0.0), forward=tuple(d), up=tuple(up / np.linalg.norm(up)), horizontal_fov_deg=1e-3
    )
    scene = Scene(camera=camera, environment=environment, settings=RenderSettings(width=1, height=1, numerics=numerics))
    return native.render(scene)[0, 0]


@pytest.mark.parametrize("numerics", NUMERICS)
@pytest.mark.parametrize(
    ("direction", "texel"),
    [
        pytest.param((0.0, 0.0, 1.0), None, id="+Z-centre"),
        pytest.param((1.0, 0.0, 0.0), None, id="+X-quarter"),
        pytest.param((-1.0, 0.0, 0.0), None, id="-X-three-quarters"),
        pytest.param(None, (5, 2), id="texel-5-2"),
        pytest.param(None, (12, 6), id="texel-12-6"),
        pytest.param(None, (0, 3), id="texel-0-3-left-edge"),
        pytest.param(None, (15, 4), id="texel-15-4-right-edge"),
    ],
)
def test_environment_camera_rays_see_latlong_texel(numerics, direction, texel):
    """UsdLux's lat-long layout (OpenEXR's): +Z is the centre of the image (u = ½: between
    columns 7 and 8 at latitude 0: rows 3 and 4), +X a quarter from the left (u = ¼: between
    columns 3 and 4), −X three quarters (u = ¾); a texel centre's direction sees that texel."""
    environment = Environment(Texture(IMAGE))
    if texel is not None:
        i, j = texel
        expected = IMAGE[j, i]
        seen = _look(_texel_direction(i, j), environment, numerics)
    else:
        expected = {(0.0, 0.0, 1.0): (7.5, 3.5), (1.0, 0.0, 0.0): (3.5, 3.5), (-1.0, 0.0, 0.0): (11.5, 3.5)}[direction]
        seen = _look(direction, environment, numerics)[:2]
    np.testing.assert_allclose(seen, expected, atol=TEXEL_TOLERANCE)


@pytest.mark.parametrize("numerics", NUMERICS)
def test_environment_poles_top_row_up(numerics):
    """The top row is +Y, the bottom row −Y (asked at the rows' own centre latitudes, where both
    numerics agree; nearer the poles they differ: below)."""
    environment = Environment(Texture(IMAGE))
    np.testing.assert_allclose(_look(_texel_direction(6, 0), environment, numerics), IMAGE[0, 6], atol=TEXEL_TOLERANCE)
    np.testing.assert_allclose(
        _look(_texel_direction(6, H - 1), environment, numerics), IMAGE[H - 1, 6], atol=TEXEL_TOLERANCE
    )


def test_environment_between_texels_is_the_bilinear_reference():
    """Away from texel centres: the bilinear blend of the four around, as _reference writes it."""
    environment = Environment(Texture(IMAGE))
    rng = np.random.default_rng(7)
    for _ in range(20):
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        for numerics in NUMERICS:
            if numerics == "povray" and abs(d[1]) > math.cos(math.pi / H / 2):
                continue  # within half a texel of a pole POV-Ray repeats the image vertically
            np.testing.assert_allclose(_look(d, environment, numerics), _reference(d), atol=TEXEL_TOLERANCE)


def test_environment_povray_numerics_repeat_across_the_pole():
    """POV-Ray's lookup wraps the row index too: straight up it blends the top row with the bottom
    one, half and half (docs/povray-3.7-semantics.md §19); the default clamps to the top row."""
    environment = Environment(Texture(IMAGE))
    up = (0.0, 1.0, 0.0)
    np.testing.assert_allclose(_look(up, environment, "scale-invariant")[1], 0.0, atol=TEXEL_TOLERANCE)
    np.testing.assert_allclose(_look(up, environment, "povray")[1], (0 + H - 1) / 2, atol=TEXEL_TOLERANCE)


@pytest.mark.parametrize("numerics", NUMERICS)
def test_environment_scale_and_dome_rotation(numerics):
    """The scale multiplies every channel; a dome turned by +90° about +Y (its +Z now along world
    +X) shows its centre column along world +X."""
    quarter = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])  # world_from_dome
    environment = Environment(Texture(IMAGE), scale=(2.0, 0.5, 1.0), dome_from_world=quarter.T)
    seen = _look((1.0, 0.0, 0.0), environment, numerics)
    np.testing.assert_allclose(seen[:2], (7.5 * 2.0, 3.5 * 0.5), atol=TEXEL_TOLERANCE)


@pytest.mark.parametrize("numerics", NUMERICS)
def test_environment_in_a_mirror_sphere_follows_the_mirror_law(numerics):
    """A pure mirror sphere of radius 1 at (0, 0, −4), seen from the origin: each pixel shows the
    environment along r = d − 2(d·n)n at the point the pixel's ray hits (computed here, in
    closed form, from the camera's own rays)."""
    width = height = 9
    camera = Camera(position=(0.0, 0.0, 0.0), forward=(0.0, 0.0, -1.0), up=(0.0, 1.0, 0.0), horizontal_fov_deg=20.0)
    centre = np.array([0.0, 0.0, -4.0])
    scene = Scene(
        camera=camera,
        spheres=(Sphere.at(tuple(centre), 1.0, PURE_MIRROR),),
        environment=Environment(Texture(IMAGE)),
        settings=RenderSettings(width=width, height=height, numerics=numerics),
    )
    image = native.render(scene)
    half = math.tan(math.radians(10.0))
    checked = 0
    for j in range(height):
        for i in range(width):
            # The pixel centre's ray (POV-Ray's camera: right −x·w/h for a right-handed scene).
            x = ((i + 0.5) / width - 0.5) * 2 * half
            y = (0.5 - (j + 0.5) / height) * 2 * half
            d = np.array([x, y, -1.0])
            d /= np.linalg.norm(d)
            b = np.dot(d, centre)
            disc = b * b - (np.dot(centre, centre) - 1.0)
            if disc <= 0:
                continue
            p = (b - math.sqrt(disc)) * d
            n = p - centre
            r = d - 2 * np.dot(d, n) * n
            if numerics == "povray" and abs(r[1]) > math.cos(math.pi / H / 2):
                continue  # POV-Ray's pole (see above)
            np.testing.assert_allclose(image[j, i], _reference(r), rtol=1e-6, atol=TEXEL_TOLERANCE)
            checked += 1
    assert checked > 20
    # The centre pixel looks straight back at the camera: +Z, the image's centre.
    np.testing.assert_allclose(image[4, 4][:2], (7.5, 3.5), atol=TEXEL_TOLERANCE)


def test_environment_replaces_the_background_only_where_rays_miss():
    """A hit is shaded as before; a miss sees the environment, not the background colour."""
    settings = RenderSettings(width=16, height=16, background=(0.3, 0.2, 0.1))
    camera = Camera(position=(0.0, 0.0, 0.0), forward=(0.0, 0.0, -1.0), up=(0.0, 1.0, 0.0), horizontal_fov_deg=40.0)
    plain = Scene(camera=camera, spheres=(Sphere.at((0.0, 0.0, -4.0), 0.5),), settings=settings)
    with_environment = dataclasses.replace(plain, environment=Environment(Texture(IMAGE)))
    a, b = native.render(plain), native.render(with_environment)
    background = np.all(a == np.float32(settings.background), axis=2)
    assert background.sum() > 100 and (~background).sum() > 10
    np.testing.assert_array_equal(a[~background], b[~background])
    assert np.all(b[background][:, 2] >= 1.0)  # the environment's blue channel is 1 + i + W·j


def test_environment_validation():
    bad = Environment(
        Texture(-IMAGE), scale=(1.0, -1.0, 1.0), dome_from_world=np.diag([2.0, 1.0, 1.0]), source="/World/Dome"
    )
    problems = validate(Scene(environment=bad))
    fields = sorted(p.attribute for p in problems)
    assert fields == ["dome_from_world", "image", "scale"], problems
    assert all(p.prim in ("/World/Dome", "") for p in problems)
    wrong = validate(Scene(environment="a dome"))  # type: ignore[arg-type]
    assert [p.attribute for p in wrong] == ["environment"]


def test_image_checks_do_not_count_the_environment_as_objects():
    """The image diagnostics tell objects from misses by the background colour; with an
    environment every pixel differs from it, which says nothing about objects in view."""
    from phongscene.diagnostics import explain_image

    camera = Camera(position=(0.0, 0.0, 0.0), forward=(0.0, 0.0, 1.0), up=(0.0, 1.0, 0.0))
    scene = Scene(
        camera=camera,
        spheres=(Sphere.at((0.0, 0.0, -4.0), 0.5),),  # behind the camera
        environment=Environment(Texture(IMAGE)),
        settings=RenderSettings(width=8, height=6),
    )
    warnings = explain_image(scene, native.render(scene))
    assert len(warnings) == 1 and warnings[0].startswith("nothing in view:"), warnings
