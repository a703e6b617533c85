# SPDX-License-Identifier: Apache-2.0
"""Primary rays in packets (backends/native/src/bvh8_packet.hpp, ray_packets.cpp): 32 rays
from one origin walk the 8-wide tree together and each gets, bit for bit, the hit closest_hit()
gives it alone (t, primitive, barycentrics), on every kind of leaf (the float prefilter's
triangle runs, spheres, intrinsic shapes), with unbounded planes and instances after the tree,
on coincident surfaces (ties to the lower id), on grazing rays, at tiny and huge scales and far
from the origin; packets whose directions cannot share the interval test (mixed signs, a zero
component) fall back to single rays. And the render that uses them gives the image of the
single-ray pixel loop."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_native_simd_dispatch import needs_avx2, render_with
from test_native_triangle_prefilter import jittered_grid

from phongscene.backends import native
from phongscene.scene import (
    AmbientLight,
    Camera,
    Intrinsic,
    PhongMaterial,
    PointLight,
    RenderSettings,
    Scene,
    Sphere,
    TriangleMesh,
)
from phongscene.usd import load_usd
from support.instanced_stages import point_instancer_stage

PACKET = 32  # kPacketRays
# A camera's primary rays start where the near tolerance puts them (math.hpp: ray_tolerances);
# any t_min in the float test's range works the same here.
T_MIN = 1e-9


def camera_block_dirs(forward, width: int, height: int, fov: float = 0.6) -> np.ndarray:
    """Unit directions of a perspective camera looking along ``forward``, in 8 x 4 pixel blocks
    (the order the render traces them in), ``width`` a multiple of 8 and ``height`` of 4."""
    f = np.asarray(forward, float)
    f /= np.linalg.norm(f)
    right = np.cross(f, [0.0, 1.0, 0.0] if abs(f[1]) < 0.9 else [1.0, 0.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, f)
    u = (np.arange(width) + 0.5) / width - 0.5
    v = 0.5 - (np.arange(height) + 0.5) / height
    d = f + fov * (u[None, :, None] * right + v[:, None, None] * up * height / width)
    blocks = d.reshape(height // 4, 4, width // 8, 8, 3).transpose(0, 2, 1, 3, 4).reshape(-1, 3)
    return blocks / np.linalg.norm(blocks, axis=1, keepdims=True)


def assert_packets_match(
    built, origin, dirs, t_min=T_MIN, walked_at_least: float = 0.0, brute_force: bool = True
) -> int:
    t, ids, bary, walked = built.intersect_packets(origin, dirs, t_min, True)
    t1, ids1, bary1, none = built.intersect_packets(origin, dirs, t_min, False)
    assert none == 0
    differ = np.flatnonzero((t != t1) | (ids != ids1) | (bary != bary1).any(axis=1))
    assert differ.size == 0, (
        f"{differ.size} of {len(t)} rays differ from their single walk, e.g. dir {dirs[differ[0]].tolist()}: "
        f"{t[differ[0]]}/{ids[differ[0]]} against {t1[differ[0]]}/{ids1[differ[0]]}"
    )
    packets = -(-len(dirs) // PACKET)
    assert walked >= walked_at_least * packets, (walked, packets)
    if brute_force:  # and the single walk is the right answer: the closest hit among the world's primitives
        count, t_brute = built.count_hits(np.tile(origin, (len(dirs), 1)), dirs, t_min)
        assert np.array_equal(t1, t_brute)
    return int(np.isfinite(t).sum())


@needs_avx2
@pytest.mark.parametrize("scale", [1e-4, 1.0, 1e5])
@pytest.mark.parametrize("offset", [(0.0, 0.0, 0.0), (3e3, -2e3, 1e3)])
def test_a_float_mesh_through_the_prefilter(scale, offset):
    mesh = jittered_grid(24, scale, np.asarray(offset) * scale, seed=2)
    built = native.build(Scene(meshes=(mesh,)))
    assert built.walk_width == 8 and built.single_precision_triangles
    centre = mesh.points.mean(axis=0)
    origin = centre + np.array([0.1, 0.2, 1.3]) * scale
    dirs = camera_block_dirs(centre - origin, 96, 64, fov=1.2)
    hits = assert_packets_match(built, origin, dirs, T_MIN * scale, walked_at_least=0.8)
    assert hits > 0.5 * len(dirs)


@needs_avx2
def test_spheres_intrinsics_planes_and_a_double_mesh():
    rng = np.random.default_rng(4)
    spheres = tuple(Sphere.at(tuple(rng.uniform(-3, 3, 3)), float(rng.uniform(0.2, 0.8))) for _ in range(40))
    box = np.diag([0.7, 0.4, 0.9, 1.0])
    box[:3, 3] = [0.5, -0.5, 0.2]
    floor = np.eye(4)
    floor[:3, :3] = [[1, 0, 0], [0, 0, -1], [0, 1, 0]]  # z up -> y up
    floor[1, 3] = -3.5
    mesh = jittered_grid(8, 3.0, (0.1, 0.2, -3.0), seed=1)
    double_mesh = TriangleMesh(points=mesh.points + [1e-3, 0.0, 0.0], triangles=mesh.triangles)
    scene = Scene(
        spheres=spheres,
        meshes=(double_mesh,),
        intrinsics=(
            Intrinsic("cube", box, source="/Box"),
            Intrinsic("cylinder", np.diag([0.3, 0.3, 1.5, 1.0]), source="/Post"),
            Intrinsic("plane", floor, source="/Floor", infinite=True),
        ),
    )
    built = native.build(scene)
    assert not built.single_precision_triangles
    origin = np.array([0.3, 1.0, 9.0])
    dirs = camera_block_dirs([0.0, -0.2, -1.0], 64, 48, fov=1.0)
    hits = assert_packets_match(built, origin, dirs, walked_at_least=0.8)
    assert hits > 0.7 * len(dirs)


@needs_avx2
def test_sphere_leaves_in_lanes_on_every_sphere_path():
    # Leaves of spheres alone take a packet's rays four at a time (sphere_lanes.hpp): rotated,
    # non-uniformly scaled ellipsoids (the full transform), scaled and translated spheres (the
    # axis-aligned one), and rays from a sphere's centre, whose b = o·d is zero in every lane (the
    # scalar test's sign rule), each ray's hit its own walk's to the bit.
    rng = np.random.default_rng(12)
    ellipsoids = []
    for _ in range(12):
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        m = np.eye(4)
        m[:3, :3] = q @ np.diag(rng.uniform(0.2, 0.9, 3))
        m[:3, 3] = rng.uniform(-3, 3, 3)
        ellipsoids.append(Sphere(m))
    spheres = (*ellipsoids, *(Sphere.at(tuple(rng.uniform(-3, 3, 3)), float(rng.uniform(0.2, 0.6))) for _ in range(12)))
    built = native.build(Scene(spheres=spheres))
    dirs = camera_block_dirs([0.05, -0.1, -1.0], 128, 64, fov=1.2)
    assert assert_packets_match(built, np.array([0.2, 0.4, 8.0]), dirs, walked_at_least=0.8) > 0.2 * len(dirs)
    # From the centre of a sphere (its object-space origin is 0), to its inside wall.
    inside = native.build(Scene(spheres=(Sphere.at((1.0, -2.0, 0.5), 3.0), Sphere.at((1.5, -2.0, -1.5), 0.4))))
    for forward in ([0.3, 0.2, -1.0], [-1.0, 0.6, 0.4]):  # every packet of one sign per axis
        centre_dirs = camera_block_dirs(forward, 32, 16, fov=0.5)
        assert assert_packets_match(inside, np.array([1.0, -2.0, 0.5]), centre_dirs, walked_at_least=0.8) == len(
            centre_dirs
        )


def _quads(centres, size: float, double: bool) -> TriangleMesh:
    """Separate quads in the plane z = 0, two triangles each (so every leaf holds two triangles
    or so: none the float prefilter takes), the second quad of each pair wound the other way;
    ``double``: corners that are not floats (a mesh stored in double, no prefilter at all)."""
    points, triangles = [], []
    for k, (x, y) in enumerate(centres):
        h = 0.5 * size
        points += [(x - h, y - h, 0.0), (x + h, y - h, 0.0), (x + h, y + h, 0.0), (x - h, y + h, 0.0)]
        q = 4 * k
        triangles += [(q, q + 1, q + 2), (q, q + 2, q + 3)] if k % 2 == 0 else [(q, q + 2, q + 1), (q, q + 3, q + 2)]
    points = np.asarray(points, np.float32).astype(float)
    if double:
        points += np.array([1e-3 / 3.0, 0.0, 0.0])
    return TriangleMesh(points=points, triangles=np.asarray(triangles))


@needs_avx2
@pytest.mark.parametrize("double", [False, True])
def test_triangle_leaves_in_lanes(double):
    # Leaves of triangles that each ray tests in full take a packet's rays four at a time
    # (triangle_lanes.hpp), each ray's hit its own walk's to the bit: quads seen from the front
    # and the back, rays exactly through their diagonals (an edge function of exactly zero:
    # those lanes take the scalar test's ownership rule), and packets whose rays' dominant axes
    # differ (ray by ray).
    rng = np.random.default_rng(21)
    centres = rng.uniform(-4, 4, size=(40, 2))
    built = native.build(Scene(meshes=(_quads(centres, 0.9, double),)))
    assert built.single_precision_triangles != double
    for origin in ([0.2, -0.3, 6.0], [0.1, 0.4, -5.0]):  # above, and below (the back faces)
        dirs = camera_block_dirs(-np.asarray(origin), 128, 64, fov=1.6)
        assert assert_packets_match(built, np.asarray(origin), dirs, walked_at_least=0.8) > 0.2 * len(dirs)
    # Through the diagonal of a quad centred below the eye: dx = dy exactly, so the sheared
    # corners on the diagonal give u, v or w = 0 in every lane.
    diagonal = native.build(Scene(meshes=(_quads([(0.0, 0.0), (3.0, 3.0)], 2.0, double),)))
    steps = np.linspace(-0.3, 0.3, PACKET * 4)
    through = np.stack([steps, steps, -np.ones_like(steps)], axis=1)
    through /= np.linalg.norm(through, axis=1, keepdims=True)
    for half in (through[steps < 0], through[steps > 0]):  # one sign per axis in a packet, as packets need
        assert assert_packets_match(diagonal, np.array([0.0, 0.0, 1.0]), half, walked_at_least=0.8) == len(half)
    # Dominant axes that differ within every packet: rays at about 45° between -z and +x, x
    # and z dominant in turn.
    k = np.arange(PACKET * 40)
    turns = np.stack(
        [1.0 + np.where(k % 2 == 0, 0.01, -0.01), np.linspace(-0.6, 0.6, k.size), -np.ones(k.size)], axis=1
    )
    turns /= np.linalg.norm(turns, axis=1, keepdims=True)
    assert assert_packets_match(built, np.array([-6.0, 0.1, 6.0]), turns, walked_at_least=0.8) > 0.1 * len(turns)


@needs_avx2
def test_coincident_surfaces_tie_to_the_lower_id():
    # The same grid twice, and a sphere tangent to it: exact ties at every hit.
    mesh = jittered_grid(10, 2.0, (-1.0, -1.0, 0.0), seed=3)
    scene = Scene(meshes=(mesh, mesh), spheres=(Sphere.at((0.0, 0.0, 0.5), 0.5),))
    built = native.build(scene)
    dirs = camera_block_dirs([0.0, 0.05, -1.0], 32, 16, fov=0.8)
    assert assert_packets_match(built, np.array([0.0, 0.0, 3.0]), dirs) > 0.5 * len(dirs)
    t, ids, _, _ = built.intersect_packets(np.array([0.0, 0.0, 3.0]), dirs, T_MIN, True)
    mesh_hits = ids[(ids >= 1) & np.isfinite(t)]
    assert mesh_hits.size > 0 and (mesh_hits <= mesh.triangles.shape[0]).all()  # the first copy's


@needs_avx2
@pytest.mark.parametrize("lift", [0.0, 1e-9, -1e-9, 1e-4])
def test_grazing_packets(lift):
    # The eye a hair above, in or below a flat grid's plane, looking along it.
    mesh = jittered_grid(16, 4.0, (0.0, 0.0, 0.0), seed=7)
    flat = TriangleMesh(points=mesh.points * [1.0, 1.0, 0.0], triangles=mesh.triangles)
    built = native.build(Scene(meshes=(flat,)))
    origin = np.array([-0.5, 2.0, lift])
    dirs = camera_block_dirs([1.0, 0.01, -1e-3], 32, 8, fov=0.3)
    assert_packets_match(built, origin, dirs)


@needs_avx2
def test_divergent_packets_fall_back_to_single_rays():
    mesh = jittered_grid(8, 2.0, (-1.0, -1.0, 0.0), seed=5)
    built = native.build(Scene(meshes=(mesh,), spheres=(Sphere.at((0.0, 0.0, 0.4), 0.3),)))
    origin = np.array([0.0, 0.0, 2.0])
    rng = np.random.default_rng(8)
    mixed = rng.normal(size=(PACKET * 20, 3)) + [0.0, 0.0, -2.0]  # x and y signs differ within a packet
    mixed /= np.linalg.norm(mixed, axis=1, keepdims=True)
    _, _, _, walked = built.intersect_packets(origin, mixed, T_MIN, True)
    assert walked < 20
    assert_packets_match(built, origin, mixed)
    # A zero component (a ray along an axis) has no finite inverse: that packet walks ray by ray.
    axis = camera_block_dirs([0.0, 0.0, -1.0], 8, 4, fov=0.1)
    axis[3] = [0.0, 0.0, -1.0]
    assert built.intersect_packets(origin, axis, T_MIN, True)[3] == 0
    assert_packets_match(built, origin, axis)
    # Partial packets (fewer than 32 rays: part of an AVX word, a word and a part, three words
    # and a part) and a lone ray.
    block = camera_block_dirs([0.3, 0.3, -1.0], 8, 4, fov=0.1)
    for count in (5, 11, 27):
        assert_packets_match(built, origin, block[:count], walked_at_least=0.8)
    assert built.intersect_packets(origin, block[:1], T_MIN, True)[3] == 0


@needs_avx2
@settings(max_examples=40, deadline=None)
@given(
    scale_exponent=st.integers(-4, 5),
    offset=st.tuples(*[st.floats(-1e4, 1e4)] * 3),
    spread=st.sampled_from([1e-6, 1e-3, 0.3, 2.0]),
    seed=st.integers(0, 2**32 - 1),
)
def test_random_packets(scale_exponent, offset, spread, seed):
    scale = 10.0**scale_exponent
    rng = np.random.default_rng(seed)
    mesh = jittered_grid(10, scale, np.asarray(offset) * scale, seed=seed % 1000)
    centre = mesh.points.mean(axis=0)
    sphere = Sphere.at(tuple(centre + [0.0, 0.0, 0.2 * scale]), 0.15 * scale)
    built = native.build(Scene(meshes=(mesh,), spheres=(sphere,)))
    origin = centre + rng.normal(size=3) * scale + [0.0, 0.0, 1.5 * scale]
    forward = centre - origin
    dirs = forward + spread * np.linalg.norm(forward) * rng.normal(size=(PACKET * 12, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    assert_packets_match(built, origin, dirs, T_MIN * scale)


@needs_avx2
def test_instances_after_the_tree(tmp_path):
    # 64 instanced copies beside the world's own ground: the instance layer answers each ray
    # after the packet's walk, as it does after a single ray's.
    scene = load_usd(point_instancer_stage(tmp_path / "pi.usda", 64, rings=12, sides=8))
    ground = TriangleMesh(points=[[-9, -3, -9], [9, -3, -9], [9, -3, 9], [-9, -3, 9]], triangles=[[0, 2, 1], [0, 3, 2]])
    built = native.build(dataclasses.replace(scene, meshes=scene.meshes + (ground,)))
    assert built.instance_count == 64
    origin = np.array(scene.camera.position)
    dirs = camera_block_dirs(-origin, 48, 32, fov=1.0)
    hits = assert_packets_match(built, origin, dirs, walked_at_least=0.8, brute_force=False)
    t, ids, _, _ = built.intersect_packets(origin, dirs, T_MIN, True)
    assert (ids <= -2).sum() > 100 and hits > 0.5 * len(dirs)


def _s1_like(width: int, height: int) -> Scene:
    spheres = tuple(
        Sphere.at((x, r, 0.3 * i - 0.5), r, PhongMaterial(ka=0.15, kd=0.75, ks=0.5, exponent=e))
        for i, (x, r, e) in enumerate(zip([-3.0, -1.2, 0.8, 3.0], [0.6, 0.7, 0.8, 0.9], [5.0, 20.0, 100.0, 1000.0]))
    )
    ground = TriangleMesh(
        points=[(-50, 0, -50), (50, 0, -50), (50, 0, 50), (-50, 0, 50)], triangles=[(0, 2, 1), (0, 3, 2)]
    )
    return Scene(
        camera=Camera.look_at((0.0, 2.6, 7.5), (0.0, 0.6, 0.0), 60.0),
        ambient=AmbientLight((0.25, 0.25, 0.28)),
        lights=(PointLight((5.0, 8.0, 6.0), (2.4, 2.3, 2.2)), PointLight((-6.0, 5.0, 3.0), (0.9, 1.0, 1.2))),
        spheres=spheres,
        meshes=(ground, jittered_grid(20, 2.0, (-1.0, 0.3, 1.0), seed=4)),
        settings=RenderSettings(width=width, height=height, samples=1),
    )


@pytest.mark.parametrize("size", [(64, 36), (37, 23)])  # whole blocks, and partial ones at the edges
def test_the_packet_render_is_the_single_ray_render(size):
    # One sample per pixel on the grid takes the packets; POV-Ray's +AM1 without a threshold at
    # one sample traces the same centre twice, ray by ray, and averages two equal colours (c + c
    # and the halving are exact): the single-ray loop's image.
    scene = _s1_like(*size)
    packets = native.render(scene)
    single = native.render(
        dataclasses.replace(
            scene, settings=dataclasses.replace(scene.settings, sample_pattern="povray-am1", aa_threshold=0.0)
        )
    )
    assert packets.max() > 0.1
    assert np.array_equal(packets.view(np.uint32), single.view(np.uint32))


@needs_avx2
@pytest.mark.parametrize(
    "pattern",
    [
        {"samples": 1, "sample_pattern": "grid"},
        {"samples": 3, "sample_pattern": "grid"},  # nine samples a pixel: one partial packet
        {"samples": 6, "sample_pattern": "grid"},  # 36: a packet of 32 and one of 4
        {"samples": 4, "sample_pattern": "stratified", "aa_threshold": 0.0},  # stages of 16
        {"samples": 8, "sample_pattern": "stratified", "aa_threshold": 0.05},  # corners, then stages
    ],
)
def test_every_pattern_in_packets_is_the_portable_paths_image(monkeypatch, pattern):
    # The SSE2 path has no packet walk (the 4-wide tree: closest_hit_packet walks every ray
    # alone); the AVX2 path walks the grid's and the stratified estimator's samples in packets.
    # The same bytes. (The pixel loop's sums are the oracle's to 1e-6: test_native_render.py.)
    # A close light over a jittered mesh filling the view: every sample of a pixel shades
    # differently, so a sum taken in another order would differ in its last bits.
    mesh = jittered_grid(30, 6.0, (-3.0, -3.0, 0.0), seed=6)
    scene = Scene(
        camera=Camera.look_at((0.3, -0.4, 4.0), (0.0, 0.0, 0.0), 50.0),
        ambient=AmbientLight((0.1, 0.1, 0.1)),
        lights=(PointLight((0.5, 0.8, 1.2), (1.5, 1.4, 1.3)),),
        spheres=(Sphere.at((0.4, 0.2, 0.5), 0.4, PhongMaterial(ka=0.1, kd=0.6, ks=0.6, exponent=40.0)),),
        meshes=(dataclasses.replace(mesh, material=PhongMaterial(ka=0.1, kd=0.8, ks=0.3, exponent=10.0)),),
        settings=dataclasses.replace(RenderSettings(width=40, height=22), **pattern),
    )
    packets = native.render(scene)
    single = render_with(monkeypatch, scene, "sse2")
    assert packets.max() > 0.1
    assert np.array_equal(packets.view(np.uint32), single.view(np.uint32))
