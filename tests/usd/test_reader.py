# SPDX-License-Identifier: Apache-2.0
"""The USD reader: geometry, normals, materials, defaults, up axis, instancing, problems collected together.
Each expected value is derived from the USD text in the test, not from the reader."""

from __future__ import annotations

import math

import numpy as np
import pytest
from usda import EXACT, read

from phongscene.errors import SceneError
from phongscene.scene import DEFAULT_MATERIAL, PointLight
from phongscene.usd import preview_to_phong, read_usd
from phongscene.usd.materials import PREVIEW_MAX_EXPONENT
from support.paths import REPO

QUAD_AND_PENTAGON = """
def Mesh "M"
{{
    int[] faceVertexCounts = [4, 5]
    int[] faceVertexIndices = [0, 1, 2, 3, 4, 5, 6, 7, 8]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (2, 0, 0), (3, 0, 0), (3, 1, 0), (2.5, 1.5, 0), (2, 1, 0)]
    uniform token subdivisionScheme = "none"
    {extra}
}}
"""


def test_mesh_fan_triangulation(tmp_path):
    mesh = read(tmp_path, QUAD_AND_PENTAGON.format(extra="")).scene.meshes[0]
    assert mesh.triangles.tolist() == [[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7], [4, 7, 8]]
    assert mesh.normals is None


def test_left_handed_mesh_flips_winding(tmp_path):
    mesh = read(tmp_path, QUAD_AND_PENTAGON.format(extra='uniform token orientation = "leftHanded"')).scene.meshes[0]
    assert mesh.triangles.tolist() == [[0, 2, 1], [0, 3, 2], [4, 6, 5], [4, 7, 6], [4, 8, 7]]


def test_hole_faces_are_skipped(tmp_path):
    mesh = read(tmp_path, QUAD_AND_PENTAGON.format(extra="int[] holeIndices = [0]")).scene.meshes[0]
    assert mesh.triangles.tolist() == [[4, 5, 6], [4, 6, 7], [4, 7, 8]]


def test_a_subdivision_mesh_is_refined_unless_its_level_is_zero(tmp_path):
    """The quad and the pentagon as Catmull-Clark (USD's fallback scheme): refined twice by
    default (two triangles a refined quad), the cage at phong:subdivisionLevel 0;
    no warning either way (tests/usd/test_subdivision.py tests the surfaces)."""
    body = QUAD_AND_PENTAGON.replace('uniform token subdivisionScheme = "none"', "")
    result = read(tmp_path, body.format(extra=""))
    assert result.scene.triangle_count == (16 + 5 * 4) * 2  # the pentagon: 5 quads, then 4 each
    assert not [w for w in result.warnings if "subdivision" in w]
    cage = read(tmp_path, body.format(extra="int phong:subdivisionLevel = 0"))
    assert cage.scene.triangle_count == 5 and not [w for w in cage.warnings if "subdivision" in w]


@pytest.mark.parametrize(
    "normals, expected_rows",
    [
        # vertex: one per point; corner normal = normals[point id]
        (
            'normal3f[] normals = [(0,0,1),(0,0,1),(0,0,1),(0,0,1),(1,0,0),(1,0,0),(1,0,0),(1,0,0),(0,1,0)] (interpolation = "vertex")',
            [[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7], [4, 7, 8]],
        ),
        # faceVarying: one per face-vertex; the pentagon's fan corners are face-vertices 4..8
        (
            'normal3f[] normals = [(0,0,1),(0,0,1),(0,0,1),(0,0,1),(1,0,0),(1,0,0),(1,0,0),(1,0,0),(0,1,0)] (interpolation = "faceVarying")',
            [[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7], [4, 7, 8]],
        ),
        # uniform: one per face
        (
            'normal3f[] normals = [(0,0,1),(1,0,0)] (interpolation = "uniform")',
            [[0, 0, 0], [0, 0, 0], [1, 1, 1], [1, 1, 1], [1, 1, 1]],
        ),
        # constant: one for all
        ('normal3f[] normals = [(0,0,1)] (interpolation = "constant")', [[0, 0, 0]] * 5),
        # indexed primvar (per point, two distinct values)
        (
            'normal3f[] primvars:normals = [(0,0,1),(1,0,0)] (interpolation = "vertex")\n    int[] primvars:normals:indices = [0,0,0,0,1,1,1,1,1]',
            [[0, 0, 0], [0, 0, 0], [1, 1, 1], [1, 1, 1], [1, 1, 1]],
        ),
    ],
)
def test_normals_of_every_interpolation(tmp_path, normals, expected_rows):
    mesh = read(tmp_path, QUAD_AND_PENTAGON.format(extra=normals)).scene.meshes[0]
    assert mesh.normal_indices.tolist() == expected_rows
    assert np.allclose(np.linalg.norm(mesh.normals, axis=1), 1.0, atol=EXACT)


def test_primvar_normals_take_precedence_over_normals(tmp_path):
    extra = 'normal3f[] normals = [(1,0,0)] (interpolation = "constant")\n    normal3f[] primvars:normals = [(0,0,1)] (interpolation = "constant")'
    mesh = read(tmp_path, QUAD_AND_PENTAGON.format(extra=extra)).scene.meshes[0]
    assert mesh.normals.tolist() == [[0.0, 0.0, 1.0]]


def test_unnormalized_normals_are_normalized(tmp_path):
    mesh = read(
        tmp_path, QUAD_AND_PENTAGON.format(extra='normal3f[] normals = [(0,0,3)] (interpolation = "constant")')
    ).scene.meshes[0]
    assert mesh.normals.tolist() == [[0.0, 0.0, 1.0]]


def test_transform_and_z_up(tmp_path):
    body = """
    def Xform "X"
    {
        double3 xformOp:translate = (1, 2, 3)
        double3 xformOp:scale = (2, 2, 2)
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale"]
        def Mesh "M"
        {
            int[] faceVertexCounts = [3]
            int[] faceVertexIndices = [0, 1, 2]
            point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 0, 1)]
            normal3f[] normals = [(0, -1, 0)] (interpolation = "constant")
            uniform token subdivisionScheme = "none"
        }
        def Sphere "S"
        {
            double radius = 0.5
        }
    }
    """
    y_up = read(tmp_path, body).scene
    assert np.allclose(y_up.meshes[0].points, [[1, 2, 3], [3, 2, 3], [1, 2, 5]], atol=EXACT)
    z_up = read(tmp_path, body, up="Z").scene
    # −90° about X: (x, y, z) → (x, z, −y)
    assert np.allclose(z_up.meshes[0].points, [[1, 3, -2], [3, 3, -2], [1, 5, -2]], atol=EXACT)
    assert np.allclose(z_up.meshes[0].normals, [[0, 0, 1]], atol=EXACT)
    assert np.allclose(z_up.spheres[0].world_from_object[:3, 3], [1, 3, -2], atol=EXACT)
    assert np.allclose(np.abs(np.linalg.det(z_up.spheres[0].world_from_object[:3, :3])), 1.0, atol=EXACT)  # (2·0.5)³


def test_mirroring_transform_flips_winding(tmp_path):
    body = QUAD_AND_PENTAGON.format(extra="").replace(
        'def Mesh "M"\n{',
        'def Mesh "M"\n{\n    double3 xformOp:scale = (-1, 1, 1)\n    uniform token[] xformOpOrder = ["xformOp:scale"]',
    )
    mesh = read(tmp_path, body).scene.meshes[0]
    assert mesh.triangles.tolist()[0] == [0, 2, 1]


@pytest.mark.parametrize(
    "prim, triangles_at_least, extent",
    [
        ('def Cube "P" { double size = 3 }', 12, (3, 3, 3)),
        ('def Plane "P" { double width = 4\n double length = 2\n uniform token axis = "Y" }', 2, (4, 0, 2)),
        ('def Plane "P" { double width = 4\n double length = 2\n uniform token axis = "X" }', 2, (0, 2, 4)),
        ('def Cylinder "P" { double radius = 1\n double height = 3\n uniform token axis = "Y" }', 64, (2, 3, 2)),
        ('def Cone "P" { double radius = 1\n double height = 2\n uniform token axis = "Z" }', 64, (2, 2, 2)),
        ('def Capsule "P" { double radius = 0.5\n double height = 1\n uniform token axis = "X" }', 64, (2, 1, 1)),
    ],
)
def test_tessellated_primitives_match_their_schema_extent(tmp_path, prim, triangles_at_least, extent):
    mesh = read(tmp_path, prim.replace(" { ", " { custom bool phong:tessellate = 1\n ", 1)).scene.meshes[0]
    assert len(mesh.triangles) >= triangles_at_least
    size = mesh.points.max(axis=0) - mesh.points.min(axis=0)
    assert np.allclose(size, extent, rtol=2e-3)  # polygonal circles: within the chord error
    assert np.allclose(mesh.points.max(axis=0) + mesh.points.min(axis=0), 0.0, atol=1e-9)  # centred


def test_curved_primitives_have_smooth_unit_normals(tmp_path):
    mesh = read(
        tmp_path, 'def Capsule "P" { custom bool phong:tessellate = 1\n double radius = 1\n double height = 2 }'
    ).scene.meshes[0]
    corners = mesh.points[mesh.triangles].reshape(-1, 3)
    spine = np.column_stack([np.zeros((len(corners), 2)), np.clip(corners[:, 2], -1, 1)])
    expected = (corners - spine) / np.linalg.norm(corners - spine, axis=1)[:, None]
    assert np.allclose(mesh.normals[mesh.normal_indices].reshape(-1, 3), expected, atol=1e-9)


def test_a_two_radius_capsule_is_read_as_its_exact_surface(tmp_path):
    """Capsule_1: the radii at the side's ends and the spine length as USD writes them; no
    tessellated mesh for it (phong:tessellate is reported, the exact surface is traced)."""
    text = 'def Capsule_1 "P" { custom bool phong:tessellate = 1\n double radiusBottom = 0.7\n double radiusTop = 0.3\n double height = 1\n uniform token axis = "X" }'
    result = read(tmp_path, text)
    (capsule,) = result.scene.intrinsics
    assert (capsule.kind, capsule.radius_bottom, capsule.radius_top, capsule.half_height) == ("capsule", 0.7, 0.3, 0.5)
    assert capsule.world_from_object[:3, 2].tolist() == [1.0, 0.0, 0.0]  # its axis onto USD's X
    assert not result.scene.meshes
    assert any("phong:tessellate on Capsule_1" in w and "/P" in w for w in result.warnings)


def test_a_capsule_without_radii_is_a_problem_naming_the_attribute(tmp_path):
    with pytest.raises(SceneError, match=r"/P\.radiusBottom"):
        read(tmp_path, 'def Capsule_1 "P" { double radiusBottom = 0\n double radiusTop = 0 }')


def test_defaults_without_camera_or_lights_warn(tmp_path):
    result = read(tmp_path, 'def Sphere "B" {}')
    assert result.scene.camera.source == "(default framing camera)"
    assert result.scene.lights == (
        PointLight(result.scene.camera.position, (math.pi,) * 3, source="(default head light)"),
    )
    assert any("no camera" in w for w in result.warnings) and any("head light" in w for w in result.warnings)


def test_instancing_visibility_and_purpose():
    scene = read_usd(REPO / "tests" / "scenes" / "instancing.usda").scene
    # /World/A (instance proxy); /World/Hidden invisible; /World/Guide guide purpose;
    # the PointInstancer: ids 0 and 1 (2 is invisible), prototype offset (0,1,0) + instancer (0,10,0).
    centres = sorted(tuple(s.world_from_object[:3, 3]) for s in scene.spheres)
    assert centres == [(-4.0, 0.0, 0.0), (0.0, 11.0, 0.0), (3.0, 11.0, 0.0)]


PREVIEW = """
def Material "M" {{
    token outputs:surface.connect = </M/S.outputs:surface>
    def Shader "S" {{
        uniform token info:id = "UsdPreviewSurface"
        {inputs}
        token outputs:surface
    }}
}}
def Sphere "B" (prepend apiSchemas = ["MaterialBindingAPI"]) {{ rel material:binding = </M> }}
"""


def test_preview_surface_mapping(tmp_path):
    inputs = "color3f inputs:diffuseColor = (0.5, 0.5, 0.5)\n float inputs:roughness = 0.5\n float inputs:metallic = 0"
    material = read(tmp_path, PREVIEW.format(inputs=inputs)).scene.spheres[0].material
    # α = 0.25: e = 1/(2α²) − 2 = 6; dielectric F0 = 0.04 → ks = F0·(e + 2)/(2π), cs white
    assert material.exponent == pytest.approx(6.0)
    assert material.ks == pytest.approx(0.04 * 8 / (2 * math.pi))
    assert material.specular_color == (1.0, 1.0, 1.0)
    assert material.diffuse_color == pytest.approx((0.5, 0.5, 0.5))
    assert material.source == "/M/S"


def test_preview_to_phong_metallic_and_specular_workflow():
    # Metallic 1: F0 = the base colour, no diffuse; the strength F0·(e + 2)/(2π) exceeds 1, so
    # ks = 1 and cs carries it (colours have no upper bound).
    metal = preview_to_phong((1.0, 0.5, 0.0), 0.33, metallic=1.0)
    e = 1 / (2 * 0.33**4) - 2
    assert metal.diffuse_color == (0.0, 0.0, 0.0) and metal.ks == 1.0 and metal.exponent == pytest.approx(e)
    assert metal.specular_color == pytest.approx(tuple(c * (e + 2) / (2 * math.pi) for c in (1.0, 0.5, 0.0)))
    # Roughness 1 (α = 1 >= ½): e = 0 and ks·cs = F0/(2πα).
    spec = preview_to_phong((0.2, 0.2, 0.2), 1.0, specular_color=(0.5, 0.25, 0.0), use_specular_workflow=1)
    assert spec.ks == pytest.approx(0.5 / (2 * math.pi)) and spec.specular_color == pytest.approx((1.0, 0.5, 0.0))
    assert spec.exponent == 0.0
    assert preview_to_phong((0.2, 0.2, 0.2), 0.0).exponent == PREVIEW_MAX_EXPONENT  # capped


def test_texture_without_an_image_uses_its_fallback_with_a_warning(tmp_path):
    inputs = "color3f inputs:diffuseColor.connect = </M/T.outputs:rgb>\n float inputs:roughness = 0.5"
    body = PREVIEW.format(inputs=inputs).replace(
        'def Shader "S"',
        'def Shader "T" { uniform token info:id = "UsdUVTexture"\n float3 outputs:rgb }\n    def Shader "S"',
    )
    result = read(tmp_path, body)
    # A texture without an image gives its fallback (UsdUVTexture's default: (0, 0, 0, 1)).
    assert result.scene.spheres[0].material.diffuse_color == pytest.approx((0.0, 0.0, 0.0))
    assert any("/M/T.inputs:file" in w and "fallback" in w for w in result.warnings)


def test_phong_shader_unauthored_inputs_take_sdr_defaults(tmp_path):
    body = """
    def Material "M" {
        token outputs:phong:surface.connect = </M/P.outputs:surface>
        def Shader "P" { uniform token info:id = "phongscene_PhongSurface"
            float inputs:ks = 0.7
            token outputs:surface }
    }
    def Sphere "B" (prepend apiSchemas = ["MaterialBindingAPI"]) { rel material:binding = </M> }
    """
    m = read(tmp_path, body).scene.spheres[0].material
    assert m.ks == pytest.approx(0.7)
    assert (m.ka, m.kd, m.exponent) == pytest.approx((0.1, 0.6, 32.0))  # schemas/phongscene_PhongSurface.usda
    assert m.diffuse_color == pytest.approx((0.8, 0.8, 0.8)) and m.specular_color == (1.0, 1.0, 1.0)


def test_display_color_unknown_shader_and_grey(tmp_path):
    body = """
    def Sphere "Red" { color3f[] primvars:displayColor = [(1, 0, 0)] }
    def Sphere "Plain" {}
    def Material "M" { token outputs:surface.connect = </M/S.outputs:surface>
        def Shader "S" { uniform token info:id = "ND_made_up_surfaceshader"
            token outputs:surface } }
    def Sphere "Odd" (prepend apiSchemas = ["MaterialBindingAPI"]) { rel material:binding = </M> }
    """
    result = read(tmp_path, body)
    red, plain, odd = result.scene.spheres
    assert red.material.diffuse_color == (1.0, 0.0, 0.0)
    assert plain.material == DEFAULT_MATERIAL and odd.material == DEFAULT_MATERIAL
    assert any("unknown surface shaders" in w and "/M/S" in w for w in result.warnings)


def test_problems_are_collected_together(tmp_path):
    body = """
    def Sphere "A" { double radius = -1 }
    def Sphere "B" { double radius = nan }
    def SphereLight "L" { float inputs:intensity = -1
        float phong:bogus = 1 }
    """
    with pytest.raises(SceneError) as info:
        read(tmp_path, body)
    found = {(p.prim, p.attribute) for p in info.value.problems}
    assert found == {("/A", "radius"), ("/B", "radius"), ("/L", "inputs:intensity"), ("/L", "phong:bogus")}
    assert all(p.file.endswith("scene.usda") for p in info.value.problems)


def test_a_control_character_in_usds_message_stays_on_one_line(tmp_path):
    """USD quotes the bytes it cannot parse; \x1c (a line boundary to str.splitlines) in a fuzzed
    header split the one error line in two (benchmarks/fuzz_campaign.py, file m274)."""
    bad = tmp_path / "bad.usda"
    bad.write_bytes(b"#usda\x1c1.0\ndef Sphere {}\n")
    with pytest.raises(SceneError) as caught:
        read_usd(bad)
    (problem,) = caught.value.problems
    assert "cannot read USD" in problem.message and "\\x1c" in problem.message
    assert len(str(problem).splitlines()) == 1


def test_unreadable_and_missing_files(tmp_path):
    bad = tmp_path / "bad.usda"
    bad.write_text("#usda 1.0\ndef Sphere {{{ nonsense")
    with pytest.raises(SceneError, match="cannot read USD"):
        read_usd(bad)
    with pytest.raises(SceneError, match="file not found"):
        read_usd(tmp_path / "missing.usda")


def test_preview_surface_opacity_is_a_dielectric_and_emission_is_read(tmp_path):
    inputs = "float inputs:opacity = 0.25\n float inputs:ior = 1.33\n color3f inputs:emissiveColor = (1, 0, 0)"
    result = read(tmp_path, PREVIEW.format(inputs=inputs))
    assert not [w for w in result.warnings if "UsdPreviewSurface" in w]
    (material,) = {o.material for o in result.scene.objects}
    assert material.emission == (1.0, 0.0, 0.0)  # Le, the model's emission
    # kt = 1 − opacity into an interior of the authored ior, split by Fresnel; the opaque part
    # (ambient, diffuse) weighted by the opacity.
    assert (material.kt, material.ior, material.fresnel) == (0.75, pytest.approx(1.33), True)
    assert (material.ka, material.kd) == (0.25, 0.25)
    opaque = read(tmp_path, PREVIEW.format(inputs="float inputs:opacity = 1")).scene.objects[0].material
    assert (opaque.kt, opaque.fresnel, opaque.kd) == (0.0, False, 1.0)


def test_preview_surface_opacity_threshold_cuts_out_or_keeps_opaque(tmp_path):
    below = read(tmp_path, PREVIEW.format(inputs="float inputs:opacity = 0.2\n float inputs:opacityThreshold = 0.5"))
    assert len(below.scene.objects) == 0  # the masked surface is absent
    above = read(tmp_path, PREVIEW.format(inputs="float inputs:opacity = 0.6\n float inputs:opacityThreshold = 0.5"))
    (material,) = {o.material for o in above.scene.objects}
    assert (material.kt, material.kd) == (0.0, 1.0)  # masked mode: at or above the threshold, opaque
    with pytest.raises(SceneError, match="inputs:opacity"):
        read(tmp_path, PREVIEW.format(inputs="float inputs:opacity = 1.5"))


def test_a_prim_with_a_type_problem_still_reports_its_range_problems(tmp_path):
    # The reader checks types, validate checks ranges: both are reported, each once, in USD terms.
    body = """
    def Material "M" { token outputs:phong:surface.connect = </M/Phong.outputs:surface>
        def Shader "Phong" { uniform token info:id = "phongscene_PhongSurface"
            double inputs:ka = 0.5
            float inputs:ks = -0.5
            token outputs:surface } }
    def Sphere "Ball" (prepend apiSchemas = ["MaterialBindingAPI"]) { rel material:binding = </M> }
    """
    with pytest.raises(SceneError) as info:
        read(tmp_path, body)
    found = sorted((p.prim, p.attribute) for p in info.value.problems)
    assert found == [("/M/Phong", "inputs:ka"), ("/M/Phong", "inputs:ks")]
    assert "must be in [0, 1], got -0.5" in str(info.value)


def test_blender_specular_level_scales_the_preview_surface_f0(tmp_path):
    body = """
    def Material "M" { token outputs:surface.connect = </M/S.outputs:surface>
        def Shader "S" { uniform token info:id = "UsdPreviewSurface"
            float inputs:roughness = 0.5
            float inputs:specular = 0
            token outputs:surface }
        def Shader "T" { uniform token info:id = "UsdPreviewSurface"
            float inputs:roughness = 0.5
            token outputs:surface } }
    def Sphere "Ball" (prepend apiSchemas = ["MaterialBindingAPI"]) { rel material:binding = </M> }
    """
    (ball,) = read(tmp_path, body).scene.spheres
    assert ball.material.ks == 0.0  # Blender's "Specular IOR Level" 0: no highlight
    neutral = preview_to_phong((0.8, 0.8, 0.8), 0.5).ks  # ior 1.5, level 0.5: F0 = 0.04
    assert neutral == pytest.approx(0.04 * 8 / (2 * math.pi))
    assert preview_to_phong((0.8, 0.8, 0.8), 0.5, specular_level=1.0).ks == pytest.approx(2 * neutral)


def test_geom_subset_material_bindings_split_the_mesh(tmp_path):
    body = """
    def Mesh "Strip" (prepend apiSchemas = ["MaterialBindingAPI"]) {
        point3f[] points = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (2, 0, 0), (2, 1, 0)]
        int[] faceVertexCounts = [4, 4]
        int[] faceVertexIndices = [0, 1, 2, 3, 1, 4, 5, 2]
        uniform token subdivisionScheme = "none"
        rel material:binding = </Grey>
        def GeomSubset "Right" (prepend apiSchemas = ["MaterialBindingAPI"]) {
            uniform token elementType = "face"
            uniform token familyName = "materialBind"
            int[] indices = [1]
            rel material:binding = </Red>
        }
    }
    def Material "Grey" { token outputs:surface.connect = </Grey/S.outputs:surface>
        def Shader "S" { uniform token info:id = "UsdPreviewSurface"
            color3f inputs:diffuseColor = (0.5, 0.5, 0.5)
            token outputs:surface } }
    def Material "Red" { token outputs:surface.connect = </Red/S.outputs:surface>
        def Shader "S" { uniform token info:id = "UsdPreviewSurface"
            color3f inputs:diffuseColor = (1, 0, 0)
            token outputs:surface } }
    """
    left, right = read(tmp_path, body).scene.meshes
    assert (left.source, right.source) == ("/Strip", "/Strip/Right")
    assert left.material.diffuse_color == pytest.approx((0.5, 0.5, 0.5)) and right.material.diffuse_color == (
        1.0,
        0.0,
        0.0,
    )
    assert len(left.triangles) == len(right.triangles) == 2
    assert set(right.triangles.ravel()) == {1, 2, 4, 5}  # the second quad's corners


def test_an_animated_stage_renders_its_start_time_with_a_warning(tmp_path):
    path = tmp_path / "anim.usda"
    path.write_text(
        "#usda 1.0\n(\n    startTimeCode = 1\n    endTimeCode = 24\n)\n"
        'def Sphere "Ball" {\n    double3 xformOp:translate.timeSamples = {1: (0, 0, 0), 24: (5, 0, 0)}\n'
        '    uniform token[] xformOpOrder = ["xformOp:translate"]\n}\n'
    )
    result = read_usd(path)
    assert result.scene.spheres[0].world_from_object[0, 3] == 0.0  # the transform at time 1
    assert any("animated (time codes 1 to 24): rendering its start time 1" in w for w in result.warnings)


def test_a_concave_face_is_ear_clipped_not_fanned(tmp_path):
    # An L-shaped hexagon whose fan from corner 0, (2, 1), would cover the notch (1..2 × 0..1).
    body = """
    def Mesh "L" {
        point3f[] points = [(2, 1, 0), (2, 2, 0), (0, 2, 0), (0, 0, 0), (1, 0, 0), (1, 1, 0)]
        int[] faceVertexCounts = [6]
        int[] faceVertexIndices = [0, 1, 2, 3, 4, 5]
        uniform token subdivisionScheme = "none" }
    """
    (mesh,) = read(tmp_path, body).scene.meshes
    p = mesh.points[mesh.triangles]
    areas = 0.5 * np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])[:, 2]
    assert len(mesh.triangles) == 4 and np.all(areas > 0)  # counter-clockwise, none flipped
    assert areas.sum() == pytest.approx(3.0)  # the L's area: the notch stays empty
    centroids = p.mean(axis=1)
    assert not np.any((centroids[:, 0] > 1) & (centroids[:, 1] < 1))


def test_a_concave_quad_is_split_along_its_inner_diagonal(tmp_path):
    # A dart: corner 3 is reflex, so the fan's diagonal 0-2 lies outside the quad.
    body = """
    def Mesh "Dart" {
        point3f[] points = [(0, 0, 0), (2, 1, 0), (0, 2, 0), (0.5, 1, 0)]
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        uniform token subdivisionScheme = "none" }
    """
    (mesh,) = read(tmp_path, body).scene.meshes
    p = mesh.points[mesh.triangles]
    areas = 0.5 * np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])[:, 2]
    assert np.all(areas > 0) and areas.sum() == pytest.approx(1.5)  # the dart's area, not the hull's 2
