# SPDX-License-Identifier: Apache-2.0
"""The C++ scene holds triangle corners (and normals) as floats when every mesh vertex (normal)
is a float (backends/native/src/triangle_store.hpp), else as doubles. Both must give the same
hits and the same images, bit for bit, and the choice must follow the numbers."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from test_native_intersect import jittered_grid, unit
from test_native_render import assert_matches_oracle

from phongscene.backends import native
from phongscene.scene import Scene, TriangleMesh
from phongscene.usd import load_usd
from support import calibration, oracle
from support.paths import EXAMPLES


def as_float(a):
    return None if a is None else a.astype(np.float32).astype(np.float64)


def float_exact(scene):
    """``scene`` with every mesh vertex rounded to float32 (kept as float64), and every normal
    rounded to float32 and renormalised until it stays a float."""

    def normals(n):
        for _ in range(4):  # renormalising a rounded unit vector moves it by an ulp at most
            n = as_float(n / np.linalg.norm(n, axis=1, keepdims=True))
        return n

    meshes = tuple(
        dataclasses.replace(m, points=as_float(m.points), normals=None if m.normals is None else normals(m.normals))
        for m in scene.meshes
    )
    return dataclasses.replace(scene, meshes=meshes)


def with_double_numbers(scene):
    """``scene`` with one more mesh, far behind the camera and every light (no ray of the image
    reaches it), whose vertex 1000.1 and normal (0.6, 0.8, 0) are not floats: the whole scene
    falls back to double storage."""
    far = np.array([[-1e3, -1e3, 1e3 + 0.1], [-1e3 + 1.0, -1e3, 1e3], [-1e3, -1e3 + 1.0, 1e3]])
    extra = TriangleMesh(
        points=far,
        triangles=[(0, 1, 2)],
        material=scene.meshes[0].material,
        normals=np.array([[0.6, 0.8, 0.0]]),
        normal_indices=np.zeros((1, 3), np.int64),
    )
    return dataclasses.replace(scene, meshes=(*scene.meshes, extra))


def test_float_numbers_are_stored_as_floats_and_any_double_keeps_doubles():
    scene = float_exact(calibration.smooth_mesh())
    assert scene.meshes[0].normals is not None
    built = native.build(scene)
    assert built.single_precision_triangles and built.single_precision_normals
    built = native.build(with_double_numbers(scene))
    assert not built.single_precision_triangles and not built.single_precision_normals
    grid = jittered_grid(4)  # jittered by float64 random numbers
    assert not native.build(dataclasses.replace(scene, meshes=(grid,))).single_precision_triangles


# More rows than for_chunks' kParallelCopyMinItems (2^16, build_threads.hpp): the normals' float
# check and copy then run in chunks on the build threads.
MANY_NORMALS = 70_000


def with_unused_normals(scene, last=None):
    """``scene`` with MANY_NORMALS unit normals (floats) put before each mesh's own and its
    indices moved past them; ``last``, when given, replaces the last of them in the last mesh."""
    rng = np.random.default_rng(11)
    meshes = []
    for k, m in enumerate(scene.meshes):
        if m.normals is None:
            meshes.append(m)
            continue
        extra = as_float(unit(rng.normal(size=(MANY_NORMALS, 3))))
        if last is not None and k == len(scene.meshes) - 1:
            extra[-1] = last
        meshes.append(
            dataclasses.replace(
                m, normals=np.vstack([extra, m.normals]), normal_indices=m.normal_indices + MANY_NORMALS
            )
        )
    return dataclasses.replace(scene, meshes=tuple(meshes))


@pytest.mark.parametrize("threads", [1, 3])
def test_many_normals_are_checked_and_copied_in_chunks(threads):
    # The same image when the normals the triangles use sit past 70,000 others in each of two
    # meshes (the copy's rows offset by mesh and by chunk), stored as floats, or as doubles
    # when the very last row checked is not a float.
    scene = float_exact(calibration.smooth_mesh())
    second = dataclasses.replace(scene.meshes[0], points=scene.meshes[0].points + (2.2, 0.0, -1.5))
    scene = dataclasses.replace(
        scene,
        meshes=(*scene.meshes, second),
        settings=dataclasses.replace(scene.settings, threads=threads),
    )
    expected = native.render(scene)
    floats = with_unused_normals(scene)
    doubles = with_unused_normals(scene, last=(0.6, 0.8, 0.1))
    assert native.build(floats, threads=threads).single_precision_normals
    assert not native.build(doubles, threads=threads).single_precision_normals
    assert np.array_equal(native.render(floats), expected)
    assert np.array_equal(native.render(doubles), expected)


def test_a_usd_mesh_is_stored_as_floats():
    # USD points are float32: a mesh read under an identity transform keeps them exactly.
    scene = load_usd(EXAMPLES / "seed_exponents.usda")
    assert scene.meshes and native.build(scene).single_precision_triangles


def test_float_and_double_storage_give_the_same_hits():
    rng = np.random.default_rng(7)
    grid = jittered_grid(24, seed=3)
    mesh = dataclasses.replace(grid, points=grid.points.astype(np.float32).astype(np.float64))
    single = native.build(Scene(meshes=(mesh,)))
    double = native.build(with_double_numbers(Scene(meshes=(mesh,))))
    assert single.single_precision_triangles and not double.single_precision_triangles
    origins = np.column_stack([rng.uniform(-1, 25, (5000, 2)), rng.uniform(0.5, 3.0, 5000)])
    d = unit(np.column_stack([rng.normal(scale=0.3, size=(5000, 2)), -np.ones(5000)]))
    t1, prim1 = single.intersect(origins, d)
    t2, prim2 = double.intersect(origins, d)
    assert (prim1 >= 0).sum() > 4000  # most rays hit the grid
    assert np.array_equal(t1, t2) and np.array_equal(prim1, prim2)
    assert np.array_equal(single.count_hits(origins, d)[0], double.count_hits(origins, d)[0])


@pytest.mark.parametrize("numerics", ["scale-invariant", "povray"])
def test_float_and_double_storage_render_the_same_image(numerics):
    scene = float_exact(calibration.smooth_mesh())
    scene = dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, numerics=numerics))
    single = native.render(scene)
    assert np.array_equal(single, native.render(with_double_numbers(scene)))
    if numerics == "scale-invariant":
        assert_matches_oracle(single, oracle.render(scene))


def far_meshes(base) -> Scene:
    """``calibration.far_from_origin`` moved to ``base``, its ball in four stretched copies side by
    side: five meshes far from the world origin, each with its own local origin (its centre)."""
    scene = calibration.far_from_origin()
    offset = np.asarray(base) - np.asarray(calibration.FAR_OFFSET)
    camera = dataclasses.replace(scene.camera, position=tuple(np.asarray(scene.camera.position) + offset))
    lights = tuple(dataclasses.replace(l, position=tuple(np.asarray(l.position) + offset)) for l in scene.lights)
    ball, ground = scene.meshes
    meshes = [dataclasses.replace(ground, points=ground.points + offset)]
    for k, shift in enumerate([(-1.3, 0.2, 0.1), (0.0, 0.0, 0.0), (1.4, -0.1, -0.6), (0.3, 1.6, -1.1)]):
        meshes.append(dataclasses.replace(ball, points=(ball.points + offset) * (1.0, 1.0 + 0.1 * k, 1.0) + shift))
    settings = dataclasses.replace(scene.settings, numerics="povray")
    return dataclasses.replace(scene, camera=camera, lights=lights, meshes=tuple(meshes), settings=settings)


@pytest.mark.parametrize("base", [(1e3, 0.0, 0.0), (3.3e4, -2e3, 1e4), (1e5, 1e5, -7e4)])
def test_povray_numerics_hold_corners_in_mesh_frames_as_the_same_doubles(base):
    # POV-Ray's numerics hold each corner as a float in its mesh's frame plus the mesh's origin
    # (triangle_store.hpp); read back they must be, bit for bit, the doubles numpy computed
    # ((p − o) rounded to float32, plus o: backends/native/__init__.py, _as_povray_stores).
    scene = far_meshes(base)
    origins = np.array([m.local_origin() for m in scene.meshes])
    assert len({tuple(o) for o in origins}) == len(scene.meshes) and np.all(np.linalg.norm(origins, axis=1) > 900)
    expected = np.concatenate(
        [((m.points - o).astype(np.float32).astype(np.float64) + o)[m.triangles] for m, o in zip(scene.meshes, origins)]
    )
    assert not np.array_equal(expected, expected.astype(np.float32))  # world floats would not hold them
    built = native.prepare(scene)._native
    assert built.triangle_storage == "mesh frame"
    corners = built.triangle_corners()
    assert corners.tobytes() == expected.tobytes()


def test_povray_numerics_keep_world_doubles_that_the_mesh_frames_do_not_give_back():
    # Points that are not float32 values in their mesh's frame (a caller other than
    # _as_povray_stores) are kept in doubles beside the mesh-frame floats, and read back as given.
    grid = jittered_grid(6, seed=5)  # float64 random numbers
    mesh = dataclasses.replace(grid, points=grid.points + (2e4, 0.0, 0.0))
    scene = Scene(meshes=(mesh,))
    arrays = dict(native.scene_arrays(scene), povray_triangles=True, mesh_origins=mesh.local_origin().reshape(1, 3))
    built = native._native.Scene(**arrays)
    assert built.triangle_storage == "mesh frame and double"
    assert built.triangle_corners().tobytes() == mesh.points[mesh.triangles].tobytes()
    rounded = native._native.Scene(**native._as_povray_stores(native.scene_arrays(scene), scene))
    assert rounded.triangle_storage == "mesh frame"
    # The hit test reads the mesh-frame floats in both: the same hits.
    rng = np.random.default_rng(11)
    origins = np.column_stack([rng.uniform(2e4 - 1, 2e4 + 7, 2000), rng.uniform(-1, 7, 2000), np.full(2000, 3.0)])
    d = unit(np.column_stack([rng.normal(scale=0.2, size=(2000, 2)), -np.ones(2000)]))
    t1, prim1 = built.intersect(origins, d)
    t2, prim2 = rounded.intersect(origins, d)
    assert (prim1 >= 0).sum() > 1000
    assert np.array_equal(t1, t2) and np.array_equal(prim1, prim2)
