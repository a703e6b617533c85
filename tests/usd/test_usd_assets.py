# SPDX-License-Identifier: Apache-2.0
"""Third-party USD files (/work/shared/assets/usd, see its README) load with the counts the
files contain. Expected counts come from the README and from pxr directly, not from the reader."""

from __future__ import annotations

import math

import pytest
from pxr import Usd, UsdGeom

from phongscene.usd import read_usd
from phongscene.usd.materials import PREVIEW_MAX_EXPONENT
from support.paths import SHARED_ASSETS

pytestmark = pytest.mark.shared_assets


def file_triangles(path) -> int:
    """Fan-triangle count of every Mesh in the file: Σ (n − 2) over its faces."""
    stage = Usd.Stage.Open(str(path))
    return sum(
        sum(n - 2 for n in UsdGeom.Mesh(p).GetFaceVertexCountsAttr().Get())
        for p in stage.Traverse()
        if p.IsA(UsdGeom.Mesh)
    )


def materials(scene) -> set[str]:
    return {x.material.source for x in (*scene.spheres, *scene.meshes) if x.material.source}


def test_teapot():
    result = read_usd(SHARED_ASSETS / "teapot" / "teapot.usda")
    s = result.scene
    assert len(s.meshes) == 1 and s.triangle_count == 25_200 == file_triangles(SHARED_ASSETS / "teapot" / "teapot.usda")
    assert s.meshes[0].normals is not None  # vertex normals authored
    assert materials(s) == set() and not s.spheres
    # no camera, no light in the file: the documented defaults, with warnings
    assert s.camera.source == "(default framing camera)" and s.lights[0].source == "(default head light)"
    assert len(result.warnings) == 2


def test_all_primitives():
    s = read_usd(SHARED_ASSETS / "primitives" / "all_primitives.usda").scene
    # Intrinsic prims are exact surfaces (not tessellated), in traversal order.
    assert not s.meshes
    assert [(i.source, i.kind) for i in s.intrinsics] == [
        ("/World/Capsule", "capsule"),
        ("/World/Cone", "cylinder"),
        ("/World/Cube", "cube"),
        ("/World/Cylinder", "cylinder"),
    ]
    assert len(s.spheres) == 1 and s.spheres[0].world_from_object[0, 3] == 8.0  # translate (8, 0, 0), radius 1
    lo, hi = s.intrinsics[2].world_bounds()
    assert lo.tolist() == [3.0, -1.0, -1.0] and hi.tolist() == [5.0, 1.0, 1.0]
    assert s.intrinsics[1].radius_top == 0.0  # the cone


def test_sphere_lights_z_up():
    path = SHARED_ASSETS / "sphere_lights" / "Environment.usda"
    result = read_usd(path)
    s = result.scene
    assert len(s.meshes) == 1 and s.triangle_count == 2 == file_triangles(path)
    # the lights carry a hard 180° ShapingAPI cone, which restricts nothing: no warning
    assert not [w for w in result.warnings if "ShapingAPI" in w]
    assert len(s.lights) == 3 and all(type(l).__name__ == "SphereAreaLight" for l in s.lights)
    assert all(l.radius == pytest.approx(5.0) for l in s.lights)
    # UsdLux units: intensities 30 / 1 / 10 of spheres of radius 5, not normalized: I = L·πr²
    assert [l.color[0] / (math.pi * l.radius**2) for l in sorted(s.lights, key=lambda l: l.color[0])] == pytest.approx(
        [1.0, 10.0, 30.0]
    )
    assert all(l.falloff == "inverse-square" for l in s.lights)
    # Z-up: the lights are 14.67 units above the ground (file z) → model +Y
    assert all(l.center[1] == pytest.approx(14.666749, abs=1e-4) for l in s.lights)
    assert s.meshes[0].points[:, 1].tolist() == [0.0] * 4  # ground plane at z = 0 → y = 0
    assert materials(s) == {"/Environment/Looks/Floor/Shader"}


def test_roughness_usdz_preview_surfaces():
    path = SHARED_ASSETS / "roughness" / "RoughnessTest.usdz"
    result = read_usd(path)
    s = result.scene
    assert len(s.meshes) == 6 and s.triangle_count == file_triangles(path)
    assert len(materials(s)) == 6
    by_name = {m.material.source.split("/")[3]: m.material for m in s.meshes}
    # roughness 0 / 0.33 / 0.66 constant → exponents 1/(2r⁴) − 2 (r = 0 capped at PREVIEW_MAX_EXPONENT; α ≥ ½: 0)
    assert by_name["Const000"].exponent == PREVIEW_MAX_EXPONENT
    assert by_name["Const033"].exponent == pytest.approx(1 / (2 * 0.33**4) - 2, rel=1e-5)
    assert by_name["Const066"].exponent == pytest.approx(max(1 / (2 * 0.66**4) - 2, 0.0), rel=1e-5)
    # The roughness textures have no per-point form (an exponent per point): their mean is used.
    assert any(
        "the texture's mean is used" in w and "Tex033/Principled_BSDF.inputs:roughness" in w for w in result.warnings
    )


@pytest.mark.povray
@pytest.mark.parametrize("width", [160, 640])
def test_diff_passes_on_roughness_usdz_texture_edges(width):
    # Its textured spheres failed diff at 1 (160 px) and 7 (640 px) texel-edge pixels while the
    # native tracer took the model's uv in POV-Ray numerics (issue 27.4; povray_mesh_uv).
    import phongscene

    result = phongscene.diff(SHARED_ASSETS / "roughness" / "RoughnessTest.usdz", None, width=width)
    assert result.ok, result.report
