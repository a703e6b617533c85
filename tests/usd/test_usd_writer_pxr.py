# SPDX-License-Identifier: Apache-2.0
"""The writer's output read with USD's own schema APIs (UsdGeom, UsdShade, UsdLux, UsdRender),
never with phongscene's reader: the prims, their types and the authored values are what the
writer documents (phongscene/usd/writer.py). The round trip through our reader is in
test_usd_writer.py; this test would catch a writer and a reader that agree on a wrong encoding.

Every number in the scene is a binary fraction, exact in float32, so that values stored as
float32 (colours, radii, points) compare exactly; only derived values carry a tolerance."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, UsdLux, UsdRender, UsdShade

from phongscene.scene import (
    AmbientLight,
    Camera,
    DirectionalLight,
    PhongMaterial,
    PointLight,
    RectAreaLight,
    RenderSettings,
    Scene,
    Sphere,
    SphereAreaLight,
    TriangleMesh,
)
from phongscene.usd import write_usd

# Values computed through tan or matrix products in double: a few ulps of 1.0.
DOUBLE_ARITHMETIC = 1e-12
# The horizontal aperture is stored as float32: 2^-24 relative rounding, with margin.
FLOAT32_ROUNDING = 1e-6

RED = PhongMaterial(0.25, 0.5, 0.125, 16.0, (1.0, 0.5, 0.25), (0.75, 0.75, 1.0), source="/World/Looks/Red/Phong")


def scene() -> Scene:
    return Scene(
        camera=Camera((0.0, 1.0, 5.0), (0.0, 0.0, -1.0), (0.0, 1.0, 0.0), horizontal_fov_deg=60.0, source="/World/Eye"),
        ambient=AmbientLight((0.125, 0.25, 0.5), source="/World/Lights/Sky"),
        lights=(
            PointLight((1.0, 2.0, 3.0), (0.5, 0.5, 0.5), 2.0, 1.0, source="/World/Lights/Seed"),
            PointLight((0.0, 4.0, 0.0), (1.0, 2.0, 3.0), falloff="inverse-square", source="/World/Lights/Bulb"),
            DirectionalLight((0.0, -1.0, 0.0), (0.75, 0.75, 0.75), specular=0.5),
            RectAreaLight(
                (0.0, 5.0, 0.0), (2.0, 0.0, 0.0), (0.0, 0.0, 1.0), (1.0, 1.0, 1.0), 5, source="/World/Lights/Panel"
            ),
            SphereAreaLight(
                (3.0, 3.0, 3.0), 0.25, (1.0, 1.0, 1.0), 9, falloff="inverse-square", source="/World/Lights/Globe"
            ),
        ),
        spheres=(Sphere.at((0.0, 1.0, 0.0), 1.5, RED, source="/World/Geometry/Ball"),),
        meshes=(
            TriangleMesh(
                [[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]],
                [[0, 2, 1], [0, 3, 2]],
                material=RED,
                source="/World/Geometry/Floor",
            ),
        ),
        settings=RenderSettings(width=64, height=32, samples=3, background=(0.25, 0.0, 0.5), source="/Render/Final"),
    )


@pytest.fixture(scope="module")
def stage(tmp_path_factory) -> Usd.Stage:
    path = tmp_path_factory.mktemp("writer") / "scene.usda"
    write_usd(scene(), path)
    opened = Usd.Stage.Open(str(path))
    assert opened is not None, path
    return opened


def world(prim: Usd.Prim) -> Gf.Matrix4d:
    return UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode.Default())


def attr(prim: Usd.Prim, name: str):
    a = prim.GetAttribute(name)
    assert a.IsAuthored(), f"{prim.GetPath()}.{name} not authored"
    return a.Get()


def test_stage_metadata(stage):
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.y
    assert UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    assert stage.GetDefaultPrim().GetPath() == "/World"
    assert stage.GetMetadata("renderSettingsPrimPath") == "/Render/Final"


def test_prims_and_their_types(stage):
    types = {str(p.GetPath()): p.GetTypeName() for p in stage.Traverse()}
    expected = {
        "/World/Eye": "Camera",
        "/World/Lights/Sky": "DomeLight",
        "/World/Lights/Seed": "SphereLight",
        "/World/Lights/Bulb": "SphereLight",
        "/World/Lights/DirectionalLight_0": "DistantLight",  # no source: named by kind
        "/World/Lights/Panel": "RectLight",
        "/World/Lights/Globe": "SphereLight",
        "/World/Geometry/Ball": "Sphere",
        "/World/Geometry/Floor": "Mesh",
        "/World/Looks/Red": "Material",
        "/World/Looks/Red/Phong": "Shader",
        "/World/Looks/Red/Preview": "Shader",
        "/Render/Final": "RenderSettings",
    }
    assert {p: types.get(p) for p in expected} == expected
    # Nothing else but the grouping prims (Xform /World, Scopes for the folders).
    others = {p: t for p, t in types.items() if p not in expected}
    assert set(others.values()) <= {"Xform", "Scope"}, others


def test_camera(stage):
    camera = UsdGeom.Camera(stage.GetPrimAtPath("/World/Eye"))
    assert camera.GetProjectionAttr().Get() == UsdGeom.Tokens.perspective
    focal = camera.GetFocalLengthAttr().Get()
    horizontal = camera.GetHorizontalApertureAttr().Get()
    # 60° horizontally: aperture = 2 f tan(30°).
    assert horizontal == pytest.approx(2 * focal * math.tan(math.radians(30.0)), rel=FLOAT32_ROUNDING)
    assert camera.GetVerticalApertureAttr().Get() == pytest.approx(horizontal / 2.0, rel=FLOAT32_ROUNDING)  # 64×32
    m = world(camera.GetPrim())
    assert m.ExtractTranslation() == Gf.Vec3d(0.0, 1.0, 5.0)
    # USD cameras look down their local −Z.
    looks = m.TransformDir(Gf.Vec3d(0.0, 0.0, -1.0))
    assert np.allclose(looks, (0.0, 0.0, -1.0), atol=DOUBLE_ARITHMETIC)
    assert np.allclose(m.TransformDir(Gf.Vec3d(0.0, 1.0, 0.0)), (0.0, 1.0, 0.0), atol=DOUBLE_ARITHMETIC)


def test_render_settings(stage):
    settings = UsdRender.Settings(stage.GetPrimAtPath("/Render/Final"))
    assert settings.GetResolutionAttr().Get() == Gf.Vec2i(64, 32)
    assert settings.GetCameraRel().GetTargets() == ["/World/Eye"]
    prim = settings.GetPrim()
    assert attr(prim, "phong:samples") == 3
    assert attr(prim, "phong:samplePattern") == "grid"
    assert attr(prim, "phong:specularConvention") == "seed"
    assert attr(prim, "phong:background") == Gf.Vec3f(0.25, 0.0, 0.5)


def test_sphere_and_its_material_binding(stage):
    sphere = UsdGeom.Sphere(stage.GetPrimAtPath("/World/Geometry/Ball"))
    assert sphere.GetRadiusAttr().Get() == 1.5
    assert world(sphere.GetPrim()).ExtractTranslation() == Gf.Vec3d(0.0, 1.0, 0.0)
    bound, _ = UsdShade.MaterialBindingAPI(sphere.GetPrim()).ComputeBoundMaterial()
    assert bound.GetPath() == "/World/Looks/Red"


def test_mesh(stage):
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/World/Geometry/Floor"))
    assert np.array_equal(np.array(mesh.GetPointsAttr().Get()), [[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]])
    assert list(mesh.GetFaceVertexCountsAttr().Get()) == [3, 3]
    assert list(mesh.GetFaceVertexIndicesAttr().Get()) == [0, 2, 1, 0, 3, 2]
    assert mesh.GetSubdivisionSchemeAttr().Get() == UsdGeom.Tokens.none
    assert mesh.GetOrientationAttr().Get() == UsdGeom.Tokens.rightHanded
    assert mesh.GetDoubleSidedAttr().Get() is True
    assert np.array_equal(np.array(mesh.GetExtentAttr().Get()), [[-1, 0, -1], [1, 0, 1]])
    assert not mesh.GetNormalsAttr().IsAuthored()  # the model mesh has no normals
    # Written in world space: no transform of its own or inherited.
    assert world(mesh.GetPrim()) == Gf.Matrix4d(1.0)
    bound, _ = UsdShade.MaterialBindingAPI(mesh.GetPrim()).ComputeBoundMaterial()
    assert bound.GetPath() == "/World/Looks/Red"  # one Material for the two equal materials


def test_phong_shader_inputs(stage):
    material = UsdShade.Material(stage.GetPrimAtPath("/World/Looks/Red"))
    assert material.GetSurfaceOutput("phong").HasConnectedSource()  # outputs:phong:surface
    shader, output, _ = material.ComputeSurfaceSource("phong")
    assert shader.GetPath() == "/World/Looks/Red/Phong" and output == "surface"
    assert shader.GetShaderId() == "phongscene_PhongSurface"
    inputs = {i.GetBaseName(): i.Get() for i in shader.GetInputs()}
    assert inputs == {
        "ka": 0.25,
        "kd": 0.5,
        "ks": 0.125,
        "exponent": 16.0,
        "diffuseColor": Gf.Vec3f(1.0, 0.5, 0.25),
        "specularColor": Gf.Vec3f(0.75, 0.75, 1.0),
    }


def test_preview_surface_fallback(stage):
    # Other tools see a UsdPreviewSurface on the universal render context: albedo kd·cd, and
    # the inverse of the reader's conversion, F0 = ks·cs·2π/(e + 2), roughness = (1/(2(e + 2)))^(1/4).
    material = UsdShade.Material(stage.GetPrimAtPath("/World/Looks/Red"))
    shader, _, _ = material.ComputeSurfaceSource()
    assert shader.GetPath() == "/World/Looks/Red/Preview"
    assert shader.GetShaderId() == "UsdPreviewSurface"
    assert shader.GetInput("diffuseColor").Get() == Gf.Vec3f(0.5, 0.25, 0.125)
    assert shader.GetInput("useSpecularWorkflow").Get() == 1
    f0 = 0.125 * 2 * math.pi / 18.0
    assert np.allclose(
        shader.GetInput("specularColor").Get(), (0.75 * f0, 0.75 * f0, f0), rtol=FLOAT32_ROUNDING, atol=0
    )
    assert shader.GetInput("roughness").Get() == pytest.approx((1 / 36) ** 0.25, rel=FLOAT32_ROUNDING)


def light(stage, path) -> UsdLux.LightAPI:
    return UsdLux.LightAPI(stage.GetPrimAtPath(path))


def test_ambient_is_a_dome_light(stage):
    sky = light(stage, "/World/Lights/Sky")
    assert sky.GetIntensityAttr().Get() == 1.0
    assert sky.GetColorAttr().Get() == Gf.Vec3f(0.125, 0.25, 0.5)
    assert sky.GetExposureAttr().Get() == 0.0


def test_seed_point_light(stage):
    seed = UsdLux.SphereLight(stage.GetPrimAtPath("/World/Lights/Seed"))
    assert seed.GetTreatAsPointAttr().Get() is True and seed.GetRadiusAttr().Get() == 0.0
    assert world(seed.GetPrim()).ExtractTranslation() == Gf.Vec3d(1.0, 2.0, 3.0)
    # A grey strength goes into intensity, colour white.
    assert seed.GetIntensityAttr().Get() == 0.5 and seed.GetColorAttr().Get() == Gf.Vec3f(1.0)
    assert not seed.GetNormalizeAttr().IsAuthored()
    prim = seed.GetPrim()
    assert attr(prim, "phong:lightModel") == "seed"
    assert attr(prim, "phong:fadeDistance") == 2.0 and attr(prim, "phong:fadePower") == 1.0


def test_inverse_square_point_light(stage):
    # UsdLux units: a normalized sphere light's radiant intensity is intensity/4 (see define_light).
    bulb = UsdLux.SphereLight(stage.GetPrimAtPath("/World/Lights/Bulb"))
    assert bulb.GetNormalizeAttr().Get() is True
    assert bulb.GetIntensityAttr().Get() == 1.0
    assert bulb.GetColorAttr().Get() == Gf.Vec3f(4.0, 8.0, 12.0)
    assert not bulb.GetPrim().GetAttribute("phong:lightModel").IsAuthored()


def test_distant_light(stage):
    sun = UsdLux.DistantLight(stage.GetPrimAtPath("/World/Lights/DirectionalLight_0"))
    assert sun.GetNormalizeAttr().Get() is True
    assert sun.GetIntensityAttr().Get() == 0.75 and sun.GetColorAttr().Get() == Gf.Vec3f(1.0)
    assert sun.GetSpecularAttr().Get() == 0.5
    assert not sun.GetDiffuseAttr().IsAuthored()  # 1, the fallback
    # It emits along its local −Z.
    emits = world(sun.GetPrim()).TransformDir(Gf.Vec3d(0.0, 0.0, -1.0))
    assert np.allclose(emits, (0.0, -1.0, 0.0), atol=DOUBLE_ARITHMETIC)


def test_rect_light(stage):
    panel = UsdLux.RectLight(stage.GetPrimAtPath("/World/Lights/Panel"))
    assert panel.GetWidthAttr().Get() == 1.0 and panel.GetHeightAttr().Get() == 1.0
    # The unit rectangle scaled by the transform: local X is axis_u, local Y is axis_v.
    m = world(panel.GetPrim())
    assert m.ExtractTranslation() == Gf.Vec3d(0.0, 5.0, 0.0)
    assert m.TransformDir(Gf.Vec3d(1.0, 0.0, 0.0)) == Gf.Vec3d(2.0, 0.0, 0.0)
    assert m.TransformDir(Gf.Vec3d(0.0, 1.0, 0.0)) == Gf.Vec3d(0.0, 0.0, 1.0)
    prim = panel.GetPrim()
    assert attr(prim, "phong:shadowSamples") == 5
    assert attr(prim, "phong:lightModel") == "seed"
    assert not prim.GetAttribute("phong:shadowAdaptive").IsAuthored()


def test_sphere_area_light(stage):
    globe = UsdLux.SphereLight(stage.GetPrimAtPath("/World/Lights/Globe"))
    assert globe.GetTreatAsPointAttr().Get() is False and globe.GetRadiusAttr().Get() == 0.25
    assert world(globe.GetPrim()).ExtractTranslation() == Gf.Vec3d(3.0, 3.0, 3.0)
    assert globe.GetNormalizeAttr().Get() is True
    assert globe.GetIntensityAttr().Get() == 4.0  # inverse-square: ×4, as the point light
    assert attr(globe.GetPrim(), "phong:shadowSamples") == 9
