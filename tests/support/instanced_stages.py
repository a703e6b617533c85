# SPDX-License-Identifier: Apache-2.0
"""Instanced USD stages written with raw pxr (not phongscene's writer): a PointInstancer of a
mesh, instanceable references of it, and nesting. Shared by the reader, native, POV-Ray and
cross-backend tests and by benchmarks/instances.py."""

from __future__ import annotations

import math

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade, Vt


def torus_mesh(
    stage: Usd.Stage, path: str, rings: int = 12, sides: int = 8, radius: float = 0.4, tube: float = 0.15
) -> UsdGeom.Mesh:
    """A torus of 2·rings·sides triangles (quads split), vertex normals."""
    u = np.arange(rings) * 2 * math.pi / rings
    v = np.arange(sides) * 2 * math.pi / sides
    uu, vv = np.meshgrid(u, v, indexing="ij")
    points = np.stack(
        [(radius + tube * np.cos(vv)) * np.cos(uu), tube * np.sin(vv), (radius + tube * np.cos(vv)) * np.sin(uu)], -1
    )
    normals = np.stack([np.cos(vv) * np.cos(uu), np.sin(vv), np.cos(vv) * np.sin(uu)], -1)
    i, j = np.meshgrid(np.arange(rings), np.arange(sides), indexing="ij")
    a = i * sides + j
    b = ((i + 1) % rings) * sides + j
    c = ((i + 1) % rings) * sides + (j + 1) % sides
    d = i * sides + (j + 1) % sides
    tris = np.stack([np.stack([a, d, c], -1), np.stack([a, c, b], -1)], -2).reshape(-1, 3)
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points.reshape(-1, 3).astype(np.float32)))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(tris), 3, np.int32)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(tris.reshape(-1).astype(np.int32)))
    mesh.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(normals.reshape(-1, 3).astype(np.float32)))
    mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    return mesh


def torus_triangles(rings: int, sides: int) -> int:
    return 2 * rings * sides


def grid_positions(count: int, spacing: float = 1.0) -> np.ndarray:
    """``count`` points on a square grid in the XZ plane, centred on the origin."""
    side = math.ceil(math.sqrt(count))
    k = np.arange(count)
    return np.stack(
        [(k % side - (side - 1) / 2) * spacing, np.zeros(count), (k // side - (side - 1) / 2) * spacing], -1
    )


def _stage_basics(stage: Usd.Stage, extent: float, width: int = 96, height: int = 54) -> None:
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    cam = UsdGeom.Camera.Define(stage, "/Camera")
    eye = Gf.Vec3d(0, extent * 0.9, extent * 1.1)
    m = Gf.Matrix4d().SetLookAt(eye, Gf.Vec3d(0, 0, 0), Gf.Vec3d(0, 1, 0)).GetInverse()
    cam.AddTransformOp().Set(m)
    cam.CreateFocalLengthAttr(20.0)
    light = UsdLux.DistantLight.Define(stage, "/Light")
    light.CreateIntensityAttr(2.5)
    light.AddRotateXYZOp().Set(Gf.Vec3f(-55, 30, 0))
    UsdLux.DomeLight.Define(stage, "/Sky").CreateIntensityAttr(0.15)
    settings = stage.DefinePrim("/Render/Settings", "RenderSettings")
    settings.CreateAttribute("resolution", Sdf.ValueTypeNames.Int2).Set(Gf.Vec2i(width, height))
    settings.CreateRelationship("camera").SetTargets(["/Camera"])


def _material(stage: Usd.Stage, path: str, color) -> UsdShade.Material:
    material = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, path + "/Surface")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*color))
    shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(0.4)
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    return material


def point_instancer_stage(
    path,
    count: int,
    rings: int = 12,
    sides: int = 8,
    spacing: float = 1.0,
    *,
    width: int = 96,
    height: int = 54,
    seed: int = 1,
    with_sphere: bool = False,
    uniform_scales: bool = False,
) -> str:
    """A PointInstancer placing ``count`` copies of a torus on a grid, each rotated and scaled
    differently (orientations, scales: uniform ones with ``uniform_scales``); optionally a second
    prototype, a sphere, every 7th copy."""
    stage = Usd.Stage.CreateNew(str(path))
    positions = grid_positions(count, spacing)
    extent = float(np.abs(positions).max()) + spacing
    _stage_basics(stage, extent, width, height)
    _material(stage, "/Looks/Gold", (0.8, 0.6, 0.2))
    inst = UsdGeom.PointInstancer.Define(stage, "/World/Scatter")
    torus = torus_mesh(stage, "/World/Scatter/Prototypes/Torus", rings, sides)
    UsdShade.MaterialBindingAPI.Apply(torus.GetPrim()).Bind(UsdShade.Material(stage.GetPrimAtPath("/Looks/Gold")))
    targets = ["/World/Scatter/Prototypes/Torus"]
    indices = np.zeros(count, np.int32)
    if with_sphere:
        UsdGeom.Sphere.Define(stage, "/World/Scatter/Prototypes/Ball").CreateRadiusAttr(0.2)
        targets.append("/World/Scatter/Prototypes/Ball")
        indices[::7] = 1
    inst.CreatePrototypesRel().SetTargets(targets)
    rng = np.random.default_rng(seed)
    axes = rng.normal(size=(count, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    angles = rng.uniform(0, math.pi, count)
    quats = np.concatenate([np.cos(angles / 2)[:, None], axes * np.sin(angles / 2)[:, None]], 1)
    inst.CreatePositionsAttr(Vt.Vec3fArray.FromNumpy(positions.astype(np.float32)))
    inst.CreateOrientationsAttr(Vt.QuathArray([Gf.Quath(*map(float, q)) for q in quats]))
    scales = rng.uniform(0.6, 1.3, (count, 1 if uniform_scales else 3)) * np.ones(3)
    inst.CreateScalesAttr(Vt.Vec3fArray.FromNumpy(scales.astype(np.float32)))
    inst.CreateProtoIndicesAttr(Vt.IntArray.FromNumpy(indices))
    stage.GetRootLayer().Save()
    return str(path)


def reference_stage(
    path,
    count: int,
    rings: int = 12,
    sides: int = 8,
    spacing: float = 1.0,
    *,
    width: int = 96,
    height: int = 54,
    instanceable: bool = True,
    red_every: int = 0,
) -> str:
    """``count`` instanceable references of one asset (an Xform holding a torus and a small
    sphere) on a grid, each turned about Y; every ``red_every``-th binds another material on the
    instance prim (the override USD allows an instance)."""
    stage = Usd.Stage.CreateNew(str(path))
    positions = grid_positions(count, spacing)
    extent = float(np.abs(positions).max()) + spacing
    _stage_basics(stage, extent, width, height)
    gold = _material(stage, "/Looks/Gold", (0.8, 0.6, 0.2))
    red = _material(stage, "/Looks/Red", (0.8, 0.1, 0.1))
    asset = stage.CreateClassPrim("/Asset")
    torus_mesh(stage, "/Asset/Torus", rings, sides)
    ball = UsdGeom.Sphere.Define(stage, "/Asset/Ball")
    ball.CreateRadiusAttr(0.1)
    ball.AddTranslateOp().Set(Gf.Vec3d(0, 0.3, 0))
    for k, p in enumerate(positions):
        x = UsdGeom.Xform.Define(stage, f"/World/Copy_{k}")
        x.GetPrim().GetReferences().AddInternalReference(asset.GetPath())
        x.GetPrim().SetInstanceable(instanceable)
        x.AddTranslateOp().Set(Gf.Vec3d(*map(float, p)))
        x.AddRotateYOp().Set(float(37 * k % 360))
        UsdShade.MaterialBindingAPI.Apply(x.GetPrim()).Bind(red if red_every and k % red_every == 0 else gold)
    stage.GetRootLayer().Save()
    return str(path)


def nested_stage(path, outer: int = 3, inner: int = 4, *, width: int = 96, height: int = 54) -> str:
    """Nesting: ``outer`` instanceable references of an asset that holds a PointInstancer of
    ``inner`` tori: outer·inner copies of one mesh."""
    stage = Usd.Stage.CreateNew(str(path))
    _stage_basics(stage, 3.0 * outer, width, height)
    asset = stage.CreateClassPrim("/Asset")
    inst = UsdGeom.PointInstancer.Define(stage, "/Asset/Scatter")
    torus_mesh(stage, "/Asset/Scatter/Prototypes/Torus")
    inst.CreatePrototypesRel().SetTargets(["/Asset/Scatter/Prototypes/Torus"])
    inst.CreatePositionsAttr(Vt.Vec3fArray.FromNumpy(grid_positions(inner).astype(np.float32)))
    inst.CreateProtoIndicesAttr(Vt.IntArray.FromNumpy(np.zeros(inner, np.int32)))
    for k in range(outer):
        x = UsdGeom.Xform.Define(stage, f"/World/Group_{k}")
        x.GetPrim().GetReferences().AddInternalReference(asset.GetPath())
        x.GetPrim().SetInstanceable(True)
        x.AddTranslateOp().Set(Gf.Vec3d(3.0 * (k - (outer - 1) / 2), 0, 0))
        x.AddScaleOp().Set(Gf.Vec3f(1.0 + 0.25 * k))
    stage.GetRootLayer().Save()
    return str(path)
