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
