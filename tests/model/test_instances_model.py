# SPDX-License-Identifier: Apache-2.0
"""The model's instancing: Prototype and Instances, counts, bounds, flattened(), validation."""

from __future__ import annotations

import numpy as np
import pytest

from phongscene.scene import Instances, Prototype, Scene, TriangleMesh
from phongscene.validate import validate


def _triangle() -> TriangleMesh:
    return TriangleMesh(
        np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float),
        np.array([[0, 1, 2]]),
        normals=np.array([[0, 0, 1.0]]),
        normal_indices=np.array([[0, 0, 0]]),
    )


def _copies() -> np.ndarray:
    m = np.tile(np.eye(4), (3, 1, 1))
    m[1, :3, 3] = (10, 0, 0)
    m[2, :3, :3] = np.diag([2.0, 1.0, 0.5])
    return m


def test_counts_bounds_and_flattened():
    prototype = Prototype((_triangle(),), source="/P")
    scene = Scene(meshes=(_triangle(),), instances=(Instances(prototype, _copies()),))
    assert scene.triangle_count == 2 and scene.instanced_triangle_count == 4 and scene.instance_count == 3
    assert scene.prototypes == (prototype,)
    lo, hi = scene.bounds()
    assert np.array_equal(lo, [0, 0, 0]) and np.array_equal(hi, [11, 1, 0])
    flat = scene.flattened()
    assert not flat.instances and len(flat.meshes) == 4
    assert np.array_equal(flat.meshes[2].points, [[10, 0, 0], [11, 0, 0], [10, 1, 0]])
    assert np.array_equal(flat.meshes[3].points, [[0, 0, 0], [2, 0, 0], [0, 1, 0]])
    assert np.allclose(flat.meshes[3].normals, [[0, 0, 1]])  # inverse transpose, renormalised
    assert validate(scene) == []


def test_transforms_are_checked():
    with pytest.raises(ValueError, match="shape"):
        Instances(Prototype((_triangle(),)), np.eye(4))
    bad = _copies()
    bad[2, 3] = (0, 0, 1, 1)
    problems = validate(Scene(instances=(Instances(Prototype((_triangle(),)), bad, sources=("/a", "/b", "/c")),)))
    assert len(problems) == 1 and "not affine" in problems[0].message and problems[0].prim == "/c"
    bad = _copies()
    bad[0, 0, 0] = np.nan
    assert "not finite" in validate(Scene(instances=(Instances(Prototype((_triangle(),)), bad),)))[0].message


def test_prototype_meshes_are_validated():
    broken = TriangleMesh(np.zeros((3, 3)), np.array([[0, 1, 5]]), source="/P/M")
    problems = validate(Scene(instances=(Instances(Prototype((broken,)), np.eye(4)[None]),)))
    assert [p.prim for p in problems] == ["/P/M"] and problems[0].attribute == "triangles"
