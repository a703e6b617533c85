# SPDX-License-Identifier: Apache-2.0
"""How the C++ scene holds textures (bindings.cpp ``set_textures``): the model's arrays without
a copy (a scene's textures can be gigabytes), or, in POV-Ray's numerics, a copy rounded to half
floats exactly as numpy's ``astype(float16)`` rounds (POV-Ray reads the texels from a half-float
EXR)."""

from __future__ import annotations

import gc
import sys

import numpy as np

from phongscene.backends import native
from phongscene.backends.native import _native
from phongscene.scene import PhongMaterial, Scene, Texture, TriangleMesh

HALF_MAX = 65504.0
HALF_MIN_NORMAL = 2.0**-14
HALF_MIN_SUBNORMAL = 2.0**-24


def numpy_half(values: np.ndarray) -> np.ndarray:
    return values.astype(np.float16).astype(np.float32)


def test_rounding_to_half_is_numpys_on_random_floats_of_every_magnitude():
    rng = np.random.default_rng(3)
    bits = rng.integers(0, 2**32, size=200_000, dtype=np.uint64).astype(np.uint32)
    values = bits.view(np.float32)
    values = values[np.isfinite(values)]
    with np.errstate(over="ignore"):
        expected = numpy_half(values)
    assert np.array_equal(_native.round_to_half(values), expected)


def test_rounding_to_half_breaks_ties_to_even_and_meets_the_range_limits():
    # Halfway between neighbouring halves (normal and subnormal), one float either side of
    # those midpoints, the range's ends and the overflow threshold 65520 (halfway to 65536).
    halves = np.arange(0, 0x7C00, dtype=np.uint16).view(np.float16).astype(np.float64)
    midpoints = (halves[:-1] + halves[1:]) / 2
    edges = np.array(
        [0.0, HALF_MIN_SUBNORMAL / 2, HALF_MIN_SUBNORMAL, HALF_MIN_NORMAL, HALF_MAX, 65519.996, 65520.0, 1e6, 3e38]
    )
    base = np.concatenate([midpoints, edges]).astype(np.float32)
    values = np.concatenate(
        [base, np.nextafter(base, np.float32(np.inf)), np.nextafter(base, np.float32(0)), -base, [-0.0]]
    ).astype(np.float32)
    with np.errstate(over="ignore"):
        expected = numpy_half(values)
    got = _native.round_to_half(values)
    assert np.array_equal(got, expected)
    assert np.array_equal(np.signbit(got), np.signbit(expected))  # -0 stays -0
    assert np.isinf(got[values == 65520.0]).all() and (got[values == np.float32(65519.996)] == HALF_MAX).all()


def _textured_quad(image: np.ndarray) -> Scene:
    material = PhongMaterial(diffuse_texture=Texture(image=image))
    mesh = TriangleMesh(
        points=[(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)],
        triangles=[(0, 1, 2), (0, 2, 3)],
        uvs=[(0, 0), (1, 0), (1, 1), (0, 1)],
        uv_indices=[(0, 1, 2), (0, 2, 3)],
        material=material,
    )
    return Scene(meshes=(mesh,))


def test_the_scene_holds_the_models_texture_array_instead_of_copying_it():
    image = np.random.default_rng(5).random((64, 32, 3)).astype(np.float32)
    scene = _textured_quad(image)
    held = scene.meshes[0].material.diffuse_texture.image
    before = sys.getrefcount(held)
    built = native.build(scene)
    assert sys.getrefcount(held) > before  # held by the C++ texture (nanobind's references)
    del built
    gc.collect()
    assert sys.getrefcount(held) == before


def test_half_texels_are_a_rounded_copy_that_holds_nothing():
    image = np.random.default_rng(5).random((64, 32, 3)).astype(np.float32)
    scene = _textured_quad(image)
    held = scene.meshes[0].material.diffuse_texture.image
    before = sys.getrefcount(held)
    textures = native.texture_arrays(scene, half_texels=True)
    assert textures["half_texels"] is True and textures["images"][0] is held  # rounded in C++
    built = _native.Scene(**native.scene_arrays(scene))
    built.set_textures(**textures)
    del textures
    gc.collect()
    assert sys.getrefcount(held) == before  # the rounded copy is the scene's own
    del built


def test_the_corner_uvs_are_held_not_copied_and_filled_mesh_by_mesh():
    image = np.random.default_rng(5).random((8, 8, 3)).astype(np.float32)
    quad = _textured_quad(image).meshes[0]
    plain = TriangleMesh(points=quad.points + 2.0, triangles=quad.triangles)  # no uvs: zeros
    scene = Scene(meshes=(quad, plain, quad))
    textures = native.texture_arrays(scene)
    corner_uv = textures["corner_uv"]
    expected = np.concatenate([quad.uvs[quad.uv_indices], np.zeros((2, 3, 2)), quad.uvs[quad.uv_indices]])
    assert np.array_equal(corner_uv, expected)
    before = sys.getrefcount(corner_uv)
    built = _native.Scene(**native.scene_arrays(scene))
    built.set_textures(**textures)
    assert sys.getrefcount(corner_uv) > before  # held by the C++ scene
    del built
    gc.collect()
    assert sys.getrefcount(corner_uv) == before
