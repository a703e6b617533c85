# SPDX-License-Identifier: Apache-2.0
"""The stage's camera and render settings: ``UsdRender.Settings`` (resolution, the ``phong:``
sampling and background settings, the camera it targets) and a ``UsdGeom.Camera`` (perspective
or orthographic), with the image aspect conformed to the camera's apertures."""

from __future__ import annotations

import math
from dataclasses import replace

from pxr import Usd, UsdGeom, UsdRender

from ..limits import MAX_IMAGE_SIDE, MAX_PIXELS
from ..scene import Camera, RenderSettings
from ..tolerances import CAMERA_ORTHOGONAL_TOLERANCE
from . import names
from .context import ReadContext, unit
from .names import FLOAT_TYPES, INT_TYPES, STRING_TYPES


def read_render_settings(ctx: ReadContext) -> tuple[RenderSettings, Usd.Prim | None]:
    prim = UsdRender.Settings.GetStageRenderSettings(ctx.stage).GetPrim()
    if not prim:
        prim = next((p for p in ctx.stage.Traverse() if p.IsA(UsdRender.Settings)), None)
    if not prim:
        return RenderSettings(), None
    defaults = RenderSettings()
    values: dict = {"source": str(prim.GetPath())}
    attr = prim.GetAttribute("resolution")
    if attr and attr.HasAuthoredValue():
        res = ctx.get(prim, "resolution", ("int2",))
        if res is not None:
            width, height = int(res[0]), int(res[1])
            # Checked here, before anything divides by them (the aperture conform does).
            if not (1 <= width <= MAX_IMAGE_SIDE and 1 <= height <= MAX_IMAGE_SIDE):
                ctx.problem(prim, "resolution", f"must be two integers in 1..{MAX_IMAGE_SIDE}, got ({width}, {height})")
            elif width * height > MAX_PIXELS:
                ctx.problem(
                    prim, "resolution", f"width × height must be at most {MAX_PIXELS} pixels, got {width} × {height}"
                )
            else:
                values["width"], values["height"] = width, height
    samples = ctx.get(prim, names.SAMPLES, INT_TYPES)
    if samples is not None:
        values["samples"] = int(samples)
    pattern = ctx.get(prim, names.SAMPLE_PATTERN, STRING_TYPES)
    if pattern is not None:
        values["sample_pattern"] = str(pattern)
    threshold = ctx.get(prim, names.AA_THRESHOLD, FLOAT_TYPES)
    if threshold is not None:
        values["aa_threshold"] = float(threshold)
    convention = ctx.get(prim, names.SPECULAR_CONVENTION, STRING_TYPES)
    if convention is not None:
        values["specular"] = str(convention)
    if prim.GetAttribute(names.BACKGROUND):
        values["background"] = ctx.color(prim, names.BACKGROUND, defaults.background)
    depth = ctx.get(prim, names.MAX_DEPTH, INT_TYPES)
    if depth is not None:
        values["max_depth"] = int(depth)
    transmission = ctx.get(prim, names.TRANSMISSION_CONVENTION, STRING_TYPES)
    if transmission is not None:
        values["transmission"] = str(transmission)
    camera = None
    targets = UsdRender.Settings(prim).GetCameraRel().GetForwardedTargets()
    if targets:
        camera = ctx.stage.GetPrimAtPath(targets[0])
        if not camera or not camera.IsA(UsdGeom.Camera):
            ctx.problem(prim, "camera", f"must target a Camera prim, got {targets[0]}")
            camera = None
    ctx.nodes.append((str(prim.GetPath()), "RenderSettings"))
    return RenderSettings(**values), camera


# Image and aperture aspects closer than this (relative) agree: apertures are float32 tenths of
# a unit, and integer pixel sizes round an aspect by up to half a pixel in a few hundred.
ASPECT_TOLERANCE = 5e-3


def conform_to_aperture(ctx: ReadContext, prim: Usd.Prim, settings: RenderSettings) -> RenderSettings:
    """The image aspect a camera's apertures ask for. Without a resolution (no RenderSettings
    resolution) the image takes the aspect horizontalAperture / verticalAperture at the default
    width; with one that disagrees, USD's default conform policy applies (fit horizontal: the
    horizontal field of view is kept, the vertical one follows the image), with a warning."""
    h_attr, v_attr = prim.GetAttribute("horizontalAperture"), prim.GetAttribute("verticalAperture")
    if not (h_attr and v_attr and (h_attr.HasAuthoredValue() or v_attr.HasAuthoredValue())):
        return settings
    horizontal = ctx.number(prim, "horizontalAperture", 20.955, minimum=0.0, strict=True)
    vertical = ctx.number(prim, "verticalAperture", 15.2908, minimum=0.0, strict=True)
    aperture_aspect = horizontal / vertical
    image_aspect = settings.width / settings.height
    if abs(image_aspect / aperture_aspect - 1.0) <= ASPECT_TOLERANCE:
        return settings
    if (
        not settings.source
        or not UsdRender.Settings(ctx.stage.GetPrimAtPath(settings.source)).GetResolutionAttr().HasAuthoredValue()
    ):
        return replace(settings, height=max(1, round(settings.width / aperture_aspect)))
    ctx.warn(
        f"{prim.GetPath()}: the aperture aspect {aperture_aspect:.4g} differs from the image's {image_aspect:.4g} "
        f"({settings.width}x{settings.height}); fitting horizontally (USD's default): the horizontal field of view is kept"
    )
    return settings


def choose_camera(ctx: ReadContext, path: str, cameras: list[str]) -> Usd.Prim | None:
    """The Camera prim at ``path`` (the CLI's --camera), or a problem naming it and the stage's
    cameras (``cameras``, those the traversal found) and None."""
    prim = ctx.stage.GetPrimAtPath(path) if isinstance(path, str) and path.startswith("/") else None
    if prim and prim.IsA(UsdGeom.Camera):
        return prim
    found = ("the stage's cameras: " + ", ".join(cameras)) if cameras else "the stage has no camera"
    what = f"is a {prim.GetTypeName() or 'typeless prim'}, not a Camera" if prim else "no such prim"
    ctx.problem(path, "", f"the camera asked for (--camera): {what}; {found}")
    return None


def read_camera(ctx: ReadContext, prim: Usd.Prim) -> Camera | None:
    cam = UsdGeom.Camera(prim)
    world = ctx.world(prim)
    forward = unit(-world[:3, 2])
    up = world[:3, 1]
    if forward is not None:
        d = float(forward @ up)
        # Gram-Schmidt only when needed, so a camera we wrote reads back bit for bit.
        up = up - forward * d if abs(d) > CAMERA_ORTHOGONAL_TOLERANCE else up
    up = unit(up)
    if forward is None or up is None:
        ctx.problem(prim, "xformOpOrder", "the camera transform is degenerate (no view or up direction)")
        return None
    projection = ctx.get(prim, "projection", ("token",), UsdGeom.Tokens.perspective)
    aperture = ctx.number(prim, "horizontalAperture", 20.955, minimum=0.0, strict=True)
    values = dict(
        position=tuple(float(c) for c in world[:3, 3]),
        forward=tuple(float(c) for c in forward),
        up=tuple(float(c) for c in up),
        source=str(prim.GetPath()),
    )
    if projection == UsdGeom.Tokens.orthographic:
        camera = Camera(projection="orthographic", ortho_width=aperture * names.APERTURE_UNIT, **values)
    elif projection == UsdGeom.Tokens.perspective:
        focal = ctx.number(prim, "focalLength", 50.0, minimum=0.0, strict=True)
        fov = 2.0 * math.degrees(math.atan(0.5 * aperture / focal)) if focal > 0 else 60.0
        camera = Camera(horizontal_fov_deg=fov, **values)
    else:
        ctx.problem(prim, "projection", f"must be perspective or orthographic, got {projection!r}")
        return None
    for offset in ("horizontalApertureOffset", "verticalApertureOffset"):
        if float(cam.GetPrim().GetAttribute(offset).Get(ctx.time) or 0.0) != 0.0:
            ctx.unsupported["camera aperture offsets (ignored)"].append(f"{prim.GetPath()}.{offset}")
    ctx.nodes.append((str(prim.GetPath()), f"Camera ({camera.projection})"))
    return camera
