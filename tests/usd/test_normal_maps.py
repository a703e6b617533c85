# SPDX-License-Identifier: Apache-2.0
"""Tangent-space normal maps (issue 28.2): the USD reader (UsdPreviewSurface ``normal`` from a
UsdUVTexture, its scale and bias giving signed texels), the native tracer against the oracle's
independent formulation (tests/support/oracle.py ``normal_mapped``), the hard cases (a flat map,
degenerate uvs, mirrored uvs, tiny and huge scales), and ``diff``: POV-Ray 3.7 has no
tangent-space normal maps, so both backends are compared without them and ``diff`` says which
pixels the maps change."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade

from phongscene import load_usd, read_usd
from phongscene.backends import native
from phongscene.scene import (
    AmbientLight,
    Camera,
    PhongMaterial,
    PointLight,
    RenderSettings,
    Scene,
    Texture,
    TriangleMesh,
)
from phongscene.usd.materials import NORMAL_MAP_NOTE
from support import oracle, png

# The native tracer against the float64 oracle: float32 texels and colour arithmetic (as the
# colour textures' test, tests/usd/test_textures.py).
NATIVE_REL = 1e-6
# Below this a channel counts as dark for the relative comparison (the image's range is ~1).
DARK = 1e-3
# The reader's texel against 2·t/255 − 1: OpenImageIO decodes 8-bit to float32 (one ulp at 1 is
# 1.2e-7, doubled by the scale 2).
DECODED_ATOL = 2.4e-7
# A scaled copy of a scene against the original: the hit points' float64 rounding at 1e-6 and
# 1e5 scales, carried through float32 colour arithmetic (measured ≤ 2e-6).
SCALED_REL = 1e-5
# A pixel "changes" with the normal map when it moves by more than this (far above rounding).
CHANGED = 1e-3
# A normal map's 8-bit texels; scale 2, bias −1 decode t as 2·t/255 − 1.
PIXELS8 = np.array(
    [
        [[128, 128, 255], [200, 128, 230], [60, 160, 220], [128, 40, 200]],
        [[255, 128, 180], [128, 128, 255], [90, 200, 210], [170, 90, 240]],
    ],
    dtype=np.uint8,
)


def bumpy_map(h: int = 16, w: int = 16, amplitude: float = 0.4) -> np.ndarray:
    """A smooth tangent-space normal map: sinusoidal tilts of at most ``amplitude``."""
    y, x = np.mgrid[0:h, 0:w]
    tx = amplitude * np.sin(2 * np.pi * x / w)
    ty = 0.75 * amplitude * np.cos(2 * np.pi * y / h)
    return np.stack([tx, ty, np.ones_like(tx)], axis=2).astype(np.float32)


def quad_scene(normal_image: np.ndarray | None, uvs=None, smooth: bool = False) -> Scene:
    """A tilted quad (two triangles) under a point light, its material normal-mapped."""
    points = np.array([(-1, -1, 0), (1, -1, 0), (1, 1, 0.3), (-1, 1, 0.3)], dtype=np.float64)
    triangles = np.array([(0, 1, 2), (0, 2, 3)])
    uvs = np.array([(0, 0), (1, 0), (1, 1), (0, 1)], dtype=np.float64) * 1.5 if uvs is None else uvs
    texture = None if normal_image is None else Texture(normal_image, "repeat", "repeat")
    material = PhongMaterial(ks=0.5, exponent=20.0, normal_texture=texture, source="/Looks/Bumpy")
    normals = None
    if smooth:  # vertex normals leaning outward: the map's N is the interpolated normal
        normals = np.array([(-0.2, -0.2, 1), (0.2, -0.2, 1), (0.2, 0.2, 1), (-0.2, 0.2, 1)], dtype=np.float64)
        normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    mesh = TriangleMesh(
        points,
        triangles,
        normals=normals,
        normal_indices=triangles if smooth else None,
        material=material,
        uvs=uvs,
        uv_indices=triangles,
        source="/World/Quad",
    )
    return Scene(
        camera=Camera(position=(0.2, -0.3, 4.0), forward=(0, 0, -1), up=(0, 1, 0), horizontal_fov_deg=50),
        lights=(PointLight(position=(1.5, 2.0, 3.0), color=(20.0, 20.0, 20.0)),),
        meshes=(mesh,),
        settings=RenderSettings(width=64, height=48),
    )


def assert_close(a: np.ndarray, b: np.ndarray, rel: float) -> None:
    error = np.abs(a - b) / np.maximum(np.abs(b), DARK)
    assert error.max() <= rel, f"max relative error {error.max():.3g} at {np.unravel_index(error.argmax(), a.shape)}"


# -- the native tracer --------------------------------------------------------------------------


@pytest.mark.parametrize(
    "case",
    ["flat-shaded", "smooth-shaded", "mirrored-u", "rotated-uvs"],
)
def test_native_normal_map_equals_the_oracle(case):
    uvs = None
    if case == "mirrored-u":  # u decreasing along x: T flips, B does not (handedness kept)
        uvs = np.array([(1, 0), (0, 0), (0, 1), (1, 1)], dtype=np.float64) * 1.5
    elif case == "rotated-uvs":  # T and B not along the quad's edges
        uvs = np.array([(0.2, 0.0), (1.1, 0.5), (0.6, 1.4), (-0.3, 0.9)], dtype=np.float64)
    scene = quad_scene(bumpy_map(), uvs=uvs, smooth=case == "smooth-shaded")
    ours = native.render(scene)
    assert_close(ours, oracle.render(scene), NATIVE_REL)
    # ... and the map does change the picture (the test would pass on an ignored map otherwise).
    plain = native.render(scene.without_normal_maps())
    assert np.mean(np.abs(ours - plain).max(axis=2) > CHANGED) > 0.2


def test_a_mirrored_layout_tilts_the_other_way():
    """Mirroring u turns the map's x tilt around in space: the same texels shade differently."""
    straight = native.render(quad_scene(bumpy_map(), uvs=np.array([(0, 0), (1, 0), (1, 1), (0, 1)], np.float64)))
    uvs = np.array([(1, 0), (0, 0), (0, 1), (1, 1)], dtype=np.float64)  # u' = 1 − u
    mirrored_map = bumpy_map()[:, ::-1].copy()
    mirrored_map[..., 0] *= -1  # the same surface normals, written for the mirrored layout
    mirrored = native.render(quad_scene(mirrored_map, uvs=uvs))
    assert_close(mirrored, straight, NATIVE_REL * 10)


def test_a_flat_normal_map_changes_nothing():
    flat = np.zeros((4, 4, 3), dtype=np.float32)
    flat[..., 2] = 1.0
    for smooth in (False, True):
        scene = quad_scene(flat, smooth=smooth)
        assert_close(native.render(scene), native.render(scene.without_normal_maps()), NATIVE_REL)


def test_degenerate_uvs_leave_the_normal_as_it_is():
    """All corners at one uv (or on a line): no tangent frame, so no perturbation (not NaN)."""
    for uvs in (np.full((4, 2), 0.5), np.array([(0, 0), (1, 1), (2, 2), (3, 3)], dtype=np.float64)):
        scene = quad_scene(bumpy_map(), uvs=uvs)
        image = native.render(scene)
        assert np.all(np.isfinite(image))
        assert_close(image, native.render(scene.without_normal_maps()), NATIVE_REL)


def test_a_zero_texel_leaves_the_normal_as_it_is():
    scene = quad_scene(np.zeros((2, 2, 3), dtype=np.float32))
    image = native.render(scene)
    assert np.all(np.isfinite(image))
    assert_close(image, native.render(scene.without_normal_maps()), NATIVE_REL)


@pytest.mark.parametrize("scale", [1e-6, 1e5])
def test_tiny_and_huge_scales_shade_as_unit_scale(scale):
    """dP/du scales with the mesh, and the frame is normalised: the shading is scale-free."""
    scene = dataclasses.replace(quad_scene(bumpy_map()), ambient=AmbientLight((0.0, 0.0, 0.0)))
    (mesh,) = scene.meshes
    light = scene.lights[0]
    scaled = dataclasses.replace(
        scene,
        meshes=(dataclasses.replace(mesh, points=mesh.points * scale),),
        camera=dataclasses.replace(scene.camera, position=tuple(c * scale for c in scene.camera.position)),
        lights=(dataclasses.replace(light, position=tuple(c * scale for c in light.position)),),
    )
    # Suffern's point light does not fall off with distance: the images are the same.
    assert_close(native.render(scaled), native.render(scene), SCALED_REL)


# -- the USD reader -----------------------------------------------------------------------------


def write_png(path, pixels=PIXELS8) -> str:
    return png.write_png(path, pixels)


def normal_mapped_stage(path, image: str, *, scale=(2, 2, 2, 1), bias=(-1, -1, -1, 0)) -> str:
    """A quad with a UsdPreviewSurface whose normal comes from a raw UsdUVTexture, as Blender
    and the UsdPreviewSurface spec write it (scale 2, bias −1)."""
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    mesh = UsdGeom.Mesh.Define(stage, "/World/Quad")
    mesh.CreatePointsAttr([(-1, -1, 0), (1, -1, 0), (1, 1, 0.3), (-1, 1, 0.3)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    mesh.CreateSubdivisionSchemeAttr("none")
    st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, "faceVarying")
    st.Set([(0, 0), (1.5, 0), (1.5, 1.5), (0, 1.5)])
    material = UsdShade.Material.Define(stage, "/World/Looks/Mat")
    reader = UsdShade.Shader.Define(stage, "/World/Looks/Mat/Reader")
    reader.CreateIdAttr("UsdPrimvarReader_float2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("st")
    tex = UsdShade.Shader.Define(stage, "/World/Looks/Mat/Normal")
    tex.CreateIdAttr("UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(image)
    tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
    tex.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("raw")
    tex.CreateInput("scale", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(*scale))
    tex.CreateInput("bias", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(*bias))
    tex.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
    surface = UsdShade.Shader.Define(stage, "/World/Looks/Mat/Surface")
    surface.CreateIdAttr("UsdPreviewSurface")
    surface.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(0.3)
    surface.CreateInput("normal", Sdf.ValueTypeNames.Normal3f).ConnectToSource(tex.ConnectableAPI(), "rgb")
    material.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)
    cam = UsdGeom.Camera.Define(stage, "/World/Camera")
    cam.AddTranslateOp().Set((0.1, 0.2, 4.0))
    light = stage.DefinePrim("/World/Light", "SphereLight")
    light.CreateAttribute("inputs:intensity", Sdf.ValueTypeNames.Float).Set(20.0)
    light.CreateAttribute("treatAsPoint", Sdf.ValueTypeNames.Bool).Set(True)
    UsdGeom.Xformable(light).AddTranslateOp().Set((0.5, 1.0, 3.0))
    render = stage.DefinePrim("/Render/Settings", "RenderSettings")
    render.CreateAttribute("resolution", Sdf.ValueTypeNames.Int2).Set(Gf.Vec2i(48, 36))
    stage.SetDefaultPrim(stage.GetPrimAtPath("/World"))
    stage.GetRootLayer().Save()
    return str(path)


def test_reader_reads_a_preview_surface_normal_map_as_signed_vectors(tmp_path):
    write_png(tmp_path / "normal.png")
    read = read_usd(normal_mapped_stage(tmp_path / "s.usda", "normal.png"))
    scene, warnings = read.scene, read.warnings
    (mesh,) = scene.meshes
    texture = mesh.material.normal_texture
    assert texture is not None and mesh.material.diffuse_texture is None
    np.testing.assert_allclose(texture.image, 2.0 * PIXELS8 / 255.0 - 1.0, rtol=0, atol=DECODED_ATOL)
    assert texture.image.min() < 0  # signed: not clipped at 0 as colours are
    assert mesh.uvs is not None  # the map needs the mesh's st
    (line,) = [w for w in warnings if NORMAL_MAP_NOTE in w]
    assert "/World/Looks/Mat/Surface" in line
    assert not [w for w in warnings if "inputs:normal" in w]  # read, not "ignored"


def test_an_unreadable_normal_map_is_ignored_with_a_warning(tmp_path):
    read = read_usd(normal_mapped_stage(tmp_path / "s.usda", "missing.png"))
    scene, warnings = read.scene, read.warnings
    (mesh,) = scene.meshes
    assert mesh.material.normal_texture is None
    assert any("cannot find the image 'missing.png'" in w for w in warnings)


@pytest.mark.povray
def test_diff_compares_without_the_maps_and_says_where_they_change_the_picture(tmp_path):
    """POV-Ray's SDL has no normal map (its bump_map is a height field in a world-fixed frame,
    POV-Ray 3.7 source/core/support/imageutil.cpp): ``diff`` passes on what both can render and
    lists the pixels the maps change in the native picture."""
    from phongscene.backends.povray import compile_pov
    from phongscene.backends.povray.compile import texture_files
    from phongscene.crossvalidation import diff

    image = np.clip(np.rint((bumpy_map(8, 8) + 1.0) / 2.0 * 255.0), 0, 255).astype(np.uint8)
    write_png(tmp_path / "normal.png", image)
    path = normal_mapped_stage(tmp_path / "s.usda", "normal.png")
    scene = load_usd(path)
    assert not texture_files(scene)  # no image for POV-Ray to read
    assert "normal" not in compile_pov(scene).split("#declare Material_0", 1)[1].split("\n", 1)[0]
    result = diff(path, tmp_path / "report")
    assert result.ok, result.report.summary()
    assert len(result.normal_map_pixels) > 0.1 * result.report.pixels
    with_maps = native.render(scene, dataclasses.replace(scene.settings, numerics="povray"))
    changed = np.abs(with_maps - result.native).max(axis=2) > CHANGED
    listed = np.zeros_like(changed)
    for x, y in result.normal_map_pixels:
        listed[y, x] = True
    assert not (changed & ~listed).any()  # every clearly changed pixel is listed
    assert "change with the scene's normal maps" in result.explanation()


def test_write_usd_round_trips_a_normal_map(tmp_path):
    """write_usd connects our shader's (and the preview stand-in's) ``normal`` to the map, written
    as a float EXR (signed texels kept): read back, the same texels and the same picture."""
    from phongscene import write_usd

    scene = quad_scene(bumpy_map())
    back = load_usd(str(write_usd(scene, tmp_path / "bumpy.usda")))
    (mesh,) = back.meshes
    np.testing.assert_array_equal(mesh.material.normal_texture.image, scene.meshes[0].material.normal_texture.image)
    settings = dataclasses.replace(back.settings, width=64, height=48)
    assert_close(native.render(back, settings), native.render(scene), NATIVE_REL)
