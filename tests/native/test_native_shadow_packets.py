# SPDX-License-Identifier: Apache-2.0
"""A light's shadow rays from a packet's shaded points are asked together
(Scene::occluded_each, backends/native/src/scene.cpp, bvh8_group.hpp): on the 8-wide tree up to
64 rays (four packets' points) walk it in groups of one direction sign per axis, a node near the
root tested once for the group, deeper ones by each ray, each leaf tested for the rays whose own
box test enters it, so each ray tests its own walk's leaves (and maybe more) in another order and
its any-hit answer must be its own walk's. `occluded(..., together=True)` asks consecutive rays
in 64s; these tests compare it with the rays one by one on hard rays: shadow rays from surfaces
to lights (coherent groups) and to scattered targets (groups of mixed direction signs, split by
sign), groups spread over an octant, rays grazing spheres, rays along the ground's plane with a
±0 direction (1/±0 = ±inf: alone), rays whose float box test does not apply (a direction
component below 2^-20: the double walk, alone), windows ending one double past a hit; at scales
1e-6, 1 and 1e6, with an unbounded plane and with instances in the scene. And the group's box
tests themselves against each ray's own."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from test_native_instances import _ground_and_post
from test_native_simd_dispatch import crowd, needs_avx2
from test_native_small_scene import SHADOW_WINDOW, course, hard_rays

from phongscene.backends import native
from phongscene.scene import Intrinsic
from support import calibration

pytestmark = needs_avx2


def tree_scenes():
    """Scenes on the 8-wide tree (not small): spheres and a ground quad, and the crowd of triangles."""
    return {"course": course(sphere_count=12), "crowd": crowd(), "smooth_mesh": calibration.smooth_mesh()}


def coherent_groups(origins, dirs, t_max):
    """The rays sorted so that each group shares a target (their directions' signs mostly agree)."""
    order = np.lexsort((origins[:, 0], np.round(dirs[:, 1], 1), np.round(dirs[:, 0], 1)))
    return origins[order], dirs[order], t_max[order]


def answers(built, origins, dirs, t_max, window):
    alone = built.occluded(origins, dirs, t_max, window)
    together = built.occluded(origins, dirs, t_max, window, together=True)
    return alone, together


@pytest.mark.parametrize("scale", [1e-6, 1.0, 1e6])
@pytest.mark.parametrize("coherent", [True, False])
def test_shadow_rays_together_answer_as_alone(scale, coherent):
    scene = course(scale=scale, sphere_count=12)
    built = native.build(scene)
    assert not built.small_scene and built.walk_width == 8
    origins, dirs, _, t_max = hard_rays(scene, scale, 0.0)
    if coherent:
        origins, dirs, t_max = coherent_groups(origins, dirs, t_max)
    window = SHADOW_WINDOW * scale
    alone, together = answers(built, origins, dirs, t_max, window)
    assert 0 < alone.sum() < len(alone)  # both answers occur
    assert np.array_equal(alone, together)


@pytest.mark.parametrize("name", sorted(tree_scenes()))
def test_windows_one_double_past_the_hit(name):
    """A window ending one double past each closest hit is blocked, together as alone; one ending
    one double before the hit (and no other hit before it) is not."""
    scene = tree_scenes()[name]
    built = native.build(scene)
    rng = np.random.default_rng(5)
    origins = np.tile(np.asarray(scene.camera.position, dtype=np.float64), (400, 1))
    targets = rng.uniform(-1.5, 1.5, (400, 3)) + [0.0, 0.6, 0.0]
    dirs = targets - origins
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    t, _ = built.intersect(origins, dirs)
    hit = np.isfinite(t)
    assert hit.sum() > 100
    o, d, t = origins[hit], dirs[hit], t[hit]
    past = np.nextafter(t, np.inf)
    alone, together = answers(built, o, d, past, 0.0)
    assert alone.all() and together.all()
    before = np.nextafter(t, 0.0)
    alone, together = answers(built, o, d, before, 0.0)
    assert np.array_equal(alone, together)


@pytest.mark.parametrize("name", sorted(tree_scenes()))
def test_groups_of_one_octant_with_spread_directions(name):
    """Rays whose directions share their signs walk as one group, tested near the root once for
    them all against the interval of their origins and inverse directions (bvh8_group.hpp). The
    loosest intervals: each group's directions spread over a whole octant (inverse directions
    from about 1 to 1e3) from origins spread over the scene, ending anywhere along the way.
    Every answer is its own walk's."""
    scene = tree_scenes()[name]
    built = native.build(scene)
    rng = np.random.default_rng(17)
    groups = 24
    signs = np.repeat(rng.choice([-1.0, 1.0], (groups, 3)), 64, axis=0)
    dirs = signs * rng.uniform(1e-3, 1.0, (groups * 64, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    origins = rng.uniform(-1.5, 1.5, (groups * 64, 3)) + [0.0, 0.5, 0.0]
    t_max = rng.uniform(0.05, 4.0, groups * 64)
    alone, together = answers(built, origins, dirs, t_max, 1e-9)
    assert 0.1 * len(alone) < alone.sum() < 0.9 * len(alone)
    assert np.array_equal(alone, together)


def _group_boxes(rng, origins, dirs, t_max, nodes: int) -> np.ndarray:
    """Boxes (lo, hi; float values) in nodes of eight around points along the rays and off them,
    of sizes from a hair to the whole spread, with empty slots (lo = +inf, hi = -inf)."""
    n = len(origins)
    pick = rng.integers(0, n, nodes * 8)
    along = origins[pick] + dirs[pick] * (t_max[pick] * rng.uniform(-0.2, 1.2, nodes * 8))[:, None]
    extent = np.ptp(np.concatenate([origins, origins + dirs * t_max[:, None]]), axis=0).max()
    centres = along + rng.normal(size=(nodes * 8, 3)) * extent * 10.0 ** rng.uniform(-4, -0.5, (nodes * 8, 1))
    half = extent * 10.0 ** rng.uniform(-5, -0.3, (nodes * 8, 3))
    boxes = np.concatenate([centres - half, centres + half], axis=1).astype(np.float32).astype(np.float64)
    empty = rng.random(nodes * 8) < 0.1
    boxes[empty] = [np.inf] * 3 + [-np.inf] * 3
    return boxes


def test_a_groups_box_test_enters_every_box_one_of_its_rays_enters():
    """FloatSlabGroup8 (bvh8_group.hpp) on hard groups: the interval test enters every child some
    ray's own float test (FloatSlabRay8, set up alone) enters; each ray's test inside the group,
    and each child's set of entering rays, are bit for bit the rays' own tests. Groups of 1 to 64
    rays of one sign per axis, directions from nearly parallel to spread over the octant, origins
    from one point to spread out, at scales 1e-3 to 1e3 and far from the origin."""
    rng = np.random.default_rng(29)
    culled = entered = 0
    for _ in range(60):
        n = int(rng.integers(1, 65))
        scale = 10.0 ** rng.uniform(-3, 3)
        dirs = rng.choice([-1.0, 1.0], 3) * rng.uniform(10.0 ** rng.uniform(-3, -0.1), 1.0, (n, 3))
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        centre = rng.normal(size=3) * scale * 10.0 ** rng.integers(0, 4)
        origins = centre + rng.normal(size=(n, 3)) * scale * 10.0 ** rng.uniform(-6, 0)
        t_max = rng.uniform(0.1, 10.0, n) * scale
        boxes = _group_boxes(rng, origins, dirs, t_max, 32)
        finite = boxes[np.isfinite(boxes)]
        magnitude = max(np.abs(finite).max(), np.abs(origins).max())
        rows, alone = native._native.group_box_tests(origins, dirs, 1e-9 * scale, t_max, boxes, magnitude)
        union = np.bitwise_or.reduce(alone, axis=1)
        assert np.array_equal(rows[:, 0] & union, union)  # the group enters every box a ray enters
        assert np.array_equal(rows[:, 1 : 1 + n], alone)  # each ray's test in the group is its own
        for i in range(8):
            own = ((alone >> np.uint64(i)) & np.uint64(1)).astype(bool)
            expected = (own.astype(np.uint64) << np.arange(n, dtype=np.uint64)).sum(axis=1, dtype=np.uint64)
            assert np.array_equal(rows[:, 1 + n + i], expected)
        culled += int(sum(8 - bin(int(m)).count("1") for m in rows[:, 0]))
        entered += int(sum(bin(int(m)).count("1") for m in union))
    assert entered > 1000 and culled > 1000  # boxes both entered and culled by the groups


def test_rays_whose_float_test_does_not_apply_walk_alone():
    """A direction component below 2^-20 (the float box test's range) takes the double walk: mixed
    in a group with rays that walk together, every answer is still its own."""
    scene = course(sphere_count=12)
    built = native.build(scene)
    rng = np.random.default_rng(8)
    origins = rng.uniform(-3, 3, (256, 3)) + [0.0, 1.5, 0.0]
    dirs = rng.normal(size=(256, 3))
    dirs[::3, 0] = 1e-7  # every third ray: x component below 2^-20
    dirs[1::3, 2] = -0.0
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    t_max = rng.uniform(0.5, 8.0, 256)
    alone, together = answers(built, origins, dirs, t_max, 1e-9)
    assert 0 < alone.sum() < len(alone)
    assert np.array_equal(alone, together)


def test_planes_and_instances_are_asked_after_the_walk():
    """occluded_tree's tail per ray: the unbounded planes and the instances' top level."""
    spheres = course(sphere_count=12)
    plane = Intrinsic("plane", calibration.translation([0.0, -0.5, 0.0]), calibration.GROUND, infinite=True)
    posts = _ground_and_post(1.0).instances  # two instances of a ground and a post
    for candidate in (
        dataclasses.replace(spheres, intrinsics=(plane,)),
        dataclasses.replace(spheres, instances=posts),
    ):
        built = native.build(candidate)
        rng = np.random.default_rng(2)
        origins = rng.uniform(-4, 4, (400, 3)) + [0.0, 2.0, 0.0]
        dirs = rng.normal(size=(400, 3))
        dirs /= np.linalg.norm(dirs, axis=1)[:, None]
        t_max = rng.uniform(0.5, 30.0, 400)
        alone, together = answers(built, origins, dirs, t_max, 1e-9)
        assert 0 < alone.sum() < len(alone)
        assert np.array_equal(alone, together)


def _slab_rays(rng, n):
    """Origins and directions with the float slab set-up's hard numbers among ordinary ones:
    midpoints between floats (the origin's outward rounding), signed zeros, subnormals, the edges
    of FloatSlabRay::applies' ranges (coordinates 1e30, direction components 2^-20 and 2^20) and
    beyond them, reciprocals past the float range, infinities and NaN."""
    specials = np.array(
        [
            0.0,
            -0.0,
            1e-310,
            -1e-310,
            2.0**-20,
            -(2.0**-20),
            2.0**-20 * (1 - 2.0**-53),
            2.0**20,
            2.0**20 * (1 + 2.0**-52),
        ]
        + [2.0**-129, -(2.0**-129), 1e30, -1e30, 1.0000000000000002e30, 1e39, np.inf, -np.inf, np.nan, 1.0, -1.0]
    )
    scale = 10.0 ** rng.integers(-8, 9, (n, 1))
    origins = rng.standard_normal((n, 3)) * scale
    floats = origins.astype(np.float32).astype(np.float64)
    midpoints = (floats + np.nextafter(floats.astype(np.float32), np.float32(np.inf)).astype(np.float64)) / 2
    origins = np.where(rng.random((n, 3)) < 0.3, midpoints, origins)
    dirs = rng.standard_normal((n, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    for array in (origins, dirs):
        where = rng.random((n, 3)) < 0.15
        array[where] = rng.choice(specials, where.sum())
    return origins, dirs


@pytest.mark.parametrize("t_min", [1e-9, 2.0**-125, 2.0**-126, 0.0])
@pytest.mark.parametrize("magnitude", [1.0, 1e30, 2e30])
def test_shadow_rays_set_up_in_lanes_as_each_ray_alone(t_min, magnitude):
    # Scene::occluded_tree_each sets its rays' float slab numbers up four at a time in AVX lanes
    # (FloatSlabLanes, bvh8.hpp); each ray's must be the bits FloatSlabRay8 has when the ray sets
    # itself up alone, whether or not the float test applies to it, and so must FloatSlabRay's
    # applies and far limit. Any count of rays in a group (the last group here is partial).
    rng = np.random.default_rng(25)
    n = 4003
    origins, dirs = _slab_rays(rng, n)
    t_max = np.abs(rng.standard_normal(n)) * 10.0 ** rng.integers(-6, 7, n)
    t_max[rng.random(n) < 0.05] = np.inf
    t_max[rng.random(n) < 0.02] = 3.4028235677973366e38 / (1 + 2.0**-21)  # just under the float range's top
    alone = native._native.float_slab_lanes(origins, dirs, t_min, t_max, magnitude, False)
    lanes = native._native.float_slab_lanes(origins, dirs, t_min, t_max, magnitude, True)
    assert np.array_equal(alone.view(np.uint32), lanes.view(np.uint32))
    applies = alone[:, 13] == 1.0
    if t_min >= 2.0**-125 and magnitude <= 1e30:
        assert 0 < applies.sum() < n  # rays of both kinds were compared
        assert np.isnan(alone[applies, 6:9]).any() and np.isinf(alone[applies, 6:9]).any()
    else:
        assert not applies.any()
