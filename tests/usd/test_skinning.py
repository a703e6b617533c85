# SPDX-License-Identifier: Apache-2.0
"""UsdSkel: a two-joint skinned cylinder, built with raw pxr, is posed at the time read. Its
bent pose is known in closed form (the upper half turns about the elbow), and it equals
usd-core's own ``UsdSkel.BakeSkinning`` of the same stage (an independent path: baked points
placed by the baked mesh's transform)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, UsdLux, UsdSkel

from phongscene.usd import read_usd

# Skinned points are float32 (USD's point3f[]): a few ulps of coordinates of size ~3.
POINT_TOLERANCE = 1e-5
# Skinned normals are float32 (UsdSkel skins them so) unit vectors: a few ulps of 1.
NORMAL_TOLERANCE = 1e-6
RADIUS, SEGMENTS, RINGS = 0.2, 8, 5  # rings at y = 0, 0.5, 1, 1.5, 2
ELBOW = np.array([0.0, 1.0, 0.0])
ROOT_OFFSET = np.array([3.0, 0.0, 0.0])  # the SkelRoot's translate: places the skeleton
BEND_DEG = 90.0  # the elbow's rotation about +z at time 10 (0 at time 0)


def _cylinder_points() -> np.ndarray:
    a = np.linspace(0.0, 2.0 * math.pi, SEGMENTS, endpoint=False)
    return np.array([(RADIUS * math.cos(t), y, RADIUS * math.sin(t)) for y in np.linspace(0, 2, RINGS) for t in a])


def _write(path) -> None:
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    stage.SetStartTimeCode(0)
    stage.SetEndTimeCode(10)
    cam = UsdGeom.Camera.Define(stage, "/Cam")
    UsdGeom.XformCommonAPI(cam).SetTranslate((3, 1, 8))
    UsdLux.DistantLight.Define(stage, "/Sun")
    root = UsdSkel.Root.Define(stage, "/Arm")
    UsdGeom.XformCommonAPI(root).SetTranslate(Gf.Vec3d(*ROOT_OFFSET))
    skel = UsdSkel.Skeleton.Define(stage, "/Arm/Skel")
    skel.CreateJointsAttr(["shoulder", "shoulder/elbow"])
    bind = [Gf.Matrix4d(1), Gf.Matrix4d(1).SetTranslate(Gf.Vec3d(*ELBOW))]  # world-space bind pose
    skel.CreateBindTransformsAttr(bind)
    skel.CreateRestTransformsAttr(bind)  # local: the elbow 1 above the shoulder
    anim = UsdSkel.Animation.Define(stage, "/Arm/Skel/Bend")
    anim.CreateJointsAttr(["shoulder", "shoulder/elbow"])
    anim.CreateTranslationsAttr([Gf.Vec3f(0), Gf.Vec3f(*ELBOW)])
    anim.CreateScalesAttr([Gf.Vec3h(1), Gf.Vec3h(1)])
    rotations = anim.CreateRotationsAttr()
    rotations.Set([Gf.Quatf(1), Gf.Quatf(1)], 0)
    rotations.Set([Gf.Quatf(1), Gf.Quatf(Gf.Rotation(Gf.Vec3d(0, 0, 1), BEND_DEG).GetQuat())], 10)
    UsdSkel.BindingAPI.Apply(skel.GetPrim()).CreateAnimationSourceRel().SetTargets([anim.GetPath()])
    mesh = UsdGeom.Mesh.Define(stage, "/Arm/Cylinder")
    p = _cylinder_points()
    mesh.CreatePointsAttr([Gf.Vec3f(*x) for x in p])
    quads = [
        (
            r * SEGMENTS + s,
            r * SEGMENTS + (s + 1) % SEGMENTS,
            (r + 1) * SEGMENTS + (s + 1) % SEGMENTS,
            (r + 1) * SEGMENTS + s,
        )
        for r in range(RINGS - 1)
        for s in range(SEGMENTS)
    ]
    mesh.CreateFaceVertexCountsAttr([4] * len(quads))
    mesh.CreateFaceVertexIndicesAttr([i for q in quads for i in reversed(q)])
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    binding = UsdSkel.BindingAPI.Apply(mesh.GetPrim())
    binding.CreateSkeletonRel().SetTargets([skel.GetPath()])
    # One influence per point: the upper rings follow the elbow rigidly (a closed-form pose).
    binding.CreateJointIndicesPrimvar(False, 1).Set([0 if y <= 1.0 else 1 for y in p[:, 1]])
    binding.CreateJointWeightsPrimvar(False, 1).Set([1.0] * len(p))
    binding.CreateGeomBindTransformAttr(Gf.Matrix4d(1))
    stage.Save()


def _posed(t: float) -> np.ndarray:
    """The cylinder's world points at time t: the upper half turned about the elbow by the
    (slerped, so linear in angle) bend, then the SkelRoot's offset."""
    p = _cylinder_points()
    a = math.radians(BEND_DEG * t / 10.0)
    rz = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
    upper = p[:, 1] > 1.0
    p[upper] = (p[upper] - ELBOW) @ rz.T + ELBOW
    return p + ROOT_OFFSET


@pytest.mark.parametrize("t", [0.0, 5.0, 10.0])
def test_a_skinned_cylinder_is_posed_at_the_time_read(tmp_path, t):
    path = tmp_path / "arm.usda"
    _write(path)
    (mesh,) = read_usd(path, time=t).scene.meshes
    np.testing.assert_allclose(np.asarray(mesh.points), _posed(t), atol=POINT_TOLERANCE)


def test_the_pose_is_usds_own_baked_skinning(tmp_path):
    path = tmp_path / "arm.usda"
    _write(path)
    ours = np.asarray(read_usd(path, time=7.0).scene.meshes[0].points)
    stage = Usd.Stage.Open(str(path))
    assert UsdSkel.BakeSkinning(UsdSkel.Root(stage.GetPrimAtPath("/Arm")), Gf.Interval(0, 10))
    baked = UsdGeom.Mesh(stage.GetPrimAtPath("/Arm/Cylinder"))
    world = np.array(baked.ComputeLocalToWorldTransform(7.0))
    p = np.asarray(baked.GetPointsAttr().Get(7.0), dtype=np.float64)
    np.testing.assert_allclose(ours, p @ world[:3, :3] + world[3, :3], atol=POINT_TOLERANCE)
    assert not np.allclose(ours, _posed(0.0), atol=0.1)  # the bend is not the bind pose


def _radial_normals() -> np.ndarray:
    p = _cylinder_points()
    n = p * (1.0, 0.0, 1.0)
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def _with_normals(path, interpolation: str) -> None:
    """The arm with smooth radial normals, per point or per face corner."""
    _write(path)
    stage = Usd.Stage.Open(str(path))
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/Arm/Cylinder"))
    n = _radial_normals()
    if interpolation == "faceVarying":
        n = n[np.asarray(mesh.GetFaceVertexIndicesAttr().Get())]
    mesh.CreateNormalsAttr([Gf.Vec3f(*x) for x in n])
    mesh.SetNormalsInterpolation(interpolation)
    stage.Save()


@pytest.mark.parametrize("interpolation", ["vertex", "faceVarying"])
@pytest.mark.parametrize("t", [0.0, 10.0])
def test_authored_normals_are_skinned_with_their_points(tmp_path, interpolation, t):
    """The upper rings turn rigidly with the elbow: their normals turn by the same rotation;
    the lower ones stay. (Per corner: each corner's normal follows its point's joint.)"""
    path = tmp_path / "arm.usda"
    _with_normals(path, interpolation)
    result = read_usd(path, time=t)
    (mesh,) = result.scene.meshes
    a = math.radians(BEND_DEG * t / 10.0)
    rz = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
    expected = _radial_normals()
    upper = _cylinder_points()[:, 1] > 1.0
    expected[upper] = expected[upper] @ rz.T
    corners = np.asarray(mesh.triangles)
    np.testing.assert_allclose(
        np.asarray(mesh.normals)[np.asarray(mesh.normal_indices)], expected[corners], atol=NORMAL_TOLERANCE
    )
    assert not [w for w in result.warnings if "normals" in w and "skinned" in w]


def test_skinned_normals_are_usds_own_baked_ones(tmp_path):
    """usd-core's BakeSkinning skins the normals by its own path; ours agree (world space)."""
    path = tmp_path / "arm.usda"
    _with_normals(path, "vertex")
    (mesh,) = read_usd(path, time=7.0).scene.meshes
    stage = Usd.Stage.Open(str(path))
    assert UsdSkel.BakeSkinning(UsdSkel.Root(stage.GetPrimAtPath("/Arm")), Gf.Interval(0, 10))
    baked = UsdGeom.Mesh(stage.GetPrimAtPath("/Arm/Cylinder"))
    world = np.array(baked.ComputeLocalToWorldTransform(7.0))[:3, :3]
    n = np.asarray(baked.GetNormalsAttr().Get(7.0), dtype=np.float64) @ np.linalg.inv(world).T
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    ours = np.asarray(mesh.normals)[np.asarray(mesh.normal_indices)]
    np.testing.assert_allclose(ours, n[np.asarray(mesh.triangles)], atol=NORMAL_TOLERANCE)
    assert not np.allclose(ours, _radial_normals()[np.asarray(mesh.triangles)], atol=0.1)  # they did turn
