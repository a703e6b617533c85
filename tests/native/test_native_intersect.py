# SPDX-License-Identifier: Apache-2.0
"""Ray/primitive hard cases through the test-only bindings ``_native.Scene.intersect`` (closest
hit through the BVH: t and primitive id) and ``count_hits`` (brute force over every primitive)."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
import trimesh

from phongscene.backends import native
from phongscene.scene import Scene, Sphere, TriangleMesh


def unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def jittered_grid(n: int, seed: int = 1) -> TriangleMesh:
    """A flat n×n-cell grid at z = 0 with jittered interior vertices and alternating diagonals."""
    rng = np.random.default_rng(seed)
    xs, ys = np.meshgrid(np.arange(n + 1.0), np.arange(n + 1.0), indexing="xy")
    points = np.stack([xs, ys, np.zeros_like(xs)], axis=-1).reshape(-1, 3)
    interior = (xs > 0) & (xs < n) & (ys > 0) & (ys < n)
    points[interior.ravel(), :2] += rng.uniform(-0.3, 0.3, size=(interior.sum(), 2))
    tris = []
    for j in range(n):
        for i in range(n):
            a, b, c, d = j * (n + 1) + i, j * (n + 1) + i + 1, (j + 1) * (n + 1) + i + 1, (j + 1) * (n + 1) + i
            tris += [(a, b, c), (a, c, d)] if (i + j) % 2 else [(a, b, d), (b, c, d)]
    return TriangleMesh(points=points, triangles=tris)


def edge_midpoints(mesh: TriangleMesh) -> np.ndarray:
    edges = np.concatenate([mesh.triangles[:, [0, 1]], mesh.triangles[:, [1, 2]], mesh.triangles[:, [2, 0]]])
    edges = np.unique(np.sort(edges, axis=1), axis=0)
    return mesh.points[edges].mean(axis=1)


def interior(points: np.ndarray, n: int) -> np.ndarray:
    inside = (points[:, 0] > 0) & (points[:, 0] < n) & (points[:, 1] > 0) & (points[:, 1] < n)
    return points[inside]


@pytest.mark.parametrize("direction", [(0.0, 0.0, -1.0), (0.31, -0.17, -1.0), (1.0, 1.0, -0.05)])
def test_rays_through_shared_edges_and_vertices_hit_exactly_one_triangle(direction):
    n = 8
    mesh = jittered_grid(n)
    built = native.build(Scene(meshes=(mesh,)))
    targets = np.concatenate([interior(mesh.points, n), interior(edge_midpoints(mesh), n)])
    d = np.broadcast_to(unit(direction), targets.shape).copy()
    origins = targets - 5.0 * d
    count, t_brute = built.count_hits(origins, d)
    assert (count == 1).all(), f"{int((count == 0).sum())} cracks, {int((count > 1).sum())} double hits"
    t, prim = built.intersect(origins, d)
    assert (prim >= 0).all() and np.array_equal(t, t_brute)
    np.testing.assert_allclose(t, 5.0, rtol=1e-12)


def test_closed_mesh_is_watertight_from_inside_and_outside():
    ico = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
    mesh = TriangleMesh(points=ico.vertices, triangles=ico.faces)
    built = native.build(Scene(meshes=(mesh,)))
    # From the centre through every vertex and edge midpoint: leaves the closed mesh exactly once.
    targets = np.concatenate([mesh.points, edge_midpoints(mesh)])
    d = unit(targets)
    count, _ = built.count_hits(np.zeros_like(d), d)
    assert (count == 1).all()
    # From outside through the centre along the same directions: in and out.
    count, _ = built.count_hits(-3.0 * d, d)
    assert (count == 2).all()


def _sphere_scene(matrix=None) -> tuple[Scene, np.ndarray]:
    m = np.eye(4) if matrix is None else np.asarray(matrix, dtype=np.float64)
    return Scene(spheres=(Sphere(m),)), m


def test_tangent_and_grazing_rays_on_a_sphere():
    built = native.build(_sphere_scene()[0])
    d = np.array([[0.0, 0.0, 1.0]])
    # Exactly tangent (closest approach = radius): the double root at the tangent point.
    t, prim = built.intersect(np.array([[1.0, 0.0, -5.0]]), d)
    assert prim[0] == 0 and t[0] == 5.0
    # Just outside: a miss, never NaN.
    t, prim = built.intersect(np.array([[1.0 + 1e-12, 0.0, -5.0]]), d)
    assert prim[0] == -1 and t[0] == math.inf
    # Grazing at 1 - 10^-k: the stable quadratic keeps the near root accurate to ~1e-15·t even
    # where the chord is tiny (the naive b² − ac form loses ~half the digits there).
    offsets = 1.0 - 10.0 ** -np.arange(1, 16, dtype=np.float64)
    origins = np.stack([offsets, np.zeros_like(offsets), np.full_like(offsets, -5.0)], axis=1)
    t, prim = built.intersect(origins, np.repeat(d, len(offsets), axis=0))
    expected = 5.0 - np.sqrt((1.0 - offsets) * (1.0 + offsets))
    assert (prim == 0).all()
    np.testing.assert_allclose(t, expected, rtol=0, atol=1e-14)


def test_rays_from_inside_a_sphere_hit_the_far_side():
    rng = np.random.default_rng(7)
    built = native.build(_sphere_scene()[0])
    origins = rng.uniform(-0.5, 0.5, size=(1000, 3))
    d = unit(rng.normal(size=(1000, 3)))
    t, prim = built.intersect(origins, d)
    assert (prim == 0).all() and (t > 0).all()
    np.testing.assert_allclose(np.linalg.norm(origins + t[:, None] * d, axis=1), 1.0, rtol=0, atol=1e-14)
    t, prim = built.intersect(np.zeros((1, 3)), d[:1])
    assert t[0] == pytest.approx(1.0, abs=1e-15)


def test_transformed_sphere_hits_lie_on_the_ellipsoid():
    rng = np.random.default_rng(3)
    c, s = math.cos(0.7), math.sin(0.7)
    m = np.array([[c, -s, 0, 0.3], [s, c, 0, -1.2], [0, 0, 1, 2.0], [0, 0, 0, 1]]) @ np.diag([2.5, 0.4, 1.1, 1.0])
    built = native.build(_sphere_scene(m)[0])
    targets = m[:3, 3] + rng.uniform(-0.3, 0.3, size=(500, 3))
    origins = targets + 10.0 * unit(rng.normal(size=(500, 3)))
    d = unit(targets - origins)
    t, prim = built.intersect(origins, d)
    assert (prim == 0).all()
    p = origins + t[:, None] * d
    p_object = (np.linalg.inv(m) @ np.c_[p, np.ones(len(p))].T).T[:, :3]
    np.testing.assert_allclose(np.linalg.norm(p_object, axis=1), 1.0, rtol=0, atol=1e-13)


def _general_sphere_t(m: np.ndarray, origin, d, t_min: float = 0.0) -> float:
    """shapes.hpp's sphere test with the full affine transform, transcribed term by term (numpy
    float64 scalars round as C++ does without fused multiply-adds), without its shortcuts (the
    sure-miss and leaving tests): the closest root > t_min."""
    o = [((m[k, 0] * origin[0] + m[k, 1] * origin[1]) + m[k, 2] * origin[2]) + m[k, 3] for k in range(3)]
    v = [(m[k, 0] * d[0] + m[k, 1] * d[1]) + m[k, 2] * d[2] for k in range(3)]
    dot = lambda x, y: (x[0] * y[0] + x[1] * y[1]) + x[2] * y[2]  # noqa: E731
    a, b, c = dot(v, v), dot(o, v), dot(o, o) - 1.0
    f = [o[k] - v[k] * (b / a) for k in range(3)]
    len_f = np.sqrt(dot(f, f))
    disc = a * (1.0 - len_f) * (1.0 + len_f)
    if not disc >= 0.0:
        return math.inf
    q = -(b + np.copysign(np.sqrt(disc), b))
    t0, t1 = (0.0, 0.0) if q == 0.0 else sorted((q / a, c / q))
    return t0 if t0 > t_min else (t1 if t1 > t_min else math.inf)


@pytest.mark.parametrize("centre", [(0.0, 0.0, 0.0), (-0.0, -0.0, -0.0), (1.5, -2.0, 0.25)])
def test_scaled_sphere_hits_equal_the_general_transform_bit_for_bit(centre):
    # A scaled, translated sphere is tested with the diagonal of its transform only (shapes.hpp,
    # axis_aligned); that differs from the full transform at most in the sign of a zero, which
    # flips the root formula (and the root by an ulp) when b = o·d is a zero of the other sign:
    # rays from the centre and the centre's planes (every sign of zero) along the axes must give
    # the general transform's bits, as must rays in general position. (Without the b = 0 fallback
    # rays from the centres of the mirrored spheres here differ by an ulp.)
    rng = np.random.default_rng(5)
    c = np.asarray(centre)
    offsets = (
        [np.array([x, y, z]) for x in (0.0, -0.0) for y in (0.0, -0.0) for z in (0.0, -0.0)]
        + [np.array([0.3, 0.0, -0.0]), np.array([0.0, -0.4, 0.0])]
        + list(rng.uniform(-3, 3, size=(8, 3)))
    )
    directions = [s * np.eye(3)[k] for k in range(3) for s in (1.0, -1.0)] + list(unit(rng.normal(size=(8, 3))))
    # Mirrored axes too: their inverses carry -0.0 translations and off-diagonal terms.
    for scales in rng.uniform(0.2, 3.0, size=(24, 3)) * rng.choice([1.0, -1.0], size=(24, 3)):
        m = np.diag([*scales, 1.0])
        m[:3, 3] = c
        scene = _sphere_scene(m)[0]
        object_from_world = native.scene_arrays(scene)["sphere_object_from_world"][0]
        origins = np.array([c + o for o in offsets for _ in directions])
        dirs = np.array([d for _ in offsets for d in directions])
        t, prim = native.build(scene).intersect(origins, dirs)
        expected = np.array([_general_sphere_t(object_from_world, o, d) for o, d in zip(origins, dirs)])
        assert np.isfinite(expected).sum() > len(expected) // 2  # the set-up hits the sphere
        assert np.array_equal(t, expected), np.c_[t, expected][t != expected]


@pytest.mark.parametrize("scale", [1e-6, 1.0, 1e6])
def test_the_sphere_tests_shortcuts_change_no_answer(scale):
    # shapes.hpp rejects two kinds of ray before the sphere test's division and square roots: a
    # sure miss (the closest approach beyond the radius by more than kSphereMissMargin) and a ray
    # leaving the sphere (b > 0) with both roots at most t_min. Both must give the full test's
    # bits: rays passing the silhouette at 1 ± 10^-16…10^-6 radii; rays leaving and entering
    # from points on the surface (computed, so just inside or outside), with t_min 0 or a
    # shadow window; and rays from just inside whose t_min is the exit root t1 and its
    # neighbouring doubles (the leaving test's margin). A rotated, stretched sphere and a scaled
    # one far from the origin, at three scales.
    rng = np.random.default_rng(11)
    c, s = math.cos(0.4), math.sin(0.4)
    rotated = np.array([[c, -s, 0, 0.3], [s, c, 0, -1.2], [0, 0, 1, 2.0], [0, 0, 0, 1]]) @ np.diag([1.5, 0.7, 1.1, 1])
    far = np.diag([1.0, 1.0, 1.0, 1.0])
    far[:3, 3] = (1e3, -2e3, 5e2)
    for m in (rotated, far):
        m = m.copy()
        m[:3, :] *= scale
        scene = _sphere_scene(m)[0]
        object_from_world = native.scene_arrays(scene)["sphere_object_from_world"][0]
        built = native.build(scene)
        inv = np.linalg.inv(m)
        n = 300
        # On the unit sphere in object space, mapped to the world: surface points and normals.
        u = unit(rng.normal(size=(n, 3)))
        surface = (m @ np.c_[u, np.ones(n)].T).T[:, :3]
        normal = unit((inv[:3, :3].T @ u.T).T)
        # Silhouette rays: from 20 radii out, aimed past the rim at 1 + δ in object space.
        offset = rng.choice([-1.0, 1.0], n) * 10.0 ** rng.uniform(-16, -6, n)
        side = unit(np.cross(u, rng.normal(size=(n, 3))))
        aim = (m @ np.c_[u * (1.0 + offset)[:, None], np.ones(n)].T).T[:, :3]
        start = (m @ np.c_[u * (1.0 + offset)[:, None] + 20.0 * side, np.ones(n)].T).T[:, :3]
        silhouette = (start, unit(aim - start), np.zeros(n))
        # From the surface: leaving (along the normal's side) and entering, t_min 0 or a window.
        d = unit(rng.normal(size=(n, 3)))
        d *= np.where((d * normal).sum(axis=1) > 0, 1.0, -1.0)[:, None]
        window = rng.choice([0.0, 1.9e-5 * scale, 1e-9 * scale], n)
        leaving = (surface, d, window)
        entering = (surface, -d, window)
        # From just inside: t_min at the exit root t1 and its neighbours.
        inside = (m @ np.c_[u * (1.0 - 1e-9), np.ones(n)].T).T[:, :3]
        t1 = np.array([_general_sphere_t(object_from_world, o, v) for o, v in zip(inside, d)])
        assert np.isfinite(t1).all()
        near = [np.nextafter(t1, 0), t1, np.nextafter(t1, np.inf), t1 * (1 - 1e-15), t1 * (1 + 1e-15)]
        exits = [(inside, d, t) for t in near]
        answers = {}
        for name, (origins, dirs, t_min) in {
            "silhouette": silhouette,
            "leaving": leaving,
            "entering": entering,
            **{f"exit {k}": e for k, e in enumerate(exits)},
        }.items():
            expected = np.array(
                [_general_sphere_t(object_from_world, o, v, lo) for o, v, lo in zip(origins, dirs, t_min)]
            )
            # (The binding takes one t_min for all its rays.)
            got = np.array(
                [built.intersect(origins[k : k + 1], dirs[k : k + 1], float(t_min[k]))[0][0] for k in range(n)]
            )
            assert np.array_equal(got, expected), (name, np.c_[got, expected][got != expected])
            answers[name] = np.isfinite(expected)
        # The cases are the hard ones: the silhouette rays split, the rays leaving the surface
        # miss but for self-hits at t ~ 1e-16 radii (from a point rounded inside, with t_min 0),
        # those entering hit, and the exit root counts exactly when t_min lies below it.
        assert 0.2 < answers["silhouette"].mean() < 0.8
        assert not answers["leaving"][leaving[2] > 0].any() and answers["entering"].mean() > 0.95
        assert answers["exit 0"].all() and not answers["exit 1"].any() and not answers["exit 2"].any()
    with pytest.raises(ValueError, match="t_min must be >= 0"):  # the tests' t_min >= 0, as the renderer's
        built.intersect(origins[:1], dirs[:1], -1e-3)


def test_bvh_closest_hit_equals_brute_force():
    rng = np.random.default_rng(11)
    v = rng.uniform(-5, 5, size=(3000, 3))
    tris = np.arange(3000).reshape(-1, 3)
    v[tris[:, 1]] = v[tris[:, 0]] + rng.normal(scale=0.4, size=(1000, 3))
    v[tris[:, 2]] = v[tris[:, 0]] + rng.normal(scale=0.4, size=(1000, 3))
    spheres = tuple(Sphere.at(tuple(rng.uniform(-5, 5, 3)), float(rng.uniform(0.05, 0.5))) for _ in range(60))
    scene = Scene(spheres=spheres, meshes=(TriangleMesh(points=v, triangles=tris),))
    built = native.build(scene)
    origins = rng.uniform(-8, 8, size=(4000, 3))
    d = unit(rng.normal(size=(4000, 3)))
    t, prim = built.intersect(origins, d)
    count, t_brute = built.count_hits(origins, d)
    assert np.array_equal(t, t_brute)
    assert np.array_equal(prim >= 0, count > 0)
    assert (count > 0).sum() > 500  # the test exercises many hits


# Large enough for the build's paths that only big nodes take (bvh.cpp: two alternating bin
# sets from 1024 primitives, the branch-free partition at every level): the trees of these
# layouts must find exactly the brute-force closest hits.
LARGE_BUILD_TRIANGLES = 20_000


def _large_layout(kind: str, rng: np.random.Generator) -> TriangleMesh:
    n = LARGE_BUILD_TRIANGLES
    if kind == "mesh order":  # neighbours in the list are neighbours in space, as in a real mesh
        grid = jittered_grid(100)
        points = grid.points * 0.1 - [5.0, 5.0, 0.0]
        points[:, 2] = np.sin(points[:, 0]) * np.cos(points[:, 1])
        return TriangleMesh(points=points, triangles=grid.triangles)
    corners = rng.uniform(-1, 1, size=(n, 3))
    if kind == "scales from 1e-3 to 1e3":  # exponentially spaced clusters
        corners *= 10.0 ** rng.uniform(-3, 3, size=(n, 1))
        size = np.abs(corners).max(axis=1, keepdims=True) * 0.05
    else:  # "coincident centroids": half the triangles share one centroid (unbinnable nodes)
        corners *= 5.0
        corners[: n // 2] = 0.0
        size = np.full((n, 1), 0.3)
    offsets = rng.normal(size=(n, 2, 3)) * size[:, None, :]
    v = np.concatenate([corners[:, None, :] + offsets, (corners - offsets.sum(axis=1))[:, None, :]], axis=1)
    return TriangleMesh(points=v.reshape(-1, 3), triangles=np.arange(3 * n).reshape(-1, 3))


@pytest.mark.parametrize("kind", ["mesh order", "scales from 1e-3 to 1e3", "coincident centroids"])
def test_large_builds_find_the_brute_force_closest_hits(kind):
    rng = np.random.default_rng(29)
    mesh = _large_layout(kind, rng)
    assert len(mesh.triangles) >= LARGE_BUILD_TRIANGLES * 0.98
    built = native.build(Scene(meshes=(mesh,)))
    extent = np.abs(mesh.points).max()
    targets = mesh.points[rng.integers(0, len(mesh.points), 3000)]
    origins = targets + unit(rng.normal(size=(3000, 3))) * extent * rng.uniform(0.01, 2.0, size=(3000, 1))
    d = unit(targets - origins + rng.normal(scale=1e-3, size=(3000, 3)) * np.abs(targets - origins))
    t, prim = built.intersect(origins, d)
    count, t_brute = built.count_hits(origins, d)
    assert np.array_equal(t, t_brute)
    assert np.array_equal(prim >= 0, count > 0)
    assert (count > 0).sum() > 1000  # aimed at the triangles: most rays hit


def test_coincident_primitives_resolve_to_the_lowest_id_whatever_the_bvh():
    # The same surface listed twice is hit at exactly the same t by both copies. The closest
    # hit is then the lower primitive id, not whichever copy the BVH happens to visit first
    # (the copies are listed in reverse order, so visiting order and id order disagree often).
    rng = np.random.default_rng(5)
    n = 400
    v = rng.uniform(-5, 5, size=(3 * n, 3))
    tris = np.arange(3 * n).reshape(-1, 3)
    v[tris[:, 1]] = v[tris[:, 0]] + rng.normal(scale=0.5, size=(n, 3))
    v[tris[:, 2]] = v[tris[:, 0]] + rng.normal(scale=0.5, size=(n, 3))
    spheres = tuple(Sphere.at(tuple(rng.uniform(-5, 5, 3)), float(rng.uniform(0.1, 0.6))) for _ in range(30))
    mesh = TriangleMesh(points=v, triangles=np.concatenate([tris, tris[::-1]]))
    built = native.build(Scene(spheres=spheres + spheres[::-1], meshes=(mesh,)))
    origins = rng.uniform(-8, 8, size=(6000, 3))
    d = unit(rng.normal(size=(6000, 3)))
    t, prim = built.intersect(origins, d)
    count, t_brute = built.count_hits(origins, d)
    assert np.array_equal(t, t_brute)
    hit = prim >= 0
    assert hit.sum() > 500 and (count[hit] >= 2).all()  # every hit is a tie of two copies
    n_spheres = 2 * len(spheres)
    on_sphere = hit & (prim < n_spheres)
    assert (prim[on_sphere] < len(spheres)).all()  # spheres: originals are 0..29
    on_triangle = hit & (prim >= n_spheres)
    assert on_sphere.sum() > 50 and on_triangle.sum() > 50
    assert (prim[on_triangle] - n_spheres < n).all()  # triangles: originals come first


# Flattening a Scene must not loop over elements in Python: a 1M-triangle mesh converts in well
# under a second (measured ~0.05 s); the budget leaves room for a loaded CI machine.
FLATTEN_1M_TRIANGLES_BUDGET_S = 1.0


@pytest.mark.slow
def test_a_million_triangles_flatten_fast_and_build():
    n = 708  # 2·707² ≈ 1.0e6 triangles
    xs, ys = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    points = np.stack([xs.ravel(), ys.ravel(), np.zeros(n * n)], axis=1)
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    tris = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    mesh = TriangleMesh(
        points=points, triangles=tris, normals=np.array([[0.0, 0.0, 1.0]]), normal_indices=np.zeros_like(tris)
    )
    scene = Scene(meshes=(mesh,))
    assert scene.triangle_count > 990_000
    start = time.perf_counter()
    arrays = native.scene_arrays(scene)
    assert time.perf_counter() - start < FLATTEN_1M_TRIANGLES_BUDGET_S
    assert sum(len(t) for t in arrays["triangles"]) == scene.triangle_count
    assert arrays["triangles"][0] is mesh.triangles and arrays["points"][0] is mesh.points  # no copies
    built = native._native.Scene(**arrays)
    t, prim = built.intersect(np.array([[0.37, 0.61, 1.0]]), np.array([[0.0, 0.0, -1.0]]))
    assert t[0] == pytest.approx(1.0) and prim[0] >= 0


def test_triangles_are_numbered_across_the_meshes_in_order():
    # Each mesh's arrays go to C++ as they are (one list entry per mesh); primitive ids count
    # spheres, then every mesh's triangles in mesh order.
    meshes = tuple(
        TriangleMesh(
            points=jittered_grid(6, seed=k).points + (0.0, 0.0, float(k)), triangles=jittered_grid(6, seed=k).triangles
        )
        for k in range(3)
    )
    spheres = (Sphere.at((3.0, 3.0, 10.0), 0.5),)
    built = native.build(Scene(spheres=spheres, meshes=meshes))
    rng = np.random.default_rng(3)
    origins = np.column_stack([rng.uniform(0.5, 5.5, (500, 2)), np.full(500, 20.0)])
    t, prim = built.intersect(origins, np.tile([0.0, 0.0, -1.0], (500, 1)))
    count, t_brute = built.count_hits(origins, np.tile([0.0, 0.0, -1.0], (500, 1)))
    assert np.array_equal(t, t_brute) and (count >= 3).all()
    # From z = 20 the first hit is the sphere (top at z = 10.5) or the top grid (z = 2, t = 18).
    on_sphere = t < 15.0
    assert on_sphere.any() and (~on_sphere).any() and (prim[on_sphere] == 0).all()
    assert np.allclose(t[~on_sphere], 18.0)
    per_mesh = len(meshes[0].triangles)
    assert ((prim[~on_sphere] >= 1 + 2 * per_mesh) & (prim[~on_sphere] < 1 + 3 * per_mesh)).all()


def test_mesh_lists_of_different_lengths_are_an_error_not_a_crash():
    arrays = native.scene_arrays(Scene(meshes=(jittered_grid(2),)))
    with pytest.raises(ValueError, match="mesh lists differ in length"):
        native._native.Scene(**dict(arrays, normals=[]))
    with pytest.raises(ValueError, match="one row per triangle"):
        native._native.Scene(**dict(arrays, normal_indices=[np.zeros((1, 3), np.int32)]))


@pytest.mark.parametrize("bad", [-1, 9])  # the 3x3 grid has points 0..8
def test_a_triangle_index_out_of_range_is_an_error_not_a_crash(bad):
    # The C++ build checks every corner (Python validates first; this is the assertion behind it).
    arrays = native.scene_arrays(Scene(meshes=(jittered_grid(2),)))
    triangles = arrays["triangles"][0].copy()
    triangles[5, 1] = bad
    with pytest.raises(ValueError, match=f"triangle vertex index {bad} out of range"):
        native._native.Scene(**dict(arrays, triangles=[triangles]))


@pytest.mark.parametrize("threads", [1, 2, 3])
def test_the_first_bad_index_is_the_error_on_any_number_of_threads(threads):
    # A mesh past for_chunks' 2^16 rows (build_threads.hpp) is checked in chunks that the build's
    # threads take in turn; with two bad corners, the error is always the first one's, as a
    # serial check reports it, whichever thread met which.
    arrays = native.scene_arrays(Scene(meshes=(jittered_grid(200),)))  # 80,000 triangles
    triangles = arrays["triangles"][0].copy()
    assert len(triangles) > 2**16
    first_bad, later_bad = -7, len(arrays["points"][0]) + 5
    triangles[len(triangles) // 3, 2] = first_bad
    triangles[len(triangles) - 10, 0] = later_bad
    with native.build_threads(threads):
        for _ in range(3):
            with pytest.raises(ValueError, match=f"triangle vertex index {first_bad} out of range"):
                native._native.Scene(**dict(arrays, triangles=[triangles]))


@pytest.mark.parametrize("t_min", [0.0, 1e-9])  # the double-precision and the float box test (bvh4.hpp)
def test_occluded_answers_whether_a_hit_lies_before_t_max(t_min):
    # Scene.occluded (the any-hit walk of shadow rays) against the closest hit: blocked exactly
    # when the closest hit beyond t_min comes before t_max; spheres and triangles, rays that end
    # just before, at and just after their hit.
    rng = np.random.default_rng(7)
    scene = Scene(
        spheres=tuple(Sphere.at(tuple(rng.uniform(-3, 3, 3)), float(rng.uniform(0.2, 0.8))) for _ in range(6)),
        meshes=(jittered_grid(8),),
    )
    built = native.build(scene)
    origins = np.column_stack([rng.uniform(-1, 9, 3000), rng.uniform(-1, 9, 3000), rng.uniform(2, 6, 3000)])
    dirs = unit(np.column_stack([rng.normal(0, 0.5, 3000), rng.normal(0, 0.5, 3000), -np.ones(3000)]))
    t, _ = built.intersect(origins, dirs, t_min)
    hit = np.isfinite(t)
    assert hit.sum() > 1000
    ends = np.where(hit, t, 10.0)
    for t_max, blocked in [(np.nextafter(ends, 0), False), (ends, False), (np.nextafter(ends, np.inf), True)]:
        assert np.array_equal(built.occluded(origins, dirs, t_max, t_min), hit & blocked)
    assert not built.occluded(origins, dirs, np.full(3000, np.inf), t_min)[~hit].any()
