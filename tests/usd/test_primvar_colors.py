# SPDX-License-Identifier: Apache-2.0
"""Diffuse colours from primvars (phongscene/usd/primvar_colors.py): a primvar reader on a
material's diffuse colour gives each gprim its primvar's value, and each instance its own
(a PointInstancer's per-instance array, a constant primvar on an instanceable prim), kept as
instances; both backends render every copy in its colour. The intent-vfx teapot scene colours
its "rgb" teapots this way."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade, Vt

from phongscene import render
from phongscene.comparison import compare
from phongscene.scene import Instances
from phongscene.usd import load_usd
from phongscene.usd.reader import read_usd
from phongscene.validate import validate
from support.instanced_stages import point_instancer_stage, reference_stage

FALLBACK = (0.2, 0.2, 0.2)
# Instanced and flattened copies reach the same points by different roundings (~1e-15
# relative): an edge decision may flip in this fraction of the pixels (as
# tests/native/test_native_instances.py says); every other pixel agrees to float precision.
FLIPPED_PIXELS = 0.005
SAME_PIXEL = 1e-5


def _read_tint(stage: Usd.Stage, material_path: str, reader_id: str = "UsdPrimvarReader_float3") -> None:
    """Connect the material's diffuseColor to a primvar reader of "tint"."""
    surface = UsdShade.Shader(stage.GetPrimAtPath(material_path + "/Surface"))
    reader = UsdShade.Shader.Define(stage, material_path + "/Tint")
    reader.CreateIdAttr(reader_id)
    reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("tint")
    reader.CreateInput("fallback", Sdf.ValueTypeNames.Float3).Set(Gf.Vec3f(*FALLBACK))
    out = reader.CreateOutput("result", Sdf.ValueTypeNames.Float3)
    surface.GetInput("diffuseColor").ConnectToSource(out)


def _colours(count: int, seed: int = 5) -> np.ndarray:
    return np.random.default_rng(seed).uniform(0.05, 0.95, (count, 3)).astype(np.float32).astype(np.float64)


def tinted_instancer(tmp_path, count: int = 16) -> tuple[str, np.ndarray]:
    path = point_instancer_stage(tmp_path / "pi.usda", count, rings=12, sides=8, uniform_scales=True)
    stage = Usd.Stage.Open(path)
    _read_tint(stage, "/Looks/Gold")
    colours = _colours(count)
    primvar = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/World/Scatter")).CreatePrimvar(
        "tint", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.vertex
    )
    primvar.Set(Vt.Vec3fArray.FromNumpy(colours.astype(np.float32)))
    stage.GetRootLayer().Save()
    return path, colours


def test_point_instancer_copies_take_their_per_instance_colour(tmp_path):
    path, colours = tinted_instancer(tmp_path)
    scene = load_usd(path)
    (group,) = scene.instances
    assert group.prototype.meshes[0].material.instance_color
    assert group.prototype.meshes[0].material.diffuse_color == pytest.approx(FALLBACK)
    np.testing.assert_array_equal(group.colors, colours)
    # Flattened, copy k's mesh wears its colour; the instanced render is the flattened one.
    assert group.placed_meshes(3)[0].material.diffuse_color == pytest.approx(tuple(colours[3]))
    instanced, flattened = render(scene, "native", explain=False), render(scene.flattened(), "native", explain=False)
    rel = np.abs(instanced - flattened).max(axis=2) / np.maximum(flattened.max(axis=2), 1e-6)
    assert np.count_nonzero(rel > SAME_PIXEL) <= FLIPPED_PIXELS * rel.size
    # ... and not the fallback's: the copies differ in colour.
    grey = dataclasses.replace(group, colors=None)
    assert not np.allclose(render(dataclasses.replace(scene, instances=(grey,)), "native", explain=False), instanced)


def test_a_copy_without_a_value_keeps_the_fallback(tmp_path):
    path, _ = tinted_instancer(tmp_path, 9)
    stage = Usd.Stage.Open(path)
    UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/World/Scatter")).GetPrimvar("tint").Set(
        Vt.Vec3fArray.FromNumpy(_colours(4).astype(np.float32))  # 4 values for 9 copies
    )
    stage.GetRootLayer().Save()
    (group,) = load_usd(path).instances
    assert group.colors is None
    assert group.placed_meshes(0)[0].material.diffuse_color == pytest.approx(FALLBACK)


def test_instanceable_prims_take_their_constant_primvar(tmp_path):
    path = reference_stage(tmp_path / "refs.usda", 6, rings=12, sides=8)
    stage = Usd.Stage.Open(path)
    _read_tint(stage, "/Looks/Gold")
    colours = _colours(6, seed=8)
    for k in range(6):
        primvar = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath(f"/World/Copy_{k}")).CreatePrimvar(
            "tint", Sdf.ValueTypeNames.Color3f, UsdGeom.Tokens.constant
        )
        primvar.Set(Gf.Vec3f(*map(float, colours[k])))
    stage.GetRootLayer().Save()
    scene = load_usd(path)
    (group,) = scene.instances
    np.testing.assert_array_equal(group.colors, colours)
    # The asset's sphere is placed in the world per copy, in the copy's colour too.
    balls = sorted(scene.spheres, key=lambda s: s.source)
    np.testing.assert_array_equal([b.material.diffuse_color for b in balls], colours)


def test_a_gprim_takes_its_own_or_an_inherited_primvar_else_the_fallback(tmp_path):
    path = tmp_path / "gprims.usda"
    stage = Usd.Stage.CreateNew(str(path))
    material = UsdShade.Material.Define(stage, "/Looks/Tinted")
    surface = UsdShade.Shader.Define(stage, "/Looks/Tinted/Surface")
    surface.CreateIdAttr("UsdPreviewSurface")
    surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(1, 1, 1))
    material.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
    _read_tint(stage, "/Looks/Tinted")
    group = UsdGeom.Xform.Define(stage, "/World/Group")
    UsdGeom.PrimvarsAPI(group.GetPrim()).CreatePrimvar("tint", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.1, 0.5, 0.9))
    for name, parent, own in (("Own", "/World/Group", (0.9, 0.3, 0.1)), ("Inherits", "/World/Group", None)):
        ball = UsdGeom.Sphere.Define(stage, f"{parent}/{name}")
        if own:
            UsdGeom.PrimvarsAPI(ball.GetPrim()).CreatePrimvar("tint", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*own))
        UsdShade.MaterialBindingAPI.Apply(ball.GetPrim()).Bind(material)
    lone = UsdGeom.Sphere.Define(stage, "/World/Lone")
    UsdShade.MaterialBindingAPI.Apply(lone.GetPrim()).Bind(material)
    stage.GetRootLayer().Save()
    result = read_usd(str(path))
    by_source = {s.source: s.material for s in result.scene.spheres}
    assert by_source["/World/Group/Own"].diffuse_color == pytest.approx((0.9, 0.3, 0.1))
    assert by_source["/World/Group/Inherits"].diffuse_color == pytest.approx((0.1, 0.5, 0.9))
    assert by_source["/World/Lone"].diffuse_color == pytest.approx(FALLBACK)
    assert not any(m.instance_color for m in by_source.values())
    assert any("/World/Lone (tint)" in w for w in result.warnings)


def test_a_standard_surface_scales_the_primvar_as_its_base_color(tmp_path):
    """base · base_color · (1 − metalness): the primvar's colour is scaled as a constant one is."""
    path = tmp_path / "mtlx.usda"
    stage = Usd.Stage.CreateNew(str(path))
    value = (0.6, 0.3, 0.15)
    for name, connected in (("Read", True), ("Constant", False)):
        material = UsdShade.Material.Define(stage, f"/Looks/{name}")
        surface = UsdShade.Shader.Define(stage, f"/Looks/{name}/Surface")
        surface.CreateIdAttr("ND_standard_surface_surfaceshader")
        surface.CreateInput("base", Sdf.ValueTypeNames.Float).Set(0.8)
        surface.CreateInput("metalness", Sdf.ValueTypeNames.Float).Set(0.25)
        base_color = surface.CreateInput("base_color", Sdf.ValueTypeNames.Color3f)
        if connected:
            reader = UsdShade.Shader.Define(stage, f"/Looks/{name}/Tint")
            reader.CreateIdAttr("ND_geompropvalue_color3")
            reader.CreateInput("geomprop", Sdf.ValueTypeNames.String).Set("tint")
            reader.CreateInput("default", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.5, 0.5, 0.5))
            base_color.ConnectToSource(reader.CreateOutput("out", Sdf.ValueTypeNames.Color3f))
        else:
            base_color.Set(Gf.Vec3f(*value))
        material.CreateSurfaceOutput("mtlx").ConnectToSource(surface.CreateOutput("out", Sdf.ValueTypeNames.Token))
        ball = UsdGeom.Sphere.Define(stage, f"/World/{name}")
        UsdGeom.PrimvarsAPI(ball.GetPrim()).CreatePrimvar("tint", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*value))
        UsdShade.MaterialBindingAPI.Apply(ball.GetPrim()).Bind(material)
    stage.GetRootLayer().Save()
    by_source = {s.source: s.material for s in load_usd(str(path)).spheres}
    assert by_source["/World/Read"].diffuse_color == pytest.approx(by_source["/World/Constant"].diffuse_color)


def test_instance_colours_are_validated(tmp_path):
    path, colours = tinted_instancer(tmp_path, 4)
    scene = load_usd(path)
    (group,) = scene.instances
    bad = colours.copy()
    bad[2, 1] = np.nan
    problems = validate(dataclasses.replace(scene, instances=(dataclasses.replace(group, colors=bad),)))
    assert any(p.attribute == "colors" and "copy 2" in p.message for p in problems)
    with pytest.raises(ValueError, match="one per copy"):
        Instances(group.prototype, group.world_from_prototype, colors=colours[:3])


@pytest.mark.povray
def test_povray_renders_each_copy_in_its_colour(tmp_path):
    path, _ = tinted_instancer(tmp_path)
    scene = load_usd(path)
    pov, native = render(scene, "povray", explain=False), render(scene, "native", explain=False)
    assert compare(pov, native).ok


def test_nested_copies_take_their_inner_instancers_colours(tmp_path):
    """Instanceable references of an asset holding a tinted PointInstancer: every outer copy
    repeats the inner instancer's colours, in the composed order (outer k, inner j) -> k·J + j,
    which the transforms follow too."""
    from support.instanced_stages import _material, nested_stage

    outer, inner = 3, 4
    path = nested_stage(tmp_path / "nested.usda", outer=outer, inner=inner)
    stage = Usd.Stage.Open(path)
    material = _material(stage, "/Asset/Looks/Tinted", (1.0, 1.0, 1.0))
    _read_tint(stage, "/Asset/Looks/Tinted")
    torus = stage.GetPrimAtPath("/Asset/Scatter/Prototypes/Torus")
    UsdShade.MaterialBindingAPI.Apply(torus).Bind(material)
    colours = _colours(inner, seed=12)
    UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/Asset/Scatter")).CreatePrimvar(
        "tint", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.vertex
    ).Set(Vt.Vec3fArray.FromNumpy(colours.astype(np.float32)))
    stage.GetRootLayer().Save()
    scene = load_usd(path)
    (group,) = scene.instances
    assert len(group) == outer * inner
    np.testing.assert_array_equal(group.colors, np.tile(colours, (outer, 1)))
    # Copy k·J + j sits where outer copy k puts inner copy j: its colour goes with its place.
    centres = group.world_from_prototype[:, :3, 3]
    firsts = centres[::inner]
    assert len({round(float(x), 6) for x in firsts[:, 0]}) == outer  # one outer copy each
