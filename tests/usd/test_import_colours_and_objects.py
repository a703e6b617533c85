# SPDX-License-Identifier: Apache-2.0
"""`import` keeps a file's colours (PLY face and vertex colours, a GLB material's base colour →
primvars:displayColor) and its objects (a GLB's nodes → one Mesh prim each, named after the
node), issue 26.6."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from pxr import Usd, UsdGeom

from phongscene.cli import main
from phongscene.usd import read_usd

# 8-bit sRGB 128 in linear light (the sRGB curve), and 255 → 1, 0 → 0.
SRGB_128 = ((128 / 255 + 0.055) / 1.055) ** 2.4
FLOAT32 = 1e-6  # displayColor is color3f


def display_color(stage, path):
    primvar = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath(path)).GetPrimvar("displayColor")
    return np.asarray(primvar.Get()), primvar.GetInterpolation()


def test_ply_face_colours_become_a_uniform_display_color(tmp_path):
    box = trimesh.creation.box()
    box.visual.face_colors = [[255, 0, 0, 255] if i < 6 else [0, 128, 255, 255] for i in range(len(box.faces))]
    box.export(tmp_path / "box.ply")
    assert main(["import", str(tmp_path / "box.ply"), "-o", str(tmp_path / "box.usda")]) == 0
    stage = Usd.Stage.Open(str(tmp_path / "box.usda"))
    colours, interpolation = display_color(stage, "/World/box")
    assert interpolation == UsdGeom.Tokens.uniform and len(colours) == len(box.faces)
    np.testing.assert_allclose(colours[0], (1, 0, 0), atol=FLOAT32)
    np.testing.assert_allclose(colours[-1], (0, SRGB_128, 1), atol=FLOAT32)
    # Unbound, so the reader takes displayColor (its mean, said) instead of a default material.
    result = read_usd(tmp_path / "box.usda")
    (mesh,) = result.scene.meshes
    np.testing.assert_allclose(mesh.material.diffuse_color, colours.mean(axis=0), atol=FLOAT32)
    assert any("non-constant displayColor" in w for w in result.warnings)


def test_ply_vertex_colours_become_a_vertex_display_color(tmp_path):
    ico = trimesh.creation.icosphere(subdivisions=1)
    ico.visual.vertex_colors = np.tile([0, 128, 0, 255], (len(ico.vertices), 1))
    ico.visual.vertex_colors[0] = [255, 255, 255, 255]
    ico.export(tmp_path / "ico.ply")
    assert main(["import", str(tmp_path / "ico.ply"), "-o", str(tmp_path / "ico.usda")]) == 0
    colours, interpolation = display_color(Usd.Stage.Open(str(tmp_path / "ico.usda")), "/World/ico")
    assert interpolation == UsdGeom.Tokens.vertex and len(colours) == len(ico.vertices)
    np.testing.assert_allclose(colours[1], (0, SRGB_128, 0), atol=FLOAT32)


def test_a_glb_scene_keeps_one_prim_per_node_with_its_name_and_colour(tmp_path):
    scene = trimesh.Scene()
    red = trimesh.creation.box()
    red.visual = trimesh.visual.TextureVisuals(
        material=trimesh.visual.material.PBRMaterial(baseColorFactor=[255, 0, 0, 255])
    )
    scene.add_geometry(red, node_name="RedBox", geom_name="box")
    scene.add_geometry(
        trimesh.creation.icosphere(),
        node_name="Ball",
        geom_name="ball",
        transform=trimesh.transformations.translation_matrix([3, 0, 0]),
    )
    scene.export(tmp_path / "two.glb")
    assert main(["import", str(tmp_path / "two.glb"), "-o", str(tmp_path / "two.usda")]) == 0
    stage = Usd.Stage.Open(str(tmp_path / "two.usda"))
    meshes = sorted(str(p.GetPath()) for p in stage.Traverse() if p.IsA(UsdGeom.Mesh))
    assert meshes == ["/World/Ball", "/World/RedBox"]
    colours, interpolation = display_color(stage, "/World/RedBox")
    assert interpolation == UsdGeom.Tokens.constant
    np.testing.assert_allclose(colours, [(1, 0, 0)], atol=FLOAT32)
    read = read_usd(tmp_path / "two.usda").scene
    by_name = {m.source: m for m in read.meshes}
    assert by_name["/World/RedBox"].material.diffuse_color == pytest.approx((1, 0, 0))
    assert by_name["/World/Ball"].points[:, 0].mean() == pytest.approx(3, abs=1e-6)  # the node's transform


def test_two_nodes_of_one_prim_name_get_distinct_prims(tmp_path):
    # "Box 1" and "Box-1" are both Box_1 as USD identifiers.
    scene = trimesh.Scene()
    for x, name in ((0, "Box 1"), (3, "Box-1")):
        scene.add_geometry(
            trimesh.creation.box(), node_name=name, transform=trimesh.transformations.translation_matrix([x, 0, 0])
        )
    scene.export(tmp_path / "boxes.glb")
    assert main(["import", str(tmp_path / "boxes.glb"), "-o", str(tmp_path / "boxes.usda")]) == 0
    assert sorted(m.source for m in read_usd(tmp_path / "boxes.usda").scene.meshes) == [
        "/World/Box_1",
        "/World/Box_1_1",
    ]
