# SPDX-License-Identifier: Apache-2.0
"""The native two-level BVH (src/instances.hpp): instanced scenes render as their flattened
copies do, hits agree ray by ray, and the tolerances hold under instances scaled from 1e-4 to
1e4 (no self-shadowing acne, no lost contact shadows)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from phongscene.backends import native
from phongscene.scene import (
    AmbientLight,
    Camera,
    DirectionalLight,
    Instances,
    PhongMaterial,
    Prototype,
    RenderSettings,
    Scene,
    TriangleMesh,
)
from phongscene.usd import load_usd
from phongscene.validate import validate
from support.instanced_stages import point_instancer_stage, reference_stage

# Instanced and flattened copies reach the same surface points by different roundings (a ray
# carried into prototype space vs points carried into the world: ~1e-15 relative), so a pixel
# differs only where a silhouette or shadow-edge decision of a ray grazing an edge flips. Such
# pixels may be at most this fraction of the image, and every other pixel must agree to
# half-float precision (2^-11 relative, the unit the cross-backend diff judges in).
FLIPPED_PIXELS = 0.005
HALF_FLOAT_RELATIVE = 2.0**-11
# The same hit found both ways: t agrees to a few roundings of the transform (relative).
SAME_HIT = 1e-12


def _compare(a: np.ndarray, b: np.ndarray) -> tuple[int, float]:
    """(pixels that differ beyond half-float precision, the largest relative error elsewhere)."""
    scale = np.maximum(np.maximum(np.abs(a), np.abs(b)), 1e-30)
    rel = (np.abs(a - b) / scale).max(axis=2)
    rel[(np.abs(a - b).max(axis=2) <= 1e-7)] = 0.0  # below the image's own float resolution
    return int(np.count_nonzero(rel > HALF_FLOAT_RELATIVE)), float(rel[rel <= HALF_FLOAT_RELATIVE].max(initial=0.0))


@pytest.mark.parametrize("kind", ["point_instancer", "references"])
def test_instanced_renders_as_flattened(tmp_path, kind):
    if kind == "point_instancer":
        # Uniform scales: a smooth normal interpolated in prototype space and then carried to the
        # world (as POV-Ray's object matrix does) is the interpolation of the carried normals only
        # when the map is a similarity; flattening interpolates carried normals.
        path = point_instancer_stage(tmp_path / "pi.usda", 100, rings=12, sides=8, uniform_scales=True)
    else:
        path = reference_stage(tmp_path / "refs.usda", 100, rings=12, sides=8, red_every=3)
    scene = load_usd(path)
    assert scene.instances
    instanced, flattened = native.render(scene), native.render(scene.flattened())
    assert instanced.max() > 0.05  # something is lit
    flipped, worst = _compare(instanced, flattened)
    assert flipped <= FLIPPED_PIXELS * instanced.shape[0] * instanced.shape[1], flipped
    assert worst <= HALF_FLOAT_RELATIVE


def test_hits_agree_with_flattened_ray_by_ray(tmp_path):
    scene = load_usd(point_instancer_stage(tmp_path / "pi.usda", 64, rings=12, sides=8))
    a, b = native.build(scene), native.build(scene.flattened())
    assert a.instance_count == 64 and a.prototype_count == 1
    rng = np.random.default_rng(3)
    origins = np.tile(np.array(scene.camera.position), (4000, 1))
    dirs = rng.uniform(-5, 5, (4000, 3)) - origins
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    ta, ida = a.intersect(origins, dirs)
    tb, idb = b.intersect(origins, dirs)
    hit = np.isfinite(tb)
    assert hit.sum() > 1000 and np.array_equal(np.isfinite(ta), hit)
    assert np.all(np.abs(ta[hit] - tb[hit]) <= SAME_HIT * tb[hit])
    assert np.all(ida[hit] <= -2)  # an instance's hit: -2 - its number
    # The copy hit is the one whose flattened mesh was hit (meshes are copies in order).
    per_copy = scene.instances[0].prototype.triangle_count
    assert np.array_equal(-2 - ida[hit], idb[hit] // per_copy)


def _ground_and_post(scale: float) -> Scene:
    """A post standing on a ground quad (one prototype), placed twice at ``scale`` with the
    camera and the grazing light scaled with it: contact shadows and self-shadow at any size."""
    ground = TriangleMesh(
        np.array([[-2, 0, -2], [2, 0, -2], [2, 0, 2], [-2, 0, 2]], float),
        np.array([[0, 2, 1], [0, 3, 2]]),
        material=PhongMaterial(ka=0.1, kd=0.8, ks=0.0),
    )
    box = np.array([[x, y, z] for x in (-0.2, 0.2) for y in (0.0, 1.0) for z in (-0.2, 0.2)])
    faces = np.array(
        [
            [0, 1, 3],
            [0, 3, 2],
            [4, 6, 7],
            [4, 7, 5],
            [0, 4, 5],
            [0, 5, 1],
            [2, 3, 7],
            [2, 7, 6],
            [0, 2, 6],
            [0, 6, 4],
            [1, 5, 7],
            [1, 7, 3],
        ]
    )
    post = TriangleMesh(box, faces, material=PhongMaterial(ka=0.1, kd=0.7, ks=0.3, diffuse_color=(0.9, 0.3, 0.2)))
    prototype = Prototype((ground, post))
    m = np.zeros((2, 4, 4))
    for k, (x, turn) in enumerate(((-2.5, 0.3), (2.5, -0.4))):
        c, s = math.cos(turn), math.sin(turn)
        m[k] = [[c * scale, 0, s * scale, x * scale], [0, scale, 0, 0], [-s * scale, 0, c * scale, 0], [0, 0, 0, 1]]
    camera = Camera.look_at((0.0, 3.0 * scale, 7.0 * scale), (0.0, 0.3 * scale, 0.0), 60.0)
    return Scene(
        camera=camera,
        ambient=AmbientLight((0.2, 0.2, 0.2)),
        lights=(
            DirectionalLight(tuple(np.array([0.6, -0.35, -0.4]) / np.linalg.norm([0.6, -0.35, -0.4])), (3.0, 3.0, 3.0)),
        ),
        instances=(Instances(prototype, m),),
        settings=RenderSettings(width=80, height=45),
    )


@pytest.mark.parametrize("scale", [1e-4, 1.0, 1e4])
def test_scaled_instances_keep_their_shadows(scale):
    """The ray's t is the same in world and prototype space, so the world's scale-aware shadow
    window applies unchanged: at each scale the instanced image is the flattened one and the
    unit-scale one (the scene is the same up to units)."""
    scene = _ground_and_post(scale)
    assert validate(scene) == []
    image = native.render(scene)
    flipped, worst = _compare(image, native.render(scene.flattened()))
    assert flipped <= FLIPPED_PIXELS * 80 * 45 and worst <= HALF_FLOAT_RELATIVE
    flipped, worst = _compare(image, native.render(_ground_and_post(1.0)))
    assert flipped <= FLIPPED_PIXELS * 80 * 45 and worst <= HALF_FLOAT_RELATIVE
    # Lit ground and post, and ground in the posts' shadows (ambient only, above the black background).
    brightest = image.max(axis=2)
    assert (brightest > 0.2).sum() > 500 and ((brightest > 0) & (brightest < 0.05)).sum() > 20


def test_singular_and_non_affine_transforms_are_refused():
    scene = _ground_and_post(1.0)
    group = scene.instances[0]
    bad = group.world_from_prototype.copy()
    bad[1, :3, :3] = 0.0
    problems = validate(replace(scene, instances=(Instances(group.prototype, bad),)))
    assert len(problems) == 1 and "singular" in problems[0].message and problems[0].attribute == "world_from_prototype"
    built = native.build(replace(scene, instances=()))
    proto = native.build(Scene(meshes=group.prototype.meshes))
    with pytest.raises(ValueError, match="singular"):
        built.add_instances(proto, np.ascontiguousarray(bad))


def test_a_stale_top_level_is_refused_and_many_prototypes_build_once():
    scene = _ground_and_post(1.0)
    group = scene.instances[0]
    built = native.build(replace(scene, instances=()))
    built.add_instances(
        native.build(Scene(meshes=group.prototype.meshes)),
        np.ascontiguousarray(group.world_from_prototype),
        rebuild=False,
    )
    origins, dirs = (
        np.array([[0.0, 3.0, 7.0]]),
        np.array([[-2.5, -2.7, -7.0]]) / np.linalg.norm([-2.5, -2.7, -7.0]),
    )  # at copy 0's post
    with pytest.raises(ValueError, match="rebuild=False"):
        built.intersect(origins, dirs)
    moved = group.world_from_prototype.copy()
    moved[:, 2, 3] -= 3.0
    built.add_instances(native.build(Scene(meshes=group.prototype.meshes)), np.ascontiguousarray(moved))
    assert built.instance_count == 4 and built.prototype_count == 2
    t, ids = built.intersect(origins, dirs)
    two = replace(scene, instances=(group, Instances(group.prototype, moved)))
    t_flat, _ = native.build(two.flattened()).intersect(origins, dirs)
    assert np.isfinite(t[0]) and abs(t[0] - t_flat[0]) <= SAME_HIT * t_flat[0] and ids[0] <= -2
