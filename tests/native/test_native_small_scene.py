# SPDX-License-Identifier: Apache-2.0
"""A scene of a few primitives skips the BVH (backends/native/src/small_scene.hpp): on the AVX2
path each ray rejects every sphere and every triangle's box at once in double lanes, and only the
primitives left take their exact test. The rejections are those of the exact tests themselves
(the sphere test's "leaving" and "sure miss" shortcuts, the tree's double box test), so every
answer must be the tree's (the SSE2 path, PHONGSCENE_NATIVE_SIMD=sse2, walks it) and brute
force's, bit for bit: on shadow rays leaving the surfaces, rays grazing the spheres, rays in the
ground's plane, at tiny and huge scales, and in whole images."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_native_bvh4 import T_MINS, unit
from test_native_simd_dispatch import built_with, needs_avx2, render_with

from phongscene.backends import native
from phongscene.scene import Camera, Intrinsic, Points, Sphere, TriangleMesh
from support import calibration

# A shadow ray's window beyond its origin, per scene unit (the renderer's is of this order: math.hpp).
SHADOW_WINDOW = 1e-9


def course(scale: float = 1.0, offset: float = 0.0, sphere_count: int = 4, max_depth: int = 1):
    """The spheres of a course's figure on a ground quad (two triangles): a unit sphere, small
    ones, one stretched along its axes (axis-aligned: the lanes' case), one a mirror; all scaled
    by `scale` and moved by `offset` along x."""
    red, mirror = calibration.RED, dataclasses.replace(calibration.GOLD, kr=0.6)
    shift = np.array([offset, 0.0, 0.0])
    spheres = [
        Sphere.at(tuple(np.array([0.07, 1.08, -0.13]) * scale + shift), 1.03 * scale, red),
        Sphere.at(tuple(np.array([-1.6, 0.7, 0.9]) * scale + shift), 0.7 * scale, mirror),
        Sphere(
            calibration.translation(np.array([1.7, 0.45, 0.6]) * scale + shift)
            @ calibration.scaling(np.array([0.6, 0.45, 0.3]) * scale),
            calibration.GREEN,
        ),
        Sphere.at(tuple(np.array([0.9, 0.25, 1.7]) * scale + shift), 0.25 * scale, red),
    ]
    rng = np.random.default_rng(3)
    while len(spheres) < sphere_count:
        spheres.append(
            Sphere.at(tuple(rng.uniform(-3, 3, 3) * scale + shift), float(rng.uniform(0.1, 0.4)) * scale, red)
        )
    ground = calibration.ground_quad(0.0, calibration.GROUND)
    ground = dataclasses.replace(ground, points=np.asarray(ground.points) * scale + shift)
    scene = calibration.mirror_floor()
    camera = calibration.look_at(np.array([0.3, 2.6, 7.5]) * scale + shift, np.array([0.0, 0.6, 0.0]) * scale + shift)
    lights = tuple(
        dataclasses.replace(light, position=tuple(np.asarray(light.position) * scale + shift)) for light in scene.lights
    )
    return dataclasses.replace(
        scene,
        camera=camera,
        lights=lights,
        spheres=tuple(spheres[:sphere_count]),
        meshes=(ground,),
        settings=dataclasses.replace(scene.settings, max_depth=max_depth),
    )


def sphere_surface_points(scene, rng, per_sphere: int) -> np.ndarray:
    """Points on each sphere's surface (the unit sphere through its matrix), as a hit leaves them."""
    points = []
    for sphere in scene.spheres:
        m = np.asarray(sphere.world_from_object)
        local = unit(rng.normal(size=(per_sphere, 3)))
        points.append(local @ m[:3, :3].T + m[:3, 3])
    return np.concatenate(points)


def hard_rays(scene, scale: float, offset: float):
    """(origins, dirs, t_min, t_max) of shadow rays from the spheres' surfaces and the ground to
    the lights and random targets, rays grazing each sphere's silhouette, and rays in and just
    off the ground's plane with a ±0 vertical direction."""
    rng = np.random.default_rng(11)
    starts = np.concatenate(
        [
            sphere_surface_points(scene, rng, 60),
            np.column_stack([rng.uniform(-4, 4, 120) * scale + offset, np.zeros(120), rng.uniform(-4, 4, 120) * scale]),
        ]
    )
    targets = np.concatenate(
        [np.array([light.position for light in scene.lights]), rng.uniform(-5, 5, (6, 3)) * scale + [offset, 0, 0]]
    )
    origins = np.repeat(starts, len(targets), axis=0)
    to = np.tile(targets, (len(starts), 1)) - origins
    distance = np.linalg.norm(to, axis=1)
    dirs = to / distance[:, None]
    window = SHADOW_WINDOW * scale
    t_min, t_max = np.full(len(origins), window), distance - window
    # Grazing: from far off, past each sphere's centre at 1 ± 1e-16 … 1e-6 of its (x) radius.
    graze = []
    for sphere in scene.spheres:
        m = np.asarray(sphere.world_from_object)
        for rel in (1e-16, 1e-12, 1e-6):
            for side in (1.0 - rel, 1.0 + rel):
                through = m[:3, 3] + np.array([m[0, 0] * side, 0.0, 0.0])
                graze.append((through - np.array([0.0, 0.0, 20.0 * scale]), [0.0, 0.0, 1.0]))
                graze.append((through - np.array([0.0, 20.0 * scale, 0.0]), [0.0, 1.0, 0.0]))
    # Rays at the ground's corners, each extreme in x or z: the hit lies on its box's face,
    # where an unwidened far plane can cull it.
    corners = np.asarray(scene.meshes[0].points)
    for corner in corners:
        for d in unit(rng.normal(size=(60, 3)) * [1.0, 0.2, 1.0] - [0.0, 1.0, 0.0]):
            graze.append((corner - 9.0 * scale * d, d))
    # The ground's plane: along it at height 0 and ±1e-300, direction y = ±0 (1/±0 = ±inf).
    for height in (0.0, 1e-300, -1e-300):
        for zero in (0.0, -0.0):
            for x in (-3.0, 0.0, 2.5):
                graze.append(([x * scale + offset, height, -80.0 * scale], [0.0, zero, 1.0]))
    g_origins = np.array([o for o, _ in graze], dtype=np.float64)
    g_dirs = np.array([d for _, d in graze], dtype=np.float64)
    return (
        np.concatenate([origins, g_origins]),
        np.concatenate([dirs, g_dirs]),
        np.concatenate([t_min, np.full(len(g_origins), window)]),
        np.concatenate([t_max, np.full(len(g_origins), np.inf)]),
    )


@needs_avx2
def test_which_scenes_are_small(monkeypatch):
    assert native.build(course()).small_scene
    assert native.build(course(sphere_count=8)).small_scene
    assert not built_with(monkeypatch, course(), "sse2").small_scene  # the portable path walks its tree
    assert not native.build(course(sphere_count=9)).small_scene
    assert not native.build(calibration.transformed_spheres()).small_scene  # rotated ellipsoids: the tree
    assert not native.build(calibration.smooth_mesh()).small_scene  # 80 triangles
    points = Points(centers=np.zeros((1, 3)), radii=np.ones(1), material=calibration.RED)
    assert not native.build(dataclasses.replace(course(), points=(points,))).small_scene


@needs_avx2
@pytest.mark.parametrize("path", sorted(T_MINS))
@pytest.mark.parametrize("spheres", [4, 8])  # one group of lanes, two
@pytest.mark.parametrize("scale, offset", [(1e-6, 0.0), (1.0, 0.0), (1e6, 0.0), (1.0, 1e7)])
def test_answers_equal_the_tree_and_brute_force(monkeypatch, path, spheres, scale, offset):
    scene = course(scale, offset, sphere_count=spheres)
    small, tree = native.build(scene), built_with(monkeypatch, scene, "sse2")
    assert small.small_scene and not tree.small_scene
    origins, dirs, t_min, t_max = hard_rays(scene, scale, offset)
    # Shadow rays, one window at a time (occluded takes one t_min).
    for window in np.unique(t_min):
        rows = t_min == window
        o, d, limit = origins[rows], dirs[rows], t_max[rows]
        blocked = small.occluded(o, d, limit, window)
        assert np.array_equal(blocked, tree.occluded(o, d, limit, window))
        _, t_closest = small.count_hits(o, d, window)
        assert np.array_equal(blocked, t_closest < limit)
        assert 0 < np.count_nonzero(blocked) < len(blocked)  # both answers occur
    # Windows that end one double past the closest hit: it still blocks (the boxes' limit is
    # widened past t_max, as the tree's is: a flat box is entered where its triangles are hit).
    # The tree's double box test (its fallback, taken at t_min = 0) is uncapped too: it culled
    # 64–82 of these rays' hits before (bvh.hpp, kAnyHitBoxLimit).
    for window in (SHADOW_WINDOW * scale, 0.0):
        _, t_closest = small.count_hits(origins, dirs, window)
        hit = np.isfinite(t_closest)
        just_past = np.nextafter(t_closest[hit], np.inf)
        assert small.occluded(origins[hit], dirs[hit], just_past, window).all()
        assert tree.occluded(origins[hit], dirs[hit], just_past, window).all()
    # Closest hits from the same origins (T_MINS: the tree's float and double box tests).
    floor = T_MINS[path] * scale
    t, prim = small.intersect(origins, dirs, floor)
    t_tree, prim_tree = tree.intersect(origins, dirs, floor)
    assert np.array_equal(t, t_tree) and np.array_equal(prim, prim_tree)
    _, t_brute = small.count_hits(origins, dirs, floor)
    assert np.array_equal(t, t_brute)


@needs_avx2
@pytest.mark.parametrize("spheres", [4, 8])
@pytest.mark.parametrize("scale", [1e-6, 1.0, 1e6])
def test_primary_packets_equal_the_tree(monkeypatch, spheres, scale):
    # Rays from one eye through the spheres' silhouettes and the ground's far edge, eight at a
    # time as a render traces them: hits, primitives and barycentrics as the tree's, and as one
    # by one.
    scene = course(scale, sphere_count=spheres)
    small, tree = native.build(scene), built_with(monkeypatch, scene, "sse2")
    eye = np.asarray(scene.camera.position)
    rng = np.random.default_rng(5)
    aims = np.concatenate([sphere_surface_points(scene, rng, 200), rng.uniform(-60, 60, (400, 3)) * scale])
    dirs = unit(aims - eye)
    t_min = T_MINS["float"] * scale
    together = small.intersect_packets(eye, dirs, t_min)
    alone = small.intersect_packets(eye, dirs, t_min, together=False)
    by_tree = tree.intersect_packets(eye, dirs, t_min)
    for a, b, c in zip(together[:3], alone[:3], by_tree[:3]):
        assert np.array_equal(a, b) and np.array_equal(a, c)
    assert np.count_nonzero(together[1] >= 0) > len(dirs) // 2


@needs_avx2
@pytest.mark.parametrize("camera", ["perspective", "orthographic"])
def test_images_equal_the_trees(monkeypatch, camera):
    # Shadows from two lights, a mirror sphere (secondary rays: the single-ray closest hit), and
    # an orthographic camera (its primary rays one by one): the image of the tree, to the bit.
    scene = course(max_depth=3)
    if camera == "orthographic":
        c = scene.camera
        scene = dataclasses.replace(
            scene, camera=Camera(c.position, c.forward, c.up, projection="orthographic", ortho_width=6.0)
        )
    assert native.build(scene).small_scene
    small, tree = render_with(monkeypatch, scene, "avx2"), render_with(monkeypatch, scene, "sse2")
    assert small.tobytes() == tree.tobytes()
    assert np.count_nonzero(small) > small.size // 2


@needs_avx2
def test_an_unbounded_plane_and_too_many_triangles(monkeypatch):
    # An unbounded plane (outside every tree) under the course's spheres in place of the ground
    # keeps the scene small: its shadows and hits come after the lanes, as after the walk. Ten
    # triangles do not: the tree.
    down = calibration.translation((0.0, -0.001, 0.0)) @ calibration.rotation((1.0, 0.0, 0.0), -90.0)
    plane = Intrinsic("plane", down, calibration.GROUND, infinite=True)
    on_plane = dataclasses.replace(course(), meshes=(), intrinsics=(plane,))
    assert native.build(on_plane).small_scene
    image = render_with(monkeypatch, on_plane, "avx2")
    assert image.tobytes() == render_with(monkeypatch, on_plane, "sse2").tobytes()
    assert np.count_nonzero(image) > image.size // 2
    quad = calibration.ground_quad(0.0, calibration.GROUND)
    many = dataclasses.replace(
        course(),
        meshes=(TriangleMesh(points=quad.points, triangles=[(0, 2, 1), (0, 3, 2)] * 5, material=quad.material),),
    )
    assert not native.build(many).small_scene


@needs_avx2
@settings(max_examples=30, deadline=None)
@given(
    spheres=st.integers(0, 8),
    triangles=st.integers(1, 8),
    scale_exponent=st.integers(-4, 5),
    seed=st.integers(0, 2**32 - 1),
)
def test_random_small_scenes(spheres, triangles, scale_exponent, seed):
    # Any small scene: stretched spheres and loose triangles in a cloud, rays from outside it,
    # from inside it and from the spheres' surfaces; closest hits and shadow answers against the
    # tree's and brute force's.
    scale = 10.0**scale_exponent
    rng = np.random.default_rng(seed)
    balls = tuple(
        Sphere(
            calibration.translation(rng.uniform(-2, 2, 3) * scale)
            @ calibration.scaling(rng.uniform(0.05, 0.8, 3) * scale)
        )
        for _ in range(spheres)
    )
    corners = rng.uniform(-2, 2, (triangles, 3, 3)) * scale
    mesh = TriangleMesh(points=corners.reshape(-1, 3), triangles=np.arange(3 * triangles).reshape(-1, 3))
    scene = dataclasses.replace(course(), spheres=balls, meshes=(mesh,))
    with pytest.MonkeyPatch.context() as monkeypatch:  # (a fixture's would outlive the examples)
        small, tree = native.build(scene), built_with(monkeypatch, scene, "sse2")
    assert small.small_scene
    origins = np.concatenate(
        [rng.uniform(-4, 4, (300, 3)) * scale, sphere_surface_points(scene, rng, 20) if spheres else np.zeros((0, 3))]
    )
    dirs = unit(rng.normal(size=origins.shape))
    window = SHADOW_WINDOW * scale
    t, prim = small.intersect(origins, dirs, window)
    t_tree, prim_tree = tree.intersect(origins, dirs, window)
    assert np.array_equal(t, t_tree) and np.array_equal(prim, prim_tree)
    assert np.array_equal(t, small.count_hits(origins, dirs, window)[1])
    limit = rng.uniform(0.1, 6.0, len(origins)) * scale
    blocked = small.occluded(origins, dirs, limit, window)
    assert np.array_equal(blocked, tree.occluded(origins, dirs, limit, window))
    assert np.array_equal(blocked, t < limit)
