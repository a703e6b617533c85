# SPDX-License-Identifier: Apache-2.0
"""Author USD from the scene model: small ``define_*`` helpers and ``write_usd(scene, path)``.

Materials get BOTH surface outputs: ``outputs:surface`` → a UsdPreviewSurface (what
usdview and other tools show) and ``outputs:phong:surface`` → our Phong shader with every input
authored. The file is written atomically (temporary file + rename).

Conventions that make ``read(write(S))`` exact up to float32 storage: nodes are written in world
space (meshes with identity transforms, spheres and lights with a double matrix), a grey light
colour becomes ``intensity`` with ``color = (1, 1, 1)``, and rect lights are unit squares whose
transform carries the edge vectors. A node's ``source`` is reused as its prim path when it is a
free, valid path, so reading a written scene and writing it again gives the same file.
"""

from __future__ import annotations

import hashlib
import math
from pathlib import Path

import numpy as np
from pxr import Gf, Sdf, Tf, Usd, UsdGeom, UsdLux, UsdRender, UsdShade, Vt

from ..errors import SceneError, SceneFileNotFoundError
from ..files import atomic_path
from ..images import write_image
from ..scene import (
    DEFAULT_MATERIAL,
    AmbientLight,
    Camera,
    DirectionalLight,
    Intrinsic,
    PhongMaterial,
    PointLight,
    Points,
    RectAreaLight,
    RenderSettings,
    Scene,
    Sphere,
    SphereAreaLight,
    TriangleMesh,
)
from ..tolerances import UNIT_TOLERANCE
from ..validate import check
from . import names
from .names import PHONG_MAP_INPUTS, PHONG_RENDER_CONTEXT, PHONG_SEED_INPUTS, PHONG_SHADER_ID
from .shader_defs import phong_inputs

# The focal length written for perspective cameras (tenths of a scene unit, as in USD); the
# horizontal aperture is chosen to give the model's FOV. 50 is USD's fallback.
FOCAL_LENGTH = 50.0
FORMATS = (".usda", ".usdc", ".usd")


def _matrix(m: np.ndarray) -> Gf.Matrix4d:
    """A column-vector numpy matrix as a USD (row-vector) matrix."""
    return Gf.Matrix4d(np.asarray(m, dtype=np.float64).T.tolist())


def _set_transform(xformable: UsdGeom.Xformable, m: np.ndarray) -> None:
    xformable.ClearXformOpOrder()
    xformable.AddTransformOp(UsdGeom.XformOp.PrecisionDouble).Set(_matrix(m))


def _set_translate(xformable: UsdGeom.Xformable, position) -> None:
    xformable.ClearXformOpOrder()
    xformable.AddTranslateOp(UsdGeom.XformOp.PrecisionDouble).Set(Gf.Vec3d(*map(float, position)))


def _frame(x, y, origin) -> np.ndarray:
    """A column-vector matrix with columns x, y, unit(x × y) and translation ``origin``."""
    x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    z = np.cross(x, y)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = x, y, z / np.linalg.norm(z), origin
    return m


# -- authoring helpers ----------------------------------------------------------------------


def _texture_shader(
    stage: Usd.Stage, path: str, texture, image_file: str, fallback, scale: float = 1.0
) -> UsdShade.Shader:
    """A UsdUVTexture reading ``image_file`` (a linear float EXR: sourceColorSpace raw) at the
    mesh's ``st`` primvar (texCoord2d, faceVarying: what define_mesh writes), its texels × scale;
    ``fallback`` (the material's own colour) where the image is missing."""
    reader = UsdShade.Shader.Define(stage, f"{path}_St")
    reader.SetShaderId("UsdPrimvarReader_float2")
    # UsdPrimvarReader's varname is a string in its Sdr definition (usdShade validators check it).
    reader.CreateInput("varname", Sdf.ValueTypeNames.String).Set("st")
    reader.CreateOutput("result", Sdf.ValueTypeNames.Float2)
    shader = UsdShade.Shader.Define(stage, path)
    shader.SetShaderId("UsdUVTexture")
    shader.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(image_file))
    shader.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("raw")
    shader.CreateInput("fallback", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(*map(float, fallback), 1.0))
    shader.CreateInput("wrapS", Sdf.ValueTypeNames.Token).Set(texture.wrap_s)
    shader.CreateInput("wrapT", Sdf.ValueTypeNames.Token).Set(texture.wrap_t)
    if scale != 1.0:
        shader.CreateInput("scale", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(scale, scale, scale, 1.0))
    shader.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
    shader.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
    return shader


def define_phong_material(
    stage: Usd.Stage, path: str, material: PhongMaterial = DEFAULT_MATERIAL, texture_file=None
) -> UsdShade.Material:
    """A Material with our Phong shader (every input authored) and a UsdPreviewSurface fallback.
    A textured material's diffuseColor (specularColor) is connected to a UsdUVTexture reading
    ``texture_file(texture)``, the image ``write_usd`` writes beside the layer."""
    if material.textures and texture_file is None:
        raise ValueError("a textured material needs the file its image is written to (write_usd writes it)")
    mat = UsdShade.Material.Define(stage, path)
    phong = UsdShade.Shader.Define(stage, f"{path}/Phong")
    phong.SetShaderId(PHONG_SHADER_ID)
    defaults = PhongMaterial()
    for name, (field, sdf_type) in phong_inputs().items():
        if name in PHONG_MAP_INPUTS:
            continue  # connected to its texture below
        value = getattr(material, field)
        if name not in PHONG_SEED_INPUTS and value == getattr(defaults, field):
            continue  # the secondary-ray inputs only where a material uses them
        if isinstance(value, tuple):
            phong.CreateInput(name, sdf_type).Set(Gf.Vec3f(*map(float, value)))
        else:
            phong.CreateInput(name, sdf_type).Set(bool(value) if isinstance(value, (bool, np.bool_)) else float(value))
    if material.diffuse_texture is not None:
        t = material.diffuse_texture
        texture = _texture_shader(stage, f"{path}/DiffuseTexture", t, texture_file(t), material.diffuse_color)
        phong.GetInput("diffuseColor").ConnectToSource(texture.ConnectableAPI(), "rgb")
    if material.specular_texture is not None:
        t = material.specular_texture
        texture = _texture_shader(stage, f"{path}/SpecularTexture", t, texture_file(t), material.specular_color)
        phong.GetInput("specularColor").ConnectToSource(texture.ConnectableAPI(), "rgb")
    normal_map = None
    if material.normal_texture is not None:
        # The texels are the decoded tangent-space normals (a float EXR keeps their sign).
        t = material.normal_texture
        normal_map = _texture_shader(stage, f"{path}/NormalTexture", t, texture_file(t), (0.0, 0.0, 1.0))
        phong.CreateInput("normal", Sdf.ValueTypeNames.Normal3f).ConnectToSource(normal_map.ConnectableAPI(), "rgb")
    mask = None
    if material.opacity_texture is not None:
        # The cut-out mask: its first channel, thresholded (the fallback: opaque).
        t = material.opacity_texture
        mask = _texture_shader(stage, f"{path}/OpacityTexture", t, texture_file(t), (1.0, 1.0, 1.0))
        mask.CreateOutput("r", Sdf.ValueTypeNames.Float)
        phong.CreateInput("opacity", Sdf.ValueTypeNames.Float).ConnectToSource(mask.ConnectableAPI(), "r")
    mat.CreateSurfaceOutput(PHONG_RENDER_CONTEXT).ConnectToSource(phong.ConnectableAPI(), "surface")

    # Preview fallback (for other tools): Lambert albedo kd·cd, and the reader's mapping
    # (materials.preview_to_phong) inverted: α² = 1/(2(e + 2)), F0 = ks·cs·2π/(e + 2), α = r².
    preview = UsdShade.Shader.Define(stage, f"{path}/Preview")
    preview.SetShaderId("UsdPreviewSurface")
    exponent = max(material.exponent, 0.0)
    albedo = np.clip(np.asarray(material.diffuse_color, dtype=np.float64) * material.kd, 0.0, 1.0)
    f0 = np.asarray(material.specular_color, dtype=np.float64) * material.ks * (2.0 * math.pi / (exponent + 2.0))
    specular = np.clip(f0, 0.0, 1.0)
    alpha = math.sqrt(1.0 / (2.0 * (exponent + 2.0)))
    preview.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*map(float, albedo)))
    preview.CreateInput("useSpecularWorkflow", Sdf.ValueTypeNames.Int).Set(1)
    preview.CreateInput("specularColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*map(float, specular)))
    preview.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(float(math.sqrt(alpha)))
    if material.diffuse_texture is not None:
        albedo_texture = _texture_shader(
            stage,
            f"{path}/PreviewDiffuseTexture",
            material.diffuse_texture,
            texture_file(material.diffuse_texture),
            albedo,
            float(material.kd),
        )
        preview.GetInput("diffuseColor").ConnectToSource(albedo_texture.ConnectableAPI(), "rgb")
    if normal_map is not None:
        preview.CreateInput("normal", Sdf.ValueTypeNames.Normal3f).ConnectToSource(normal_map.ConnectableAPI(), "rgb")
    if mask is not None:  # the spec's masked mode
        preview.CreateInput("opacity", Sdf.ValueTypeNames.Float).ConnectToSource(mask.ConnectableAPI(), "r")
        preview.CreateInput("opacityThreshold", Sdf.ValueTypeNames.Float).Set(float(material.opacity_threshold))
    mat.CreateSurfaceOutput().ConnectToSource(preview.ConnectableAPI(), "surface")
    return mat


def bind_material(prim: Usd.Prim, material: UsdShade.Material) -> None:
    UsdShade.MaterialBindingAPI.Apply(prim).Bind(material)


def define_sphere(stage: Usd.Stage, path: str, sphere: Sphere) -> UsdGeom.Sphere:
    """A Sphere prim: radius + translate when the transform is a uniform scale, else a matrix."""
    prim = UsdGeom.Sphere.Define(stage, path)
    m = sphere.world_from_object
    r = float(m[0, 0])
    if r > 0 and np.array_equal(m[:3, :3], np.diag([r, r, r])):
        prim.CreateRadiusAttr(r)
        _set_translate(prim, m[:3, 3])
    else:
        prim.CreateRadiusAttr(1.0)
        _set_transform(prim, m)
    return prim


def define_points(stage: Usd.Stage, path: str, points: Points) -> UsdGeom.Points:
    """A world-space Points prim: ``points`` and vertex ``widths`` = 2 · radii (float32, as a
    Mesh's points are written)."""
    prim = UsdGeom.Points.Define(stage, path)
    centers = np.asarray(points.centers, dtype=np.float32)
    prim.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(centers))
    prim.CreateWidthsAttr(Vt.FloatArray.FromNumpy(np.asarray(2.0 * points.radii, dtype=np.float32)))
    prim.SetWidthsInterpolation(UsdGeom.Tokens.vertex)
    return prim


def define_intrinsic(stage: Usd.Stage, path: str, intrinsic: Intrinsic) -> Usd.Prim:
    """An intrinsic prim in the model's canonical frame (axis Z, unit sizes) under its matrix:
    Cube of size 2; Cylinder, Cone or Cylinder_1 of height 2; Capsule or Capsule_1; Plane of 2 × 2 (and
    ``phong:infinite``). Read back, the same ``Intrinsic``."""
    kind = intrinsic.kind
    if kind == "cube":
        prim = UsdGeom.Cube.Define(stage, path)
        prim.CreateSizeAttr(2.0)
    elif kind == "cylinder":
        r0, r1 = float(intrinsic.radius_bottom), float(intrinsic.radius_top)
        if r0 == r1:
            prim = UsdGeom.Cylinder.Define(stage, path)
            prim.CreateRadiusAttr(r0)
        elif r1 == 0.0:
            prim = UsdGeom.Cone.Define(stage, path)
            prim.CreateRadiusAttr(r0)
        else:
            prim = UsdGeom.Cylinder_1.Define(stage, path)
            prim.CreateRadiusBottomAttr(r0)
            prim.CreateRadiusTopAttr(r1)
        prim.CreateHeightAttr(2.0)
        prim.CreateAxisAttr(UsdGeom.Tokens.z)
    elif kind == "capsule":
        r0, r1 = float(intrinsic.radius_bottom), float(intrinsic.radius_top)
        if r0 == r1:
            prim = UsdGeom.Capsule.Define(stage, path)
            prim.CreateRadiusAttr(r0)
        else:
            prim = UsdGeom.Capsule_1.Define(stage, path)
            prim.CreateRadiusBottomAttr(r0)
            prim.CreateRadiusTopAttr(r1)
        prim.CreateHeightAttr(2.0 * float(intrinsic.half_height))
        prim.CreateAxisAttr(UsdGeom.Tokens.z)
    else:
        prim = UsdGeom.Plane.Define(stage, path)
        prim.CreateWidthAttr(2.0)
        prim.CreateLengthAttr(2.0)
        prim.CreateAxisAttr(UsdGeom.Tokens.z)
        if intrinsic.infinite:
            prim.GetPrim().CreateAttribute(names.INFINITE, Sdf.ValueTypeNames.Bool, custom=True).Set(True)
    _set_transform(prim, intrinsic.world_from_object)
    return prim.GetPrim()


def define_linking(stage: Usd.Stage, light_path: str, linking, written: dict[str, list[str]]) -> None:
    """A light's ``Linking`` as UsdLux says it: ShadowAPI's shadow:enable, and the light and
    shadow link collections as explicit includes (includeRoot off) of the prims written for the
    member sources (``written``: source -> paths)."""
    prim = stage.GetPrimAtPath(light_path)
    if not linking.shadows:
        UsdLux.ShadowAPI.Apply(prim).CreateShadowEnableAttr(False)
    api = UsdLux.LightAPI(prim)
    for members, collection in (
        (linking.illuminates, api.GetLightLinkCollectionAPI()),
        (linking.shadowed_by, api.GetShadowLinkCollectionAPI()),
    ):
        if members is None:
            continue
        collection.CreateIncludeRootAttr(False)
        collection.CreateIncludesRel().SetTargets([Sdf.Path(p) for s in sorted(members) for p in written.get(s, ())])


def define_mesh(stage: Usd.Stage, path: str, mesh: TriangleMesh) -> UsdGeom.Mesh:
    """A world-space triangle Mesh (subdivisionScheme none); normals as vertex-interpolated
    ``normals`` when they are per point, else as indexed faceVarying ``primvars:normals``."""
    prim = UsdGeom.Mesh.Define(stage, path)
    points = np.asarray(mesh.points, dtype=np.float32)
    prim.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points))
    prim.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(mesh.triangles), 3, dtype=np.int32)))
    prim.CreateFaceVertexIndicesAttr(
        Vt.IntArray.FromNumpy(np.ascontiguousarray(mesh.triangles.ravel(), dtype=np.int32))
    )
    prim.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    prim.CreateOrientationAttr(UsdGeom.Tokens.rightHanded)
    prim.CreateDoubleSidedAttr(True)  # the model shades both sides (so do both backends)
    if len(points):
        prim.CreateExtentAttr(Vt.Vec3fArray.FromNumpy(np.stack([points.min(axis=0), points.max(axis=0)])))
    if mesh.normals is not None:
        normals = Vt.Vec3fArray.FromNumpy(np.asarray(mesh.normals, dtype=np.float32))
        if len(mesh.normals) == len(mesh.points) and np.array_equal(mesh.normal_indices, mesh.triangles):
            prim.CreateNormalsAttr(normals)
            prim.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
        else:
            primvar = UsdGeom.PrimvarsAPI(prim).CreatePrimvar(
                "normals", Sdf.ValueTypeNames.Normal3fArray, UsdGeom.Tokens.faceVarying
            )
            primvar.Set(normals)
            primvar.SetIndices(Vt.IntArray.FromNumpy(np.ascontiguousarray(mesh.normal_indices.ravel(), dtype=np.int32)))
    if mesh.uvs is not None:
        # Double precision: the model's uvs read back unchanged.
        st = UsdGeom.PrimvarsAPI(prim).CreatePrimvar(
            "st", Sdf.ValueTypeNames.TexCoord2dArray, UsdGeom.Tokens.faceVarying
        )
        st.Set(Vt.Vec2dArray.FromNumpy(np.ascontiguousarray(mesh.uvs, dtype=np.float64)))
        st.SetIndices(Vt.IntArray.FromNumpy(np.ascontiguousarray(mesh.uv_indices.ravel(), dtype=np.int32)))
    return prim


def _set_light_color(light: UsdLux.LightAPI, color) -> None:
    """ls·cl as intensity × color: a grey strength goes into intensity (color white), so that
    the reader's intensity · 2^0 · color reproduces the float32 value exactly."""
    r, g, b = map(float, color)
    light.CreateExposureAttr(0.0)
    if r == g == b:
        light.CreateIntensityAttr(r)
        light.CreateColorAttr(Gf.Vec3f(1.0, 1.0, 1.0))
    else:
        light.CreateIntensityAttr(1.0)
        light.CreateColorAttr(Gf.Vec3f(r, g, b))


def _define_cone(prim: Usd.Prim, cone, position) -> None:
    """A ShapingAPI cone the reader reads back as ``cone``: angle θo = acos(cos_outer), softness
    1 − θi/θo, focus; the axis is the light's −Z (an aimed light's transform is a rotation)."""
    outer, inner = math.acos(cone.cos_outer), math.acos(cone.cos_inner)
    shaping = UsdLux.ShapingAPI.Apply(prim)
    shaping.CreateShapingConeAngleAttr(math.degrees(outer))
    shaping.CreateShapingConeSoftnessAttr(1.0 - inner / outer if outer > 0 else 0.0)
    if cone.focus > 0:
        shaping.CreateShapingFocusAttr(float(cone.focus))
    axis = np.asarray(cone.axis, dtype=np.float64)
    helper = np.array([0.0, 1.0, 0.0]) if abs(axis[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    x = np.cross(helper, -axis)
    x /= np.linalg.norm(x)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2] = x, np.cross(-axis, x), -axis  # the light emits along its −Z
    m[:3, 3] = position
    _set_transform(UsdLux.SphereLight(prim), m)


def define_light(stage: Usd.Stage, path: str, light) -> Usd.Prim:
    """A UsdLux light for a model light (PointLight, DirectionalLight, RectAreaLight,
    SphereAreaLight) or an AmbientLight (an untextured DomeLight).

    A seed light (falloff "none") is marked ``phong:lightModel = "seed"``; an inverse-square one
    is written in UsdLux's units with ``normalize = 1``, where the reader's radiant intensity is
    intensity/4 for a SphereLight and the intensity itself for a RectLight (exact: ×4 and /4
    are exact in binary). A DistantLight is written normalized, so its intensity is the
    irradiance whatever its angle.
    """
    strength = np.asarray(light.color, dtype=np.float64)
    falloff = getattr(light, "falloff", "none")
    if isinstance(light, AmbientLight):
        prim = UsdLux.DomeLight.Define(stage, path)
    elif isinstance(light, PointLight):
        prim = UsdLux.SphereLight.Define(stage, path)
        prim.CreateTreatAsPointAttr(True)
        prim.CreateRadiusAttr(0.0)
        _set_translate(prim, light.position)
        p = prim.GetPrim()
        if falloff == "none":
            p.CreateAttribute(names.FADE_DISTANCE, Sdf.ValueTypeNames.Double).Set(float(light.fade_distance))
            p.CreateAttribute(names.FADE_POWER, Sdf.ValueTypeNames.Double).Set(float(light.fade_power))
        else:
            strength = strength * 4.0
        if light.cone is not None:
            _define_cone(p, light.cone, light.position)
    elif isinstance(light, SphereAreaLight):
        prim = UsdLux.SphereLight.Define(stage, path)
        prim.CreateTreatAsPointAttr(False)
        prim.CreateRadiusAttr(float(light.radius))
        _set_translate(prim, light.center)
        prim.GetPrim().CreateAttribute(names.SHADOW_SAMPLES, Sdf.ValueTypeNames.Int).Set(int(light.samples))
        if light.adaptive is not None:
            prim.GetPrim().CreateAttribute(names.SHADOW_ADAPTIVE, Sdf.ValueTypeNames.Int).Set(int(light.adaptive))
        if light.cell_samples is not None:
            prim.GetPrim().CreateAttribute(names.SHADOW_CELL_SAMPLES, Sdf.ValueTypeNames.Int).Set(
                int(light.cell_samples)
            )
        if falloff != "none":
            strength = strength * 4.0
    elif isinstance(light, DirectionalLight):
        prim = UsdLux.DistantLight.Define(stage, path)
        d = np.asarray(light.direction, dtype=np.float64)
        helper = np.array([0.0, 1.0, 0.0]) if abs(d[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
        x = np.cross(helper, -d)
        x /= np.linalg.norm(x)
        m = np.eye(4)
        m[:3, 0], m[:3, 1], m[:3, 2] = x, np.cross(-d, x), -d  # the light emits along its −Z
        _set_transform(prim, m)
    elif isinstance(light, RectAreaLight):
        prim = UsdLux.RectLight.Define(stage, path)
        prim.CreateWidthAttr(1.0)
        prim.CreateHeightAttr(1.0)
        _set_transform(prim, _frame(light.axis_u, light.axis_v, light.center))
        prim.GetPrim().CreateAttribute(names.SHADOW_SAMPLES, Sdf.ValueTypeNames.Int).Set(int(light.samples))
        if light.adaptive is not None:
            prim.GetPrim().CreateAttribute(names.SHADOW_ADAPTIVE, Sdf.ValueTypeNames.Int).Set(int(light.adaptive))
        if light.cell_samples is not None:
            prim.GetPrim().CreateAttribute(names.SHADOW_CELL_SAMPLES, Sdf.ValueTypeNames.Int).Set(
                int(light.cell_samples)
            )
    else:
        raise TypeError(f"not a light: {light!r}")
    api = UsdLux.LightAPI(prim.GetPrim())
    if isinstance(light, (PointLight, SphereAreaLight, RectAreaLight)) and falloff == "none":
        prim.GetPrim().CreateAttribute(names.LIGHT_MODEL, Sdf.ValueTypeNames.Token).Set(names.LIGHT_MODEL_SEED)
    elif not isinstance(light, AmbientLight):
        api.CreateNormalizeAttr(True)
    _set_light_color(api, strength)
    if getattr(light, "diffuse", 1.0) != 1.0:
        api.CreateDiffuseAttr(float(light.diffuse))
    if getattr(light, "specular", 1.0) != 1.0:
        api.CreateSpecularAttr(float(light.specular))
    return prim.GetPrim()


def define_camera(stage: Usd.Stage, path: str, camera: Camera, aspect: float = 4 / 3) -> UsdGeom.Camera:
    """A Camera prim; ``aspect`` (width/height) sets verticalAperture for other tools."""
    prim = UsdGeom.Camera.Define(stage, path)
    forward = np.asarray(camera.forward, dtype=np.float64)
    up = np.asarray(camera.up, dtype=np.float64)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = camera.right, up, -forward, camera.position  # looks down −Z
    _set_transform(prim, m)
    if camera.projection == "orthographic":
        prim.CreateProjectionAttr(UsdGeom.Tokens.orthographic)
        aperture = camera.ortho_width / names.APERTURE_UNIT
    else:
        prim.CreateProjectionAttr(UsdGeom.Tokens.perspective)
        prim.CreateFocalLengthAttr(FOCAL_LENGTH)
        aperture = 2.0 * FOCAL_LENGTH * math.tan(math.radians(camera.horizontal_fov_deg) / 2)
    prim.CreateHorizontalApertureAttr(float(aperture))
    prim.CreateVerticalApertureAttr(float(aperture / aspect))
    return prim


def define_render_settings(
    stage: Usd.Stage, path: str, settings: RenderSettings, camera_path: str | None
) -> UsdRender.Settings:
    """A UsdRender.Settings prim with resolution, camera and our ``phong:`` knobs; it becomes
    the stage's render settings."""
    prim = UsdRender.Settings.Define(stage, path)
    prim.CreateResolutionAttr(Gf.Vec2i(int(settings.width), int(settings.height)))
    if camera_path:
        prim.CreateCameraRel().SetTargets([Sdf.Path(camera_path)])
    p = prim.GetPrim()
    p.CreateAttribute(names.SAMPLES, Sdf.ValueTypeNames.Int).Set(int(settings.samples))
    p.CreateAttribute(names.SAMPLE_PATTERN, Sdf.ValueTypeNames.Token).Set(settings.sample_pattern)
    if settings.aa_threshold:
        p.CreateAttribute(names.AA_THRESHOLD, Sdf.ValueTypeNames.Double).Set(float(settings.aa_threshold))
    p.CreateAttribute(names.SPECULAR_CONVENTION, Sdf.ValueTypeNames.Token).Set(settings.specular)
    p.CreateAttribute(names.BACKGROUND, Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*map(float, settings.background)))
    # Secondary rays' settings only where they differ from the defaults.
    if settings.max_depth != RenderSettings().max_depth:
        p.CreateAttribute(names.MAX_DEPTH, Sdf.ValueTypeNames.Int).Set(int(settings.max_depth))
    if settings.transmission != RenderSettings().transmission:
        p.CreateAttribute(names.TRANSMISSION_CONVENTION, Sdf.ValueTypeNames.Token).Set(settings.transmission)
    stage.SetMetadata("renderSettingsPrimPath", path)
    return prim


def new_stage() -> Usd.Stage:
    """An in-memory stage with phongscene's conventions: Y up, /World as default prim."""
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    stage.SetDefaultPrim(UsdGeom.Xform.Define(stage, "/World").GetPrim())
    return stage


def save_stage(stage: Usd.Stage, path) -> Path:
    """Export ``stage`` to ``path`` atomically (a temporary file in the same folder, renamed)."""
    path = Path(path)
    if path.suffix not in FORMATS:
        raise SceneError(f"{path}: can only write {', '.join(FORMATS)} files")
    with atomic_path(path) as tmp:
        if not stage.GetRootLayer().Export(str(tmp)):
            raise SceneError(f"{path}: USD could not write the file")
    return path


# -- whole scenes ---------------------------------------------------------------------------


class _Paths:
    """Prim paths for nodes: the node's source when it is a free valid path not nested with
    another node's path (nodes are written in world space, so none may inherit a transform),
    else ``<parent>/<Kind>_<n>``."""

    def __init__(self, stage: Usd.Stage):
        self.stage = stage
        self.used: set[str] = set()

    def _free(self, path: str) -> bool:
        if not path.startswith("/") or not Sdf.Path.IsValidPathString(path) or path in ("/", "/World", "/Render"):
            return False
        p = Sdf.Path(path)
        if not p.IsPrimPath() or path in self.used:
            return False
        return not any(p.HasPrefix(Sdf.Path(u)) or Sdf.Path(u).HasPrefix(p) for u in self.used)

    def take(self, source: str, parent: str, kind: str) -> str:
        path = source if self._free(source) else ""
        n = 0
        while not path:
            candidate = f"{parent}/{Tf.MakeValidIdentifier(kind)}_{n}"
            path = candidate if self._free(candidate) else ""
            n += 1
        self.used.add(path)
        for ancestor in Sdf.Path(path).GetParentPath().GetPrefixes():
            if not self.stage.GetPrimAtPath(ancestor):
                UsdGeom.Scope.Define(self.stage, ancestor)  # grouping only: no transform
        return path


def scene_to_stage(scene: Scene, texture_files: dict[int, str] | None = None) -> Usd.Stage:
    """Author every node of ``scene`` on a new in-memory stage. ``texture_files``: the image
    file of each texture, by ``id(texture)`` (``write_usd`` writes them)."""
    texture_files = texture_files or {}
    stage = new_stage()
    paths = _Paths(stage)
    materials: list[tuple[PhongMaterial, UsdShade.Material]] = []

    def material_for(m: PhongMaterial) -> UsdShade.Material:
        for known, usd in materials:
            if known == m:
                return usd
        source = m.source.rsplit("/", 1)[0] if m.source.endswith("/Phong") else ""
        images = (lambda t: texture_files[id(t)]) if m.textures else None
        usd = define_phong_material(stage, paths.take(source, "/World/Looks", "Material"), m, images)
        materials.append((m, usd))
        return usd

    camera_path = paths.take(scene.camera.source, "/World", "Camera")
    define_camera(stage, camera_path, scene.camera, scene.settings.width / scene.settings.height)
    define_render_settings(stage, paths.take(scene.settings.source, "/Render", "Settings"), scene.settings, camera_path)
    if any(scene.ambient.color):
        define_light(stage, paths.take(scene.ambient.source, "/World/Lights", "Ambient"), scene.ambient)
    light_paths = []
    for light in scene.lights:
        light_paths.append(paths.take(light.source, "/World/Lights", type(light).__name__))
        define_light(stage, light_paths[-1], light)
    written: dict[str, list[str]] = {}  # each geometry source -> the prims written for it
    for sphere in scene.spheres:
        path = paths.take(sphere.source, "/World/Geometry", "Sphere")
        prim = define_sphere(stage, path, sphere)
        bind_material(prim.GetPrim(), material_for(sphere.material))
        written.setdefault(sphere.source, []).append(path)
    for mesh in scene.meshes:
        path = paths.take(mesh.source, "/World/Geometry", "Mesh")
        prim = define_mesh(stage, path, mesh)
        bind_material(prim.GetPrim(), material_for(mesh.material))
        written.setdefault(mesh.source, []).append(path)
    for intrinsic in scene.intrinsics:
        path = paths.take(intrinsic.source, "/World/Geometry", intrinsic.kind.capitalize())
        bind_material(define_intrinsic(stage, path, intrinsic), material_for(intrinsic.material))
        written.setdefault(intrinsic.source, []).append(path)
    for points in scene.points:
        path = paths.take(points.source, "/World/Geometry", "Points")
        bind_material(define_points(stage, path, points).GetPrim(), material_for(points.material))
        written.setdefault(points.source, []).append(path)
    for light, path in zip(scene.lights, light_paths):
        if not light.linking.default:
            define_linking(stage, path, light.linking, written)
    return stage


def write_usd(scene: Scene, path) -> Path:
    """Validate ``scene`` and write it to a .usda/.usdc/.usd file, atomically.

    Returns:
        The path written.

    Raises:
        SceneError: the scene is invalid (nothing is written: a file with a NaN would not read back).
    """
    check(scene)
    # Instances are written out as world meshes (a PointInstancer writer is not built yet).
    scene = scene.flattened()
    path = Path(path)
    texture_files: dict[int, str] = {}
    for t in (t for obj in scene.objects for t in obj.material.textures):
        if id(t) not in texture_files:
            # Beside the layer, named after it and the texels (float EXR: linear, exact).
            digest = hashlib.sha1(np.ascontiguousarray(t.image).tobytes()).hexdigest()[:12]
            name = f"{path.stem}-texture-{digest}.exr"
            write_image(path.parent / name, t.image)
            texture_files[id(t)] = f"./{name}"
    return save_stage(scene_to_stage(scene, texture_files), path)


# Faces meeting at a larger angle than this get split normals on import (a crease); smaller
# angles are smoothed. 30 degrees is Blender's "Smooth by Angle" (auto smooth) default.
DEFAULT_CREASE_ANGLE_DEG = 30.0


def import_mesh(
    mesh_file, output, material: PhongMaterial = DEFAULT_MATERIAL, *, crease_angle_deg: float = DEFAULT_CREASE_ANGLE_DEG
) -> Path:
    """Convert a mesh file (anything ``trimesh.load`` reads: OBJ, PLY, STL, OFF, GLB, ...) to a
    USD file: one Mesh (subdivisionScheme none, world space) per object of the file (a GLB's or
    OBJ's scene nodes, each named after its node; a file of one object is named after the file).
    No camera or lights: readers then use the framing camera and head light.

    Colours: a part with vertex or face colours (PLY, OFF, GLB), or a material's base colour
    (GLB), keeps them as ``primvars:displayColor`` (vertex, uniform or constant; 8-bit sRGB
    decoded to linear) and is left unbound, so that USD tools show its colours (phongscene
    renders a non-constant displayColor's mean, with a warning); a part without colours is bound
    to the Phong ``material``.

    Normals: the file's own vertex normals when it has them; otherwise (STL, and most PLY and
    OFF files, have none) normals smoothed across edges where faces meet at less than
    ``crease_angle_deg`` and split where they meet at more (trimesh's ``smooth_shade``), so a
    box stays a box and a sphere stays smooth."""
    import trimesh  # noqa: F401 - the file's reader; imported here, only when importing

    mesh_file = Path(mesh_file)
    if not mesh_file.exists():
        raise SceneFileNotFoundError(str(mesh_file))
    if not mesh_file.is_file():
        raise SceneError(f"{mesh_file}: not a file")
    if not (isinstance(crease_angle_deg, (int, float)) and 0.0 <= crease_angle_deg <= 180.0):
        raise ValueError(f"crease angle must be in 0..180 degrees, got {crease_angle_deg!r}")
    try:
        parts = _load_trimesh_parts(mesh_file)
    except Exception as e:  # trimesh raises many types for unreadable files
        raise SceneError(f"{mesh_file}: trimesh cannot read it: {e}") from None
    if not parts:
        raise SceneError(f"{mesh_file}: no triangles found")
    stage = new_stage()
    usd_material = None
    names: set[str] = set()
    for name, tm, file_normals in parts:
        faces = np.asarray(tm.faces, dtype=np.int64)
        if file_normals:
            normals, normal_indices = _unit_vertex_normals(tm), faces
        else:
            normals, normal_indices = _crease_normals(tm, math.radians(crease_angle_deg))
        model = TriangleMesh(np.asarray(tm.vertices), faces, normals, normal_indices, material)
        prim_name = _unique_name(Tf.MakeValidIdentifier(mesh_file.stem if len(parts) == 1 else name), names)
        prim = define_mesh(stage, f"/World/{prim_name}", model)
        colours = _display_colours(tm)
        if colours is not None:
            values, interpolation = colours
            primvar = UsdGeom.PrimvarsAPI(prim).CreatePrimvar(
                "displayColor", Sdf.ValueTypeNames.Color3fArray, interpolation
            )
            primvar.Set(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(values, dtype=np.float32)))
        else:
            if usd_material is None:
                usd_material = define_phong_material(stage, "/World/Looks/Default", material)
            bind_material(prim.GetPrim(), usd_material)
    return save_stage(stage, output)


def _unique_name(name: str, taken: set[str]) -> str:
    """``name``, or ``name_1``, ``name_2``, ... when it is taken (two nodes of one name)."""
    unique, n = name, 0
    while unique in taken:
        n += 1
        unique = f"{name}_{n}"
    taken.add(unique)
    return unique


def _srgb_to_linear(codes: np.ndarray) -> np.ndarray:
    """8-bit sRGB codes (a mesh file's colours) → linear values (displayColor is linear)."""
    c = np.asarray(codes, dtype=np.float64) / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _display_colours(tm) -> tuple[np.ndarray, str] | None:
    """(linear RGB colours, USD interpolation) of a trimesh part's own colours, or None: vertex
    colours → vertex, face colours → uniform, a material's base colour (or one colour for all)
    → constant."""
    visual = tm.visual
    kind = getattr(visual, "kind", None)
    if kind == "vertex":
        colours, interpolation = np.asarray(visual.vertex_colors)[:, :3], UsdGeom.Tokens.vertex
    elif kind == "face":
        colours, interpolation = np.asarray(visual.face_colors)[:, :3], UsdGeom.Tokens.uniform
    elif kind == "texture" and getattr(visual, "material", None) is not None:
        main = getattr(visual.material, "main_color", None)
        if main is None:
            return None
        colours, interpolation = np.asarray(main, dtype=np.float64).reshape(1, -1)[:, :3], UsdGeom.Tokens.constant
    else:
        return None
    if len(colours) > 1 and np.all(colours == colours[0]):
        colours, interpolation = colours[:1], UsdGeom.Tokens.constant
    return _srgb_to_linear(colours), interpolation


def _load_trimesh_parts(mesh_file: Path) -> list[tuple[str, object, bool]]:
    """(node name, Trimesh in world space, whether the file gave its vertex normals) for every
    object of the file. ``trimesh.load(force="mesh")`` would merge them and drop the file's
    normals (its scene flattening copies meshes without their cache, where trimesh keeps given
    normals), so each node's geometry is copied with the cache kept; ``apply_transform`` then
    transforms the normals."""
    import trimesh

    scene = trimesh.load_scene(mesh_file)
    parts = []
    for node in scene.graph.nodes_geometry:
        transform, name = scene.graph[node]
        geometry = scene.geometry[name]
        if isinstance(geometry, trimesh.Trimesh) and len(geometry.faces):
            part = geometry.copy(include_cache=True)
            part.apply_transform(transform)
            # Given normals live in trimesh's cache (the test trimesh.util.concatenate makes too).
            parts.append((str(node), part, "vertex_normals" in part._cache))
    return parts


def _crease_normals(tm, angle: float) -> tuple[np.ndarray, np.ndarray]:
    """Per-corner normals split at creases sharper than ``angle`` (radians): trimesh's
    ``smooth_shade`` cuts the mesh into smooth patches; the patches' vertex normals, indexed
    per corner of the original faces."""
    import trimesh

    smooth = trimesh.graph.smooth_shade(tm, angle=angle)
    components = smooth.metadata.get("original_components")
    if components is None or len(smooth.faces) != len(tm.faces):  # no patches: smooth everywhere
        return _unit_vertex_normals(tm), np.asarray(tm.faces, dtype=np.int64)
    faces = np.asarray(tm.faces, dtype=np.int64)
    order = np.concatenate([np.asarray(c, dtype=np.int64).ravel() for c in components])
    normal_indices = np.empty_like(faces)
    normal_indices[order] = np.asarray(smooth.faces, dtype=np.int64)
    normals = _unit_vertex_normals(smooth)
    # Where no vertex has two normals (nothing split, e.g. a sphere), one normal per point is the
    # same and simpler (vertex-interpolated normals in USD); points of no face keep +Z.
    corners = normals[normal_indices].reshape(-1, 3)
    per_point = np.tile([0.0, 0.0, 1.0], (len(tm.vertices), 1))
    per_point[faces.ravel()] = corners
    if np.array_equal(per_point[faces.ravel()], corners):
        return per_point, faces
    return normals, normal_indices


def _unit_vertex_normals(tm) -> np.ndarray:
    """trimesh's vertex normals, with a unit normal wherever trimesh has none: where the faces'
    normals cancel (a two-sided sheet) or every face is degenerate, the normal of one of the
    vertex's faces (shading is two-sided), and +Z on a vertex with no face of any area (it is
    never seen). Otherwise the file would fail validation when read back."""
    normals = np.array(tm.vertex_normals, dtype=np.float64)
    bad = np.abs(np.linalg.norm(normals, axis=1) - 1.0) > UNIT_TOLERANCE
    if bad.any():
        face_normals = np.asarray(tm.face_normals, dtype=np.float64)
        usable = np.abs(np.linalg.norm(face_normals, axis=1) - 1.0) <= UNIT_TOLERANCE
        fallback = np.tile([0.0, 0.0, 1.0], (len(normals), 1))
        fallback[np.asarray(tm.faces)[usable].ravel()] = np.repeat(face_normals[usable], 3, axis=0)
        normals[bad] = fallback[bad]
    return normals
