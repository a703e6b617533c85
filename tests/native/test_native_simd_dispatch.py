# SPDX-License-Identifier: Apache-2.0
"""The BVH walk's two SIMD paths (backends/native/src/simd_dispatch.hpp): the 8-wide AVX2 walk
(bvh8.hpp), chosen at run time where the CPU has AVX2, and the portable 4-wide SSE2 walk, forced
with PHONGSCENE_NATIVE_SIMD=sse2. Their float slab tests do the same operations per lane and both
answers are independent of the visiting order, so every image and every hit must be the same
bit for bit; each path must also equal brute force on rays at the edge of the float arithmetic."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from test_native_bvh4 import T_MINS, assert_equals_brute_force, float32_triangles, mesh_scene, unit

from phongscene.backends import native
from phongscene.scene import PhongMaterial, PointLight, RenderSettings, Scene, Sphere, TriangleMesh
from support import calibration

SIMD = "PHONGSCENE_NATIVE_SIMD"


def avx2_here() -> bool:
    """Whether this CPU takes the AVX2 path by default (its walk is 8 wide)."""
    return native.build(mesh_scene(float32_triangles(np.random.default_rng(0), 4, 1.0, 0.0))).walk_width == 8


needs_avx2 = pytest.mark.skipif(not avx2_here(), reason="this CPU has no AVX2: only the SSE2 path runs")


def built_with(monkeypatch, scene: Scene, simd: str):
    monkeypatch.setenv(SIMD, simd)
    built = native.build(scene)
    monkeypatch.delenv(SIMD)
    return built


def render_with(monkeypatch, scene: Scene, simd: str) -> np.ndarray:
    monkeypatch.setenv(SIMD, simd)
    image = native.render(scene, scene.settings)
    monkeypatch.delenv(SIMD)
    return image


def crowd() -> Scene:
    """Spheres and a few thousand small triangles in front of the camera, two point lights: a deep
    tree whose 8-wide nodes are full (the 4-wide tree's are a different grouping of the same leaves)."""
    rng = np.random.default_rng(25)
    corners = float32_triangles(rng, 3000, 0.6, 0.0)
    points = corners.reshape(-1, 3)
    grey = PhongMaterial(ka=0.1, kd=0.7, ks=0.4, exponent=30.0, diffuse_color=(0.7, 0.7, 0.7))
    mesh = TriangleMesh(points=points, triangles=np.arange(len(points)).reshape(-1, 3), material=grey)
    spheres = tuple(Sphere.at(tuple(rng.uniform(-1, 1, 3)), float(rng.uniform(0.05, 0.2)), grey) for _ in range(40))
    return Scene(
        camera=calibration.look_at((0.0, 0.5, 4.0), (0.0, 0.0, 0.0)),
        lights=(PointLight((3.0, 4.0, 3.0), (1.0, 1.0, 1.0)), PointLight((-4.0, 2.0, 1.0), (0.5, 0.6, 0.7))),
        spheres=spheres,
        meshes=(mesh,),
        settings=RenderSettings(width=96, height=72),
    )


def test_the_environment_variable_chooses_the_path(monkeypatch):
    scene = crowd()
    assert built_with(monkeypatch, scene, "sse2").walk_width == 4
    assert built_with(monkeypatch, scene, "auto").walk_width == (8 if avx2_here() else 4)


def test_an_unknown_path_is_an_error_naming_the_variable(monkeypatch):
    with pytest.raises(ValueError, match="PHONGSCENE_NATIVE_SIMD=avx9"):
        built_with(monkeypatch, crowd(), "avx9")


@needs_avx2
@pytest.mark.parametrize("name", ["crowd", "rect_area_light", "smooth_mesh", "transformed_spheres", "far_from_origin"])
def test_both_paths_give_the_same_image(monkeypatch, name):
    scene = crowd() if name == "crowd" else calibration.SCENES[name]()
    avx2 = built_with(monkeypatch, scene, "avx2")
    assert avx2.walk_width == 8
    sse2, wide = render_with(monkeypatch, scene, "sse2"), render_with(monkeypatch, scene, "avx2")
    assert sse2.tobytes() == wide.tobytes()
    assert np.count_nonzero(sse2) > 0  # the scene is lit: the comparison sees something


@needs_avx2
@pytest.mark.parametrize("path", sorted(T_MINS))
def test_both_paths_give_the_same_hits_and_equal_brute_force(monkeypatch, path):
    scene = crowd()
    rng = np.random.default_rng(7)
    n = 4000
    origins = np.tile([0.0, 0.5, 4.0], (n, 1)) + rng.normal(scale=0.3, size=(n, 3))
    dirs = unit(rng.uniform(-0.4, 0.4, size=(n, 3)) - origins / 4.0)
    sse2, avx2 = built_with(monkeypatch, scene, "sse2"), built_with(monkeypatch, scene, "avx2")
    for t_a, t_b in zip(sse2.intersect(origins, dirs, T_MINS[path]), avx2.intersect(origins, dirs, T_MINS[path])):
        assert np.array_equal(t_a, t_b)
    count = assert_equals_brute_force(avx2, origins, dirs, T_MINS[path])
    assert np.count_nonzero(count) > n // 4  # many rays hit something


def test_thread_count_does_not_change_a_bit_on_either_path(monkeypatch):
    scene = crowd()
    for simd in ("sse2", "auto"):
        images = [
            render_with(
                monkeypatch, dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, threads=t)), simd
            )
            for t in (1, 2)
        ]
        assert images[0].tobytes() == images[1].tobytes()
