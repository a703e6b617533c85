# SPDX-License-Identifier: Apache-2.0
"""Subdivision surfaces (phongscene/usd/subdivision.py, OpenSubdiv through the extension):
against closed forms where they exist (a regular Catmull-Clark mesh is a uniform bicubic
B-spline surface; an infinitely sharp cube stays the cube), the refinement's distance to the
limit surface falling with the level, and USD's options (level, creases, holes, subsets, st,
orientation) read right or refused with the prim and attribute named."""

from __future__ import annotations

import dataclasses
import subprocess
import sys

import numpy as np
import pytest
import trimesh
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade, Vt
from scipy.spatial import cKDTree

from phongscene import render
from phongscene.comparison import compare
from phongscene.errors import SceneError
from phongscene.rendering import settings_for
from phongscene.scene_files import read_scene_file
from phongscene.usd import read_usd
from phongscene.usd.subdivision import DEFAULT_LEVEL, MAX_LEVEL

# The refined vertices are OpenSubdiv's double-precision limit stencils applied to the cage:
# a few hundred roundings of unit-sized values.
LIMIT_TOLERANCE = 1e-12
# Limit normals against the B-spline's: the same tangents, normalised.
NORMAL_TOLERANCE = 1e-12

CUBE_POINTS = [(-1, -1, -1), (1, -1, -1), (1, 1, -1), (-1, 1, -1), (-1, -1, 1), (1, -1, 1), (1, 1, 1), (-1, 1, 1)]
CUBE_FACES = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]  # outward, CCW


def write_mesh(path, points, faces, *, level=None, scheme=None, **attributes):
    """A stage with one Mesh /M (its faces' vertex lists), attributes set by USD name."""
    stage = Usd.Stage.CreateNew(str(path))
    mesh = UsdGeom.Mesh.Define(stage, "/M")
    mesh.CreatePointsAttr(points)
    mesh.CreateFaceVertexCountsAttr([len(f) for f in faces])
    mesh.CreateFaceVertexIndicesAttr([i for f in faces for i in f])
    if scheme is not None:
        mesh.CreateSubdivisionSchemeAttr(scheme)
    if level is not None:
        mesh.GetPrim().CreateAttribute("phong:subdivisionLevel", Sdf.ValueTypeNames.Int).Set(level)
    for name, value in attributes.items():
        mesh.GetPrim().GetAttribute(name).Set(value)
    stage.GetRootLayer().Save()
    return stage, mesh


def refined(tmp_path, points, faces, **kwargs):
    path = tmp_path / "mesh.usda"
    write_mesh(path, points, faces, **kwargs)
    result = read_usd(str(path))
    assert len(result.scene.meshes) == 1
    return result, result.scene.meshes[0]


# -- closed forms ---------------------------------------------------------------------------------


def torus_cage(n_u=8, n_v=6, big=2.0, small=0.7):
    """A closed quad torus, every vertex of valence 4: its Catmull-Clark limit is the periodic
    uniform bicubic B-spline surface of its control points. Faces counter-clockwise seen from
    outside."""
    u = 2 * np.pi * np.arange(n_u) / n_u
    v = 2 * np.pi * np.arange(n_v) / n_v
    uu, vv = np.meshgrid(u, v, indexing="ij")
    ring = big + small * np.cos(vv)
    control = np.stack([ring * np.cos(uu), ring * np.sin(uu), small * np.sin(vv)], axis=-1)  # (n_u, n_v, 3)

    def vid(i, j):
        return (i % n_u) * n_v + (j % n_v)

    faces = [(vid(i, j), vid(i + 1, j), vid(i + 1, j + 1), vid(i, j + 1)) for i in range(n_u) for j in range(n_v)]
    return control, faces


def bspline(control, s, t):
    """The periodic uniform bicubic B-spline of control (n_u, n_v, 3) at parameters s, t (in
    control-point units) and its two partial derivatives."""

    def basis(x):
        i = np.floor(x).astype(int)
        f = x - i
        b = np.stack([(1 - f) ** 3, 3 * f**3 - 6 * f**2 + 4, -3 * f**3 + 3 * f**2 + 3 * f + 1, f**3], -1) / 6
        d = np.stack([-3 * (1 - f) ** 2, 9 * f**2 - 12 * f, -9 * f**2 + 6 * f + 3, 3 * f**2], -1) / 6
        return i - 1, b, d  # the four control points from i - 1

    n_u, n_v, _ = control.shape
    iu, bu, du = basis(s)
    iv, bv, dv = basis(t)
    point = np.zeros((len(s), 3))
    d_s = np.zeros((len(s), 3))
    d_t = np.zeros((len(s), 3))
    for a in range(4):
        for b in range(4):
            c = control[(iu + a) % n_u, (iv + b) % n_v]
            point += (bu[:, a] * bv[:, b])[:, None] * c
            d_s += (du[:, a] * bv[:, b])[:, None] * c
            d_t += (bu[:, a] * dv[:, b])[:, None] * c
    return point, d_s, d_t


@pytest.mark.parametrize("level", [1, 2, 3])
def test_a_regular_catmull_clark_mesh_refines_onto_its_bicubic_b_spline(tmp_path, level):
    control, faces = torus_cage()
    control = control.astype(np.float32).astype(np.float64)  # as the stage holds it (point3f)
    _, mesh = refined(tmp_path, control.reshape(-1, 3).tolist(), faces, level=level)
    n_u, n_v, _ = control.shape
    # The refined vertices are the limit surface at the dyadic parameters (B-spline knots are the
    # control points' own parameters: vertex (i, j) of the cage at (i + 1, j + 1) here, since
    # each span starts one control point earlier).
    k = 2**level
    s, t = np.meshgrid(np.arange(n_u * k) / k, np.arange(n_v * k) / k, indexing="ij")
    expected, d_s, d_t = bspline(control, s.ravel() + 1.0, t.ravel() + 1.0)
    assert len(mesh.points) == len(expected)
    distance, nearest = cKDTree(expected).query(mesh.points)
    assert distance.max() < LIMIT_TOLERANCE * np.abs(control).max()
    assert len(set(nearest.tolist())) == len(expected)  # one to one
    # The limit normals are the B-spline's, facing outward.
    normal = np.cross(d_s, d_t)[nearest]
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    outward = np.sign(np.einsum("ij,ij->i", normal, mesh.normals))
    assert (outward == outward[0]).all()
    np.testing.assert_allclose(mesh.normals, normal * outward[0], atol=NORMAL_TOLERANCE)
    centre_of_tube = mesh.points.copy()
    centre_of_tube[:, 2] = 0
    centre_of_tube *= 2.0 / np.linalg.norm(centre_of_tube, axis=1)[:, None]
    assert (np.einsum("ij,ij->i", mesh.normals, mesh.points - centre_of_tube) > 0).all()


def test_an_infinitely_sharp_cube_stays_the_cube(tmp_path):
    chains = [0, 1, 2, 3, 0, 4, 5, 6, 7, 4, 0, 4, 1, 5, 2, 6, 3, 7]
    _, mesh = refined(
        tmp_path,
        CUBE_POINTS,
        CUBE_FACES,
        level=3,
        creaseIndices=chains,
        creaseLengths=[5, 5, 2, 2, 2, 2],
        creaseSharpnesses=[10.0] * 6,  # USD's infinitely sharp
    )
    assert np.abs(np.abs(mesh.points).max(axis=1) - 1.0).max() < LIMIT_TOLERANCE
    area = trimesh.Trimesh(mesh.points, mesh.triangles, process=False).area
    assert area == pytest.approx(24.0, rel=LIMIT_TOLERANCE)


def midpoint_errors(tmp_path, level):
    """Each level-`level` triangle's edge midpoints (its diagonals' too) against the limit surface
    at the same parameters: the vertices of level + 1, which lie on the limit (the nearest one
    is that point, or closer). The largest distance; the cube has size 2."""
    _, mesh = refined(tmp_path, CUBE_POINTS, CUBE_FACES, level=level)
    _, finer = refined(tmp_path, CUBE_POINTS, CUBE_FACES, level=level + 1)
    corners = mesh.points[mesh.triangles]
    midpoints = 0.5 * (corners + np.roll(corners, 1, axis=1)).reshape(-1, 3)
    distance, _ = cKDTree(finer.points).query(midpoints)
    return distance.max()


def test_the_refined_cube_converges_to_its_limit_surface(tmp_path):
    errors = [midpoint_errors(tmp_path, level) for level in (1, 2, 3, 4)]
    # Measured 0.12, 0.038, 0.014, 0.0056: ~2.5x per level, not the 4x of a smooth region (the
    # largest errors sit at the cube's valence-3 corners, where the limit's curvature is unbounded).
    assert all(coarse > 2.0 * fine for coarse, fine in zip(errors, errors[1:]))
    assert errors[DEFAULT_LEVEL - 1] < 0.04  # the default level: within 2 % of the cube's size (2)


# -- USD's options ------------------------------------------------------------------------------------


def test_the_default_level_and_level_zero(tmp_path):
    result, mesh = refined(tmp_path, CUBE_POINTS, CUBE_FACES)
    assert len(mesh.triangles) == 6 * 2 * 4**DEFAULT_LEVEL
    assert not [w for w in result.warnings if "subdivision" in w]
    result, cage = refined(tmp_path, CUBE_POINTS, CUBE_FACES, level=0)
    assert len(cage.triangles) == 12 and cage.normals is None
    assert not [w for w in result.warnings if "subdivision" in w]


def test_a_crease_lies_between_smooth_and_sharp(tmp_path):
    def corner_distance(**creases):
        _, mesh = refined(tmp_path, CUBE_POINTS, CUBE_FACES, level=3, **creases)
        return np.linalg.norm(mesh.points, axis=1).max()

    smooth = corner_distance()
    semi = corner_distance(creaseIndices=[0, 1, 2, 3, 0], creaseLengths=[5], creaseSharpnesses=[2.0])
    per_edge = corner_distance(creaseIndices=[0, 1, 2, 3, 0], creaseLengths=[5], creaseSharpnesses=[2.0] * 4)
    corner = corner_distance(cornerIndices=[0], cornerSharpnesses=[10.0])
    assert smooth < semi < np.sqrt(3.0) and semi == per_edge
    assert corner == pytest.approx(np.sqrt(3.0), rel=LIMIT_TOLERANCE)  # a sharp corner stays put


def test_holes_and_subsets_follow_their_cage_faces(tmp_path):
    path = tmp_path / "mesh.usda"
    stage, mesh = write_mesh(path, CUBE_POINTS, CUBE_FACES, level=2, holeIndices=[1])
    red = UsdShade.Material.Define(stage, "/Red")
    shader = UsdShade.Shader.Define(stage, "/Red/S")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set((1, 0, 0))
    red.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    subset = UsdGeom.Subset.CreateGeomSubset(mesh, "top", UsdGeom.Tokens.face, [2], UsdShade.Tokens.materialBind)
    UsdShade.MaterialBindingAPI.Apply(subset.GetPrim()).Bind(red)
    stage.GetRootLayer().Save()
    meshes = read_usd(str(path)).scene.meshes
    per_face = 2 * 4**2
    assert sorted(len(m.triangles) for m in meshes) == [per_face, 4 * per_face]  # face 1 a hole
    top = next(m for m in meshes if len(m.triangles) == per_face)
    assert top.material.diffuse_color == pytest.approx((1, 0, 0))
    assert (top.points[np.unique(top.triangles)][:, 1] < 0).all()  # cage face 2 is the y = -1 side


def test_a_left_handed_mesh_keeps_its_normals_outward(tmp_path):
    flipped = [tuple(reversed(f)) for f in CUBE_FACES]
    for faces, orientation in ((CUBE_FACES, "rightHanded"), (flipped, "leftHanded")):
        _, mesh = refined(tmp_path, CUBE_POINTS, faces, level=2, orientation=orientation)
        assert (np.einsum("ij,ij->i", mesh.normals, mesh.points) > 0).all()
        # the triangles turn counter-clockwise seen from outside, as the fan path winds them
        a, b, c = (mesh.points[mesh.triangles[:, k]] for k in range(3))
        assert (np.einsum("ij,ij->i", np.cross(b - a, c - a), a + b + c) > 0).all()


def test_st_is_refined_with_the_surface(tmp_path):
    """A flat grid with st = an affine function of (x, y): subdivision is affine invariant, so the
    refined st is the same function of the refined points (boundaries and corners treated alike
    for both: edgeAndCorner, cornersOnly)."""
    xs = np.linspace(0, 3, 4)
    points = [(x, y, 0.0) for y in xs for x in xs]
    faces = [(j * 4 + i, j * 4 + i + 1, (j + 1) * 4 + i + 1, (j + 1) * 4 + i) for j in range(3) for i in range(3)]
    path = tmp_path / "grid.usda"
    stage, mesh = write_mesh(path, points, faces, level=2, faceVaryingLinearInterpolation="cornersOnly")
    st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying)
    st.Set([(0.25 * points[i][0], 0.125 + 0.25 * points[i][1]) for f in faces for i in f])
    material = UsdShade.Material.Define(stage, "/Tex")
    shader = UsdShade.Shader.Define(stage, "/Tex/S")
    shader.CreateIdAttr("UsdPreviewSurface")
    texture = UsdShade.Shader.Define(stage, "/Tex/Image")
    texture.CreateIdAttr("UsdUVTexture")
    texture.CreateInput("file", Sdf.ValueTypeNames.Asset).Set("checker.png")
    reader = UsdShade.Shader.Define(stage, "/Tex/St")
    reader.CreateIdAttr("UsdPrimvarReader_float2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("st")
    texture.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(texture.ConnectableAPI(), "rgb")
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)
    stage.GetRootLayer().Save()
    import OpenImageIO as oiio

    checker = np.zeros((4, 4, 3), dtype=np.float32)
    checker[::2, ::2] = 1
    oiio.ImageBuf(checker).write(str(tmp_path / "checker.png"))
    out = read_usd(str(path)).scene.meshes[0]
    assert out.uvs is not None and out.material.textures
    corner_points = out.points[out.triangles]  # (T, 3, 3)
    corner_uvs = out.uvs[out.uv_indices]  # (T, 3, 2)
    np.testing.assert_allclose(corner_uvs[..., 0], 0.25 * corner_points[..., 0], atol=1e-6)  # st is float
    np.testing.assert_allclose(corner_uvs[..., 1], 0.125 + 0.25 * corner_points[..., 1], atol=1e-6)


def test_loop_refines_triangles_and_leaves_other_faces_as_the_cage(tmp_path):
    octahedron = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]
    faces = [(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)]
    result, mesh = refined(tmp_path, octahedron, faces, level=2, scheme="loop")
    assert len(mesh.triangles) == 8 * 4**2
    r = np.linalg.norm(mesh.points, axis=1)
    # Rounder than the cage (whose distance from the centre spans 0.58 to 1), and inside it.
    assert r.max() < 1.0 and r.max() - r.min() < 0.1
    result, cage = refined(tmp_path, CUBE_POINTS, CUBE_FACES, level=2, scheme="loop")
    assert len(cage.triangles) == 12
    assert any("Loop subdivision" in w and "/M" in w for w in result.warnings)


@pytest.mark.parametrize(
    "attributes, attribute, message",
    [
        ({"level": MAX_LEVEL + 1}, "phong:subdivisionLevel", f"must be in 0..{MAX_LEVEL}"),
        ({"creaseIndices": [0, 1, 2], "creaseLengths": [2]}, "creaseLengths", "sums to 2"),
        ({"creaseIndices": [0, 99], "creaseLengths": [2], "creaseSharpnesses": [1.0]}, "creaseIndices", "out of range"),
        (
            {"creaseIndices": [0, 1, 2], "creaseLengths": [3], "creaseSharpnesses": [1, 2, 3]},
            "creaseSharpnesses",
            "expected 1",
        ),
        ({"cornerIndices": [0, 1], "cornerSharpnesses": [1.0]}, "cornerSharpnesses", "expected 2"),
        ({"interpolateBoundary": "bogus"}, "interpolateBoundary", "must be one of"),
        ({"scheme": "bogus"}, "subdivisionScheme", "must be one of"),
    ],
)
def test_bad_subdivision_input_names_the_prim_and_attribute(tmp_path, attributes, attribute, message):
    path = tmp_path / "bad.usda"
    attributes = dict(attributes)
    level = attributes.pop("level", None)
    scheme = attributes.pop("scheme", None)
    write_mesh(path, CUBE_POINTS, CUBE_FACES, level=level, scheme=scheme, **attributes)
    with pytest.raises(SceneError) as caught:
        read_usd(str(path))
    text = str(caught.value)
    assert f"/M.{attribute}" in text and message in text and "bad.usda" in text


def test_the_command_line_level_overrides_the_scenes(tmp_path):
    path = tmp_path / "cube.usda"
    write_mesh(path, CUBE_POINTS, CUBE_FACES, level=3)
    for sandbox in (False, True):  # in process, and through the read sandbox's child
        assert read_scene_file(path, sandbox=sandbox, subdivision_level=1).scene.triangle_count == 6 * 2 * 4
    shown = subprocess.run(
        [sys.executable, "-m", "phongscene", "info", "--subdivision-level", "0", str(path)],
        capture_output=True,
        text=True,
        check=True,
    )
    assert "12 triangles" in shown.stdout


@pytest.mark.povray
def test_povray_renders_the_refined_surface_as_the_native_tracer(tmp_path):
    """Both backends get the same refined, smooth-shaded triangles: `compare` passes."""
    path = tmp_path / "cube.usda"
    stage, mesh = write_mesh(path, CUBE_POINTS, CUBE_FACES, level=2)
    UsdGeom.Xformable(mesh).AddRotateXYZOp().Set((30.0, 40.0, 0.0))
    stage.GetRootLayer().Save()
    scene = read_usd(str(path)).scene
    scene = dataclasses.replace(
        scene, settings=dataclasses.replace(scene.settings, width=64, height=48, numerics="povray")
    )
    native = render(scene, "native", settings=settings_for(scene, mapping="exact"))
    assert native.max() > 0.1  # lit
    result = compare(render(scene, "povray", mapping="exact"), native)
    assert result.ok, result


def test_authored_normals_give_way_to_the_limit_surfaces_with_a_warning(tmp_path):
    normals = Vt.Vec3fArray([Gf.Vec3f(*(np.sign(p) / np.sqrt(3.0))) for p in CUBE_POINTS])
    result, mesh = refined(tmp_path, CUBE_POINTS, CUBE_FACES, level=1, normals=normals)
    said = [w for w in result.warnings if "authored normals of subdivision surfaces" in w]
    assert len(said) == 1 and "/M" in said[0] and "--subdivision-level 0" in said[0]
    assert len(mesh.normals) == len(mesh.points)  # the limit normals, one per refined vertex
    result, cage = refined(tmp_path, CUBE_POINTS, CUBE_FACES, level=0, normals=normals)
    assert not [w for w in result.warnings if "authored normals" in w]
    assert cage.normals is not None and len(cage.triangles) == 12  # the cage, with its normals


def test_a_mesh_with_normals_and_no_scheme_is_the_polygon_mesh_they_describe(tmp_path):
    """USD's fallback scheme is catmullClark, but a mesh that authors normals and no scheme is a
    polygon export (OpenChessSet's pieces): drawn as its cage with its normals, with a warning;
    an authored level or scheme still refines it."""
    normals = Vt.Vec3fArray([Gf.Vec3f(*(np.sign(p) / np.sqrt(3.0))) for p in CUBE_POINTS])
    result, cage = refined(tmp_path, CUBE_POINTS, CUBE_FACES, normals=normals)
    assert len(cage.triangles) == 12 and cage.normals is not None
    (said,) = [w for w in result.warnings if "no subdivisionScheme" in w]
    assert "/M" in said and "--subdivision-level" in said
    _, refined_cube = refined(tmp_path, CUBE_POINTS, CUBE_FACES, scheme="catmullClark", normals=normals)
    assert len(refined_cube.triangles) > 12
    _, without_normals = refined(tmp_path, CUBE_POINTS, CUBE_FACES)
    assert len(without_normals.triangles) > 12  # no normals: the fallback scheme, refined
    path = tmp_path / "mesh.usda"
    write_mesh(path, CUBE_POINTS, CUBE_FACES, normals=normals)
    assert len(read_usd(str(path), subdivision_level=1).scene.meshes[0].triangles) > 12
