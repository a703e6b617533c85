# SPDX-License-Identifier: Apache-2.0
"""The 4-wide BVH's float slab test (backends/native/src/bvh4.hpp) never misses a box that holds a
hit: the closest hit through it equals brute force (``count_hits``) on rays built to sit on the
edge of the float arithmetic: through triangle corners and along box faces and edges, on slab
planes with axis-parallel directions (0·inf = NaN), at tiny and huge scales.

``intersect(..., t_min)`` takes the float test for t_min >= 2^-125 and the double-precision test
on the same nodes below (and beyond 1e30 scene units); both are checked."""

from __future__ import annotations

import numpy as np
import pytest

from phongscene.backends import native
from phongscene.scene import Scene, Sphere, TriangleMesh

# The two traversal paths: t_min = 0 is below the float test's smallest t_min (2^-125), so the
# double test runs; 1e-300 too; a t_min far below every hit but a normal float takes the float
# test. Per scene unit, so that tiny scenes keep every hit beyond it.
FLOAT_PATH_T_MIN = 1e-12
T_MINS = {"double": 0.0, "float": FLOAT_PATH_T_MIN}


def unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def assert_equals_brute_force(built, origins, dirs, t_min) -> np.ndarray:
    t, prim = built.intersect(origins, dirs, t_min)
    count, t_brute = built.count_hits(origins, dirs, t_min)
    missed = np.flatnonzero(t != t_brute)
    assert missed.size == 0, (
        f"{missed.size} of {len(t)} rays differ from brute force, e.g. ray {missed[0]}: "
        f"origin {origins[missed[0]].tolist()} dir {dirs[missed[0]].tolist()}: {t[missed[0]]} vs {t_brute[missed[0]]}"
    )
    assert np.array_equal(prim >= 0, count > 0)
    return count


def float32_triangles(rng, n: int, scale: float, offset: float) -> np.ndarray:
    """n small random triangles whose corners are float32 numbers, so their float boxes are
    exactly tight (rounding the box outward adds no slack to hide an error)."""
    a = rng.uniform(-1, 1, size=(n, 3))
    corners = np.stack([a, a + rng.normal(scale=0.2, size=(n, 3)), a + rng.normal(scale=0.2, size=(n, 3))], axis=1)
    return (corners * scale + offset).astype(np.float32).astype(np.float64)


def mesh_scene(corners: np.ndarray) -> Scene:
    points = corners.reshape(-1, 3)
    return Scene(meshes=(TriangleMesh(points=points, triangles=np.arange(len(points)).reshape(-1, 3)),))


@pytest.mark.parametrize("path", sorted(T_MINS))
@pytest.mark.parametrize("scale, offset", [(1e-6, 0.0), (1.0, 0.0), (1e6, 0.0), (1.0, 1e7), (1e20, 0.0), (1e35, 0.0)])
def test_rays_through_corners_and_edges_equal_brute_force(path, scale, offset):
    # Rays from far away through each triangle's corners and edge midpoints: such a ray enters
    # the triangle's (tight) box exactly at its boundary, where a float slab test without its
    # widening can cull it. 1e35 is beyond the float test's range: both paths run the double one.
    rng = np.random.default_rng(21)
    corners = float32_triangles(rng, 300, scale, offset)
    built = native.build(mesh_scene(corners))
    targets = np.concatenate([corners.reshape(-1, 3), 0.5 * (corners + np.roll(corners, 1, axis=1)).reshape(-1, 3)])
    dirs = unit(rng.normal(size=targets.shape))
    origins = targets - 7.0 * scale * dirs
    count = assert_equals_brute_force(built, origins, dirs, T_MINS[path] * scale)
    assert (count > 0).sum() > len(targets) // 2  # most rays hit what they aim at


@pytest.mark.parametrize("path", sorted(T_MINS))
@pytest.mark.parametrize("zero", [0.0, -0.0])
def test_axis_parallel_rays_on_slab_planes_equal_brute_force(path, zero):
    # A grid of unit squares at z = 0 (corners on integers) and rays along −z whose x and y are
    # integers or half-integers: their origins lie on the slab planes of many boxes, with a
    # direction component ±0 (1/±0 = ±inf, and (plane − origin)·inf = 0·inf = NaN), which must
    # keep the box. Every ray hits exactly one triangle (a shared edge or corner counts once).
    n = 6
    xs, ys = np.meshgrid(np.arange(n + 1.0), np.arange(n + 1.0), indexing="xy")
    points = np.stack([xs, ys, np.zeros_like(xs)], axis=-1).reshape(-1, 3)
    tris = []
    for j in range(n):
        for i in range(n):
            a, b, c, d = j * (n + 1) + i, j * (n + 1) + i + 1, (j + 1) * (n + 1) + i + 1, (j + 1) * (n + 1) + i
            tris += [(a, b, c), (a, c, d)]
    built = native.build(Scene(meshes=(TriangleMesh(points=points, triangles=tris),)))
    g = np.arange(1, 2 * n) * 0.5
    gx, gy = np.meshgrid(g, g)
    origins = np.stack([gx.ravel(), gy.ravel(), np.full(gx.size, 3.0)], axis=1)
    dirs = np.tile([zero, zero, -1.0], (len(origins), 1))
    count = assert_equals_brute_force(built, origins, dirs, T_MINS[path])
    assert (count == 1).all()
    # Grazing: rays in the grid's plane (z = 0, d_z = ±0) along its lines, and the same rays
    # just above it: whatever the triangle test says of them, the BVH must say the same.
    line = np.stack([np.full(2 * n - 1, -1.0), g, np.zeros(2 * n - 1)], axis=1)
    origins = np.concatenate([line, line + [0.0, 0.0, 1e-300], line[:, [1, 0, 2]]])
    dirs = np.concatenate([np.tile([1.0, zero, zero], (2 * len(line), 1)), np.tile([zero, 1.0, zero], (len(line), 1))])
    assert_equals_brute_force(built, origins, dirs, T_MINS[path])


@pytest.mark.slow
@pytest.mark.parametrize("path", sorted(T_MINS))
@pytest.mark.parametrize("scale", [1e-6, 1.0, 1e6])
def test_random_rays_equal_brute_force(path, scale):
    # Spheres and triangles in a cloud, random rays from inside and outside it: the closest hit
    # through the 4-wide BVH (nearest child first, culled by the closest hit so far) is the
    # brute-force one, to the last bit.
    rng = np.random.default_rng(13)
    corners = float32_triangles(rng, 2000, 5.0 * scale, 0.0)
    spheres = tuple(
        Sphere.at(tuple(rng.uniform(-5, 5, 3) * scale), float(rng.uniform(0.05, 0.5)) * scale) for _ in range(80)
    )
    points = corners.reshape(-1, 3)
    scene = Scene(
        spheres=spheres, meshes=(TriangleMesh(points=points, triangles=np.arange(len(points)).reshape(-1, 3)),)
    )
    built = native.build(scene)
    origins = rng.uniform(-8, 8, size=(5000, 3)) * scale
    dirs = unit(rng.normal(size=(5000, 3)))
    count = assert_equals_brute_force(built, origins, dirs, T_MINS[path] * scale)
    assert (count > 0).sum() > 2000


@pytest.mark.parametrize("path", sorted(T_MINS))
def test_tiny_and_huge_direction_components_equal_brute_force(path):
    # Direction components whose reciprocal is beyond the float range (1e-40: the float test
    # ignores that axis) or a subnormal double (5e-324), beside the dominant one.
    rng = np.random.default_rng(4)
    corners = float32_triangles(rng, 500, 1.0, 0.0)
    built = native.build(mesh_scene(corners))
    targets = corners.mean(axis=1)
    dirs = np.zeros_like(targets)
    dirs[:, 2] = -1.0
    dirs[:, 0] = rng.choice([1e-40, -1e-40, 5e-324, -5e-324, 1e-30, 0.0], size=len(targets))
    origins = targets - 4.0 * dirs
    count = assert_equals_brute_force(built, origins, dirs, T_MINS[path])
    assert (count > 0).sum() > len(targets) // 2


def _outward_reference(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The floats nearest to x below and above (bvh.hpp's round_down / round_up) in numpy."""
    with np.errstate(over="ignore", invalid="ignore"):  # beyond the float range: ±inf, as C's cast
        f = x.astype(np.float32)
        down = np.where(f.astype(np.float64) > x, np.nextafter(f, np.float32(-np.inf)), f)
        up = np.where(f.astype(np.float64) < x, np.nextafter(f, np.float32(np.inf)), f)
    return down, up


def test_a_ray_origin_rounds_outward_in_lanes_as_the_scalar_functions_do():
    # FloatSlabOrigin rounds the three coordinates in SSE2 lanes; the binding checks each lane
    # against the scalar round_down / round_up bit for bit, and here both against numpy: floats,
    # midpoints between floats (ties), signed zeros, subnormals, the float range's edges, beyond
    # it, infinities and NaN.
    rng = np.random.default_rng(11)
    f = rng.standard_normal(3000).astype(np.float32) * np.float32(10.0) ** rng.integers(-40, 39, 3000)
    f = f.astype(np.float64)
    specials = np.array(
        [
            0.0,
            -0.0,
            1e-50,
            -1e-50,
            1e-45,
            -1e-45,
            2.0**-149,
            2.0**-150,
            -(2.0**-150),
            3.4028234663852886e38,
            3.4028235677973366e38,
            -3.4028235677973366e38,
            1e39,
            -1e39,
            np.inf,
            -np.inf,
            np.nan,
            1.0,
            -1.0,
        ]
    )
    with np.errstate(over="ignore"):
        midpoints = (f + np.nextafter(f.astype(np.float32), np.float32(np.inf)).astype(np.float64)) / 2
    values = np.concatenate([f, midpoints, f * (1 + 2.0**-30), specials, np.roll(specials, 5), np.roll(specials, 11)])
    values = values[: len(values) // 3 * 3]
    rows = values.reshape(-1, 3)
    out = native._native.round_outward(rows)
    down, up = _outward_reference(rows)
    assert np.array_equal(out[:, :3], down, equal_nan=True)
    assert np.array_equal(out[:, 3:], up, equal_nan=True)
    # Signed zeros compare equal above: their bits too.
    assert np.array_equal(np.signbit(out[:, :3]), np.signbit(down)) and np.array_equal(
        np.signbit(out[:, 3:]), np.signbit(up)
    )
