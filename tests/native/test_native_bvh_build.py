# SPDX-License-Identifier: Apache-2.0
"""The BVH build's shortcuts keep every hit exact (backends/native/src/bvh.cpp): nodes of 2^8
primitives or more choose their split from every fourth primitive by position (every 8th from
2^12, every 16th from 2^14: sampled binning),
and nodes of at most 8 sort their primitives with a branch-free network whose ties keep their
order; the collapse to wide nodes splits a large tree into regions collapsed in parallel. Each
case is made to mislead them, and checked against brute force."""

from __future__ import annotations

import numpy as np
import pytest
from test_native_bvh_cost import grid_mesh

from phongscene.backends import native
from phongscene.scene import Scene, TriangleMesh

# bvh.cpp's binning_stride(n): from 2^8 primitives every 4th, from 2^12 every 8th, from 2^14
# every 16th.
STRIDES = {1 << 8: 4, 1 << 12: 8, 1 << 14: 16}


def flat_triangles(centres: np.ndarray, size: float) -> TriangleMesh:
    """A small triangle in the plane y = 0 around each (x, z) centre, in the centres' order."""
    n = len(centres)
    offsets = np.array([[-size, 0.0, -size], [size, 0.0, -size], [0.0, 0.0, size]])
    points = np.zeros((n, 3, 3))
    points[:, :, 0] = centres[:, None, 0] + offsets[None, :, 0]
    points[:, :, 2] = centres[:, None, 1] + offsets[None, :, 2]
    return TriangleMesh(points=points.reshape(-1, 3), triangles=np.arange(3 * n, dtype=np.int32).reshape(n, 3))


def rays_down_onto(targets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    origins = np.column_stack([targets[:, 0], np.ones(len(targets)), targets[:, 1]])
    dirs = np.tile([0.0, -1.0, 0.0], (len(targets), 1))
    return origins, dirs


@pytest.mark.parametrize("smallest", sorted(STRIDES))
def test_a_cluster_only_the_samples_see_does_not_mislead_the_split(smallest):
    # 2 x `smallest` triangles (512, 8,192, 32,768): the root's sampled positions (every
    # 4th/8th/16th from the first) all in one tight cluster, the others spread over a wide
    # square, so that the root's bins see only the cluster. The split may be poor; the hits must
    # still be exact. (Rays onto at most 4,096 of the centres: brute force checks each ray
    # against every triangle.)
    n, stride = 2 * smallest, STRIDES[smallest]
    rng = np.random.default_rng(50)
    centres = rng.uniform(-10.0, 10.0, (n, 2))
    centres[::stride] = rng.uniform(-0.5, 0.5, (n // stride, 2)) + [-8.0, -8.0]
    built = native.build(Scene(meshes=(flat_triangles(centres, 0.05),)))
    aimed = centres[:: max(1, n // 4096)]
    targets = np.concatenate([aimed, rng.uniform(-10.5, 10.5, (2000, 2))])
    origins, dirs = rays_down_onto(targets)
    t, ids = built.intersect(origins, dirs, 1e-9)
    _, t_brute = built.count_hits(origins, dirs, 1e-9)
    assert np.array_equal(t, t_brute)
    assert np.isfinite(t[: len(aimed)]).all()  # every aimed-at triangle's own centre is hit


# bvh.cpp's kPiecewisePartitionMinPrimitives: nodes this large partition in 16 fixed pieces.
PIECEWISE_FROM = 1 << 18


@pytest.mark.parametrize("threads", [1, 2])
def test_a_large_node_partitions_in_pieces_whole_runs_to_one_side(threads):
    # 2^18 + 4,000 tiny triangles: A spread over x in [-20, -10], B in a 0.1-unit square at x = 10,
    # which the root's split separates. By position (16 pieces of ~16.6k): pieces 0-3 all A,
    # 4-5 all B, 6-15 a random mix. So the root's pieces are wholly on one side or mixed, before
    # and after the split point, and the swaps of the misplaced meet runs of every kind. B's box
    # is so small that the wide root keeps it as a child (it opens the larger A boxes): an A
    # triangle left in B's range would lie outside it, and the ray onto its centre would miss.
    # Every such ray finds the plane at t = 1, and 300 rays anywhere hit what brute force hits.
    n = PIECEWISE_FROM + 4000
    rng = np.random.default_rng(18)
    piece = np.arange(n) * 16 // n
    in_b = np.where(piece < 4, False, np.where(piece < 6, True, rng.random(n) < 0.5))
    a = np.column_stack([rng.uniform(-20.0, -10.0, n), rng.uniform(-10.0, 10.0, n)])
    b = np.column_stack([rng.uniform(10.0, 10.1, n), rng.uniform(0.0, 0.1, n)])
    centres = np.where(in_b[:, None], b, a)
    built = native.build(Scene(meshes=(flat_triangles(centres, 0.001),)), threads=threads)
    t, _ = built.intersect(*rays_down_onto(centres), 1e-9)
    assert (t == 1.0).all()
    origins, dirs = rays_down_onto(rng.uniform(-21.0, 21.0, (300, 2)))
    t, _ = built.intersect(origins, dirs, 1e-9)
    assert np.array_equal(t, built.count_hits(origins, dirs, 1e-9)[1])


def test_coincident_triangles_tie_to_the_lowest_id_however_the_build_sorts_them():
    # 300 places, five identical triangles at each (rows p, p + 300, ..., p + 1200): 1,500
    # triangles (sampled at the root), whose equal centroids the small nodes' sorting network must
    # keep in order. A ray onto place p hits all five at one distance; the lowest id, p, wins.
    places = 300
    rng = np.random.default_rng(6)
    centres = rng.permutation(np.stack(np.meshgrid(np.arange(20.0), np.arange(15.0)), -1).reshape(-1, 2))
    mesh = flat_triangles(np.tile(centres, (5, 1)), 0.3)
    built = native.build(Scene(meshes=(mesh,)))
    origins, dirs = rays_down_onto(centres)
    t, ids = built.intersect(origins, dirs, 1e-9)
    count, t_brute = built.count_hits(origins, dirs, 1e-9)
    assert np.array_equal(t, t_brute)
    assert (count == 5).all()
    assert np.array_equal(ids, np.arange(places))


def test_the_collapse_in_regions_walks_the_same_on_both_paths_and_any_threads(monkeypatch):
    # 40,000 triangles: past bvh4.cpp's kParallelCollapseMinSlots (2^16 binary slots), so the
    # root's children collapse into regions of their own, on the 8-wide and the 4-wide tree alike.
    scene = Scene(meshes=(grid_mesh(40_000),))
    rng = np.random.default_rng(7)
    origins = np.column_stack([rng.uniform(-1.2, 1.2, 2000), np.full(2000, 1.0), rng.uniform(-1.2, 1.2, 2000)])
    dirs = np.column_stack([rng.normal(0, 0.3, 2000), -np.ones(2000), rng.normal(0, 0.3, 2000)])
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    answers = []
    for simd in ("auto", "sse2"):
        monkeypatch.setenv("PHONGSCENE_NATIVE_SIMD", simd)
        digests = {native.build(scene, threads=threads).tree_digest for threads in (1, 2, 3)}
        assert len(digests) == 1
        built = native.build(scene)
        t, ids = built.intersect(origins, dirs, 1e-9)
        _, t_brute = built.count_hits(origins, dirs, 1e-9)
        assert np.array_equal(t, t_brute)
        assert np.isfinite(t).sum() > 1000
        answers.append((t, ids))
    assert np.array_equal(answers[0][0], answers[1][0]) and np.array_equal(answers[0][1], answers[1][1])
