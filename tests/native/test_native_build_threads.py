# SPDX-License-Identifier: Apache-2.0
"""A scene build uses at most the threads it is given (backends/native/src/build_threads.hpp):
``native.build(scene, threads=N)`` and a render's ``RenderSettings.threads`` cap the BVH's
parallel binning and subtrees and the input copies, as they cap the render; the tree is the same
for any cap, so images are bit-identical."""

from __future__ import annotations

import dataclasses

import numpy as np

from phongscene.backends import native
from phongscene.backends.native import _native
from support import calibration

# Large enough for the parallel paths (binning from 2^16 primitives, subtrees, input copies):
# an icosphere of 20·4^6 = 81,920 triangles.
SUBDIVISIONS = 6


def _big_scene():
    scene = calibration.smooth_mesh()
    mesh = scene.meshes[0]
    ball = calibration.icosphere(SUBDIVISIONS, (0.0, 1.0, 0.0), 1.0, mesh.material, smooth=True)
    return dataclasses.replace(scene, meshes=(ball, *scene.meshes[1:]))


def test_the_cap_is_set_for_the_build_and_lifted_after():
    assert _native.build_threads() == max(1, _native.hardware_threads())
    with native.build_threads(1):
        assert _native.build_threads() == 1
    assert _native.build_threads() == max(1, _native.hardware_threads())


def test_a_build_on_one_thread_traces_as_one_on_every_core():
    scene = _big_scene()
    assert scene.triangle_count >= 1 << 16
    rng = np.random.default_rng(2)
    origins = np.tile(np.array(scene.camera.position), (5000, 1))
    dirs = rng.normal(size=(5000, 3)) + np.asarray(scene.camera.forward) * 3
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    one, every = native.build(scene, threads=1), native.build(scene)
    t1, id1 = one.intersect(origins, dirs)
    t2, id2 = every.intersect(origins, dirs)
    assert np.array_equal(t1, t2) and np.array_equal(id1, id2)
    assert np.isfinite(t1).sum() > 100
    image = native.render(scene)
    assert np.array_equal(native.render(scene, dataclasses.replace(scene.settings, threads=1)), image)


# A wavy heightfield of 2·405·405 = 328,050 triangles: large enough that a 4-thread build splits
# two levels down on other threads (each side of a parallel split holds >= 2^15 primitives).
HEIGHTFIELD_QUADS = 405


def _heightfield_scene():
    n = HEIGHTFIELD_QUADS
    u, v = np.meshgrid(np.linspace(-2.0, 2.0, n + 1), np.linspace(-2.0, 2.0, n + 1), indexing="ij")
    points = np.stack([u, 0.2 * np.sin(3.1 * u) * np.cos(2.3 * v), v], axis=-1).reshape(-1, 3)
    corner = (np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]).ravel()
    quads = np.stack([corner, corner + n + 1, corner + n + 2, corner + 1], axis=1)
    triangles = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]]).astype(np.int32)
    scene = calibration.smooth_mesh()
    field = dataclasses.replace(scene.meshes[1], points=points, triangles=triangles)
    return dataclasses.replace(scene, meshes=(field,))


def test_the_tree_is_the_same_on_any_number_of_threads():
    """Subtrees built on other threads write their nodes into fixed slots of one array (bvh.cpp),
    collapsed as one tree: the walk's tree and leaf order equal a one-thread build's for 1 to 4
    threads, and the digest that says so changes when the tree does."""
    scene = _heightfield_scene()
    assert scene.triangle_count == 2 * HEIGHTFIELD_QUADS**2
    digests = {threads: native.build(scene, threads=threads).tree_digest for threads in (1, 2, 3, 4)}
    assert len(set(digests.values())) == 1, digests
    mesh = scene.meshes[0]
    moved = mesh.points.copy()
    moved[mesh.triangles[1000, 0], 1] += 0.05  # one corner: that triangle's box, so its leaf, changes
    other = dataclasses.replace(scene, meshes=(dataclasses.replace(mesh, points=moved),))
    assert native.build(other, threads=1).tree_digest != digests[1]
