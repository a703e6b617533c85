# SPDX-License-Identifier: Apache-2.0
"""The model's arrays are read-only and its own: a caller's writable array is copied (writing it
afterwards changes nothing), while an array already frozen and owning its memory (as the USD
reader hands its big ones over: issue 23.4, memory per triangle) is kept without a copy."""

from __future__ import annotations

import numpy as np

from phongscene.scene import TriangleMesh

POINTS = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]


def test_a_writable_array_is_copied_and_the_copy_is_read_only():
    points = np.array(POINTS)
    mesh = TriangleMesh(points, np.array([[0, 1, 2]], dtype=np.int32))
    points[1, 0] = 5.0
    assert mesh.points[1, 0] == 1.0
    assert not mesh.points.flags.writeable and not mesh.triangles.flags.writeable


def test_a_frozen_array_of_its_own_is_kept_without_a_copy():
    points, triangles = np.array(POINTS), np.array([[0, 1, 2]], dtype=np.int32)
    points.setflags(write=False)
    triangles.setflags(write=False)
    mesh = TriangleMesh(points, triangles)
    assert mesh.points is points and mesh.triangles is triangles


def test_a_frozen_view_or_another_dtype_is_copied():
    owner = np.array(POINTS)
    view = owner[:]
    view.setflags(write=False)  # the owner can still be written: the model must not share it
    mesh = TriangleMesh(view, np.array([[0, 1, 2]], dtype=np.int64))
    owner[1, 0] = 5.0
    assert mesh.points[1, 0] == 1.0 and not np.shares_memory(mesh.points, owner)
    assert mesh.triangles.dtype == np.int32


def test_points_bounds_block_by_block_equal_the_whole_array_s(monkeypatch):
    import phongscene.scene as model
    from phongscene.diagnostics import _Spheres

    rng = np.random.default_rng(5)
    cloud = model.Points(rng.normal(size=(1001, 3)) * 100, rng.random(1001) * 10 + 0.01, source="/Cloud")
    whole = (cloud.centers - cloud.radii[:, None]).min(axis=0), (cloud.centers + cloud.radii[:, None]).max(axis=0)
    eye = cloud.centers[17] + 0.001
    inside = int((((eye - cloud.centers) ** 2).sum(axis=1) < cloud.radii**2).sum())
    monkeypatch.setattr(model, "POINTS_BLOCK", 100)  # 11 blocks, the last one short
    lo, hi = cloud.bounds()
    assert np.array_equal(lo, whole[0]) and np.array_equal(hi, whole[1])
    assert inside >= 1 and len(_Spheres(np.zeros((0, 4, 4)), (), (cloud,)).containing(eye)) == inside
