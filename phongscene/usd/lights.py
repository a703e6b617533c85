# SPDX-License-Identifier: Apache-2.0
"""UsdLux lights → model lights, one function per UsdLux light type (``_READERS`` dispatches on
the prim's schema), in UsdLux's units unless a light asks for the seed's.

Every light's emitted luminance is L = intensity · 2^exposure · color (× the blackbody colour
when ``enableColorTemperature``). In UsdLux's units (the default) L is divided by the emitting
area when ``inputs:normalize``, and each type's area factor is applied: a SphereLight of world
radius r radiates I = L·πr² (L/4 normalized), a RectLight of world area A the intensity I = L·A
along its normal (L normalized), a DistantLight the irradiance E = L·π·sin²(angle/2) (L
normalized or at angle 0); an untextured DomeLight gives the ambient radiance L. A light with
``phong:lightModel = "seed"`` gives the seed's constant light: strength ls·cl = L, no normalize,
no area factor, no falloff. Area lights shade from their centre (POV-Ray's area-light
semantics: only the shadows are sampled).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from pxr import Usd, UsdLux

from ..limits import MAX_RADIANCE, MAX_TEXEL
from ..scene import (
    AmbientLight,
    Cone,
    DirectionalLight,
    Environment,
    PointLight,
    RectAreaLight,
    SphereAreaLight,
    Texture,
)
from ..tolerances import SINGULAR_RELATIVE_DET
from . import names
from .context import ReadContext, unit
from .layers import not_regular
from .names import INT_TYPES, STRING_TYPES

# inputs:colorTemperature, Kelvin: UsdLux.BlackbodyTemperatureAsRgb tabulates 1000..10000 K and
# returns the end colours beyond (500 K and 1e38 K give 1000 K's and 10000 K's colour), so a
# temperature outside cannot be honoured by any renderer that follows UsdLux.
MIN_KELVIN = 1000.0
MAX_KELVIN = 10000.0
DEFAULT_SHADOW_SAMPLES = 9  # phong:shadowSamples on area lights: a 9×9 grid (2^3 + 1)


def _luminance(ctx: ReadContext, prim: Usd.Prim) -> np.ndarray:
    """UsdLux's emitted luminance L = intensity · 2^exposure · color (× the blackbody colour when
    enableColorTemperature), before normalize."""
    api = UsdLux.LightAPI(prim)
    intensity = ctx.number(prim, "inputs:intensity", 1.0, minimum=0.0)
    exposure = ctx.number(prim, "inputs:exposure", 0.0)
    color = np.asarray(ctx.color(prim, "inputs:color", (1.0, 1.0, 1.0)), dtype=np.float64)
    if np.any(color < 0):  # here, not only in validate: a factor of 0 (radius 0) would hide it
        ctx.problem(prim, "inputs:color", f"must be >= 0 in every channel, got {tuple(float(c) for c in color)}")
        color = np.zeros(3)  # reported once
    if api.GetEnableColorTemperatureAttr().Get(ctx.time):
        kelvin = ctx.number(prim, "inputs:colorTemperature", 6500.0, minimum=0.0, strict=True)
        if not MIN_KELVIN <= kelvin <= MAX_KELVIN:
            ctx.problem(
                prim,
                "inputs:colorTemperature",
                f"must be in [{MIN_KELVIN:g}, {MAX_KELVIN:g}] K (the range "
                f"UsdLux's blackbody table covers; it clamps beyond), got {kelvin!r}",
            )
            kelvin = 6500.0
        color = color * np.asarray(UsdLux.BlackbodyTemperatureAsRgb(kelvin), dtype=np.float64)
    with np.errstate(over="ignore"):
        scale = np.float64(intensity) * np.exp2(np.float64(exposure))
    if not np.isfinite(scale):
        ctx.problem(prim, "inputs:exposure", f"intensity · 2^exposure overflows ({intensity!r} · 2^{exposure!r})")
        scale = 1.0
    return color * scale if scale != 1.0 else color


def _terms(ctx: ReadContext, prim: Usd.Prim) -> dict[str, float]:
    """UsdLux's multipliers of a light's diffuse and specular contributions (model fields
    ``diffuse`` and ``specular``)."""
    return {
        "diffuse": ctx.number(prim, "inputs:diffuse", 1.0, minimum=0.0),
        "specular": ctx.number(prim, "inputs:specular", 1.0, minimum=0.0),
    }


def _seed_light(ctx: ReadContext, prim: Usd.Prim) -> bool:
    """Whether the light asks for the seed's constant light (``phong:lightModel = "seed"``):
    strength ls·cl = intensity · 2^exposure · color arriving unchanged, no normalize, no falloff.
    Otherwise (the default) UsdLux's units and falloff apply."""
    model = ctx.get(prim, names.LIGHT_MODEL, STRING_TYPES, names.LIGHT_MODEL_USDLUX)
    if model not in names.LIGHT_MODELS:
        ctx.problem(prim, names.LIGHT_MODEL, f"must be one of {', '.join(names.LIGHT_MODELS)}, got {model!r}")
        return False
    seed = model == names.LIGHT_MODEL_SEED
    if seed and _normalized(ctx, prim):
        ctx.unsupported["seed lights with inputs:normalize = 1 (normalize is not applied to the seed's light)"].append(
            str(prim.GetPath())
        )
    return seed


def _normalized(ctx: ReadContext, prim: Usd.Prim) -> bool:
    return bool(UsdLux.LightAPI(prim).GetNormalizeAttr().Get(ctx.time))


def _rgb(v) -> tuple[float, float, float]:
    return tuple(float(c) for c in v)


def _blender_sun_factor(ctx: ReadContext) -> float:
    """Blender's USD exporter (5.0) writes a sun of strength S W/m² as a DistantLight of intensity
    S/4 (normalize 1, angle 0), which UsdLux reads as an irradiance of S/4 where Cycles renders S
    (measured: a white Lambert plane under a sun of strength 3). A layer Blender wrote says so in
    its ``doc``; its suns are read as Cycles renders them, with a warning."""
    doc = ctx.stage.GetRootLayer().documentation or ""
    return 4.0 if doc.startswith("Blender") else 1.0


# A cone of this half-angle or wider restricts nothing.
FULL_CONE_DEG = 180.0
# POV-Ray's spotlight lights only cos θ > 0: a cone must be narrower than a hemisphere.
HEMISPHERE_DEG = 90.0


def _shaping(ctx: ReadContext, prim: Usd.Prim) -> tuple[float, float, float] | None:
    """(cone angle in degrees, softness in [0, 1], focus >= 0) of a ShapingAPI light whose cone
    restricts its emission; None when it restricts nothing (no ShapingAPI, or a hard 180° cone).
    A non-black focusTint is warned about (not modelled: the off-axis light fades to black)."""
    if not prim.HasAPI(UsdLux.ShapingAPI):
        return None
    focus = ctx.number(prim, "inputs:shaping:focus", 0.0, minimum=0.0)
    tint = ctx.color(prim, "inputs:shaping:focusTint", (0.0, 0.0, 0.0))
    if focus > 0 and any(c != 0.0 for c in tint):
        ctx.unsupported["lights with a shaping:focusTint (off-axis light fades to black)"].append(str(prim.GetPath()))
    angle = ctx.number(prim, "inputs:shaping:cone:angle", 90.0, minimum=0.0)
    softness = float(np.clip(ctx.number(prim, "inputs:shaping:cone:softness", 0.0), 0.0, 1.0))
    if angle >= FULL_CONE_DEG and softness == 0.0:
        if focus > 0:
            ctx.unsupported["lights with shaping:focus but no cone (focus ignored)"].append(str(prim.GetPath()))
        return None
    return angle, softness, focus


def _cone(ctx: ReadContext, prim: Usd.Prim, world: np.ndarray) -> Cone | None:
    """A point light's ShapingAPI cone: zero beyond shaping:cone:angle θc off its −Z axis, full
    inside θc·(1 − softness) (UsdLux's smooth start), smoothstep in cos θ between (UsdLux
    interpolates the angle; POV-Ray's spotlight the cosine, which both backends then share),
    times cos θ^focus (UsdLux's "off-axis cosine power", POV-Ray's tightness)."""
    shape = _shaping(ctx, prim)
    if shape is None:
        return None
    angle, softness, focus = shape
    path = str(prim.GetPath())
    if angle >= HEMISPHERE_DEG:
        ctx.unsupported["spot cones of 90° or more (ignored: the light shines everywhere)"].append(path)
        return None
    axis = unit(world[:3, :3] @ np.array([0.0, 0.0, -1.0]))
    if axis is None:
        ctx.problem(prim, "xformOpOrder", "the light's transform is degenerate (no −Z direction for its cone)")
        return None
    outer = math.radians(angle)
    return Cone(_rgb(axis), math.cos(outer), math.cos(outer * (1.0 - softness)), focus)


def _shadow_samples(ctx: ReadContext, prim: Usd.Prim) -> int:
    return int(ctx.get(prim, names.SHADOW_SAMPLES, INT_TYPES, DEFAULT_SHADOW_SAMPLES))


def _shadow_adaptive(ctx: ReadContext, prim: Usd.Prim) -> int | None:
    level = ctx.get(prim, names.SHADOW_ADAPTIVE, INT_TYPES)
    return None if level is None else int(level)


def _shadow_cell_samples(ctx: ReadContext, prim: Usd.Prim) -> int | None:
    k = ctx.get(prim, names.SHADOW_CELL_SAMPLES, INT_TYPES)
    return None if k is None else int(k)


@dataclass(frozen=True)
class _Common:
    """What every UsdLux light has, read (in this order) before its type's own inputs."""

    path: str
    world: np.ndarray
    centre: tuple[float, float, float]
    seed: bool
    luminance: np.ndarray
    terms: dict[str, float]
    falloff: str


def read_light(ctx: ReadContext, prim: Usd.Prim, lights: list, ambient: list, environments: list | None = None) -> None:
    """One UsdLux light into the model, in UsdLux's units (see README: lights) unless it asks for
    the seed's light. The emitted luminance L (normalized by the emitting area when
    ``inputs:normalize``) becomes: for a SphereLight of world radius r the radiant intensity
    I = L·πr² (= L/4 when normalized; treatAsPoint or r = 0: a point light with that I), for a
    RectLight of world area A the intensity along its normal I = L·A (= L when normalized), for
    a DistantLight the irradiance E = L·π·sin²(angle/2) (= L when normalized or angle = 0), for
    an untextured DomeLight the ambient radiance La = L; a textured one its mean radiance, and in
    ``environments`` the dome as an environment (``_environment``)."""
    path = str(prim.GetPath())
    world = ctx.world(prim)
    centre = tuple(float(c) for c in world[:3, 3])
    type_name = prim.GetTypeName()
    read = _READERS_BY_NAME.get(type_name) or next((r for schema, r in _READERS if prim.IsA(schema)), None)
    if read is None:
        ctx.unsupported["unsupported lights (ignored)"].append(f"{path} ({type_name})")
        return
    seed = _seed_light(ctx, prim)
    luminance = _luminance(ctx, prim)
    terms = _terms(ctx, prim)
    common = _Common(path, world, centre, seed, luminance, terms, "none" if seed else "inverse-square")
    first_light, first_ambient = len(lights), len(ambient)
    if read is _dome_light:
        read = functools.partial(_dome_light, environments=environments)
    read(ctx, prim, common, lights, ambient)
    for made in (*lights[first_light:], *ambient[first_ambient:]):
        if max(made.color) > MAX_RADIANCE:
            exposure = prim.GetAttribute("inputs:exposure")
            attribute = "inputs:exposure" if exposure and exposure.HasAuthoredValue() else "inputs:intensity"
            ctx.problem(
                prim,
                attribute,
                (
                    f"the light's radiance intensity · 2^exposure · color (× its area) is {max(made.color):.4g}, beyond the "
                    f"{MAX_RADIANCE:.4g} the renderers' float32 radiance can shade without overflowing to inf"
                ),
            )
            del lights[first_light:], ambient[first_ambient:]
            break


def _dome_light(
    ctx: ReadContext, prim: Usd.Prim, light: _Common, lights: list, ambient: list, environments: list | None = None
) -> None:
    luminance = light.luminance
    texture = prim.GetAttribute("inputs:texture:file")
    asset = texture.Get(ctx.time) if texture else None
    if asset and asset.path:
        read = _texture_mean(ctx, prim, asset)
        if read is None:
            return
        mean, image = read
        if image is not None and environments is not None:
            environment = _environment(ctx, prim, light, image, asset)
            if environment is not None:
                environments.append(environment)
        luminance = luminance * mean
    # The ambient term is diffuse light: the dome's diffuse multiplier scales it.
    ambient.append(AmbientLight(_rgb(luminance * light.terms["diffuse"]), light.path))
    ctx.nodes.append((light.path, "AmbientLight"))


def _environment(ctx: ReadContext, prim: Usd.Prim, light: _Common, image: np.ndarray, asset) -> Environment | None:
    """The textured dome as the environment rays that miss may see (the reader decides whether
    they do: reader.py), or None with a warning when it cannot be one and only its mean is used.
    Its frame is the rotation of the dome's transform (the polar factor: a dome at infinity has
    no size or shear); UsdLux puts the texture's top pole on the frame's +Y, which DomeLight_1
    moves with poleAxis (only +Y is modelled)."""
    path = light.path
    pole = prim.GetAttribute("poleAxis")
    axis = pole.Get(ctx.time) if pole and pole.HasAuthoredValue() else "scene"
    if prim.GetTypeName() == "DomeLight_1" and not (axis == "Y" or (axis == "scene" and not ctx.z_up)):
        ctx.unsupported["DomeLight_1 with its pole on Z (its mean is the background)"].append(path)
        return None
    high = float(image.max())
    if not (np.isfinite(high) and float(image.min()) >= 0.0 and high <= MAX_TEXEL):
        ctx.unsupported[f"dome textures with texels outside [0, {MAX_TEXEL:g}] (their mean is the background)"].append(
            path
        )
        return None
    if high * float(np.max(light.luminance)) > MAX_RADIANCE:
        ctx.unsupported["dome textures brighter than the renderers' radiance (their mean is the background)"].append(
            path
        )
        return None
    linear = light.world[:3, :3]
    u, sigma, vt = np.linalg.svd(linear)
    if sigma[-1] <= SINGULAR_RELATIVE_DET * sigma[0] or not np.all(np.isfinite(sigma)):
        ctx.unsupported["domes with a degenerate transform (their mean is the background)"].append(path)
        return None
    world_from_dome = u @ vt
    file = asset.resolvedPath or asset.path
    return Environment(Texture(image, source=path, file=file), _rgb(light.luminance), world_from_dome.T, path)


def _sphere_light(ctx: ReadContext, prim: Usd.Prim, light: _Common, lights: list, ambient: list) -> None:
    path, world, luminance, seed, terms = light.path, light.world, light.luminance, light.seed, light.terms
    radius = ctx.number(prim, "inputs:radius", 0.5, minimum=0.0)
    point = bool(ctx.get(prim, "treatAsPoint", ("bool",), False)) or radius == 0
    # The world radius: the light's transform scales its radius (mean axis scale).
    radius_world = radius * float(np.mean(np.linalg.norm(world[:3, :3], axis=0)))
    if seed:
        colour = luminance
    elif _normalized(ctx, prim):
        colour = luminance / 4.0  # L/(4πr²) · πr², also in the limit r → 0
    else:
        colour = luminance * (math.pi * radius_world**2)
        if radius_world == 0 and np.any(luminance > 0):
            ctx.unsupported["point lights of radius 0 without inputs:normalize (they emit nothing in UsdLux)"].append(
                path
            )
    if point:
        if prim.GetAttribute(names.SHADOW_SAMPLES).HasAuthoredValue():
            ctx.problem(prim, names.SHADOW_SAMPLES, "applies to area lights only (this SphereLight is a point light)")
        fade_distance = ctx.number(prim, names.FADE_DISTANCE, 0.0)
        fade_power = ctx.number(prim, names.FADE_POWER, 0.0)
        cone = _cone(ctx, prim, world)
        lights.append(
            PointLight(light.centre, _rgb(colour), fade_distance, fade_power, path, light.falloff, cone, **terms)
        )
        ctx.nodes.append((path, "PointLight" + ("" if seed else " (UsdLux)")))
    else:
        if _shaping(ctx, prim) is not None:
            ctx.unsupported["spherical or rect lights with a UsdLuxShapingAPI cone (ignored)"].append(path)
        for name in (names.FADE_DISTANCE, names.FADE_POWER):
            if prim.GetAttribute(name).HasAuthoredValue():
                ctx.problem(prim, name, "applies to point lights only (treatAsPoint or radius 0)")
        lights.append(
            SphereAreaLight(
                light.centre,
                radius_world,
                _rgb(colour),
                _shadow_samples(ctx, prim),
                path,
                light.falloff,
                adaptive=_shadow_adaptive(ctx, prim),
                cell_samples=_shadow_cell_samples(ctx, prim),
                **terms,
            )
        )
        ctx.nodes.append((path, "SphereAreaLight" + ("" if seed else " (UsdLux)")))


def _cylinder_light(ctx: ReadContext, prim: Usd.Prim, light: _Common, lights: list, ambient: list) -> None:
    # A tube of radius r and length l along its X axis, emitting luminance L from its side:
    # intensity L·2rl·sin θ off the axis, power π²·L·r·l. Lit as a point light of the same
    # power at its centre (I = L·π·r·l/2; normalized, L/(2πrl): I = L/4, as a sphere light).
    luminance = light.luminance
    radius = ctx.number(prim, "inputs:radius", 0.5, minimum=0.0)
    length = ctx.number(prim, "inputs:length", 1.0, minimum=0.0)
    scales = np.linalg.norm(light.world[:3, :3], axis=0)
    if light.seed:
        colour = luminance
    elif _normalized(ctx, prim):
        colour = luminance / 4.0
    else:
        colour = luminance * (math.pi / 2 * radius * float(np.mean(scales[1:])) * length * float(scales[0]))
    ctx.unsupported["CylinderLights (each lit as a point light of the same power at its centre)"].append(light.path)
    lights.append(PointLight(light.centre, _rgb(colour), 0.0, 0.0, light.path, light.falloff, None, **light.terms))
    ctx.nodes.append((light.path, "PointLight (UsdLux CylinderLight)"))


def _distant_light(ctx: ReadContext, prim: Usd.Prim, light: _Common, lights: list, ambient: list) -> None:
    luminance = light.luminance
    direction = unit(light.world[:3, :3] @ np.array([0.0, 0.0, -1.0]))
    if direction is None:
        ctx.problem(prim, "xformOpOrder", "the light's transform is degenerate (no −Z direction)")
        return
    irradiance = luminance
    if not light.seed:
        angle = ctx.number(prim, "inputs:angle", 0.53, minimum=0.0)
        if not _normalized(ctx, prim) and angle > 0:
            irradiance = luminance * (math.pi * math.sin(math.radians(min(angle, 180.0)) / 2) ** 2)
        factor = _blender_sun_factor(ctx)
        if factor != 1.0:
            irradiance = irradiance * factor
            ctx.unsupported[
                "Blender suns (its exporter writes strength S as intensity S/4: read as S, as Cycles renders them)"
            ].append(light.path)
    lights.append(DirectionalLight(tuple(float(c) for c in direction), _rgb(irradiance), light.path, **light.terms))
    ctx.nodes.append((light.path, "DirectionalLight"))


def _rect_light(ctx: ReadContext, prim: Usd.Prim, light: _Common, lights: list, ambient: list) -> None:
    if _shaping(ctx, prim) is not None:
        ctx.unsupported["spherical or rect lights with a UsdLuxShapingAPI cone (ignored)"].append(light.path)
    width = ctx.number(prim, "inputs:width", 1.0, minimum=0.0, strict=True)
    height = ctx.number(prim, "inputs:height", 1.0, minimum=0.0, strict=True)
    _rect_area_light(ctx, prim, light, width, height, lights)


def _disk_light(ctx: ReadContext, prim: Usd.Prim, light: _Common, lights: list, ambient: list) -> None:
    """A DiskLight as the square of its area: the same area, emission and falloff; only its
    shadows' outline (and grid) differ."""
    if _shaping(ctx, prim) is not None:
        ctx.unsupported["spherical or rect lights with a UsdLuxShapingAPI cone (ignored)"].append(light.path)
    radius = ctx.number(prim, "inputs:radius", 0.5, minimum=0.0, strict=True)
    width = height = radius * math.sqrt(math.pi)
    ctx.unsupported["DiskLights (each lit as the square of its area, facing the same way)"].append(light.path)
    _rect_area_light(ctx, prim, light, width, height, lights)


def _rect_area_light(
    ctx: ReadContext, prim: Usd.Prim, light: _Common, width: float, height: float, lights: list
) -> None:
    """A rectangle of ``width`` × ``height`` in the light's XY plane, facing its −Z axis."""
    axis_u = light.world[:3, :3] @ np.array([width, 0.0, 0.0])
    axis_v = light.world[:3, :3] @ np.array([0.0, height, 0.0])
    if light.seed or _normalized(ctx, prim):
        colour = light.luminance
    else:
        colour = light.luminance * float(np.linalg.norm(np.cross(axis_u, axis_v)))
    lights.append(
        RectAreaLight(
            light.centre,
            _rgb(axis_u),
            _rgb(axis_v),
            _rgb(colour),
            _shadow_samples(ctx, prim),
            light.path,
            light.falloff,
            adaptive=_shadow_adaptive(ctx, prim),
            cell_samples=_shadow_cell_samples(ctx, prim),
            **light.terms,
        )
    )
    ctx.nodes.append((light.path, "RectAreaLight" + ("" if light.seed else " (UsdLux)")))


# The UsdLux light types read, by schema (``IsA``: a schema derived from one reads as it); the
# types no entry takes are unsupported (ignored, with a warning).
_READERS = (
    (UsdLux.DomeLight, _dome_light),
    (UsdLux.SphereLight, _sphere_light),
    (UsdLux.CylinderLight, _cylinder_light),
    (UsdLux.DistantLight, _distant_light),
    (UsdLux.RectLight, _rect_light),
    (UsdLux.DiskLight, _disk_light),
)
# UsdLux's versioned DomeLight_1 is not IsA DomeLight: known by its type name.
_READERS_BY_NAME = {"DomeLight_1": _dome_light}


def _texture_mean(ctx: ReadContext, prim: Usd.Prim, asset) -> tuple[np.ndarray, np.ndarray | None] | None:
    """The mean radiance of a DomeLight's texture (OpenImageIO), over texels weighted by the
    solid angle they cover in a lat-long map (cos of the latitude), with a warning, and the
    image (read-only float32); 1 (an untextured dome) and no image, with a warning, when it
    cannot be read; None (and a problem) when it is not a regular file."""
    from ..errors import PhongSceneError
    from ..images import read_image  # OpenImageIO: only for a scene with a textured dome
    from ..memory_model import announce, texture_model_bytes
    from .texture_files import TextureRefused, TextureTooBig, read_header

    path = asset.resolvedPath or asset.path
    why = not_regular(path)
    if why is not None:  # could block: refused, as layers are
        ctx.problem(prim, "inputs:texture:file", f"{path} {why}")
        return None
    # A texture that cannot be read is a warning, and the dome lights as an untextured one (its
    # intensity and colour), as a missing UsdUVTexture image falls back: the rest is drawn.
    try:
        # Its header first, as for a UsdUVTexture: a decompression bomb is refused undecoded.
        header = read_header(path, path)
        announce(texture_model_bytes(header.texels), path)
        image = read_image(path)
    except TextureTooBig as e:
        ctx.problem(prim, "inputs:texture:file", str(e))
        return None
    except (PhongSceneError, TextureRefused) as e:
        ctx.warn(f"{prim.GetPath()}.inputs:texture:file: cannot read the texture: {e} (the dome lights untextured)")
        return np.ones(3), None
    image.setflags(write=False)  # owned and frozen: the model keeps it without a copy
    rows = image.shape[0]
    latitude = (np.arange(rows) + 0.5) / rows * math.pi - math.pi / 2
    weights = np.cos(latitude)[:, None] * np.ones(image.shape[1])
    mean = (image[..., :3] * weights[..., None]).sum(axis=(0, 1)) / weights.sum()
    ctx.unsupported["textured DomeLights (their mean radiance is the ambient light)"].append(
        f"{prim.GetPath()} (mean {', '.join(f'{c:.4g}' for c in mean)})"
    )
    return mean, image
