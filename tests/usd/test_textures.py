# SPDX-License-Identifier: Apache-2.0
"""Textured materials (issue 14): the USD reader (UsdUVTexture, st primvars of every
interpolation, colour spaces, channels, scale/bias, Transform2d, .usdz), the native lookup in
every wrap mode against the oracle, and both backends on a textured USD scene."""

from __future__ import annotations

import dataclasses
import zipfile

import numpy as np
import OpenImageIO as oiio
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade

from phongscene import load_usd
from phongscene.backends import native
from phongscene.validate import check, validate
from support import calibration, oracle, png
from support.paths import SCENES

# The native tracer against the float64 oracle: float32 texels and colour arithmetic.
NATIVE_REL = 1e-6
# OpenImageIO's sRGB → linear (its built-in OCIO transform) against the standard's formula:
# measured within 2.41e-5 relative on these texels; far below one 8-bit step (~1e-2 relative).
SRGB_REL = 3e-5
# ... and on the linear toe (c <= 0.04045) within 7.6e-7 absolute (its slope differs slightly
# from 1/12.92); one 8-bit step there is 3e-4.
SRGB_ABS = 1e-6

# A 4 × 2 RGB texture with distinct 8-bit values (row 0 at the top of the file).
PIXELS8 = np.array(
    [
        [[10, 200, 30], [250, 5, 60], [90, 90, 240], [0, 128, 255]],
        [[255, 255, 255], [40, 10, 170], [128, 64, 32], [7, 77, 177]],
    ],
    dtype=np.uint8,
)


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    """The sRGB transfer function's inverse (IEC 61966-2-1), written from the standard."""
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def write_png(path, pixels=PIXELS8) -> str:
    return png.write_png(path, pixels)


def textured_stage(
    path,
    image: str,
    *,
    interpolation="faceVarying",
    color_space=None,
    output="rgb",
    wrap=("repeat", "repeat"),
    scale=None,
    bias=None,
    transform=None,
    phong=False,
    inputs=("diffuseColor",),
    specular_workflow=False,
):
    """A quad (two triangles as one 4-sided face) under a camera and a light, its material's
    diffuseColor from a UsdUVTexture whose st comes from a primvar reader (varname through a
    material interface input, as Blender writes it)."""
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    mesh = UsdGeom.Mesh.Define(stage, "/World/Quad")
    mesh.CreatePointsAttr([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    mesh.CreateSubdivisionSchemeAttr("none")
    mesh.CreateDoubleSidedAttr(True)
    st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, interpolation)
    corners = [(-0.25, -0.5), (1.5, -0.25), (1.25, 1.5), (-0.5, 1.25)]
    if interpolation == "faceVarying":
        st.Set([corners[i] for i in (0, 1, 2, 3)])
    elif interpolation in ("vertex", "varying"):
        st.Set(corners)
        st.SetIndices([0, 1, 2, 3])  # indexed: exercises the indices path
    else:  # uniform / constant: one value
        st.Set([(0.3, 0.6)])
    material = UsdShade.Material.Define(stage, "/World/Looks/Mat")
    name = material.CreateInput("frame:stPrimvarName", Sdf.ValueTypeNames.Token)
    name.Set("st")
    reader = UsdShade.Shader.Define(stage, "/World/Looks/Mat/Reader")
    reader.CreateIdAttr("UsdPrimvarReader_float2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.Token).ConnectToSource(name)
    st_source = reader.ConnectableAPI(), "result"
    if transform is not None:
        t2d = UsdShade.Shader.Define(stage, "/World/Looks/Mat/Transform")
        t2d.CreateIdAttr("UsdTransform2d")
        t2d.CreateInput("in", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
        t2d.CreateInput("scale", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(*transform[0]))
        t2d.CreateInput("rotation", Sdf.ValueTypeNames.Float).Set(transform[1])
        t2d.CreateInput("translation", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(*transform[2]))
        st_source = t2d.ConnectableAPI(), "result"
    tex = UsdShade.Shader.Define(stage, "/World/Looks/Mat/Texture")
    tex.CreateIdAttr("UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(image)
    tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(*st_source)
    tex.CreateInput("wrapS", Sdf.ValueTypeNames.Token).Set(wrap[0])
    tex.CreateInput("wrapT", Sdf.ValueTypeNames.Token).Set(wrap[1])
    if color_space:
        tex.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set(color_space)
    if scale:
        tex.CreateInput("scale", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(*scale))
    if bias:
        tex.CreateInput("bias", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(*bias))
    kind = Sdf.ValueTypeNames.Float if output in ("r", "g", "b", "a") else Sdf.ValueTypeNames.Float3
    tex.CreateOutput(output, kind)
    surface = UsdShade.Shader.Define(stage, "/World/Looks/Mat/Surface")
    if phong:
        surface.CreateIdAttr("phongscene_PhongSurface")
        material.CreateSurfaceOutput("phong").ConnectToSource(surface.ConnectableAPI(), "surface")
    else:
        surface.CreateIdAttr("UsdPreviewSurface")
        surface.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(0.4)
        if specular_workflow:
            surface.CreateInput("useSpecularWorkflow", Sdf.ValueTypeNames.Int).Set(1)
        material.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
    for name in inputs:
        surface.CreateInput(name, Sdf.ValueTypeNames.Color3f).ConnectToSource(tex.ConnectableAPI(), output)
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


def _texture(scene, field="diffuse_texture"):
    (mesh,) = scene.meshes
    assert getattr(mesh.material, field) is not None
    return mesh, getattr(mesh.material, field)


# -- the reader ---------------------------------------------------------------------------------


@pytest.mark.parametrize("space", [None, "auto", "sRGB", "raw"])
@pytest.mark.slow
def test_colour_space_of_an_8bit_png(tmp_path, space):
    png = write_png(tmp_path / "tex.png")
    scene = load_usd(textured_stage(tmp_path / "s.usda", "tex.png", color_space=space))
    _, texture = _texture(scene)
    expected = PIXELS8 / 255.0
    if space != "raw":  # auto: an 8-bit image is sRGB-encoded
        expected = srgb_to_linear(expected)
    np.testing.assert_allclose(texture.image, expected, rtol=SRGB_REL, atol=SRGB_ABS)
    assert texture.file == png and (texture.wrap_s, texture.wrap_t) == ("repeat", "repeat")


def test_float_exr_is_raw_under_auto(tmp_path):
    values = np.random.default_rng(3).uniform(0, 4, (3, 5, 3)).astype(np.float32)
    assert oiio.ImageBuf(values).write(str(tmp_path / "tex.exr"), "float")
    _, texture = _texture(load_usd(textured_stage(tmp_path / "s.usda", "tex.exr")))
    np.testing.assert_array_equal(texture.image, values)


@pytest.mark.parametrize("output,channel", [("r", 0), ("g", 1), ("b", 2)])
@pytest.mark.slow
def test_single_channel_output_scale_and_bias(tmp_path, output, channel):
    write_png(tmp_path / "tex.png")
    scene = load_usd(
        textured_stage(
            tmp_path / "s.usda",
            "tex.png",
            color_space="raw",
            output=output,
            scale=(2, 3, 4, 1),
            bias=(0.1, 0.2, 0.3, 0),
        )
    )
    _, texture = _texture(scene)
    expected = PIXELS8[:, :, channel] / 255.0 * (2, 3, 4)[channel] + (0.1, 0.2, 0.3)[channel]
    np.testing.assert_allclose(texture.image, np.repeat(expected[:, :, None], 3, axis=2), rtol=1e-6)


def test_alpha_output_of_an_rgb_image_is_one(tmp_path):
    write_png(tmp_path / "tex.png")
    _, texture = _texture(load_usd(textured_stage(tmp_path / "s.usda", "tex.png", output="a")))
    assert np.all(texture.image == 1.0)


@pytest.mark.parametrize("interpolation", ["faceVarying", "vertex", "varying", "uniform", "constant"])
@pytest.mark.slow
def test_st_of_every_interpolation(tmp_path, interpolation):
    write_png(tmp_path / "tex.png")
    mesh, _ = _texture(load_usd(textured_stage(tmp_path / "s.usda", "tex.png", interpolation=interpolation)))
    corner_uv = mesh.uvs[mesh.uv_indices]  # (2 triangles, 3 corners, uv)
    corner_of_point = {(-1, -1): (-0.25, -0.5), (1, -1): (1.5, -0.25), (1, 1): (1.25, 1.5), (-1, 1): (-0.5, 1.25)}
    for tri, uvs in zip(mesh.triangles, corner_uv):
        for point, uv in zip(mesh.points[tri], uvs):
            per_point = interpolation in ("faceVarying", "vertex", "varying")
            expected = corner_of_point[(int(point[0]), int(point[1]))] if per_point else (0.3, 0.6)
            np.testing.assert_allclose(uv, expected, rtol=1e-7)


def test_transform2d_applies_scale_rotation_translation(tmp_path):
    write_png(tmp_path / "tex.png")
    mesh, _ = _texture(
        load_usd(textured_stage(tmp_path / "s.usda", "tex.png", transform=((2.0, 0.5), 90.0, (0.25, -1.0))))
    )
    plain, _ = _texture(load_usd(textured_stage(tmp_path / "p.usda", "tex.png")))
    st = plain.uvs * (2.0, 0.5)
    expected = np.column_stack([-st[:, 1], st[:, 0]]) + (0.25, -1.0)  # 90° counter-clockwise
    np.testing.assert_allclose(mesh.uvs, expected, atol=1e-6)


def test_usdz_packaged_texture(tmp_path):
    write_png(tmp_path / "tex.png")
    layer = textured_stage(tmp_path / "scene.usdc", "tex.png")
    # usdz: an uncompressed zip whose files are 64-byte aligned (USD's own packager does this).
    from pxr import UsdUtils

    package = tmp_path / "scene.usdz"
    assert UsdUtils.CreateNewUsdzPackage(Sdf.AssetPath(layer), str(package))
    (tmp_path / "tex.png").unlink()  # only the packaged copy remains
    assert any(n.endswith("tex.png") for n in zipfile.ZipFile(package).namelist())
    _, texture = _texture(load_usd(str(package)))
    np.testing.assert_allclose(texture.image, srgb_to_linear(PIXELS8 / 255.0), rtol=SRGB_REL, atol=SRGB_ABS)


def test_missing_image_uses_the_fallback_with_a_warning(tmp_path):
    scene = load_usd(textured_stage(tmp_path / "s.usda", "missing.png", phong=True))
    (mesh,) = scene.meshes
    assert mesh.material.diffuse_texture is None
    assert not validate(scene)


def test_textured_phong_shader(tmp_path):
    write_png(tmp_path / "tex.png")
    mesh, texture = _texture(load_usd(textured_stage(tmp_path / "s.usda", "tex.png", phong=True)))
    assert mesh.material.source.endswith("/Surface") and texture.source == "/World/Looks/Mat/Texture"


# -- the native lookup against the oracle, every wrap mode ---------------------------------------


@pytest.mark.parametrize("wrap_s", ["repeat", "clamp", "mirror", "black"])
@pytest.mark.parametrize("wrap_t", ["repeat", "clamp", "mirror", "black"])
def test_native_matches_oracle_in_every_wrap_mode(wrap_s, wrap_t):
    # uvs from -2.3 to 3.1: every wrap rule is exercised beyond both edges of both axes.
    scene = calibration.point_light()
    quad = calibration.textured_quad(calibration.checker_texture(wrap_s, wrap_t), -2.3, 3.1)
    scene = check(
        dataclasses.replace(scene, meshes=(quad,), settings=dataclasses.replace(scene.settings, width=40, height=30))
    )
    image = native.render(scene)
    ref = oracle.render(scene)
    np.testing.assert_allclose(image, ref, rtol=NATIVE_REL, atol=1e-7)
    if (wrap_s, wrap_t) != ("repeat", "repeat"):  # the wrap rule shows beyond [0, 1]
        repeat = dataclasses.replace(quad.material.diffuse_texture, wrap_s="repeat", wrap_t="repeat")
        tiled = dataclasses.replace(quad, material=dataclasses.replace(quad.material, diffuse_texture=repeat))
        assert np.abs(image - native.render(dataclasses.replace(scene, meshes=(tiled,)))).max() > 0.05


def test_validation_needs_uvs_for_a_textured_mesh():
    scene = calibration.texture_repeat()
    mesh = dataclasses.replace(scene.meshes[0], uvs=None, uv_indices=None)
    problems = validate(dataclasses.replace(scene, meshes=(mesh,)))
    assert [p.attribute for p in problems] == ["uvs"]


# -- both backends on a textured USD scene ---------------------------------------------------------


@pytest.mark.povray
@pytest.mark.parametrize("mapping", ["exact", "classic"])
@pytest.mark.slow
def test_textured_usd_scene_agrees_on_both_backends(tmp_path, mapping):
    from phongscene import compare
    from phongscene.backends import povray

    write_png(tmp_path / "tex.png")
    scene = check(load_usd(textured_stage(tmp_path / "s.usda", "tex.png", wrap=("repeat", "repeat"))))
    if mapping == "classic":
        scene = calibration.classic_variant(scene)
    settings = dataclasses.replace(scene.settings, numerics="povray")
    a = native.render(scene, settings)
    b = povray.render(scene, mapping=mapping)
    assert np.ptp(a[:, :, 0]) > 0.1
    report = compare(a, b)
    assert report.ok, report


# -- POV-Ray's image_map, measured directly (docs/povray-3.7-semantics.md §16) ------------------

# POV-Ray's half-float output: one rounding, 2^-11 relative (ref §2), plus float32 colour arithmetic.
POV_OUTPUT_REL = 2.0**-11 + 1e-6


def _pov_quad(tmp_path, texture, uv_lo, uv_hi, modifiers, n=60):
    """Render a uv-mapped square with an emissive-like finish (ambient 1, ambient_light 1) seen
    orthographically, so each pixel is the pigment at its uv; return (image, u, v of pixels)."""
    import subprocess

    from phongscene.images import read_image, write_image

    write_image(tmp_path / "tex.exr", texture.image, half=True)
    sdl = f"""#version 3.7;
global_settings {{ assumed_gamma 1.0 ambient_light 1 }}
background {{ rgb <0, 0, 100> }}
camera {{ orthographic location <0.5, 0.5, -1> direction <0, 0, 1> right <1, 0, 0> up <0, 1, 0> }}
mesh2 {{ vertex_vectors {{ 4, <0, 0, 0>, <1, 0, 0>, <1, 1, 0>, <0, 1, 0> }}
  uv_vectors {{ 4, <{uv_lo}, {uv_lo}>, <{uv_hi}, {uv_lo}>, <{uv_hi}, {uv_hi}>, <{uv_lo}, {uv_hi}> }}
  face_indices {{ 2, <0, 1, 2>, <0, 2, 3> }}
  texture {{ uv_mapping pigment {{ image_map {{ exr "tex.exr" {modifiers} }} }} finish {{ ambient 1 diffuse 0 }} }} }}
"""
    (tmp_path / "quad.pov").write_text(sdl)
    subprocess.run(
        ["povray", "+Iquad.pov", "+Oquad.exr", "+FE", f"+W{n}", f"+H{n}", "-D", "-V", "-GA", "-A", "+WT1"],
        cwd=tmp_path,
        check=True,
        capture_output=True,
        env={"HOME": str(tmp_path), "PATH": "/usr/bin:/bin"},
    )
    s = (np.arange(n) + 0.5) / n
    u, v = np.meshgrid(uv_lo + (uv_hi - uv_lo) * s, uv_lo + (uv_hi - uv_lo) * (1 - s))
    return read_image(tmp_path / "quad.exr"), u, v


@pytest.mark.povray
def test_povray_image_map_is_the_model_lookup_on_half_texels(tmp_path):
    # interpolate 2 = bilinear between texel centres, repeat wrap (uvs -0.7..1.6), on the texels
    # rounded to half floats: POV-Ray holds an EXR image map as half floats.
    texture = calibration.checker_texture()
    image, u, v = _pov_quad(tmp_path, texture, -0.7, 1.6, "interpolate 2")
    half = dataclasses.replace(texture, image=texture.image.astype(np.float16).astype(np.float32))
    expected = oracle.sample_texture(half, u.ravel(), v.ravel()).reshape(image.shape)
    assert np.all(np.abs(image - expected) <= POV_OUTPUT_REL * expected)
    # ... and not on the float32 texels (the half rounding is visible above the output rounding).
    full = oracle.sample_texture(texture, u.ravel(), v.ravel()).reshape(image.shape)
    assert np.any(np.abs(image - full) > POV_OUTPUT_REL * full)


@pytest.mark.povray
def test_povray_once_is_clamp_inside_the_unit_square_and_clear_outside(tmp_path):
    texture = dataclasses.replace(calibration.checker_texture(), wrap_s="clamp", wrap_t="clamp")
    image, u, v = _pov_quad(tmp_path, texture, -0.3, 1.3, "interpolate 2 once")
    half = dataclasses.replace(texture, image=texture.image.astype(np.float16).astype(np.float32))
    expected = oracle.sample_texture(half, u.ravel(), v.ravel()).reshape(image.shape)
    inside = (u >= 0) & (u <= 1) & (v >= 0) & (v <= 1)
    assert np.all(np.abs(image - expected)[inside] <= (POV_OUTPUT_REL * expected)[inside])
    outside = (u < -0.01) | (u > 1.01) | (v < -0.01) | (v > 1.01)
    assert np.all(image[outside] == (0.0, 0.0, 100.0))  # transparent: the background shows


# A tilted quad with off-grid corners: POV-Ray's hit lies on its float32-rounded plane, and
# Mesh::UVCoord weighs the corners' uvs by distances to the sides in 3D (not barycentrics), so
# POV-Ray's uv is off the model's by ~1e-7 of the uvs' magnitude: where a texel edge is that
# close, POV-Ray reads the other texel (issue 27: 1-19 failing pixels on public textured files).
EDGE_QUAD_ORIGIN = np.array([0.1234567, -0.0765432, 0.3141593])
EDGE_QUAD_A = np.array([0.9876543, 0.1111111, 0.4321987])
EDGE_QUAD_B = np.array([-0.0987654, 0.9234567, -0.2718282])
EDGE_QUAD_PIXELS = 60


def _edge_quad(wrap, lo, span):
    """The quad with uvs lo .. lo + span across it, a minified random two-valued texture (every
    pixel sees a sharp texel edge nearby), ambient-only (each pixel is the texel lookup)."""
    from phongscene.scene import AmbientLight, Camera, Scene, Texture, TriangleMesh

    rng = np.random.default_rng(3)
    texture = Texture(rng.choice([0.05, 1.0], (64, 64, 3)).astype(np.float32), wrap, wrap, source="/Edge/Texture")
    o, a, b = EDGE_QUAD_ORIGIN, EDGE_QUAD_A, EDGE_QUAD_B
    material = dataclasses.replace(calibration.GROUND, diffuse_texture=texture, ka=1.0, kd=0.0, ks=0.0)
    quad = TriangleMesh(
        [tuple(c) for c in (o, o + a, o + a + b, o + b)],
        [(0, 1, 2), (0, 2, 3)],
        material=material,
        uvs=[(lo + span * s, lo + span * t) for s, t in ((0, 0), (1, 0), (1, 1), (0, 1))],
        uv_indices=[(0, 1, 2), (0, 2, 3)],
    )
    n = EDGE_QUAD_PIXELS
    settings = dataclasses.replace(calibration.point_light().settings, width=n, height=n)
    camera = Camera(position=(0.55, 0.45, 3.0), projection="orthographic", ortho_width=1.2)
    return check(Scene(camera=camera, ambient=AmbientLight((1.0, 1.0, 1.0)), meshes=(quad,), settings=settings))


def _edge_quad_model_uv(lo, span):
    """The model's (exact) uv at each pixel centre, and the pixels well inside the quad."""
    n = EDGE_QUAD_PIXELS
    c = (np.arange(n) + 0.5) / n
    x, y = np.meshgrid(0.55 - 0.6 + 1.2 * c, 0.45 + 0.6 - 1.2 * c)
    frame = np.array([[EDGE_QUAD_A[0], EDGE_QUAD_B[0]], [EDGE_QUAD_A[1], EDGE_QUAD_B[1]]])
    st = np.linalg.solve(frame, np.stack([x.ravel() - EDGE_QUAD_ORIGIN[0], y.ravel() - EDGE_QUAD_ORIGIN[1]]))
    inside = ((st > 0.02) & (st < 0.98)).all(axis=0).reshape(n, n)
    return lo + span * st[0], lo + span * st[1], inside


@pytest.mark.povray
def test_povray_numerics_take_the_mesh_uv_as_povray_computes_it():
    from phongscene.backends import povray

    # uvs near 1000 (repeat) and spanning 1000 texture widths: POV-Ray's uv error is ~1e-4 there;
    # uvs in [0, 0.7495] with clamp: the uvs the SDL holds are mapped into the UvFrame.
    cases = [("repeat", 1000.0, 0.75), ("repeat", 0.0, 1000.75), ("clamp", 0.0, 0.7495)]
    scenes = [_edge_quad(*case) for case in cases]
    images = povray.render_many([(s, None, None) for s in scenes])
    for (wrap, lo, span), scene, pov in zip(cases, scenes, images):
        ours = native.render(scene, dataclasses.replace(scene.settings, numerics="povray"))
        u, v, inside = _edge_quad_model_uv(lo, span)
        rel = np.abs(ours - pov) / np.maximum(pov, SRGB_ABS)
        assert np.all(rel[inside] <= POV_OUTPUT_REL), (wrap, lo, span, np.count_nonzero(rel[inside] > POV_OUTPUT_REL))
        if lo + span > 2.0:  # ... where the model's own uv reads other texels at hundreds of pixels
            texture = scene.meshes[0].material.diffuse_texture
            half = dataclasses.replace(texture, image=texture.image.astype(np.float16).astype(np.float32))
            model = oracle.sample_texture(half, np.mod(u, 1.0), np.mod(v, 1.0)).reshape(pov.shape)
            off = (np.abs(model - pov) > POV_OUTPUT_REL * pov)[inside].any(axis=-1)
            assert np.count_nonzero(off) > 100, (wrap, lo, span)


# -- a textured Blender export ----------------------------------------------------------------------

# Blender 5.0.1's USD export of benchmarks/blender/build_scenes.py's "textured_glossy" (its colour
# grid texture on a glossy sphere and a tiled floor), converted to .usdc to keep it small.
BLENDER_TEXTURED = SCENES / "blender_textured" / "textured_glossy.usdc"


def test_blender_export_reads_its_image_texture():
    scene = load_usd(str(BLENDER_TEXTURED))
    textures = {m.material.diffuse_texture for m in scene.meshes}
    # Floor and sphere: both textured, by one shared Texture (same image and sampling rules).
    assert len(scene.meshes) == 2 and len(textures) == 1 and None not in textures
    for t in textures:
        assert (t.width, t.height, t.wrap_s, t.wrap_t) == (64, 64, "repeat", "repeat")
        assert t.file.endswith("textured_glossy_grid.png")
    floor = next(m for m in scene.meshes if m.source.startswith("/root/Floor"))
    assert floor.uvs.max() == 2.0  # the floor's uvs tile the grid twice (repeat)


@pytest.mark.slow
@pytest.mark.povray
@pytest.mark.parametrize("mapping", ["exact", "classic"])
def test_blender_textured_export_agrees_on_both_backends(mapping):
    from phongscene import compare
    from phongscene.backends import povray

    scene = check(load_usd(str(BLENDER_TEXTURED)))
    if mapping == "classic":
        scene = calibration.classic_variant(scene)
    settings = dataclasses.replace(scene.settings, width=80, height=60, numerics="povray")
    a = native.render(scene, settings)
    b = povray.render(scene, dataclasses.replace(settings, numerics="scale-invariant"), mapping=mapping)
    # Its colours: the grid's hues differ across the image (a grey render would not).
    assert np.ptp(a[..., 0] - a[..., 2]) > 0.3
    report = compare(a, b)
    assert report.ok, report


@pytest.mark.slow
@pytest.mark.povray
def test_compile_writes_the_texture_beside_the_sdl_and_povray_renders_it(tmp_path, capsys):
    import subprocess

    from phongscene.backends import povray
    from phongscene.cli import main
    from phongscene.images import read_image

    out = tmp_path / "out"
    out.mkdir()
    assert (
        main(["compile", str(BLENDER_TEXTURED), "-o", str(out / "scene.pov"), "--width", "40", "--height", "30"]) == 0
    )
    (texture,) = out.glob("phongscene-texture-*.exr")
    assert texture.name in (out / "scene.pov").read_text() and texture.name in capsys.readouterr().out
    # The half EXR holds the texture's texels rounded to half.
    model = load_usd(str(BLENDER_TEXTURED)).meshes[0].material.diffuse_texture
    np.testing.assert_array_equal(read_image(texture), model.image.astype(np.float16).astype(np.float32))
    # povray with the written .ini renders in that folder, as the command printed says.
    run = subprocess.run(
        ["povray", "scene.ini"], cwd=out, capture_output=True, env={"HOME": str(tmp_path), "PATH": "/usr/bin:/bin"}
    )
    assert run.returncode == 0, run.stderr[-500:]
    frames = sorted(out.glob("scene*.exr"))
    assert len(frames) == 2  # exact mapping: one frame per light
    summed = np.sum([read_image(f) for f in frames], axis=0)
    scene = check(load_usd(str(BLENDER_TEXTURED)))
    expected = povray.render(scene, dataclasses.replace(scene.settings, width=40, height=30))
    np.testing.assert_allclose(summed, expected, rtol=1e-6, atol=1e-7)


@pytest.mark.parametrize("name", ["texture_repeat", "texture_clamp", "texture_specular"])
@pytest.mark.slow
def test_write_usd_round_trips_textures(tmp_path, name):
    from phongscene import write_usd

    scene = calibration.SCENES[name]()
    path = write_usd(scene, tmp_path / "scene.usda")
    images = sorted(str(p) for p in tmp_path.glob("scene-texture-*.exr"))  # beside the layer
    back = load_usd(str(path))
    (mesh,) = back.meshes
    original = scene.meshes[0]
    assert len(images) == len(original.material.textures)
    for field in ("diffuse_texture", "specular_texture"):
        t, u = getattr(mesh.material, field), getattr(original.material, field)
        assert (t is None) == (u is None)
        if u is not None:
            np.testing.assert_array_equal(t.image, u.image)
            assert (t.wrap_s, t.wrap_t) == (u.wrap_s, u.wrap_t) and t.file in images
    np.testing.assert_array_equal(mesh.uvs[mesh.uv_indices], original.uvs[original.uv_indices])
    assert mesh.material.diffuse_color == pytest.approx(original.material.diffuse_color)
    assert mesh.material.specular_color == pytest.approx(original.material.specular_color)


def test_phong_specular_color_texture(tmp_path):
    write_png(tmp_path / "tex.png")
    scene = load_usd(
        textured_stage(tmp_path / "s.usda", "tex.png", phong=True, inputs=("specularColor",), color_space="raw")
    )
    mesh, texture = _texture(scene, "specular_texture")
    assert mesh.material.diffuse_texture is None
    np.testing.assert_allclose(texture.image, PIXELS8 / 255.0, rtol=1e-7)


def test_preview_specular_workflow_texture_keeps_the_highlight_strength_per_texel(tmp_path):
    from phongscene.usd import preview_to_phong

    write_png(tmp_path / "tex.png")
    path = textured_stage(
        tmp_path / "s.usda", "tex.png", inputs=("specularColor",), color_space="raw", specular_workflow=True
    )
    mesh, texture = _texture(load_usd(path), "specular_texture")
    m = mesh.material
    f0 = (PIXELS8 / 255.0).reshape(-1, 3)
    for texel, cs in zip(f0, texture.image.reshape(-1, 3)):
        # Per texel, ks·cs is what the untextured mapping gives that texel's F0 (same exponent).
        alone = preview_to_phong((0.18, 0.18, 0.18), 0.4, specular_color=tuple(texel), use_specular_workflow=1)
        assert alone.exponent == pytest.approx(m.exponent)
        np.testing.assert_allclose(m.ks * cs, alone.ks * np.asarray(alone.specular_color), rtol=1e-6)


def test_a_specular_texture_changes_only_the_highlight():
    scene = check(calibration.texture_specular())
    plain_mesh = dataclasses.replace(
        scene.meshes[0], material=dataclasses.replace(scene.meshes[0].material, specular_texture=None)
    )
    plain = dataclasses.replace(scene, meshes=(plain_mesh,))
    textured, untextured = native.render(scene), native.render(plain)
    assert np.abs(textured - untextured).max() > 0.05
    no_highlight = lambda s: dataclasses.replace(  # noqa: E731
        s, meshes=tuple(dataclasses.replace(m, material=dataclasses.replace(m.material, ks=0.0)) for m in s.meshes)
    )
    np.testing.assert_array_equal(native.render(no_highlight(scene)), native.render(no_highlight(plain)))


def _wrap_scene(wrap_s, wrap_t, uv_lo=-2.3, uv_hi=3.1):
    scene = calibration.point_light()
    quad = calibration.textured_quad(calibration.checker_texture(wrap_s, wrap_t), uv_lo, uv_hi)
    return check(
        dataclasses.replace(scene, meshes=(quad,), settings=dataclasses.replace(scene.settings, width=40, height=30))
    )


def _edge_scene(wrap_s, wrap_t):
    from phongscene.scene import AmbientLight, Camera, PointLight, Scene, TriangleMesh

    corners = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
    material = dataclasses.replace(calibration.GROUND, diffuse_texture=calibration.checker_texture(wrap_s, wrap_t))
    quad = TriangleMesh(
        corners,
        [(0, 1, 2), (0, 2, 3)],
        material=material,
        uvs=[c[:2] for c in corners],
        uv_indices=[(0, 1, 2), (0, 2, 3)],
    )
    camera = Camera(position=(0.5, 0.5, 2.0), projection="orthographic", ortho_width=1.3)
    return check(
        Scene(
            camera=camera,
            ambient=AmbientLight((0.2, 0.2, 0.2)),
            lights=(PointLight((0.3, 0.6, 3.0), (3.0, 3.0, 3.0)),),
            meshes=(quad,),
            settings=dataclasses.replace(calibration.point_light().settings, width=40, height=40),
        )
    )


WRAP_PAIRS = [(s, t) for s in ("repeat", "clamp", "mirror", "black") for t in ("repeat", "clamp", "mirror", "black")]


@pytest.mark.slow
@pytest.mark.povray
def test_every_wrap_mode_agrees_on_both_backends_beyond_the_unit_square():
    # uvs from -2.3 to 3.1: POV-Ray gets each image tiled over the uvs' integer box by its own
    # rules, with the uvs mapped into [0, 1]² (compile.UvFrame); one POV-Ray run for all 16.
    from phongscene import compare
    from phongscene.backends import povray

    # And a unit square seen whole with uvs ending exactly on the image's edges: there the lookup
    # blends the edge texel with what lies beyond it (the other edge, black, or itself).
    cases = [("far", pair) for pair in WRAP_PAIRS] + [("edges", pair) for pair in WRAP_PAIRS]
    scenes = [_wrap_scene(*pair) if kind == "far" else _edge_scene(*pair) for kind, pair in cases]
    images = povray.render_many([(s, None, None) for s in scenes])
    for pair, scene, b in zip(cases, scenes, images):
        a = native.render(scene, dataclasses.replace(scene.settings, numerics="povray"))
        report = compare(a, b)
        assert report.ok, (pair, report)


def test_uv_frame_tiles_by_each_axis_rule():
    from phongscene.backends.povray.compile import UvFrame

    t = dataclasses.replace(calibration.checker_texture(), wrap_s="mirror", wrap_t="black")  # 5 x 3
    # u in [-1, 2] (whole tiles, g_u = 1); v in [-1/3, 4/3] (g_v = 3: one texel row below and above).
    frame = UvFrame(g_u=1, lo_u=-1, n_u=3, g_v=3, lo_v=-1, n_v=5)
    tiled = frame.tile(t)
    assert tiled.shape == (t.height + 2, 3 * t.width, 3)
    # The image itself: u in [0, 1] (the middle tile), v in [0, 1] (below the top row).
    np.testing.assert_array_equal(tiled[1 : 1 + t.height, t.width : 2 * t.width], t.image)
    np.testing.assert_array_equal(tiled[0], 0.0)  # black above v = 1 ...
    np.testing.assert_array_equal(tiled[-1], 0.0)  # ... and below v = 0
    np.testing.assert_array_equal(tiled[1:-1, : t.width], t.image[:, ::-1])  # mirrored left of u = 0
    np.testing.assert_allclose(frame.apply(np.array([[-1.0, -1 / 3], [2.0, 4 / 3]])), [[0, 0], [1, 1]])


def test_use_metadata_takes_the_files_wrap_modes(tmp_path):
    values = np.random.default_rng(5).uniform(0, 1, (2, 3, 3)).astype(np.float32)
    buf = oiio.ImageBuf(values)
    buf.specmod().attribute("wrapmodes", "clamp,mirror")
    assert buf.write(str(tmp_path / "tex.exr"), "float")
    _, texture = _texture(load_usd(textured_stage(tmp_path / "s.usda", "tex.exr", wrap=("useMetadata", "useMetadata"))))
    assert (texture.wrap_s, texture.wrap_t) == ("clamp", "mirror")
    # Without the file's modes, useMetadata is black (the UsdUVTexture spec).
    assert oiio.ImageBuf(values).write(str(tmp_path / "plain.exr"), "float")
    _, texture = _texture(load_usd(textured_stage(tmp_path / "p.usda", "plain.exr", wrap=("useMetadata", "repeat"))))
    assert (texture.wrap_s, texture.wrap_t) == ("black", "repeat")


def test_textured_mesh_without_its_st_primvar_and_sphere_use_the_fallback(tmp_path):
    write_png(tmp_path / "tex.png")
    path = textured_stage(tmp_path / "s.usda", "tex.png")
    stage = Usd.Stage.Open(path)
    UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/World/Quad")).RemovePrimvar("st")
    sphere = UsdGeom.Sphere.Define(stage, "/World/Ball")
    UsdShade.MaterialBindingAPI.Apply(sphere.GetPrim()).Bind(UsdShade.Material(stage.GetPrimAtPath("/World/Looks/Mat")))
    stage.GetRootLayer().Save()
    from phongscene.usd import read_usd

    result = read_usd(path)
    assert all(not m.material.textures for m in (*result.scene.meshes, *result.scene.spheres))
    assert any("without their st primvar" in w and "/World/Quad" in w for w in result.warnings)
    assert any("without texture coordinates" in w and "/World/Ball" in w for w in result.warnings)
    assert not validate(result.scene)


def test_unreadable_image_is_a_warning_and_non_finite_texels_an_error(tmp_path):
    from phongscene.errors import SceneError
    from phongscene.usd import read_usd

    (tmp_path / "bad.png").write_bytes(b"\x89PNG\r\n\x1a\nnot a png")
    result = read_usd(textured_stage(tmp_path / "s.usda", "bad.png"))
    assert not result.scene.meshes[0].material.textures
    assert any("/World/Looks/Mat/Texture.inputs:file: cannot read" in w and "fallback" in w for w in result.warnings)
    values = np.ones((2, 2, 3), np.float32)
    values[0, 1, 2] = np.nan
    assert oiio.ImageBuf(values).write(str(tmp_path / "nan.exr"), "float")
    with pytest.raises(
        SceneError, match=r"/World/Looks/Mat/Texture\.inputs:file: .*nan\.exr: 1 texel values are not finite"
    ):
        load_usd(textured_stage(tmp_path / "n.usda", "nan.exr"))


def test_preview_metallic_texture_is_the_mapping_per_texel(tmp_path):
    from phongscene.usd import preview_to_phong

    write_png(tmp_path / "tex.png")
    path = textured_stage(tmp_path / "s.usda", "tex.png", inputs=(), output="g", color_space="raw")
    stage = Usd.Stage.Open(path)
    surface = UsdShade.Shader(stage.GetPrimAtPath("/World/Looks/Mat/Surface"))
    texture = UsdShade.Shader(stage.GetPrimAtPath("/World/Looks/Mat/Texture"))
    surface.CreateInput("metallic", Sdf.ValueTypeNames.Float).ConnectToSource(texture.ConnectableAPI(), "g")
    surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set((0.9, 0.5, 0.2))
    stage.GetRootLayer().Save()
    (mesh,) = load_usd(path).meshes
    m = mesh.material
    metallic = (PIXELS8[:, :, 1] / 255.0).reshape(-1)
    cd, cs = m.diffuse_texture.image.reshape(-1, 3), m.specular_texture.image.reshape(-1, 3)
    for k, metal in enumerate(metallic):
        alone = preview_to_phong((0.9, 0.5, 0.2), 0.4, metallic=float(metal))
        np.testing.assert_allclose(cd[k], alone.diffuse_color, rtol=1e-6, atol=1e-7)
        np.testing.assert_allclose(m.ks * cs[k], alone.ks * np.asarray(alone.specular_color), rtol=1e-6)
        assert alone.exponent == pytest.approx(m.exponent)


def test_phong_ks_texture_is_a_highlight_colour_texture(tmp_path):
    write_png(tmp_path / "tex.png")
    path = textured_stage(tmp_path / "s.usda", "tex.png", phong=True, inputs=(), output="b", color_space="raw")
    stage = Usd.Stage.Open(path)
    surface = UsdShade.Shader(stage.GetPrimAtPath("/World/Looks/Mat/Surface"))
    texture = UsdShade.Shader(stage.GetPrimAtPath("/World/Looks/Mat/Texture"))
    surface.CreateInput("ks", Sdf.ValueTypeNames.Float).ConnectToSource(texture.ConnectableAPI(), "b")
    surface.CreateInput("specularColor", Sdf.ValueTypeNames.Color3f).Set((0.5, 1.0, 2.0))
    stage.GetRootLayer().Save()
    (mesh,) = load_usd(path).meshes
    m = mesh.material
    ks = PIXELS8[:, :, 2] / 255.0
    assert m.ks == pytest.approx(ks.max())
    # ks·cs per texel is the texel's ks times the authored cs.
    np.testing.assert_allclose(m.ks * m.specular_texture.image, ks[:, :, None] * (0.5, 1.0, 2.0), rtol=1e-6)


def test_texels_beyond_half_range_are_an_error_naming_the_file_input(tmp_path):
    from phongscene.errors import SceneError

    values = np.ones((2, 2, 3), np.float32)
    values[0, 0, 1] = 1e5  # POV-Ray holds image maps as half floats (max 65504)
    assert oiio.ImageBuf(values).write(str(tmp_path / "big.exr"), "float")
    with pytest.raises(
        SceneError, match=r"/World/Looks/Mat/Texture\.inputs:file: texel values must be in \[0, 65504\]"
    ):
        load_usd(textured_stage(tmp_path / "s.usda", "big.exr"))  # it validates
