# SPDX-License-Identifier: Apache-2.0
"""USD materials → ``PhongMaterial``: our Phong shader exactly, a ``UsdPreviewSurface``, a
MaterialX Standard Surface / OpenPBR or an OmniPBR approximately (pbr_networks), else
displayColor or grey."""

from __future__ import annotations

import dataclasses

import numpy as np
from pxr import Sdf, Sdr, Usd, UsdGeom, UsdShade

from ..scene import DEFAULT_MATERIAL, PhongMaterial, Texture
from .context import ReadContext
from .names import COLOR_TYPES, PHONG_INPUTS, PHONG_MAP_INPUTS, PHONG_RENDER_CONTEXT, PHONG_SHADER_ID
from .pbr_networks import MDL_NETWORKS, MTLX_NETWORKS, OMNI_PBR, Network, inputs, reduce
from .primvar_colors import DIFFUSE_COLOUR_INPUTS, PrimvarColor, constant_primvar, primvar_reader
from .shader_defs import phong_input_defaults, phong_inputs
from .textures import Connected, StSource, TextureReader

PREVIEW_SHADER_ID = "UsdPreviewSurface"
# Highest Phong exponent produced from a UsdPreviewSurface: e = 1/(2α²) − 2 reaches 1e6 at
# roughness 0.026 (a lobe of ~1e-3 rad, far below a pixel at our resolutions); smoother surfaces
# keep their albedo (the highlight's energy) with a lower, wider peak.
PREVIEW_MAX_EXPONENT = 1e6
# Smallest roughness used in the mapping (keeps 2/α² finite).
PREVIEW_MIN_ROUGHNESS = 1e-3
# Not in the UsdPreviewSurface spec: Blender writes its Principled BSDF's "Specular IOR Level" here.
BLENDER_SPECULAR_LEVEL = "specular"
PREVIEW_INPUTS = ("diffuseColor", "roughness", "metallic", "specularColor", "useSpecularWorkflow", "ior")
# A metal (metallic > 0, the metallic workflow) at most this rough mirrors its surroundings: kr = 1,
# cr = its F0's metallic part m·cd (docs/reflection.md). Rougher metals only have the highlight
# (their reflection is a blur, Suffern ch. 25, that a single mirror ray does not approximate well).
PREVIEW_MIRROR_MAX_ROUGHNESS = 0.35


# UsdPreviewSurface inputs the Phong model has no term for, with the spec's neutral value: an
# authored other value or a connection is warned (never dropped silently).
# MaterialX standard_surface / OpenPBR / OmniPBR inputs that carry a normal map.
NORMAL_MAP_INPUTS = ("normal", "geometry_normal", "normalmap_texture")
# OmniPBR's texture inputs (assets on the MDL shader itself) that the model reads.
OMNI_DIFFUSE_TEXTURE = "diffuse_texture"
OMNI_NORMAL_TEXTURE = "normalmap_texture"
OMNI_UNREAD_TEXTURES = ("reflectionroughness_texture", "metallic_texture", "ORM_texture", "opacity_texture")
PREVIEW_UNMODELLED = {"clearcoat": 0.0, "occlusion": 1.0, "normal": (0.0, 0.0, 1.0)}
# What a read normal map is told as (one grouped warning listing the materials): the model has
# it, but one backend cannot draw it.
NORMAL_MAP_NOTE = (
    "normal maps (in the native tracer's shading; POV-Ray 3.7 has no tangent-space normal maps, "
    "so its SDL leaves them out and `diff` compares without them)"
)


def preview_to_phong(
    diffuse_color,
    roughness: float,
    metallic: float = 0.0,
    specular_color=(0.0, 0.0, 0.0),
    use_specular_workflow: int = 0,
    ior: float = 1.5,
    source: str = "",
    specular_level: float = 0.5,
) -> PhongMaterial:
    """A Phong material with a UsdPreviewSurface's look under direct light.

    The spec's specular lobe is GGX (α = roughness²) with Schlick's Fresnel (F0 from ``ior``, or
    ``specular_color`` in the specular workflow, tinted toward the diffuse colour by
    ``metallic``); its diffuse lobe is Lambert, diffuseColor·(1 − metallic)/π. A Phong lobe
    ks·cs·(r·wo)^e has, at normal incidence, the peak ks·cs and the directional albedo
    2π·ks·cs/(e + 2); GGX has the peak F0/(4πα²) and the albedo ≈ F0. Matching both:

        e = 1/(2α²) − 2,      ks·cs = F0·(e + 2)/(2π)

    (for α ≥ 1/2, e = 0 and the strength F0/(2πα), see below; e is capped at
    PREVIEW_MAX_EXPONENT, with the albedo still matched). A smooth material's highlight strength exceeds 1: ks stays in
    the seed's [0, 1] and the rest goes into cs (colours have no upper bound). kd = 1 (the
    Lambert BRDF cd/π). ka = 1: an untextured DomeLight of radiance La lights an unoccluded
    Lambert surface with ∫ cd/π·La·cosθ dω = cd·La, which is ka·cd·La with ka = 1. Measured
    against the spec's BRDF in tests/test_preview_fidelity.py (README: the shading model).
    """
    cd = np.clip(np.asarray(diffuse_color, dtype=np.float64), 0.0, None)
    alpha = max(float(roughness), PREVIEW_MIN_ROUGHNESS) ** 2
    exponent = min(max(1.0 / (2.0 * alpha**2) - 2.0, 0.0), PREVIEW_MAX_EXPONENT)
    if use_specular_workflow:
        f0, kd_colour = np.clip(np.asarray(specular_color, dtype=np.float64), 0.0, None), cd
    else:
        m = float(np.clip(metallic, 0.0, 1.0))
        # 0.04 at ior 1.5 (UsdPreviewSurface spec), scaled by Blender's "Specular IOR Level"
        # (exported as the non-standard inputs:specular; 0.5 leaves F0 as the IOR gives it, 0 removes it).
        dielectric = ((1.0 - ior) / (1.0 + ior)) ** 2 * (2.0 * float(np.clip(specular_level, 0.0, 1.0)))
        f0, kd_colour = (1.0 - m) * dielectric + m * cd, cd * (1.0 - m)
    # α < ½: the albedo (and so the peak) matched; α ≥ ½ (e = 0, a flat lobe): F0/(2πα), which
    # meets the first form at α = ½ and follows the reference's falling albedo (Smith shadowing),
    # measured in tests/preview_reference.py.
    strength = f0 * (exponent + 2.0) / (2.0 * np.pi) if alpha < 0.5 else f0 / (2.0 * np.pi * alpha)
    ks = float(min(1.0, strength.max()))
    cs = strength / ks if ks > 0 else np.ones(3)
    # The mirror of a smooth metal (Suffern ch. 24): its F0 at normal incidence, m·cd; Schlick's rise
    # of F toward white at grazing angles is not modelled (kr·cr is constant), nor the blur of
    # roughness > 0 (docs/reflection.md measures both against Cycles).
    mirror = {}
    if not use_specular_workflow and metallic > 0 and float(roughness) <= PREVIEW_MIRROR_MAX_ROUGHNESS:
        m = float(np.clip(metallic, 0.0, 1.0))
        mirror = {"kr": 1.0, "reflective_color": tuple(float(c) for c in m * cd)}
    return PhongMaterial(
        ka=1.0,
        kd=1.0,
        ks=ks,
        exponent=float(exponent),
        diffuse_color=tuple(float(c) for c in kd_colour),
        specular_color=tuple(float(c) for c in cs),
        source=source,
        **mirror,
    )


def preview_glass(material: PhongMaterial, opacity: float, ior: float, roughness: float) -> PhongMaterial:
    """A translucent UsdPreviewSurface (opacity < 1, opacityThreshold 0) as the book's dielectric
    (Suffern ch. 28): the spec blends the opaque surface (weight opacity) with transmission
    through an interior of index ``ior`` (weight 1 − opacity). So ka and kd are scaled by the
    opacity, kt = 1 − opacity, and Fresnel splits each crossing between the refracted ray and the
    mirror (kr = 1, cr white) where the surface is smooth enough to mirror (roughness at most
    PREVIEW_MIRROR_MAX_ROUGHNESS; rougher glass refracts without its mirror image). The highlight
    stays the mapping's (the GGX lobe of the lights). docs/reflection.md states the mapping."""
    mirror = {"kr": 1.0, "reflective_color": (1.0, 1.0, 1.0)} if roughness <= PREVIEW_MIRROR_MAX_ROUGHNESS else {}
    return dataclasses.replace(
        material,
        ka=material.ka * opacity,
        kd=material.kd * opacity,
        kt=1.0 - opacity,
        ior=ior,
        fresnel=True,
        **mirror,
    )


# The render contexts whose surface outputs are read, most specific first: ours, then the
# MaterialX and MDL networks files ship (the universal output, usually a UsdPreviewSurface
# stand-in written for viewers, is read only where none of these is connected).
SURFACE_CONTEXTS = (PHONG_RENDER_CONTEXT, "mtlx", "mdl")
MDL_SOURCE_TYPE = "mdl"


def surface_source(material: UsdShade.Material) -> UsdShade.Shader | None:
    """The surface shader the reader maps for ``material`` (see SURFACE_CONTEXTS)."""
    for context in SURFACE_CONTEXTS:
        output = material.GetSurfaceOutput(context)
        if output and output.HasConnectedSource():
            shader, _, _ = material.ComputeSurfaceSource(context)
            if shader:
                return shader
    shader, _, _ = material.ComputeSurfaceSource()
    return shader if shader else None


class MaterialReader:
    """Resolves the material of each gprim, caching by material prim."""

    def __init__(self, ctx: ReadContext):
        self.ctx = ctx
        self.cache: dict[str, PhongMaterial] = {}
        self.textures = TextureReader(ctx)
        # Where each textured material's st comes from (the mesh reader reads that primvar).
        self.st_of: dict[PhongMaterial, StSource] = {}
        # The sources of materials whose constant opacity is below their opacityThreshold
        # (UsdPreviewSurface's masked mode): gprims bound to them are not rendered.
        self.cut_out: set[str] = set()
        # Materials whose cd a primvar reader gives (primvar_colors.py), and what it reads.
        self.primvar_colors: dict[PhongMaterial, PrimvarColor] = {}
        self._primvar_read: tuple[str, tuple] | None = None  # set by _input_value while mapping
        # The root of the prototype being read (Instancing), or None: a primvar above it is
        # the copy's, not the prototype's.
        self.prototype_root: Usd.Prim | None = None
        self.phong_defaults = phong_input_defaults()
        preview = Sdr.Registry().GetShaderNodeByIdentifier(PREVIEW_SHADER_ID)
        self.preview_defaults = {n: preview.GetShaderInput(n).GetDefaultValue() for n in PREVIEW_INPUTS}

    def for_gprim(self, prim: Usd.Prim) -> PhongMaterial:
        material, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()
        if not material:
            return self._display_color(prim)
        m = self.for_material(material)
        reads = self.primvar_colors.get(m)
        if reads is None:
            return m
        value = constant_primvar(prim, reads.name, self.ctx.time, stop=self.prototype_root)
        if value is not None:
            return dataclasses.replace(m, diffuse_color=reads.of(value), instance_color=False)
        if self.prototype_root is not None:
            return m  # each copy's value: Instances.colors (instancing.py)
        self.ctx.unsupported["primvar readers whose primvar the gprim lacks (the reader's fallback is used)"].append(
            f"{prim.GetPath()} ({reads.name})"
        )
        return dataclasses.replace(m, instance_color=False)

    def for_material(self, material: UsdShade.Material) -> PhongMaterial:
        key = str(material.GetPath())
        if key not in self.cache:
            self.cache[key] = self._material(material)
        return self.cache[key]

    def face_subsets(self, prim: Usd.Prim) -> list[tuple[str, PhongMaterial, np.ndarray]]:
        """The mesh's GeomSubsets (family materialBind) that bind a material of their own:
        (subset prim path, material, face indices). Faces in none keep the mesh's material."""
        parts = []
        for subset in UsdShade.MaterialBindingAPI(prim).GetMaterialBindSubsets():
            material, _ = UsdShade.MaterialBindingAPI(subset.GetPrim()).ComputeBoundMaterial()
            indices = subset.GetIndicesAttr().Get(self.ctx.time)
            if material and indices is not None and len(indices):
                if self.for_material(material).source in self.cut_out:
                    self.ctx.unsupported[
                        "GeomSubsets bound to a cut-out material (opacity below opacityThreshold; rendered opaque)"
                    ].append(str(subset.GetPath()))
                parts.append((str(subset.GetPath()), self.for_material(material), np.asarray(indices, dtype=np.int64)))
        return parts

    def _material(self, material: UsdShade.Material) -> PhongMaterial:
        """The mapped material; one whose cd a primvar reader gives is marked instance_color
        and remembered with the primvar it reads (primvar_colors.py)."""
        self._primvar_read = None
        m = self._mapped(material)
        if self._primvar_read is None:
            return m
        name, fallback = self._primvar_read
        # The mapping's scale of the colour it read (base · (1 − metalness)), channel by channel;
        # where the fallback is 0 the other channels' mean ratio (the mappings scale all alike).
        ratios = [c / f for c, f in zip(m.diffuse_color, fallback) if f > 0]
        mean = sum(ratios) / len(ratios) if ratios else 1.0
        scale = tuple(c / f if f > 0 else mean for c, f in zip(m.diffuse_color, fallback))
        m = dataclasses.replace(m, instance_color=True)
        self.primvar_colors[m] = PrimvarColor(name, scale)
        return m

    def _mapped(self, material: UsdShade.Material) -> PhongMaterial:
        shader = surface_source(material)
        if not shader:
            self.ctx.unsupported["materials without a surface shader (rendered grey)"].append(str(material.GetPath()))
            return DEFAULT_MATERIAL
        shader_id = shader.GetShaderId()
        if shader_id == PHONG_SHADER_ID:
            return self._phong(shader)
        if shader_id in MTLX_NETWORKS:
            return self._network(shader, MTLX_NETWORKS[shader_id])
        if shader_id == PREVIEW_SHADER_ID:
            return self._preview(shader)
        if not shader_id and shader.GetImplementationSource() == UsdShade.Tokens.sourceAsset:
            network = MDL_NETWORKS.get(shader.GetSourceAssetSubIdentifier(MDL_SOURCE_TYPE))
            if network is not None:
                return self._network(shader, network)
            shader_id = (
                f"{shader.GetSourceAsset(MDL_SOURCE_TYPE)} {shader.GetSourceAssetSubIdentifier(MDL_SOURCE_TYPE)}"
            )
        self.ctx.unsupported["unknown surface shaders (rendered grey)"].append(f"{shader.GetPath()} ({shader_id})")
        return DEFAULT_MATERIAL

    def _input_value(self, shader: UsdShade.Shader, name: str, default):
        """An input's value: authored, through an interface connection, else ``default``.
        An input fed by a UsdUVTexture that the model has no per-point form for (roughness,
        an exponent): the texture's mean (of its fallback without an image), with a warning;
        by another shader: its own value or default, with a warning."""
        inp = shader.GetInput(name)
        if not inp:
            return default
        if inp.HasConnectedSource():
            attrs = inp.GetValueProducingAttributes()
            if attrs and UsdShade.Utils.GetType(attrs[0].GetName()) == UsdShade.AttributeType.Input:
                value = attrs[0].Get(self.ctx.time)
                return default if value is None else value
            where = f"{shader.GetPath()}.inputs:{name}"
            if name in DIFFUSE_COLOUR_INPUTS:
                reader = primvar_reader(shader, name, self.ctx.time)
                if reader is not None:  # cd per gprim or per copy (for_gprim, instancing.py)
                    self._primvar_read = reader
                    return reader[1] if np.shape(default) == (3,) else reader[1][0]
            connected = self.textures.connected(shader, name)
            if connected is not None:
                self.ctx.unsupported["textured inputs without a per-point model (the texture's mean is used)"].append(
                    where
                )
                if connected.texture is None:
                    value = connected.fallback
                else:
                    value = tuple(float(c) for c in connected.texture.image.mean(axis=(0, 1)))
                return value if isinstance(default, tuple) else value[0]
            self.ctx.unsupported["inputs connected to other shaders (authored value or default used)"].append(where)
        attr = inp.GetAttr()
        if attr.HasAuthoredValue():
            value = attr.Get(self.ctx.time)
            return default if value is None else value
        return default

    def _textured(self, material: PhongMaterial, diffuse, specular=None) -> PhongMaterial:
        """``material`` with the diffuse and specular textures of ``diffuse`` and ``specular``
        (``textures.Connected``, where their images were read)."""
        fields = {}
        for field, connected in (("diffuse_texture", diffuse), ("specular_texture", specular)):
            if connected is not None and connected.texture is not None:
                fields[field] = connected.texture
                st = connected.st
        if not fields:
            return material
        textured = dataclasses.replace(material, **fields)
        self.st_of[textured] = st  # one st per material: the specular texture's if both differ
        return textured

    def _phong(self, shader: UsdShade.Shader) -> PhongMaterial:
        prim = shader.GetPrim()
        values = {}
        connected = {n: self.textures.connected(shader, n) for n in ("diffuseColor", "specularColor", "ks")}
        for name, (field, sdf_type) in phong_inputs().items():
            if name in PHONG_MAP_INPUTS:
                continue  # read as a texture below
            default = self.phong_defaults[name]
            if connected.get(name) is not None:
                fallback = connected[name].fallback
                values[field] = fallback if isinstance(default, tuple) else fallback[0]
                continue
            inp = shader.GetInput(name)
            found = self.ctx.authored_type(inp.GetAttr()) if inp else ""
            if inp and Sdf.ValueTypeNames.Find(found).type != sdf_type.type:
                self.ctx.problem(prim, f"inputs:{name}", f"has type {found}, expected {sdf_type}")
                values[field] = default
                continue
            value = self._input_value(shader, name, default)
            values[field] = (
                tuple(float(c) for c in value)
                if isinstance(default, tuple)
                else bool(value)
                if isinstance(default, bool)
                else float(value)
            )
        for inp in shader.GetInputs():
            if inp.GetBaseName() not in PHONG_INPUTS:
                self.ctx.problem(
                    prim,
                    f"inputs:{inp.GetBaseName()}",
                    f"is not an input of {PHONG_SHADER_ID} (expected one of {', '.join(PHONG_INPUTS)})",
                )
        material = PhongMaterial(source=str(prim.GetPath()), **values)
        specular = connected["specularColor"]
        ks = connected["ks"]
        if ks is not None and ks.texture is not None:
            if specular is not None and specular.texture is not None:
                self.ctx.unsupported["textured ks over a textured specularColor (ks's fallback is used)"].append(
                    str(prim.GetPath())
                )
            else:
                # The highlight is ks·cs: a textured ks with a constant cs is the texture
                # cs·ks(x)/max ks under ks = max ks (the same product at every point).
                k = ks.texture.image[..., :1].astype(np.float64)
                if k.min() < 0 or k.max() > 1:
                    self.ctx.warn(f"{ks.texture.source}: ks texels outside [0, 1] (clipped)")
                    k = np.clip(k, 0.0, 1.0)
                top = float(k.max())
                image = np.asarray(material.specular_color) * (k / top if top > 0 else k)
                cs = Texture(
                    image.astype(np.float32),
                    ks.texture.wrap_s,
                    ks.texture.wrap_t,
                    source=ks.texture.source,
                    file=ks.texture.file,
                )
                material = dataclasses.replace(material, ks=top)
                specular = Connected(cs, material.specular_color, ks.st)
        textured = self._textured(material, connected["diffuseColor"], specular)
        mapped = self._with_normal_map(textured, self._normal_map(shader, "normal"))
        return self._with_opacity_mask(mapped, shader, material.opacity_threshold)

    def _preview_emission(self, shader: UsdShade.Shader) -> tuple[float, float, float]:
        """UsdPreviewSurface's emissiveColor: Le, added to the shaded colour (the model's
        emission). A texture on it is not read: its fallback stands, with a warning."""
        prim = shader.GetPrim()
        inp = shader.GetInput("emissiveColor")
        if not inp:
            return (0.0, 0.0, 0.0)
        if inp.HasConnectedSource():
            self.ctx.unsupported[
                "UsdPreviewSurface inputs:emissiveColor connected to a texture (its constant value is used)"
            ].append(str(prim.GetPath()))
        value = self._input_value(shader, "emissiveColor", (0.0, 0.0, 0.0))
        try:
            arr = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError):
            arr = None
        if arr is None or arr.shape != (3,) or not np.all(np.isfinite(arr)) or arr.min() < 0:
            self.ctx.problem(prim, "inputs:emissiveColor", f"must be 3 finite numbers >= 0 (a color3f), got {value!r}")
            return (0.0, 0.0, 0.0)
        return tuple(float(c) for c in arr)

    def _preview_scalar(self, shader: UsdShade.Shader, name: str, default: float) -> float:
        """A UsdPreviewSurface input in [0, 1], read as a constant. A texture on it is not read
        (per-texel opacity needs a hit-skipping any-hit test neither backend has): the input's
        default, with a warning. Not the texture's fallback: Blender connects opacity to an
        image's alpha on opaque materials, and a fallback alpha of 0 would turn them to glass."""
        prim = shader.GetPrim()
        inp = shader.GetInput(name)
        if not inp:
            return default
        if inp.HasConnectedSource():
            self.ctx.unsupported[
                f"UsdPreviewSurface inputs:{name} connected to a texture (not read; {default:g} is used)"
            ].append(str(prim.GetPath()))
            return default
        value = self._input_value(shader, name, default)
        if not isinstance(value, (int, float)) or not np.isfinite(value) or not 0.0 <= value <= 1.0:
            self.ctx.problem(prim, f"inputs:{name}", f"must be a number in [0, 1], got {value!r}")
            return default
        return float(value)

    def _preview_opacity(self, shader: UsdShade.Shader) -> tuple[float, float]:
        """UsdPreviewSurface's (opacity, opacityThreshold), constants in [0, 1]. A textured
        opacity with a threshold > 0 is the masked mode's cut-out (_with_opacity_mask): its
        constant here is 1 (the texture decides)."""
        threshold = self._preview_scalar(shader, "opacityThreshold", 0.0)
        inp = shader.GetInput("opacity")
        if threshold > 0 and inp and inp.HasConnectedSource():
            return 1.0, threshold
        return self._preview_scalar(shader, "opacity", 1.0), threshold

    def _with_opacity_mask(self, material: PhongMaterial, shader: UsdShade.Shader, threshold: float) -> PhongMaterial:
        """``material`` cut out by the texture on ``shader``'s opacity input where it is below
        ``threshold`` (UsdPreviewSurface's masked mode; our shader's opacity and
        opacityThreshold). Without a threshold, or a texture, as it is; an image that could not
        be read leaves its fallback as a constant opacity (below the threshold: nothing of the
        gprims is hit, as a constant cut-out)."""
        inp = shader.GetInput("opacity")
        if not (threshold > 0 and inp and inp.HasConnectedSource()):
            return dataclasses.replace(material, opacity_threshold=0.0) if material.opacity_threshold else material
        connected = self.textures.connected(shader, "opacity")
        plain = dataclasses.replace(material, opacity_threshold=0.0)
        if connected is None or connected.texture is None:
            fallback = 1.0 if connected is None else float(connected.fallback[0])
            if fallback < threshold:
                self.cut_out.add(material.source)
            return plain
        masked = dataclasses.replace(material, opacity_texture=connected.texture, opacity_threshold=float(threshold))
        self.st_of[masked] = self.st_of.get(material, connected.st)
        return masked

    def _preview(self, shader: UsdShade.Shader) -> PhongMaterial:
        prim = shader.GetPrim()
        values = {}
        diffuse_texture = self.textures.connected(shader, "diffuseColor")
        specular_texture = self.textures.connected(shader, "specularColor")
        metallic_texture = self.textures.connected(shader, "metallic")
        for name in PREVIEW_INPUTS:
            default = self.preview_defaults[name]
            if name == "metallic" and metallic_texture is not None:
                value = metallic_texture.fallback[0]
                if metallic_texture.texture is not None:  # the mean, where one value stands for all
                    value = float(np.clip(metallic_texture.texture.image[..., 0], 0.0, 1.0).mean())
            elif name == "diffuseColor" and diffuse_texture is not None:
                value = diffuse_texture.fallback
                if diffuse_texture.texture is not None:
                    # The metallic tint of F0 takes the texture's mean colour (one cs per material).
                    value = tuple(float(c) for c in diffuse_texture.texture.image.mean(axis=(0, 1)))
            elif name == "specularColor" and specular_texture is not None:
                value = specular_texture.fallback
                if specular_texture.texture is not None:
                    # ks from the brightest texel (ks·cs stays the matched strength, ks <= 1).
                    value = tuple(float(c) for c in specular_texture.texture.image.max(axis=(0, 1)))
            else:
                value = self._input_value(shader, name, default)
            shape = np.shape(default)
            try:
                arr = np.asarray(value, dtype=np.float64)
            except (TypeError, ValueError):
                arr = None
            if arr is None or arr.shape != shape:
                kind = f"{shape[0]} numbers (a color3f)" if shape else "a number"
                self.ctx.problem(prim, f"inputs:{name}", f"must be {kind}, got {value!r}")
                value = default
            elif not np.all(np.isfinite(arr)):
                self.ctx.problem(prim, f"inputs:{name}", f"must be finite, got {value}")
                value = default
            elif name == "ior" and not float(arr) > 0:
                self.ctx.problem(prim, "inputs:ior", f"must be > 0, got {float(arr)!r}")
                value = default
            values[name] = value
        # Inputs the classic model has no term for: say so instead of dropping them silently.
        # (A connected input counts: an occlusion map, a normal map.) The neutral values are the
        # UsdPreviewSurface spec's defaults, under which the input changes nothing.
        normal_map = self._normal_map(shader, "normal")
        for name, neutral in PREVIEW_UNMODELLED.items():
            if name == "normal" and normal_map is not None:
                continue
            inp = shader.GetInput(name)
            if inp and (inp.HasConnectedSource() or np.any(np.asarray(inp.Get(self.ctx.time)) != neutral)):
                self.ctx.unsupported[f"UsdPreviewSurface inputs:{name} (not in the Phong model; ignored)"].append(
                    str(prim.GetPath())
                )
        opacity, threshold = self._preview_opacity(shader)
        emission = self._preview_emission(shader)
        level = shader.GetInput(BLENDER_SPECULAR_LEVEL)
        specular_level = 0.5
        if level and level.GetAttr().HasAuthoredValue():
            value = level.Get(self.ctx.time)
            if isinstance(value, (int, float)) and np.isfinite(value):
                specular_level = float(value)
            else:
                self.ctx.problem(prim, f"inputs:{BLENDER_SPECULAR_LEVEL}", f"must be a finite number, got {value!r}")
        if (
            diffuse_texture is not None
            and diffuse_texture.texture is not None
            and not int(values["useSpecularWorkflow"])
        ):
            # The spec's diffuse lobe is diffuseColor·(1 − metallic): the texels are scaled so.
            factor = 1.0 - float(np.clip(values["metallic"], 0.0, 1.0))
            if factor != 1.0:
                diffuse_texture = self.textures.connected(shader, "diffuseColor", factor)
        material = preview_to_phong(
            tuple(values["diffuseColor"]),
            float(values["roughness"]),
            float(values["metallic"]),
            tuple(values["specularColor"]),
            int(values["useSpecularWorkflow"]),
            float(values["ior"]),
            source=str(prim.GetPath()),
            specular_level=specular_level,
        )
        if any(emission):
            material = dataclasses.replace(material, emission=emission)
        if threshold > 0:
            # The spec's masked mode: below the threshold the surface is absent, at or above it
            # fully opaque (no translucency). A constant opacity omits the gprims; a textured one
            # is a cut-out mask (_with_opacity_mask).
            if opacity < threshold:
                self.cut_out.add(material.source)
        elif opacity < 1:
            material = preview_glass(material, opacity, float(values["ior"]), float(values["roughness"]))
        metal = None if metallic_texture is None else metallic_texture.texture
        if metal is not None and not int(values["useSpecularWorkflow"]):
            if diffuse_texture is None or diffuse_texture.texture is None:
                return self._with_opacity_mask(
                    self._with_normal_map(
                        self._metallic_textured(material, metallic_texture, values, specular_level), normal_map
                    ),
                    shader,
                    threshold,
                )
            self.ctx.unsupported["textured metallic over a textured diffuseColor (the mean metallic is used)"].append(
                str(prim.GetPath())
            )
        if specular_texture is not None and specular_texture.texture is not None:
            if int(values["useSpecularWorkflow"]):
                # cs = strength/ks is linear in F0 = the texel: the texels are scaled by cs/F0.
                f0 = np.asarray(values["specularColor"], dtype=np.float64)
                c = int(np.argmax(f0))
                factor = material.specular_color[c] / f0[c] if f0[c] > 0 else 0.0
                specular_texture = self.textures.connected(shader, "specularColor", factor)
            else:
                specular_texture = None  # the metallic workflow does not read specularColor
        mapped = self._with_normal_map(self._textured(material, diffuse_texture, specular_texture), normal_map)
        return self._with_opacity_mask(mapped, shader, threshold)

    def _normal_map(self, shader: UsdShade.Shader, name: str) -> Connected | None:
        """The tangent-space normal map feeding input ``name`` of ``shader`` (a texture whose
        image was read: its texels signed, as the texture node's scale and bias make them), or None."""
        connected = self.textures.normal_map(shader, name)
        return connected if connected is not None and connected.texture is not None else None

    def _with_normal_map(self, material: PhongMaterial, normal_map: Connected | None) -> PhongMaterial:
        """``material`` with the normal map ``normal_map`` (None: as it is)."""
        if normal_map is None:
            return material
        mapped = dataclasses.replace(material, normal_texture=normal_map.texture)
        self.st_of[mapped] = self.st_of.get(material, normal_map.st)
        self.ctx.unsupported[NORMAL_MAP_NOTE].append(material.source)
        return mapped

    def _network(self, shader: UsdShade.Shader, network: Network) -> PhongMaterial:
        """A MaterialX Standard Surface / OpenPBR or an OmniPBR shader, through the
        UsdPreviewSurface mapping's specular workflow (pbr_networks.reduce gives its F0)."""
        prim = shader.GetPrim()
        source = str(prim.GetPath())
        values = {}
        base_name = network.base_color[0]
        omni = network is OMNI_PBR

        def base_read(factor: float = 1.0):  # OmniPBR's texture is an asset input, MaterialX's a node
            if omni:
                return self.textures.omni_texture(shader, OMNI_DIFFUSE_TEXTURE, factor)
            return self.textures.connected(shader, base_name, factor)

        base_texture = base_read()
        for name, default in inputs(network).items():
            if name == base_name and base_texture is not None:
                # The metal's F0 tint takes the texture's mean colour (one cs per material).
                texture = base_texture.texture
                value = base_texture.fallback if texture is None else tuple(texture.image.mean(axis=(0, 1)).tolist())
            else:
                value = self._input_value(shader, name, default)
            try:
                arr = np.asarray(value, dtype=np.float64)
            except (TypeError, ValueError):
                arr = None
            shape = np.shape(default)
            if arr is None or arr.shape != shape or not np.all(np.isfinite(arr)):
                kind = "3 finite numbers (a color3f)" if shape else "a finite number"
                self.ctx.problem(prim, f"inputs:{name}", f"must be {kind}, got {value!r}")
                value = default
            values[name] = value
        if network.ior is not None and not float(values[network.ior[0]]) > 0:
            self.ctx.problem(prim, f"inputs:{network.ior[0]}", f"must be > 0, got {values[network.ior[0]]!r}")
            values[network.ior[0]] = network.ior[1]
        for name, neutral in network.unmodelled.items():
            inp = shader.GetInput(name)
            if inp and (inp.HasConnectedSource() or np.any(np.asarray(inp.Get(self.ctx.time)) != neutral)):
                # One line per network kind, naming each material's inputs (a shader with seven
                # unmodelled lobes made seven lines).
                self.ctx.unsupported[f"{network.label} lobes not in the Phong model (ignored)"].append(
                    f"{source}.inputs:{name}"
                )
        normal_map = self._omni_normal_map(shader) if omni else self._normal_map(shader, "normal")
        for name in OMNI_UNREAD_TEXTURES if omni else ():
            inp = shader.GetInput(name)
            if inp and inp.GetAttr().HasAuthoredValue():
                self.ctx.unsupported[f"{network.label} inputs:{name} (no per-point form; the constant is used)"].append(
                    source
                )
        for name in NORMAL_MAP_INPUTS:
            # No neutral constant: any authored value or connection (a normalmap node, an
            # OmniPBR normal texture) perturbs the normal; what is not read as a map is named.
            inp = shader.GetInput(name)
            if name in ("normal", OMNI_NORMAL_TEXTURE) and normal_map is not None:
                continue
            if inp and (inp.HasConnectedSource() or inp.GetAttr().HasAuthoredValue()):
                self.ctx.unsupported[f"{network.label} inputs:{name} (not read as a normal map; ignored)"].append(
                    source
                )
        diffuse, roughness, f0 = reduce(network, values)
        material = preview_to_phong(
            tuple(diffuse), roughness, specular_color=tuple(f0), use_specular_workflow=1, source=source
        )
        transmission = 0.0 if network.transmission is None else float(values[network.transmission[0]])
        if transmission > 0:
            # Transmission weight t: the opaque surface × (1 − t) plus refraction × t, the
            # UsdPreviewSurface's opacity 1 − t (the same dielectric, Suffern ch. 28).
            ior = float(values[network.ior[0]]) if network.ior is not None else 1.5
            material = preview_glass(material, 1.0 - min(transmission, 1.0), ior, roughness)
            tint = values[network.transmission_color[0]]
            if tuple(float(c) for c in tint) != (1.0, 1.0, 1.0):
                self.ctx.unsupported[f"{network.label} tinted transmission (clear glass is used)"].append(source)
        if base_texture is not None and base_texture.texture is not None:
            # The diffuse lobe is base·base_color·(1 − metalness): the texels are scaled so.
            weight = 1.0 if network.base_weight is None else max(float(values[network.base_weight[0]]), 0.0)
            metal = float(np.clip(float(values[network.metalness[0]]), 0.0, 1.0))
            if network.base_tint is not None and tuple(values[network.base_tint[0]]) != (1.0, 1.0, 1.0):
                self.ctx.unsupported[f"{network.label} tinted textures (the tint is not applied)"].append(source)
            base_texture = base_read(weight * (1.0 - metal))
            material = self._textured(material, base_texture)
        return self._with_normal_map(material, normal_map)

    def _omni_normal_map(self, shader: UsdShade.Shader) -> Connected | None:
        """OmniPBR's ``normalmap_texture`` (MDL's tangent_space_normal_texture): v = 2·texel − 1,
        its x and y times ``bump_factor`` and negated by ``flip_tangent_u`` / ``flip_tangent_v``."""
        factor = float(np.nan_to_num(float(self._input_value(shader, "bump_factor", 1.0))))
        sx = -factor if bool(self._input_value(shader, "flip_tangent_u", False)) else factor
        sy = -factor if bool(self._input_value(shader, "flip_tangent_v", False)) else factor
        connected = self.textures.omni_texture(
            shader, OMNI_NORMAL_TEXTURE, signed=True, scale_bias=((2 * sx, 2 * sy, 2.0), (-sx, -sy, -1.0))
        )
        return connected if connected is not None and connected.texture is not None else None

    def _metallic_textured(
        self, material: PhongMaterial, connected, values: dict, specular_level: float
    ) -> PhongMaterial:
        """A UsdPreviewSurface with a textured metallic m (and a constant diffuseColor): the
        mapping's diffuse colour cd·(1 − m) and highlight strength ks·cs (F0 = (1 − m)·F0_ior +
        m·cd, times a factor of the roughness) are both linear in m, so they are two textures,
        each the blend of the mapping at m = 0 and m = 1 (preview_to_phong) by the texel's m."""
        metal = connected.texture
        ends = [
            preview_to_phong(
                tuple(values["diffuseColor"]),
                float(values["roughness"]),
                m,
                ior=float(values["ior"]),
                source=material.source,
                specular_level=specular_level,
            )
            for m in (0.0, 1.0)
        ]
        m = np.clip(metal.image[..., :1].astype(np.float64), 0.0, 1.0)
        diffuse = [np.asarray(p.diffuse_color) for p in ends]
        strength = [np.asarray(p.specular_color) * p.ks for p in ends]
        diffuse_image = diffuse[0] + m * (diffuse[1] - diffuse[0])
        strength_image = strength[0] + m * (strength[1] - strength[0])
        ks = float(min(1.0, strength_image.max()))
        cs_image = strength_image / ks if ks > 0 else np.ones_like(strength_image)
        fallback_cs = np.asarray(material.specular_color) * material.ks / ks if ks > 0 else np.ones(3)

        def texture(image):
            return Texture(image.astype(np.float32), metal.wrap_s, metal.wrap_t, source=metal.source, file=metal.file)

        textured = dataclasses.replace(
            material,
            ks=ks,
            specular_color=tuple(float(c) for c in fallback_cs),
            diffuse_texture=texture(diffuse_image),
            specular_texture=texture(cs_image),
        )
        self.st_of[textured] = connected.st
        return textured

    def _display_color(self, prim: Usd.Prim) -> PhongMaterial:
        opacity = UsdGeom.PrimvarsAPI(prim).GetPrimvar("displayOpacity")
        if opacity and opacity.HasAuthoredValue():
            values = opacity.ComputeFlattened(self.ctx.time)
            if values is not None and np.any(np.asarray(values, dtype=np.float64) < 1.0):
                self.ctx.unsupported["primvars:displayOpacity below 1 (not modelled; drawn opaque)"].append(
                    str(prim.GetPath())
                )
        primvar = UsdGeom.PrimvarsAPI(prim).GetPrimvar("displayColor")
        if not primvar or not primvar.HasAuthoredValue():
            return DEFAULT_MATERIAL
        found = self.ctx.authored_type(primvar.GetAttr())
        if found not in tuple(t + "[]" for t in COLOR_TYPES):
            self.ctx.problem(prim, "primvars:displayColor", f"has type {found}, expected color3f[]")
            return DEFAULT_MATERIAL
        colors = np.asarray(primvar.ComputeFlattened(self.ctx.time), dtype=np.float64).reshape(-1, 3)
        if len(colors) == 0:
            return DEFAULT_MATERIAL
        if len(colors) > 1 and primvar.GetInterpolation() != UsdGeom.Tokens.constant:
            self.ctx.unsupported["non-constant displayColor (the mean colour is used)"].append(str(prim.GetPath()))
        colour = tuple(float(c) for c in colors.mean(axis=0))
        if not all(np.isfinite(colour)) or min(colour) < 0:
            self.ctx.problem(prim, "primvars:displayColor", f"must be finite and >= 0, got {colour}")
            return DEFAULT_MATERIAL
        return PhongMaterial(diffuse_color=colour, source=str(prim.GetPath()))
