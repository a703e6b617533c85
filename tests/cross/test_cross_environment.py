# SPDX-License-Identifier: Apache-2.0
"""The environment (model ``Environment``, a textured DomeLight) in POV-Ray: the compiler's
``sky_sphere { pigment { image_map { exr … map_type 1 interpolate 2 } } emission … matrix … }``
against the native tracer in POV-Ray's numerics, camera rays that miss and a mirror sphere
reflecting it, turned domes, both mappings (the exact one carries it in pass 0 only). The native
lookup itself: tests/native/test_environment.py; the measured semantics: ref §19."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from phongscene import compile_pov, render
from phongscene.backends.povray import pass_scenes
from phongscene.comparison import compare
from phongscene.scene import Camera, Environment, PhongMaterial, PointLight, RenderSettings, Scene, Sphere, Texture

MIRROR = PhongMaterial(ka=0.0, kd=0.0, ks=0.0, exponent=1.0, diffuse_color=(0.0, 0.0, 0.0), kr=1.0)
# A lit, partly mirroring ball beside the chrome one: the environment adds to Phong shading.
SATIN = PhongMaterial(ka=0.2, kd=0.5, ks=0.4, exponent=20.0, diffuse_color=(0.7, 0.3, 0.2), kr=0.4)


def _gradient(w: int, h: int) -> np.ndarray:
    """Smooth in both directions, different in every channel (a texel misplaced by one shows)."""
    u = (np.arange(w) + 0.5) / w
    v = (np.arange(h) + 0.5) / h
    r = 0.2 + 0.8 * u[None, :] * np.ones((h, 1))
    g = 0.1 + 0.9 * (1 - v)[:, None] * np.ones((1, w))
    b = 0.5 + 0.5 * np.sin(2 * np.pi * u)[None, :] * np.cos(np.pi * (v - 0.5))[:, None]
    return np.stack([r, g, b], -1).astype(np.float32)


def _checker(w: int, h: int, n: int = 8) -> np.ndarray:
    """Hard edges: a lookup off by a fraction of a texel shows as whole failing pixels."""
    c = ((np.arange(w)[None, :] * n // w + np.arange(h)[:, None] * (n // 2) // h) % 2).astype(np.float32)
    return np.stack([0.1 + 0.9 * c, 0.3 + 0.0 * c, 1.0 - 0.8 * c], -1).astype(np.float32)


def _turn_y(degrees: float) -> np.ndarray:
    a = math.radians(degrees)
    return np.array([[math.cos(a), 0.0, math.sin(a)], [0.0, 1.0, 0.0], [-math.sin(a), 0.0, math.cos(a)]])


def _scene(image: np.ndarray, world_from_dome: np.ndarray, forward, mapping: str) -> Scene:
    f = np.asarray(forward, dtype=np.float64)
    f /= np.linalg.norm(f)
    up = np.array([0.0, 1.0, 0.0]) - f[1] * f
    camera = Camera(
        position=(0.0, 0.0, 0.0), forward=tuple(f), up=tuple(up / np.linalg.norm(up)), horizontal_fov_deg=100.0
    )
    return Scene(
        camera=camera,
        # Ahead of the camera wherever it looks: the chrome ball, and the satin one beside it.
        spheres=(
            Sphere.at(tuple(3.0 * f), 1.0, MIRROR),
            Sphere.at(tuple(2.5 * f + 1.8 * np.cross(f, up / np.linalg.norm(up)) - 0.6 * up), 0.5, SATIN),
        ),
        lights=(PointLight((5.0, 5.0, 5.0), (1.0, 0.9, 0.8)), PointLight((-4.0, 2.0, 1.0), (0.3, 0.4, 0.6))),
        environment=Environment(Texture(image), scale=(1.5, 1.0, 0.75), dome_from_world=world_from_dome.T),
        settings=RenderSettings(
            width=64,
            height=48,
            numerics="povray",  # as `phongscene diff` renders the native image
            specular="povray-classic" if mapping == "classic" else "seed",
        ),
    )


pytestmark = pytest.mark.povray


@pytest.mark.parametrize("mapping", ["exact", "classic"])
@pytest.mark.parametrize(
    ("image", "turn", "forward"),
    [
        pytest.param(_gradient(64, 32), 0.0, (0.0, 0.0, -1.0), id="gradient-ahead"),
        pytest.param(_checker(64, 32), 30.0, (0.0, 0.0, -1.0), id="checker-turned"),
        # Up at the pole (where POV-Ray's lookup repeats the rows; the native one in POV-Ray
        # numerics too), a map of odd sides, a turned dome.
        pytest.param(_gradient(37, 19), 30.0, (0.3, 0.8, 0.5), id="odd-up-turned"),
    ],
)
def test_povray_sky_sphere_is_the_native_environment(mapping, image, turn, forward):
    scene = _scene(image, _turn_y(turn), forward, mapping)
    sdl = compile_pov(scene, mapping=mapping)
    assert sdl.count("sky_sphere") == 1 and "map_type 1" in sdl
    result = compare(render(scene, "povray", mapping=mapping), render(scene, "native"))
    assert result.ok, result


def test_sky_sphere_only_with_an_environment_and_in_pass_zero():
    scene = _scene(_gradient(8, 4), np.eye(3), (0.0, 0.0, -1.0), "exact")
    assert "sky_sphere {" not in compile_pov(dataclasses.replace(scene, environment=None), mapping="exact")
    sdl = compile_pov(scene, mapping="exact")
    # The exact mapping renders one pass per light: the sky, like the background, in pass 0 only.
    case_one = sdl.index("#case (1)")
    assert sdl.index("sky_sphere {") < case_one and "sky_sphere {" not in sdl[case_one:]
    passes = pass_scenes(scene, "exact")
    assert passes[0].environment is scene.environment and all(p.environment is None for p in passes[1:])


# Texel (i, j) of a 16×8 map holds (i, j, i²): a blend of two columns tells which two they are.
W, H = 16, 8
INDEX_MAP = np.stack(
    np.broadcast_arrays(
        np.arange(W, dtype=np.float32)[None, :],
        np.arange(H, dtype=np.float32)[:, None],
        np.arange(W, dtype=np.float32)[None, :] ** 2,
    ),
    axis=-1,
).astype(np.float32)
# (i, j, i²) values are small integers and halves: exact in half floats (POV-Ray's EXR output).
INDEX_TOLERANCE = 1e-6


@pytest.mark.parametrize(
    ("direction", "seen"),
    [
        pytest.param((1.0, 0.0, 0.0), (7.5, 3.5, 112.5), id="+X-seam-columns-15-0"),
        pytest.param((0.0, 0.0, 1.0), (3.5, 3.5, 12.5), id="+Z-columns-3-4"),
        pytest.param((-1.0, 0.0, 0.0), (7.5, 3.5, 56.5), id="-X-columns-7-8"),
        pytest.param((0.0, 0.0, -1.0), (11.5, 3.5, 132.5), id="-Z-columns-11-12"),
        pytest.param((0.0, 1.0, 0.0), (7.5, 3.5, 112.5), id="+Y-rows-0-7"),
        pytest.param((0.0, -1.0, 0.0), (7.5, 3.5, 112.5), id="-Y-rows-7-0"),
    ],
)
def test_povray_spherical_map_as_measured(direction, seen):
    """POV-Ray's own map_type 1 (ref §19), through an environment whose frame makes the SDL's
    matrix the identity (dome_from_world = Pᵀ): u from +X towards +Z, and at the poles the rows
    repeat (top and bottom blend) at the seam's longitude."""
    to_povray = np.array([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
    d = np.asarray(direction)
    up = np.array([1.0, 0.0, 0.0]) if abs(d[1]) > 0.5 else np.array([0.0, 1.0, 0.0])
    scene = Scene(
        camera=Camera(position=(0.0, 0.0, 0.0), forward=direction, up=tuple(up), horizontal_fov_deg=1e-3),
        environment=Environment(Texture(INDEX_MAP), dome_from_world=to_povray.T),
        settings=RenderSettings(width=1, height=1),
    )
    sdl = compile_pov(scene, mapping="classic")
    assert "matrix <1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0>" in sdl.replace("-0.0", "0.0")
    np.testing.assert_allclose(
        render(scene, "povray", mapping="classic", explain=False)[0, 0], seen, atol=INDEX_TOLERANCE
    )
