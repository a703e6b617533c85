# SPDX-License-Identifier: Apache-2.0
"""Cut-out masks read from USD: UsdPreviewSurface's masked mode with a textured opacity (the
image's alpha, as Blender writes a leaf's; or a channel) and ``opacityThreshold`` > 0 becomes the
material's opacity_texture; our Phong shader's ``opacity`` / ``opacityThreshold`` likewise, and
``write_usd`` writes them back. Without a threshold a textured opacity stays unread (warned)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade

from phongscene import load_usd, read_usd, write_usd
from phongscene.backends import native
from support import png

# USD holds the written material's and light's numbers as float32: the picture read back moves by
# their rounding (a few float32 ulps), far below a hole's worth.
ROUND_TRIP_REL = 1e-5
# An RGBA image: colour everywhere, alpha 255 on the left column, 0 on the right.
PIXELS = np.array(
    [[[200, 40, 30, 255], [30, 200, 40, 0]], [[40, 30, 200, 255], [90, 90, 90, 0]]],
    dtype=np.uint8,
)


def masked_stage(path, image: str, threshold: float | None, *, phong: bool = False, output: str = "a") -> str:
    """A quad facing a camera over a red backdrop; the quad's material's opacity from ``output``
    of a UsdUVTexture reading ``image`` (clamped), with ``threshold`` (None: not authored)."""
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    quad = UsdGeom.Mesh.Define(stage, "/World/Leaf")
    quad.CreatePointsAttr([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)])
    quad.CreateFaceVertexCountsAttr([4])
    quad.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    quad.CreateSubdivisionSchemeAttr("none")
    st = UsdGeom.PrimvarsAPI(quad).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, "faceVarying")
    st.Set([(0, 0), (1, 0), (1, 1), (0, 1)])
    backdrop = UsdGeom.Mesh.Define(stage, "/World/Backdrop")
    backdrop.CreatePointsAttr([(-5, -5, -3), (5, -5, -3), (5, 5, -3), (-5, 5, -3)])
    backdrop.CreateFaceVertexCountsAttr([4])
    backdrop.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    backdrop.CreateSubdivisionSchemeAttr("none")
    backdrop.CreateDisplayColorAttr([(0.8, 0.05, 0.05)])
    material = UsdShade.Material.Define(stage, "/World/Looks/Leaf")
    reader = UsdShade.Shader.Define(stage, "/World/Looks/Leaf/Reader")
    reader.CreateIdAttr("UsdPrimvarReader_float2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("st")
    tex = UsdShade.Shader.Define(stage, "/World/Looks/Leaf/Texture")
    tex.CreateIdAttr("UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(image)
    tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
    tex.CreateInput("wrapS", Sdf.ValueTypeNames.Token).Set("clamp")
    tex.CreateInput("wrapT", Sdf.ValueTypeNames.Token).Set("clamp")
    tex.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("raw")
    tex.CreateOutput(output, Sdf.ValueTypeNames.Float)
    surface = UsdShade.Shader.Define(stage, "/World/Looks/Leaf/Surface")
    if phong:
        surface.CreateIdAttr("phongscene_PhongSurface")
        material.CreateSurfaceOutput("phong").ConnectToSource(surface.ConnectableAPI(), "surface")
    else:
        surface.CreateIdAttr("UsdPreviewSurface")
        material.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
    surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.1, 0.6, 0.1))
    surface.CreateInput("opacity", Sdf.ValueTypeNames.Float).ConnectToSource(tex.ConnectableAPI(), output)
    if threshold is not None:
        surface.CreateInput("opacityThreshold", Sdf.ValueTypeNames.Float).Set(threshold)
    UsdShade.MaterialBindingAPI.Apply(quad.GetPrim()).Bind(material)
    cam = UsdGeom.Camera.Define(stage, "/World/Camera")
    cam.AddTranslateOp().Set((0.0, 0.0, 4.0))
    stage.DefinePrim("/World/Sun", "DistantLight").CreateAttribute("inputs:intensity", Sdf.ValueTypeNames.Float).Set(
        2.0
    )
    render = stage.DefinePrim("/Render/Settings", "RenderSettings")
    render.CreateAttribute("resolution", Sdf.ValueTypeNames.Int2).Set(Gf.Vec2i(40, 30))
    stage.SetDefaultPrim(stage.GetPrimAtPath("/World"))
    stage.GetRootLayer().Save()
    return str(path)


def _leaf(scene):
    (leaf,) = [m for m in scene.meshes if m.source.endswith("Leaf")]
    return leaf.material


@pytest.mark.parametrize("phong", [False, True], ids=["preview", "phong"])
def test_a_textured_opacity_with_a_threshold_is_a_cut_out_mask(tmp_path, phong):
    image = png.write_png(tmp_path / "leaf.png", PIXELS)
    scene = load_usd(masked_stage(tmp_path / "s.usda", image, 0.5, phong=phong))
    material = _leaf(scene)
    assert material.opacity_threshold == 0.5
    mask = material.opacity_texture.image[..., 0]
    np.testing.assert_array_equal(mask, [[1.0, 0.0], [1.0, 0.0]])  # the alpha, row 0 at the top
    # Through the right half (alpha 0) the backdrop shows; the left half is the leaf, as without
    # the mask.
    image = native.render(scene)
    solid = native.render(
        dataclasses.replace(
            scene,
            meshes=tuple(
                dataclasses.replace(m, material=m.material.without_textures()) if m.source.endswith("Leaf") else m
                for m in scene.meshes
            ),
        )
    )
    middle = image.shape[0] // 2
    assert np.array_equal(image[middle, 12], solid[middle, 12])
    assert not np.array_equal(image[middle, 27], solid[middle, 27])


def test_without_a_threshold_a_textured_opacity_is_not_read(tmp_path):
    image = png.write_png(tmp_path / "leaf.png", PIXELS)
    result = read_usd(masked_stage(tmp_path / "s.usda", image, None))
    material = _leaf(result.scene)
    assert material.opacity_texture is None and material.kt == 0.0  # opaque, as before
    assert any("inputs:opacity connected to a texture" in w for w in result.warnings)


def test_a_mask_whose_image_is_missing_falls_back_to_its_constant(tmp_path):
    scene = load_usd(masked_stage(tmp_path / "s.usda", "missing.png", 0.5))
    assert _leaf(scene).opacity_texture is None  # UsdUVTexture's fallback (opacity 1 >= 0.5): opaque


def test_write_usd_round_trips_a_cut_out_mask(tmp_path):
    image = png.write_png(tmp_path / "leaf.png", PIXELS)
    scene = load_usd(masked_stage(tmp_path / "s.usda", image, 0.5))
    (tmp_path / "out").mkdir()
    back = load_usd(str(write_usd(scene, tmp_path / "out" / "leaf.usda")))
    before, after = _leaf(scene), _leaf(back)
    assert after.opacity_threshold == before.opacity_threshold
    np.testing.assert_array_equal(after.opacity_texture.image[..., 0], before.opacity_texture.image[..., 0])
    np.testing.assert_allclose(native.render(back), native.render(scene), rtol=ROUND_TRIP_REL, atol=0)


def test_info_lists_the_mask_and_its_threshold(tmp_path, capsys):
    from phongscene.cli import main

    image = png.write_png(tmp_path / "leaf.png", PIXELS)
    assert main(["info", masked_stage(tmp_path / "s.usda", image, 0.5)]) == 0
    out = capsys.readouterr().out
    assert "/World/Looks/Leaf/Surface opacity (cut out below 0.5) <- " in out and "leaf.png, 2x2" in out
