# SPDX-License-Identifier: Apache-2.0
"""The float prefilter of a BVH leaf's triangles on the AVX2 path (backends/native/src/
triangle_prefilter.hpp) rejects a triangle only where the double watertight test rejects it too,
so hits, shadows and images stay bit for bit those of the double test alone. Checked directly
(``prefilter_check``: every ray against every triangle, the prefilter's rejections against the
double test at any t) on rays built to sit where the float and double edge functions differ
most: exactly through shared vertices and edges of float meshes, at scales 1e-3 to 1e4 and far
from the origin, grazing the mesh's plane, and random; and end to end against the SSE2 path
(which has no prefilter) and brute force."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_native_bvh4 import FLOAT_PATH_T_MIN, assert_equals_brute_force, unit
from test_native_simd_dispatch import built_with, needs_avx2

from phongscene.backends import native
from phongscene.scene import Scene, TriangleMesh


def jittered_grid(n: int, scale: float, offset, seed: int = 0) -> TriangleMesh:
    """An n x n grid of quads, two triangles each, its vertices jittered and rounded to float32
    (so the mesh is stored as floats): every inner edge and vertex shared."""
    rng = np.random.default_rng(seed)
    xs, ys = np.meshgrid(np.arange(n + 1.0), np.arange(n + 1.0), indexing="xy")
    grid = np.stack([xs, ys, np.zeros_like(xs)], axis=-1).reshape(-1, 3)
    grid += rng.uniform(-0.3, 0.3, size=grid.shape) * [1.0, 1.0, 0.5]
    points = (grid / n * scale + np.asarray(offset, dtype=np.float64)).astype(np.float32).astype(np.float64)
    tris = []
    for j in range(n):
        for i in range(n):
            a, b, c, d = j * (n + 1) + i, j * (n + 1) + i + 1, (j + 1) * (n + 1) + i + 1, (j + 1) * (n + 1) + i
            tris += [(a, b, c), (a, c, d)]
    return TriangleMesh(points=points, triangles=np.array(tris))


def vertices_and_edge_points(mesh: TriangleMesh) -> np.ndarray:
    """Every vertex, and every edge's midpoint (exact in double: the mean of two floats), on
    which the double test's edge function is a rounding of 0."""
    corners = mesh.points[mesh.triangles]
    midpoints = 0.5 * (corners + np.roll(corners, 1, axis=1))
    return np.concatenate([mesh.points, midpoints.reshape(-1, 3)])


def assert_prefilter_sound(built, origins, dirs) -> np.ndarray:
    wrong, kept = built.prefilter_check(origins, dirs)
    assert (kept >= 0).all(), "the prefilter should apply to every ray here"
    bad = np.flatnonzero(wrong)
    assert bad.size == 0, (
        f"{bad.size} of {len(wrong)} rays: the prefilter rejected a triangle the double test hits, e.g. "
        f"origin {origins[bad[0]].tolist()} dir {dirs[bad[0]].tolist()} ({wrong[bad[0]]} triangles)"
    )
    return kept


SCALES = [1e-3, 1.0, 1e4]
# Offsets per unit of scale: at the origin, and far from it (the float rounding of the origin
# and of v − o then dominates the error bound).
OFFSETS = [(0.0, 0.0, 0.0), (3e3, -2e3, 1e3)]


@needs_avx2
@pytest.mark.parametrize("scale", SCALES)
@pytest.mark.parametrize("offset", OFFSETS)
def test_rays_through_shared_vertices_and_edges(monkeypatch, scale, offset):
    mesh = jittered_grid(12, scale, np.asarray(offset) * scale, seed=5)
    scene = Scene(meshes=(mesh,))
    built = native.build(scene)
    assert built.single_precision_triangles and built.walk_width == 8
    rng = np.random.default_rng(11)
    targets = vertices_and_edge_points(mesh)
    dirs = unit(rng.normal(size=targets.shape) + [0.0, 0.0, -2.0])  # from above, at all angles
    centre = mesh.points.mean(axis=0)
    for distance in (0.1, 3.0, 1e3):  # origins near, at the mesh's size, and far away (in units of scale)
        origins = targets - distance * scale * dirs
        kept = assert_prefilter_sound(built, origins, dirs)
        # The prefilter keeps about the triangles at the target, not the whole mesh.
        assert np.median(kept) <= 12, np.median(kept)
        t_min = FLOAT_PATH_T_MIN * scale
        count = assert_equals_brute_force(built, origins, dirs, t_min)
        # Watertight: a ray through an inner vertex or edge hits (on the border it may not).
        assert (count > 0).mean() > 0.8
        sse2 = built_with(monkeypatch, scene, "sse2")
        for a, b in zip(built.intersect(origins, dirs, t_min), sse2.intersect(origins, dirs, t_min)):
            assert np.array_equal(a, b)
        # Shadow rays towards the far side of the mesh's centre, and stopping short of it.
        t_max = np.linalg.norm(origins - centre, axis=1) * rng.uniform(0.5, 2.0, len(origins))
        assert np.array_equal(built.occluded(origins, dirs, t_max, t_min), sse2.occluded(origins, dirs, t_max, t_min))


@needs_avx2
@pytest.mark.parametrize("scale", SCALES)
def test_grazing_rays(monkeypatch, scale):
    # A flat grid (z = 0 exactly, no jitter in z) and rays in its plane or a hair above and
    # below it, along and across its edges: every edge function is tiny or zero.
    mesh = jittered_grid(10, scale, (0.0, 0.0, 0.0), seed=9)
    flat = TriangleMesh(points=mesh.points * [1.0, 1.0, 0.0], triangles=mesh.triangles)
    scene = Scene(meshes=(flat,))
    built = native.build(scene)
    rng = np.random.default_rng(3)
    targets = vertices_and_edge_points(flat)
    angles = rng.uniform(0, 2 * np.pi, len(targets))
    lift = rng.choice([0.0, 1e-7, -1e-7, 1e-3], size=len(targets))
    dirs = np.stack([np.cos(angles), np.sin(angles), lift], axis=1)
    origins = targets - 2.0 * scale * dirs
    assert_prefilter_sound(built, origins, dirs)
    t_min = FLOAT_PATH_T_MIN * scale
    assert_equals_brute_force(built, origins, dirs, t_min)
    sse2 = built_with(monkeypatch, scene, "sse2")
    for a, b in zip(built.intersect(origins, dirs, t_min), sse2.intersect(origins, dirs, t_min)):
        assert np.array_equal(a, b)


@needs_avx2
@settings(max_examples=60, deadline=None)
@given(
    scale_exponent=st.integers(-3, 4),
    offset=st.tuples(*[st.floats(-1e4, 1e4)] * 3),
    seed=st.integers(0, 2**32 - 1),
)
def test_random_rays(scale_exponent, offset, seed):
    scale = 10.0**scale_exponent
    rng = np.random.default_rng(seed)
    mesh = jittered_grid(6, scale, np.asarray(offset) * scale, seed=seed % 1000)
    built = native.build(Scene(meshes=(mesh,)))
    n = 200
    # Half the rays through vertices and edge points, half through random points of the mesh's box.
    targets = vertices_and_edge_points(mesh)[rng.integers(0, len(mesh.points), n // 2)]
    lo, hi = mesh.points.min(axis=0), mesh.points.max(axis=0)
    targets = np.concatenate([targets, rng.uniform(lo, hi, size=(n - n // 2, 3))])
    dirs = unit(rng.normal(size=(n, 3)))
    origins = targets - rng.uniform(0.01, 100.0, size=(n, 1)) * scale * dirs
    assert_prefilter_sound(built, origins, dirs)
    assert_equals_brute_force(built, origins, dirs, FLOAT_PATH_T_MIN * scale)


@needs_avx2
def test_where_the_bound_is_not_guaranteed_the_prefilter_stands_aside():
    mesh = jittered_grid(4, 1.0, (0.0, 0.0, 0.0))
    built = native.build(Scene(meshes=(mesh,)))
    origins = np.array([[0.5, 0.5, 2.0], [1e20, 0.0, 0.0], [np.nan, 0.0, 1.0], [0.5, 0.5, 2.0]])
    dirs = np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 0.0, 0.0]])
    wrong, kept = built.prefilter_check(origins, dirs)
    assert kept.tolist() == [kept[0], -1, -1, -1] and kept[0] >= 0  # a huge or NaN origin, a zero direction
    # Double storage (a vertex that is no float): the prefilter never applies.
    double = TriangleMesh(points=mesh.points + [0.1, 0.0, 0.0], triangles=mesh.triangles)
    built = native.build(Scene(meshes=(double,)))
    assert not built.single_precision_triangles
    assert (built.prefilter_check(origins, dirs)[1] == -1).all()
    # Fewer triangles than the smallest leaf it takes (kMinPrefilterLeaf, 3): the corners stay in
    # rows (reading a triangle from nine arrays costs more) and the prefilter never applies.
    two = TriangleMesh(points=mesh.points[:4], triangles=np.array([[0, 1, 2], [1, 3, 2]]))
    built = native.build(Scene(meshes=(two,)))
    assert built.single_precision_triangles
    assert (built.prefilter_check(origins, dirs)[1] == -1).all()
