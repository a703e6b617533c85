# SPDX-License-Identifier: Apache-2.0
"""The reader keeps instances: PointInstancers and instanceable references become one Prototype
each (read once, in its own space) and Instances (transforms); nesting is composed; a prototype
used once is flattened. Scenes are written with raw pxr (support/instanced_stages.py)."""

from __future__ import annotations

import numpy as np
from pxr import Gf, Usd, UsdGeom, Vt

from phongscene.usd import read_usd
from support.instanced_stages import nested_stage, point_instancer_stage, reference_stage, torus_mesh, torus_triangles

# Points composed by different products (instance transform · prototype point vs USD's own
# flattening of the same transforms): a few roundings of unit-sized doubles and float32 data.
COMPOSED = 1e-5


def _sorted_points(meshes) -> np.ndarray:
    points = np.concatenate([m.points for m in meshes])
    return points[np.lexsort(np.round(points, 4).T)]


def test_point_instancer_is_one_prototype_and_its_transforms(tmp_path):
    path = point_instancer_stage(tmp_path / "pi.usda", 200, rings=6, sides=4, with_sphere=True)
    scene = read_usd(path).scene
    assert len(scene.instances) == 1 and len(scene.meshes) == 0
    group = scene.instances[0]
    balls = len(range(0, 200, 7))
    assert len(group) == 200 - balls and len(scene.spheres) == balls  # spheres: placed in the world
    assert scene.triangle_count == torus_triangles(6, 4)  # the prototype, once
    assert scene.instanced_triangle_count == (200 - balls) * torus_triangles(6, 4)
    # The transforms are USD's own (IncludeProtoXform), in column-vector form.
    stage = Usd.Stage.Open(path)
    instancer = UsdGeom.PointInstancer(stage.GetPrimAtPath("/World/Scatter"))
    usd = np.array(instancer.ComputeInstanceTransformsAtTime(Usd.TimeCode.Default(), Usd.TimeCode.Default()))
    torus = np.array([k for k in range(200) if k % 7])
    assert np.allclose(group.world_from_prototype, usd[torus].transpose(0, 2, 1), atol=1e-12)
    assert group.sources[0] == "/World/Scatter[1]"
    assert group.prototype.source == "/World/Scatter/Prototypes/Torus"


def test_invisible_ids_and_ids_mask_copies(tmp_path):
    path = point_instancer_stage(tmp_path / "pi.usda", 10, rings=6, sides=4)
    stage = Usd.Stage.Open(path)
    instancer = UsdGeom.PointInstancer(stage.GetPrimAtPath("/World/Scatter"))
    instancer.CreateIdsAttr(Vt.Int64Array(list(range(100, 110))))
    instancer.CreateInvisibleIdsAttr(Vt.Int64Array([103, 107]))
    stage.Save()
    group = read_usd(path).scene.instances[0]
    assert len(group) == 8
    assert "/World/Scatter[103]" not in group.sources and "/World/Scatter[104]" in group.sources


def test_velocities_at_a_time(tmp_path):
    """positions sampled at 0, velocities in units per second: read at time 12 (24 fps) the copy
    has moved half a second's velocity (USD's ComputeInstanceTransformsAtTime)."""
    stage = Usd.Stage.CreateNew(str(tmp_path / "moving.usda"))
    stage.SetTimeCodesPerSecond(24)
    stage.SetStartTimeCode(0)
    stage.SetEndTimeCode(24)
    instancer = UsdGeom.PointInstancer.Define(stage, "/Scatter")
    torus_mesh(stage, "/Scatter/Prototypes/Torus", 6, 4)
    instancer.CreatePrototypesRel().SetTargets(["/Scatter/Prototypes/Torus"])
    instancer.CreateProtoIndicesAttr(Vt.IntArray([0, 0]))
    instancer.CreatePositionsAttr().Set(Vt.Vec3fArray([Gf.Vec3f(0, 0, 0), Gf.Vec3f(5, 0, 0)]), 0)
    instancer.CreateVelocitiesAttr().Set(Vt.Vec3fArray([Gf.Vec3f(2, 0, 0), Gf.Vec3f(0, 4, 0)]), 0)
    stage.Save()
    group = read_usd(tmp_path / "moving.usda", time=12).scene.instances[0]
    assert np.allclose(group.world_from_prototype[:, :3, 3], [[1, 0, 0], [5, 2, 0]], atol=1e-6)


def test_instanceable_references_share_one_prototype_per_inherited_material(tmp_path):
    path = reference_stage(tmp_path / "refs.usda", 12, rings=6, sides=4, red_every=4)
    result = read_usd(path)
    scene = result.scene
    # Copies 0, 4, 8 bind /Looks/Red on the instance prim: the override USD allows an instance.
    groups = sorted(scene.instances, key=len)
    assert [len(g) for g in groups] == [3, 9]
    red, gold = groups
    assert red.prototype.meshes[0].material.diffuse_color[0] > 5 * red.prototype.meshes[0].material.diffuse_color[1]
    assert gold.prototype.meshes[0].material != red.prototype.meshes[0].material
    assert red.sources == ("/World/Copy_0", "/World/Copy_4", "/World/Copy_8")
    assert red.prototype.meshes[0].source == "/World/Copy_0/Torus"  # read through a real instance's proxies
    assert len(scene.spheres) == 12 and scene.spheres[0].source.startswith("/World/Copy_")
    assert any("Instances (9 copies" in node for _, node in result.nodes)


def test_instanced_references_flatten_to_what_usd_flattens(tmp_path):
    """The same stage without `instanceable` (USD composes every copy): the instanced scene's
    flattened() has the same points, spheres and triangles."""
    kept = read_usd(reference_stage(tmp_path / "a.usda", 6, rings=6, sides=4)).scene
    plain = read_usd(reference_stage(tmp_path / "b.usda", 6, rings=6, sides=4, instanceable=False)).scene
    assert kept.instances and not plain.instances
    flat = kept.flattened()
    assert len(flat.meshes) == len(plain.meshes) == 6
    assert np.allclose(_sorted_points(flat.meshes), _sorted_points(plain.meshes), atol=COMPOSED)
    centres = lambda s: np.sort(np.array([x.world_from_object[:3, 3] for x in s.spheres]), axis=0)  # noqa: E731
    assert np.allclose(centres(kept), centres(plain), atol=COMPOSED)


def test_nested_instancing_is_composed(tmp_path):
    """3 instanceable references of an asset holding a PointInstancer of 4: 12 copies of one
    prototype, each outer transform times each inner one."""
    scene = read_usd(nested_stage(tmp_path / "nested.usda", outer=3, inner=4)).scene
    assert len(scene.instances) == 1 and len(scene.instances[0]) == 12
    stage = Usd.Stage.Open(str(tmp_path / "nested.usda"))
    for prim in stage.Traverse():
        prim.SetInstanceable(False) if prim.IsInstance() else None
    flattened = read_usd(stage).scene
    assert len(flattened.instances) == 3  # each group's own instancer (nothing shared)
    assert np.allclose(
        _sorted_points(scene.flattened().meshes), _sorted_points(flattened.flattened().meshes), atol=COMPOSED
    )


def test_a_prototype_used_once_is_flattened(tmp_path):
    scene = read_usd(reference_stage(tmp_path / "one.usda", 1, rings=6, sides=4)).scene
    assert not scene.instances and len(scene.meshes) == 1 and len(scene.spheres) == 1
    scene = read_usd(point_instancer_stage(tmp_path / "pi1.usda", 1, rings=6, sides=4)).scene
    assert not scene.instances and len(scene.meshes) == 1


def test_existing_instancing_scene_still_reads(tmp_path):
    from support.paths import SCENES

    scene = read_usd(SCENES / "instancing.usda").scene  # spheres only: placed in the world
    assert not scene.instances and len(scene.spheres) == 3
