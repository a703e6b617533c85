# SPDX-License-Identifier: Apache-2.0
"""MaterialX image and normalmap nodes, in USD and in referenced .mtlx documents (issue 28.1-2):
a ``.mtlx`` reference composes (usd-core has no MaterialX file format: phongscene translates the
document with the MaterialX package, phongscene/usd/materialx_documents.py), its image nodes
become the model's textures (base colour, sRGB or linear as the file's colour space says, scaled
by the diffuse lobe's weight) and its normalmap node a normal map; the same nodes written as USD
prims read the same; a document that cannot be read is a warning and the rest is drawn."""

from __future__ import annotations

import numpy as np
import pytest
from usda import read

from support.png import write_png

# OpenImageIO's sRGB decoding and 8-bit → float32 (as in tests/usd/test_textures.py): far below an
# 8-bit step.
DECODED_ATOL = 3e-5

PIXELS8 = np.array(
    [
        [[10, 200, 30], [250, 5, 60], [90, 90, 240], [0, 128, 255]],
        [[255, 255, 255], [40, 10, 170], [128, 64, 32], [7, 77, 177]],
    ],
    dtype=np.uint8,
)
NORMAL8 = np.array(
    [[[128, 128, 255], [200, 128, 230]], [[60, 160, 220], [128, 40, 200]]],
    dtype=np.uint8,
)


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


MTLX = """<?xml version="1.0"?>
<materialx version="1.38" colorspace="lin_rec709">
  <nodegraph name="NG_Wood" fileprefix="tex/">
    <image name="base" type="color3">
      <input name="file" type="filename" value="base.png" colorspace="srgb_texture" />
    </image>
    <image name="bump" type="vector3">
      <input name="file" type="filename" value="normal.png" />
    </image>
    <normalmap name="decode" type="vector3">
      <input name="in" type="vector3" nodename="bump" />
      <input name="scale" type="float" value="0.5" />
    </normalmap>
    <output name="base_out" type="color3" nodename="base" />
    <output name="normal_out" type="vector3" nodename="decode" />
  </nodegraph>
  <standard_surface name="Wood" type="surfaceshader">
    <input name="base_color" type="color3" nodegraph="NG_Wood" output="base_out" />
    <input name="metalness" type="float" value="0.25" />
    <input name="specular_roughness" type="float" value="0.4" />
    <input name="normal" type="vector3" nodegraph="NG_Wood" output="normal_out" />
  </standard_surface>
  <surfacematerial name="M_Wood" type="material">
    <input name="surfaceshader" type="surfaceshader" nodename="Wood" />
  </surfacematerial>
</materialx>
"""

QUAD = """
def Camera "Cam" { double3 xformOp:translate = (0, 0, 5)
    uniform token[] xformOpOrder = ["xformOp:translate"] }
def DistantLight "Sun" { float inputs:intensity = 1 }
def Mesh "Quad" (prepend apiSchemas = ["MaterialBindingAPI"]) {
    uniform token subdivisionScheme = "none"
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 1, 2, 3]
    point3f[] points = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
    texCoord2f[] primvars:st = [(0, 0), (1, 0), (1, 1), (0, 1)] ( interpolation = "vertex" )
    rel material:binding = </Looks/M_Wood>
}
"""


def _textures(tmp_path):
    (tmp_path / "tex").mkdir()
    write_png(tmp_path / "tex" / "base.png", PIXELS8)
    write_png(tmp_path / "tex" / "normal.png", NORMAL8)


def _check_wood(result) -> None:
    (mesh,) = result.scene.meshes
    m = mesh.material
    assert m.diffuse_texture is not None and m.normal_texture is not None, result.warnings
    # The diffuse lobe is base_color·(1 − metalness): the sRGB texels, decoded, times 0.75.
    np.testing.assert_allclose(m.diffuse_texture.image, srgb_to_linear(PIXELS8 / 255.0) * 0.75, atol=DECODED_ATOL)
    # normalmap: v = 2·texel − 1 (linear: a vector3 image is never colour-decoded), x and y × scale.
    expected = 2.0 * NORMAL8 / 255.0 - 1.0
    expected[..., :2] *= 0.5
    np.testing.assert_allclose(m.normal_texture.image, expected, atol=DECODED_ATOL)
    assert mesh.uvs is not None  # read from st, the first uv set
    assert not [w for w in result.warnings if "no shader" in w or "not composed" in w or "cannot" in w]


def test_a_referenced_mtlx_document_composes_with_its_textures(tmp_path):
    _textures(tmp_path)
    (tmp_path / "wood.mtlx").write_text(MTLX)
    looks = 'def Scope "Looks" ( prepend references = @./wood.mtlx@</MaterialX/Materials> ) { }\n'
    _check_wood(read(tmp_path, looks + QUAD))


def test_the_same_nodes_written_in_usd_read_the_same(tmp_path):
    _textures(tmp_path)
    looks = """
def Scope "Looks" {
    def Material "M_Wood" {
        token outputs:mtlx:surface.connect = </Looks/M_Wood/Wood.outputs:out>
        def Shader "Wood" {
            uniform token info:id = "ND_standard_surface_surfaceshader"
            color3f inputs:base_color.connect = </Looks/M_Wood/NG_Wood.outputs:base_out>
            float inputs:metalness = 0.25
            float inputs:specular_roughness = 0.4
            float3 inputs:normal.connect = </Looks/M_Wood/NG_Wood.outputs:normal_out>
            token outputs:out
        }
        def NodeGraph "NG_Wood" {
            color3f outputs:base_out.connect = </Looks/M_Wood/NG_Wood/base.outputs:out>
            float3 outputs:normal_out.connect = </Looks/M_Wood/NG_Wood/decode.outputs:out>
            def Shader "base" {
                uniform token info:id = "ND_image_color3"
                asset inputs:file = @./tex/base.png@ ( colorSpace = "srgb_texture" )
                color3f outputs:out
            }
            def Shader "bump" {
                uniform token info:id = "ND_image_vector3"
                asset inputs:file = @./tex/normal.png@
                float3 outputs:out
            }
            def Shader "decode" {
                uniform token info:id = "ND_normalmap_float"
                float3 inputs:in.connect = </Looks/M_Wood/NG_Wood/bump.outputs:out>
                float inputs:scale = 0.5
                float3 outputs:out
            }
        }
    }
}
"""
    _check_wood(read(tmp_path, looks + QUAD))


def test_tiledimage_tiling_and_address_modes(tmp_path):
    _textures(tmp_path)
    looks = """
def Material "M_Wood" {
    token outputs:mtlx:surface.connect = </M_Wood/S.outputs:out>
    def Shader "S" {
        uniform token info:id = "ND_standard_surface_surfaceshader"
        color3f inputs:base_color.connect = </M_Wood/T.outputs:out>
        token outputs:out
    }
    def Shader "T" {
        uniform token info:id = "ND_tiledimage_color3"
        asset inputs:file = @./tex/base.png@
        float2 inputs:uvtiling = (2, 3)
        float2 inputs:uvoffset = (0.5, 0.25)
        string inputs:uaddressmode = "mirror"
        string inputs:vaddressmode = "clamp"
        color3f outputs:out
    }
}
"""
    result = read(tmp_path, looks + QUAD.replace("</Looks/M_Wood>", "</M_Wood>"))
    (mesh,) = result.scene.meshes
    t = mesh.material.diffuse_texture
    assert (t.wrap_s, t.wrap_t) == ("mirror", "clamp")
    # No colorSpace: linear texels (MaterialX's default, the document's lin_rec709).
    np.testing.assert_allclose(t.image, PIXELS8 / 255.0, atol=DECODED_ATOL)
    corners = np.array([(0, 0), (1, 0), (1, 1), (0, 1)], dtype=np.float64)
    np.testing.assert_allclose(mesh.uvs, corners * (2, 3) - (0.5, 0.25), atol=1e-12)


def test_an_unreadable_document_is_a_warning_and_the_rest_is_drawn(tmp_path):
    (tmp_path / "broken.mtlx").write_text("<materialx version='1.38'><unclosed>")
    looks = 'def Scope "Looks" ( prepend references = @./broken.mtlx@</MaterialX/Materials> ) { }\n'
    result = read(tmp_path, looks + QUAD)
    (mesh,) = result.scene.meshes  # drawn, with the default look
    assert mesh.material.diffuse_texture is None
    assert any("cannot read the MaterialX document" in w and "broken.mtlx" in w for w in result.warnings)


@pytest.mark.parametrize(("shader_id", "warned"), [("ND_add_color3", False), ("ND_imag_color3", True)])
def test_materialx_node_ids_are_known_and_a_misspelt_one_is_not(tmp_path, shader_id, warned):
    looks = f"""
def Material "M" {{
    token outputs:mtlx:surface.connect = </M/S.outputs:out>
    def Shader "S" {{
        uniform token info:id = "ND_standard_surface_surfaceshader"
        color3f inputs:base_color.connect = </M/Odd.outputs:out>
        token outputs:out
    }}
    def Shader "Odd" {{
        uniform token info:id = "{shader_id}"
        color3f outputs:out
    }}
}}
"""
    result = read(tmp_path, looks + QUAD.replace("</Looks/M_Wood>", "</M>"))
    assert any("no shader" in w and shader_id in w for w in result.warnings) == warned


def test_omni_pbr_textures_are_its_diffuse_texture_and_normal_map(tmp_path):
    """OmniPBR's asset inputs: diffuse_texture (8-bit, colour space auto: sRGB) × (1 − metallic),
    normalmap_texture (2·texel − 1, x and y × bump_factor, v flipped by flip_tangent_v), at st
    through texture_scale / texture_translate; a roughness texture is named as not read."""
    _textures(tmp_path)
    looks = """
def Material "M_Wood" {
    token outputs:mdl:surface.connect = </M_Wood/S.outputs:out>
    def Shader "S" {
        uniform token info:implementationSource = "sourceAsset"
        uniform asset info:mdl:sourceAsset = @OmniPBR.mdl@
        uniform token info:mdl:sourceAsset:subIdentifier = "OmniPBR"
        asset inputs:diffuse_texture = @./tex/base.png@
        float inputs:metallic_constant = 0.25
        asset inputs:normalmap_texture = @./tex/normal.png@ ( colorSpace = "raw" )
        float inputs:bump_factor = 0.5
        bool inputs:flip_tangent_v = 1
        asset inputs:reflectionroughness_texture = @./tex/base.png@
        float2 inputs:texture_scale = (2, 2)
        float2 inputs:texture_translate = (0.25, 0)
        token outputs:out
    }
}
"""
    result = read(tmp_path, looks + QUAD.replace("</Looks/M_Wood>", "</M_Wood>"))
    (mesh,) = result.scene.meshes
    m = mesh.material
    np.testing.assert_allclose(m.diffuse_texture.image, srgb_to_linear(PIXELS8 / 255.0) * 0.75, atol=DECODED_ATOL)
    expected = 2.0 * NORMAL8 / 255.0 - 1.0
    expected[..., 0] *= 0.5
    expected[..., 1] *= -0.5
    np.testing.assert_allclose(m.normal_texture.image, expected, atol=DECODED_ATOL)
    corners = np.array([(0, 0), (1, 0), (1, 1), (0, 1)], dtype=np.float64)
    np.testing.assert_allclose(mesh.uvs, corners * 2 + (0.25, 0), atol=1e-12)
    assert any("reflectionroughness_texture" in w and "/M_Wood/S" in w for w in result.warnings)
    assert not [w for w in result.warnings if "normalmap_texture" in w]
