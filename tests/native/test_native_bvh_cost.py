# SPDX-License-Identifier: Apache-2.0
"""The SAH's traversal cost by scene size (backends/native/src/bvh.cpp): a small scene's tree is
built for the fastest walk (a node visit costs about one primitive test), so S1's four spheres
are four leaves (at cost 2 they were two pairs, each ray meeting a pair testing both: S1 rendered
with 5 % more instructions); a large mesh keeps the smaller tree. Hits do not depend on the
tree: brute force agrees on both sides of the size threshold. Where the float prefilter tests a
leaf's triangles eight to an AVX pass (triangles with float corners on the AVX2 walk), nodes of up
to eight triangles alone become leaves: such a leaf costs one pass whatever its size."""

from __future__ import annotations

import dataclasses

import numpy as np
from test_native_simd_dispatch import built_with, needs_avx2

from phongscene.backends import native
from phongscene.scene import Scene, Sphere, TriangleMesh

# bvh.cpp's kSmallTreeTraversalCostBelow: scenes of fewer primitives take traversal cost 1.
SMALL_TREE_BELOW = 1 << 16


def s1_like_scene() -> Scene:
    """benchmarks' S1: four spheres in a row on a 100 x 100 ground quad."""
    spheres = tuple(
        Sphere.at((x, r, z), r) for x, z, r in [(-3.0, -0.5, 0.6), (-1.2, -0.2, 0.7), (0.8, 0.1, 0.8), (3.0, 0.4, 0.9)]
    )
    ground = TriangleMesh(
        points=np.array([[-50, 0, -50], [50, 0, -50], [50, 0, 50], [-50, 0, 50]], dtype=np.float64),
        triangles=np.array([[0, 1, 2], [0, 2, 3]], dtype=np.int32),
    )
    return Scene(spheres=spheres, meshes=(ground,))


def grid_mesh(n_triangles: int) -> TriangleMesh:
    """A bumpy grid of about n_triangles triangles (two per cell)."""
    side = int(np.ceil(np.sqrt(n_triangles / 2)))
    u, v = np.meshgrid(np.linspace(-1, 1, side + 1), np.linspace(-1, 1, side + 1), indexing="ij")
    points = np.stack([u, 0.05 * np.sin(9 * u) * np.cos(7 * v), v], axis=-1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(side), np.arange(side), indexing="ij")
    a = (i * (side + 1) + j).ravel()
    b, c, d = a + 1, a + side + 1, a + side + 2
    triangles = np.concatenate([np.stack([a, b, d], 1), np.stack([a, d, c], 1)]).astype(np.int32)
    return TriangleMesh(points=points, triangles=triangles)


def test_each_of_s1s_spheres_is_a_leaf_of_its_own():
    built = native.build(s1_like_scene())
    assert built.leaf_count >= 5  # four spheres and the ground (3 leaves at traversal cost 2)


def test_leaves_are_smaller_below_the_size_threshold():
    # The same surface just below and just above the threshold: above it the SAH's larger
    # traversal cost makes fewer, fuller leaves (the 10M-triangle tree's memory, issue 23.4).
    below = native.build(Scene(meshes=(grid_mesh(SMALL_TREE_BELOW - 2000),)))
    above = native.build(Scene(meshes=(grid_mesh(SMALL_TREE_BELOW + 2000),)))
    per_leaf_below = (SMALL_TREE_BELOW - 2000) / below.leaf_count
    per_leaf_above = (SMALL_TREE_BELOW + 2000) / above.leaf_count
    assert per_leaf_above > 1.2 * per_leaf_below


def test_hits_equal_brute_force_on_both_sides_of_the_threshold():
    rng = np.random.default_rng(25)
    for n in (SMALL_TREE_BELOW - 2000, SMALL_TREE_BELOW + 2000):
        built = native.build(Scene(meshes=(grid_mesh(n),)))
        origins = np.column_stack([rng.uniform(-1.2, 1.2, 2000), np.full(2000, 1.0), rng.uniform(-1.2, 1.2, 2000)])
        dirs = np.column_stack([rng.normal(0, 0.2, 2000), -np.ones(2000), rng.normal(0, 0.2, 2000)])
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        t, _ = built.intersect(origins, dirs, 1e-9)
        _, t_brute = built.count_hits(origins, dirs, 1e-9)
        assert np.array_equal(t, t_brute)


def float_grid_mesh(n_triangles: int) -> TriangleMesh:
    """grid_mesh with its points rounded to float32: the corners the prefilter reads."""
    mesh = grid_mesh(n_triangles)
    return TriangleMesh(points=mesh.points.astype(np.float32).astype(np.float64), triangles=mesh.triangles)


def triangles_per_leaf(built, scene: Scene) -> float:
    return sum(len(m.triangles) for m in scene.meshes) / built.leaf_count


@needs_avx2
def test_leaves_of_eight_where_the_prefilter_tests_them(monkeypatch):
    lanes = Scene(meshes=(float_grid_mesh(20000),))
    per_leaf = triangles_per_leaf(native.build(lanes), lanes)
    assert 5.0 < per_leaf <= 8.0  # kMaxLeafSize; most nodes of at most eight are leaves
    # A few spheres among the triangles leave the triangles' leaves as they are.
    spheres = tuple(Sphere.at((x, 0.0, 0.0), 0.05) for x in (-0.5, 0.0, 0.5))
    with_spheres = dataclasses.replace(lanes, spheres=spheres)
    assert triangles_per_leaf(native.build(with_spheres), with_spheres) > 0.95 * per_leaf
    # Where leaves are tested one primitive at a time the SAH keeps them small: the portable
    # walk, or double corners.
    doubles = Scene(meshes=(grid_mesh(20000),))
    assert triangles_per_leaf(built_with(monkeypatch, lanes, "sse2"), lanes) < per_leaf / 2
    assert triangles_per_leaf(native.build(doubles), doubles) < per_leaf / 2


@needs_avx2
def test_hits_equal_brute_force_in_leaves_of_eight():
    rng = np.random.default_rng(26)
    # Spheres on the surface: leaves of triangles alone beside leaves that hold a sphere.
    spheres = tuple(Sphere.at((x, 0.0, z), 0.04) for x in (-0.6, 0.0, 0.6) for z in (-0.6, 0.0, 0.6))
    built = native.build(Scene(meshes=(float_grid_mesh(20000),), spheres=spheres))
    origins = np.column_stack([rng.uniform(-1.2, 1.2, 3000), np.full(3000, 1.0), rng.uniform(-1.2, 1.2, 3000)])
    dirs = np.column_stack([rng.normal(0, 0.3, 3000), -np.ones(3000), rng.normal(0, 0.3, 3000)])
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    t, _ = built.intersect(origins, dirs, 1e-9)
    count, t_brute = built.count_hits(origins, dirs, 1e-9)
    assert np.array_equal(t, t_brute)
    # Shadow rays from the surface back up, some blocked by the bumps: any-hit agrees too.
    hit = np.isfinite(t)
    points = origins[hit] + t[hit, None] * dirs[hit]
    up = np.column_stack([rng.normal(0, 1.0, hit.sum()), np.full(hit.sum(), 0.15), rng.normal(0, 1.0, hit.sum())])
    up /= np.linalg.norm(up, axis=1, keepdims=True)
    blocked = built.occluded(points, up, np.full(hit.sum(), 10.0), 1e-6)
    count_up, _ = built.count_hits(points, up, 1e-6)
    assert 0 < blocked.sum() < len(blocked)
    assert np.array_equal(blocked, count_up > 0)
