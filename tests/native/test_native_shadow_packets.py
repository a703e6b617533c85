# SPDX-License-Identifier: Apache-2.0
"""A light's shadow rays from a packet's shaded points are asked together
(Scene::occluded_each, backends/native/src/scene.cpp): on the 8-wide tree up to four rays walk it
as one, each child taken by the rays whose own box test enters it, each leaf tested for them, so
each ray tests its own walk's leaves in another order and its any-hit answer must be its own
walk's. `occluded(..., together=True)` asks consecutive rays in fours; these tests compare it with
the rays one by one on hard rays: shadow rays from surfaces to lights (coherent fours) and to
scattered targets (fours of mixed direction signs, which load a node's planes per ray), rays
grazing spheres, rays along the ground's plane with a ±0 direction (1/±0 = ±inf), rays whose
float box test does not apply (a direction component below 2^-20: the double walk, alone),
windows ending one double past a hit; at scales 1e-6, 1 and 1e6, with an unbounded plane and with
instances in the scene."""

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


def coherent_fours(origins, dirs, t_max):
    """The rays sorted so that each four share a target (their directions' signs mostly agree)."""
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
        origins, dirs, t_max = coherent_fours(origins, dirs, t_max)
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


def test_rays_whose_float_test_does_not_apply_walk_alone():
    """A direction component below 2^-20 (the float box test's range) takes the double walk: mixed
    in a four with rays that walk together, every answer is still its own."""
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
