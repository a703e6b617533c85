# SPDX-License-Identifier: Apache-2.0
"""Read a USD stage into a validated ``Scene``.

Every problem found (unreadable file, wrong types, NaN, out-of-range values and indices,
unknown ``phong:`` attributes) is collected and raised as ONE ``SceneError``, each naming the
file, the prim path and the attribute; then ``validate()`` runs on the result. Things the model
cannot represent become warnings, one per kind, listing the prims.

Lights: the model's light strength is ``ls·cl = intensity · 2^exposure · color`` (× the
blackbody colour when ``enableColorTemperature``). ``inputs:normalize`` and any area factor are
NOT applied (a warning lists lights with ``normalize = 1``), so a RectLight or SphereLight of
intensity π lights like a point light of strength π at its centre (POV-Ray area-light
semantics: shading from the centre, only shadows sampled).
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass, field, replace

import numpy as np
from pxr import Tf, Usd, UsdGeom, UsdLux, UsdRender

from ..errors import Problem, SceneError, SceneFileNotFoundError
from ..scene import (
    AmbientLight,
    Camera,
    Cone,
    DirectionalLight,
    Intrinsic,
    PointLight,
    RectAreaLight,
    RenderSettings,
    Scene,
    SphereAreaLight,
    framing_camera,
    head_light,
)
from ..tolerances import CAMERA_ORTHOGONAL_TOLERANCE
from ..validate import validate
from . import geometry, names, typos
from .diagnostics import as_warnings, usd_output
from .layers import not_regular, preflight
from .context import ReadContext, gf_to_numpy, tf_error_text, unit
from .materials import MaterialReader
from .read_cache import KeptRead, ReadCache
from .read_parts import EveryPart, RecordParts, Redo
from .names import FLOAT_TYPES, INT_TYPES, PHONG_ATTRIBUTES, STRING_TYPES, in_usd_terms

DEFAULT_SHADOW_SAMPLES = 9  # phong:shadowSamples on area lights: a 9×9 grid (2^3 + 1)
# Composition errors name their arc in the text; report it as the "attribute" (a metadata field).
_ARC_ATTRIBUTE = {"for reference": "references", "for payload": "payload", "sublayer": "subLayers"}
_GEOMETRY_TYPES = {"Sphere", "Mesh", "Cube", "Plane", "Cylinder", "Cylinder_1", "Cone", "Capsule"}


@dataclass
class ReadResult:
    """What ``read_usd`` found: the scene, the warnings, and which prim became which node."""

    scene: Scene
    warnings: list[str] = field(default_factory=list)
    nodes: list[tuple[str, str]] = field(default_factory=list)  # (prim path, model node)


def load_usd(source, time: float | None = None) -> Scene:
    """Read a USD file (.usda/.usdc/.usdz) or an open ``Usd.Stage`` into a validated Scene.

    Args:
        source: the file's path, or an open stage.
        time: the USD time code to read every value at (camera, lights, materials, visibility,
            transforms; USD interpolates between time samples). None: the stage's start time
            when it is animated (with a warning), else its default values.

    Raises:
        SceneError: listing every problem found, each with file, prim path and attribute.
    """
    return read_usd(source, time=time).scene


@dataclass(eq=False)
class OpenStage:
    """A USD file opened once to be read at many times (the frames one Dask worker renders):
    the stage, what USD printed while opening it, and the outcome of the checks that do not
    depend on the time (made by the first read, replayed by the others). ``read_usd`` of it at a
    time gives what ``read_usd`` of the file at that time gives. Path-like: it names its file."""

    stage: Usd.Stage
    file: str
    usd_output: str = ""  # USD's diagnostics while opening (raw: each read makes warnings of it)
    checks: tuple[list[Problem], list[str]] | None = None  # (problems, warnings) of _stage_checks
    types: dict = field(default_factory=dict)  # ReadContext.types: each attribute's authored type
    reads: ReadCache = field(default_factory=ReadCache)  # a stage nothing of which varies is read once

    def __fspath__(self) -> str:
        return self.file


def open_stage(path) -> OpenStage:
    """Open (and check, as ``read_usd`` does) the USD file at ``path`` to read it at many times.

    Raises:
        SceneError: the file is missing, not a file, or not USD (naming it).
    """
    texts: list[str] = []
    with usd_output(texts):
        stage, file = _open(path)
    return OpenStage(stage, file, "".join(texts))


def read_usd(source, time: float | None = None) -> ReadResult:
    """Like ``load_usd`` but also returns the warnings and the prim → node mapping. ``source``
    may also be an ``OpenStage`` (``open_stage``): read at a time, a stage nothing of which
    varies in time gives its first read again (``read_cache``), and one where only lights' and
    gprims' own inputs vary reads only those again (``read_parts``)."""
    cache = source.reads if isinstance(source, OpenStage) else None
    if cache is not None:
        cache.survey(source.stage)  # once per stage
    texts: list[str] = []
    kept = assets = None
    with usd_output(texts):  # USD's own "Warning: in ..." lines become warnings
        opened = source if isinstance(source, OpenStage) else OpenStage(*_open(source))
        file = opened.file
        if time is not None and not (isinstance(time, (int, float)) and math.isfinite(time)):
            raise SceneError(Problem(f"the time must be a finite number (a USD time code), got {time!r}", file=file))
        code, said = _time_to_read(opened.stage, time)
        parts = None
        if cache is not None:
            kept = cache.replay(code)
            if kept is None:
                assets = cache.assets(code)  # the files' states before reading them
                parts = cache.parts(code, assets)
        if kept is None:
            try:
                try:
                    result = _read(opened, code, parts or EveryPart())
                except Redo:
                    parts = None
                    result = _read(opened, code, EveryPart())
            except Tf.ErrorException as e:
                # A value USD itself cannot produce while we read it (where no prim-level check
                # caught it first): one error naming the file, not a traceback.
                raise SceneError(Problem(f"USD could not read a value: {tf_error_text(e)}", file=file)) from None
    read_text = "".join(texts)
    if kept is not None:
        result = ReadResult(kept.scene, list(kept.warnings), list(kept.nodes))
        read_text = kept.usd_text + read_text
    elif assets is not None:
        cache.keep(code, KeptRead(result.scene, tuple(result.warnings), tuple(result.nodes), read_text, assets))
        if isinstance(parts, RecordParts):
            cache.keep_parts(code, parts, assets)
    # As a read of the file gives them: which time is read first, USD's diagnostics last.
    result.warnings[:0] = [said] if said else []
    result.warnings.extend(as_warnings(opened.usd_output + read_text))
    return result


def _stage_checks(ctx: ReadContext) -> None:
    """What is read of the stage whatever the time: composition errors, unknown ``phong:``
    attributes, names nothing reads (typos)."""
    for error in ctx.stage.GetCompositionErrors():
        # As USD and usdview do: a reference, payload or sublayer that cannot be composed (a
        # missing file, a .mtlx without USD's MaterialX plugin) is said, and the rest is drawn.
        site = getattr(error, "rootSite", None)
        text = str(error)
        arc = next((a for k, a in _ARC_ATTRIBUTE.items() if k in text), "")
        where = (str(site.path) if site is not None else "") + (f".{arc}" if arc else "")
        ctx.warn(f"{where}: {text} (not composed; the rest of the stage is drawn)")
    _check_phong_namespace(ctx)
    typos.check_names(ctx)


def _read(opened: OpenStage, code: Usd.TimeCode, parts: EveryPart) -> ReadResult:
    stage, file = opened.stage, opened.file
    ctx = ReadContext(stage, file, code, opened.types)
    if opened.checks is None:
        problems, warnings = len(ctx.problems), len(ctx.warnings)
        _stage_checks(ctx)
        opened.checks = (ctx.problems[problems:], ctx.warnings[warnings:])
    else:
        ctx.problems.extend(opened.checks[0])
        ctx.warnings.extend(opened.checks[1])
    settings, camera_prim = _render_settings(ctx)
    camera, lights, ambient, spheres, meshes = None, [], [], [], []
    # Each light and gprim is read through ``parts``: anew, or replayed from a stage's first read.
    materials = parts.materials(ctx)
    parts.start(ctx, (lights, ambient, spheres, meshes))

    it = iter(Usd.PrimRange(stage.GetPseudoRoot(), Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)))
    renderable = _Renderable(ctx)
    for prim in it:
        if not renderable(prim):
            it.PruneChildren()
            continue
        _warm_transform(ctx, prim)
        if prim.IsA(UsdGeom.Camera):
            if camera_prim is None:
                camera_prim = prim
        elif prim.HasAPI(UsdLux.LightAPI):
            parts.read(prim, lambda: _light(ctx, prim, lights, ambient))
        elif prim.IsA(UsdGeom.PointInstancer):
            it.PruneChildren()  # its prototypes may be anywhere: read at every time
            parts.read(prim, lambda: _instances(ctx, prim, ctx.world(prim), materials, spheres, meshes), keep=False)
        elif prim.IsA(UsdGeom.Gprim):
            parts.read(prim, lambda: _gprim(ctx, prim, ctx.world(prim), materials, spheres, meshes))

    if camera_prim is not None:
        camera = _camera(ctx, camera_prim)
        if camera is not None:
            settings = _conform_to_aperture(ctx, camera_prim, settings)
    ambient_color = tuple(float(sum(a.color[i] for a in ambient)) for i in range(3)) if ambient else (0.0, 0.0, 0.0)
    scene = Scene(
        camera=camera or Camera(),
        ambient=AmbientLight(ambient_color, ambient[0].source if len(ambient) == 1 else ""),
        lights=tuple(lights),
        spheres=tuple(spheres),
        meshes=tuple(m for m in meshes if not isinstance(m, Intrinsic)),
        intrinsics=tuple(m for m in meshes if isinstance(m, Intrinsic)),
        settings=settings,
        source_file=file,
    )
    if camera is None:
        scene = replace(scene, camera=framing_camera(scene))
        ctx.warn("no camera: using a default framing camera (phongscene.scene.framing_camera)")
    if not lights:
        scene = replace(scene, lights=(head_light(scene.camera),))
        ctx.warn("no point, distant or area light: using a head light at the camera (phongscene.scene.head_light)")
    _warn_single_sided(ctx, stage, scene)
    _warn_clipping_lights(ctx, scene)
    ctx.flush_unsupported()

    # Validation of the model, in the file's terms. The reader replaced each value it found wrong
    # by its default, so the model does not report it again; a problem both found on the same
    # attribute is listed once.
    reported = {(p.prim, p.attribute) for p in ctx.problems}
    found = [in_usd_terms(p) for p in validate(scene)]
    problems = ctx.problems + [p for p in found if (p.prim, p.attribute) not in reported]
    if problems:
        raise SceneError(problems)
    return ReadResult(scene, ctx.warnings, ctx.nodes)


# A light is said to clip when the median radiance it gives a white surface exceeds this: one
# stop above what an sRGB image holds (1), so a light that brings white to exactly white (our
# head light and seed examples) or a little above is left alone.
CLIP_RADIANCE = 2.0
# Points of the geometry sampled to judge how bright a light makes the scene (a fixed, evenly
# spaced selection: deterministic).
CLIP_SAMPLE_POINTS = 1024


def _median(values: np.ndarray) -> float:
    """np.median of finite ``values``, the same value: np.median imports numpy.ma for its NaN
    check, ~40 ms of every render's start-up (issue 15); these values are finite."""
    n = len(values)
    middle = np.partition(values, [(n - 1) // 2, n // 2])
    return float((middle[(n - 1) // 2] + middle[n // 2]) / 2)


def _warn_clipping_lights(ctx: ReadContext, scene: Scene) -> None:
    """A light alone brighter than an sRGB image holds: where the median of the radiance it gives a
    white Lambert surface facing it, over points of the geometry (shadows ignored), exceeds
    CLIP_RADIANCE, a PNG clips most of what it lights to white. Said per light, with the exposure change that
    brings that median to 1 (UsdLux ``inputs:exposure``)."""
    points = [m.points[:: max(1, len(m.points) * max(1, len(scene.meshes)) // CLIP_SAMPLE_POINTS)] for m in scene.meshes]
    points += [s.world_from_object[:3, 3][None, :] for s in scene.spheres]
    if not points:
        return
    p = np.concatenate(points)
    for light in scene.lights:
        colour = float(np.max(light.color))
        if isinstance(light, DirectionalLight) or light.falloff == "none":
            irradiance = np.full(len(p), colour)
        else:
            centre = np.asarray(getattr(light, "position", getattr(light, "center", None)), dtype=np.float64)
            d2 = np.maximum(((p - centre) ** 2).sum(axis=1), 1e-300)
            irradiance = colour / d2
        radiance = _median(irradiance) / math.pi
        if radiance > CLIP_RADIANCE:
            ctx.warn(
                f"{light.source}: lights a white surface to radiance {radiance:.3g} at the median point of the "
                f"geometry, which an sRGB image clips to white; inputs:exposure {-math.log2(radiance):+.2f} would bring it to 1"
            )


def _warn_single_sided(ctx: ReadContext, stage: Usd.Stage, scene: Scene) -> None:
    """phongscene shades every surface from both sides (Suffern's model, and POV-Ray, which has no
    back-face culling for mesh2, so both backends agree); USD renderers cull the back of a mesh
    with ``doubleSided = false`` (USD's fallback). Said once, listing the single-sided meshes whose
    back the camera may see: open ones (a closed mesh hides its back faces) with a triangle facing
    away from the camera."""
    eye = np.asarray(scene.camera.position, dtype=np.float64)
    seen = []
    for mesh in scene.meshes:
        prim = stage.GetPrimAtPath(mesh.source)
        if not prim or not prim.IsA(UsdGeom.Mesh) or UsdGeom.Mesh(prim).GetDoubleSidedAttr().Get(ctx.time):
            continue
        tri = mesh.triangles.astype(np.int64)
        p = mesh.points[tri]
        facing = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 0] - eye)
        if not np.any(facing > 0):
            continue  # every triangle faces the camera: no back to see
        # Closed (every edge used twice): its back faces are hidden behind its front faces. An
        # edge is one int64 key (a 1-D unique is ~10x faster than np.unique(axis=0) on pairs).
        edges = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
        _, uses = np.unique(edges[:, 0] * len(mesh.points) + edges[:, 1], return_counts=True)
        if not np.all(uses == 2):
            seen.append(mesh.source)
    if seen:
        ctx.unsupported["single-sided meshes (doubleSided = false) whose back the camera may see, shaded from both "
                        "sides as POV-Ray does (USD renderers would not draw the back)"].extend(seen)


def _time_to_read(stage: Usd.Stage, time: float | None) -> tuple[Usd.TimeCode, str]:
    """The time code to read the stage at, and a warning to give (or "").

    Asked for a time: that time (outside the stage's authored range, USD holds the first or last
    sample, which is said). Not asked: an animated stage (an authored range with end > start)
    is read at its start time, said; a stage with time samples but no range at its earliest
    sample (its default time would drop every value authored only as samples, putting an object
    at the origin), said; any other stage at its default values, as before."""
    ranged = stage.HasAuthoredTimeCodeRange()
    start, end = stage.GetStartTimeCode(), stage.GetEndTimeCode()
    if time is not None:
        outside = ranged and not (start <= time <= end)
        said = f"time {time:g} is outside the stage's time codes {start:g} to {end:g}: USD holds the nearest sample" if outside else ""
        return Usd.TimeCode(float(time)), said
    if ranged and end > start:
        return Usd.TimeCode(start), (
            f"the stage is animated (time codes {start:g} to {end:g}): rendering its start time {start:g} "
            "(choose one with --time T, or all with --frames START:END)"
        )
    if not ranged:
        earliest = _earliest_time_sample(stage)
        if earliest is not None:
            return Usd.TimeCode(earliest), (
                f"the stage has time samples but no startTimeCode/endTimeCode: rendering its earliest sample, time {earliest:g} "
                "(choose one with --time T)"
            )
    return (Usd.TimeCode(start) if ranged else Usd.TimeCode.Default()), ""


def _earliest_time_sample(stage: Usd.Stage) -> float | None:
    """The earliest time sample of any attribute on the stage, or None when nothing is sampled
    (a walk over the attributes' sample metadata, values are not read)."""
    earliest = None
    for prim in Usd.PrimRange(stage.GetPseudoRoot(), Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)):
        for attr in prim.GetAuthoredAttributes():
            if attr.GetNumTimeSamples():
                first = attr.GetTimeSamples()[0]
                earliest = first if earliest is None else min(earliest, first)
    return earliest


def _open(source) -> tuple[Usd.Stage, str]:
    if isinstance(source, Usd.Stage):
        layer = source.GetRootLayer()
        return source, layer.realPath or layer.identifier
    path = os.fspath(source)
    if not os.path.exists(path):
        raise SceneFileNotFoundError(path)
    if not os.path.isfile(path):
        raise SceneError(Problem("not a file", file=path))
    try:
        layers = preflight(path)  # noqa: F841 (kept open: the stage reuses them)
        stage = Usd.Stage.Open(path)
    except Tf.ErrorException as e:
        raise SceneError(Problem(f"cannot read USD: {_usd_error_text(e)}", file=path)) from None
    if stage is None:
        raise SceneError(Problem("cannot read USD", file=path))
    return stage, path


def _usd_error_text(error: Exception) -> str:
    """The informative part of a Tf error: the parser's message (with line:column), without the
    C++ source location and the generic "Failed to open layer" line."""
    try:
        text = str(error)
    except UnicodeDecodeError:  # USD quotes the offending bytes, and Python cannot decode them
        return "the file is not valid UTF-8 text (USD's message could not be decoded)"
    messages = [m.group(1) for m in re.finditer(r"Error in '[^']*' at line \d+ in file \S+ : '(.*)'", text)]
    specific = [m for m in messages if not m.startswith("Failed to open layer")]
    return (specific or messages or [text.strip()])[-1]


def _warm_transform(ctx: ReadContext, prim: Usd.Prim) -> None:
    """Cache the prim's world transform while its parent's is cached (the traversal is top-down):
    ``XformCache`` computes an uncached transform by recursing through every ancestor, which
    overflows the C stack (a segfault) at ~30 000 levels of nesting. A transform USD cannot
    evaluate is a problem naming this prim (USD raises only on the first request)."""
    if prim.IsA(UsdGeom.Xformable):
        ctx.world(prim)


class _Renderable:
    """Visibility and purpose (only visible prims of purpose default or render) along one pruned
    depth-first traversal, in time linear in its prims. ``ComputeVisibility`` and
    ``ComputePurpose`` walk every ancestor, which is quadratic in nesting depth (30 000 nested
    Xforms took over 60 s; USD opens them in 0.04 s). Below a prim this accepted, only the prim's
    own visibility can hide it (an invisible ancestor was pruned), and its purpose follows from
    its parent's (``ComputePurposeInfo(parent)``); the first prim of a traversal, and a prim under
    a non-imageable one, are computed in full. One instance per traversal."""

    def __init__(self, ctx: ReadContext):
        self.ctx = ctx
        self.purposes: dict = {}  # prim path -> PurposeInfo, for the accepted imageable prims

    def __call__(self, prim: Usd.Prim) -> bool:
        img = UsdGeom.Imageable(prim)
        if not img:
            return True
        parent = self.purposes.get(prim.GetPath().GetParentPath())
        if parent is None:
            if img.ComputeVisibility(self.ctx.time) == UsdGeom.Tokens.invisible:
                return False
            info = img.ComputePurposeInfo()
        else:
            if img.GetVisibilityAttr().Get(self.ctx.time) == UsdGeom.Tokens.invisible:
                return False
            info = img.ComputePurposeInfo(parent)
        if info.purpose not in (UsdGeom.Tokens.default_, UsdGeom.Tokens.render):
            return False
        self.purposes[prim.GetPath()] = info
        return True


def _check_phong_namespace(ctx: ReadContext) -> None:
    """Unknown attributes in our `phong:` namespace are errors."""
    predicate = Usd.TraverseInstanceProxies(Usd.PrimAllPrimsPredicate)
    for prim in Usd.PrimRange(ctx.stage.GetPseudoRoot(), predicate):
        props = prim.GetAuthoredPropertiesInNamespace("phong")
        if not props:
            continue
        allowed = PHONG_ATTRIBUTES.get(prim.GetTypeName(), {})
        for prop in props:
            name = prop.GetName()
            if name not in allowed:
                where = f"on a {prim.GetTypeName() or 'typeless prim'}"
                known = f" (known here: {', '.join(allowed)})" if allowed else ""
                ctx.problem(prim, name, f"unknown attribute in the phong: namespace {where}{known}")


# -- render settings and camera -------------------------------------------------------------


def _render_settings(ctx: ReadContext) -> tuple[RenderSettings, Usd.Prim | None]:
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
            values["width"], values["height"] = int(res[0]), int(res[1])
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


def _conform_to_aperture(ctx: ReadContext, prim: Usd.Prim, settings: RenderSettings) -> RenderSettings:
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
    if not settings.source or not UsdRender.Settings(ctx.stage.GetPrimAtPath(settings.source)).GetResolutionAttr().HasAuthoredValue():
        return replace(settings, height=max(1, round(settings.width / aperture_aspect)))
    ctx.warn(
        f"{prim.GetPath()}: the aperture aspect {aperture_aspect:.4g} differs from the image's {image_aspect:.4g} "
        f"({settings.width}x{settings.height}); fitting horizontally (USD's default): the horizontal field of view is kept"
    )
    return settings


def _camera(ctx: ReadContext, prim: Usd.Prim) -> Camera | None:
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


# -- lights ---------------------------------------------------------------------------------


def _luminance(ctx: ReadContext, prim: Usd.Prim) -> np.ndarray:
    """UsdLux's emitted luminance L = intensity · 2^exposure · color (× the blackbody colour when
    enableColorTemperature), before normalize."""
    api = UsdLux.LightAPI(prim)
    intensity = ctx.number(prim, "inputs:intensity", 1.0, minimum=0.0)
    exposure = ctx.number(prim, "inputs:exposure", 0.0)
    color = np.asarray(ctx.color(prim, "inputs:color", (1.0, 1.0, 1.0)), dtype=np.float64)  # >= 0: validate
    if api.GetEnableColorTemperatureAttr().Get(ctx.time):
        kelvin = ctx.number(prim, "inputs:colorTemperature", 6500.0, minimum=0.0, strict=True)
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


def _light(ctx: ReadContext, prim: Usd.Prim, lights: list, ambient: list) -> None:
    """One UsdLux light into the model, in UsdLux's units (see README: lights) unless it asks for
    the seed's light. The emitted luminance L (normalized by the emitting area when
    ``inputs:normalize``) becomes: for a SphereLight of world radius r the radiant intensity
    I = L·πr² (= L/4 when normalized; treatAsPoint or r = 0: a point light with that I), for a
    RectLight of world area A the intensity along its normal I = L·A (= L when normalized), for
    a DistantLight the irradiance E = L·π·sin²(angle/2) (= L when normalized or angle = 0), for
    an untextured DomeLight the ambient radiance La = L."""
    path = str(prim.GetPath())
    world = ctx.world(prim)
    centre = tuple(float(c) for c in world[:3, 3])
    type_name = prim.GetTypeName()
    dome = prim.IsA(UsdLux.DomeLight) or type_name == "DomeLight_1"
    known = (UsdLux.SphereLight, UsdLux.DistantLight, UsdLux.RectLight, UsdLux.DiskLight, UsdLux.CylinderLight)
    if not (dome or any(prim.IsA(kind) for kind in known)):
        ctx.unsupported["unsupported lights (ignored)"].append(f"{path} ({type_name})")
        return
    seed = _seed_light(ctx, prim)
    luminance = _luminance(ctx, prim)
    terms = _terms(ctx, prim)
    falloff = "none" if seed else "inverse-square"
    if dome:
        texture = prim.GetAttribute("inputs:texture:file")
        asset = texture.Get(ctx.time) if texture else None
        if asset and asset.path:
            mean = _texture_mean(ctx, prim, asset)
            if mean is None:
                return
            luminance = luminance * mean
        # The ambient term is diffuse light: the dome's diffuse multiplier scales it.
        ambient.append(AmbientLight(_rgb(luminance * terms["diffuse"]), path))
        ctx.nodes.append((path, "AmbientLight"))
    elif prim.IsA(UsdLux.SphereLight):
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
                ctx.unsupported["point lights of radius 0 without inputs:normalize (they emit nothing in UsdLux)"].append(path)
        if point:
            if prim.GetAttribute(names.SHADOW_SAMPLES).HasAuthoredValue():
                ctx.problem(prim, names.SHADOW_SAMPLES, "applies to area lights only (this SphereLight is a point light)")
            fade_distance = ctx.number(prim, names.FADE_DISTANCE, 0.0)
            fade_power = ctx.number(prim, names.FADE_POWER, 0.0)
            cone = _cone(ctx, prim, world)
            lights.append(PointLight(centre, _rgb(colour), fade_distance, fade_power, path, falloff, cone, **terms))
            ctx.nodes.append((path, "PointLight" + ("" if seed else " (UsdLux)")))
        else:
            if _shaping(ctx, prim) is not None:
                ctx.unsupported["spherical or rect lights with a UsdLuxShapingAPI cone (ignored)"].append(path)
            for name in (names.FADE_DISTANCE, names.FADE_POWER):
                if prim.GetAttribute(name).HasAuthoredValue():
                    ctx.problem(prim, name, "applies to point lights only (treatAsPoint or radius 0)")
            lights.append(
                SphereAreaLight(
                    centre, radius_world, _rgb(colour), _shadow_samples(ctx, prim), path, falloff,
                    adaptive=_shadow_adaptive(ctx, prim), cell_samples=_shadow_cell_samples(ctx, prim), **terms,
                )
            )
            ctx.nodes.append((path, "SphereAreaLight" + ("" if seed else " (UsdLux)")))
    elif prim.IsA(UsdLux.CylinderLight):
        # A tube of radius r and length l along its X axis, emitting luminance L from its side:
        # intensity L·2rl·sin θ off the axis, power π²·L·r·l. Lit as a point light of the same
        # power at its centre (I = L·π·r·l/2; normalized, L/(2πrl): I = L/4, as a sphere light).
        radius = ctx.number(prim, "inputs:radius", 0.5, minimum=0.0)
        length = ctx.number(prim, "inputs:length", 1.0, minimum=0.0)
        scales = np.linalg.norm(world[:3, :3], axis=0)
        if seed:
            colour = luminance
        elif _normalized(ctx, prim):
            colour = luminance / 4.0
        else:
            colour = luminance * (math.pi / 2 * radius * float(np.mean(scales[1:])) * length * float(scales[0]))
        ctx.unsupported["CylinderLights (each lit as a point light of the same power at its centre)"].append(path)
        lights.append(PointLight(centre, _rgb(colour), 0.0, 0.0, path, falloff, None, **terms))
        ctx.nodes.append((path, "PointLight (UsdLux CylinderLight)"))
    elif prim.IsA(UsdLux.DistantLight):
        direction = unit(world[:3, :3] @ np.array([0.0, 0.0, -1.0]))
        if direction is None:
            ctx.problem(prim, "xformOpOrder", "the light's transform is degenerate (no −Z direction)")
            return
        irradiance = luminance
        if not seed:
            angle = ctx.number(prim, "inputs:angle", 0.53, minimum=0.0)
            if not _normalized(ctx, prim) and angle > 0:
                irradiance = luminance * (math.pi * math.sin(math.radians(min(angle, 180.0)) / 2) ** 2)
            factor = _blender_sun_factor(ctx)
            if factor != 1.0:
                irradiance = irradiance * factor
                ctx.unsupported["Blender suns (its exporter writes strength S as intensity S/4: read as S, "
                                "as Cycles renders them)"].append(path)
        lights.append(DirectionalLight(tuple(float(c) for c in direction), _rgb(irradiance), path, **terms))
        ctx.nodes.append((path, "DirectionalLight"))
    else:  # RectLight, or a DiskLight as the square of its area
        if _shaping(ctx, prim) is not None:
            ctx.unsupported["spherical or rect lights with a UsdLuxShapingAPI cone (ignored)"].append(path)
        if prim.IsA(UsdLux.DiskLight):
            # Same area, emission and falloff; only its shadows' outline (and grid) differ.
            radius = ctx.number(prim, "inputs:radius", 0.5, minimum=0.0, strict=True)
            width = height = radius * math.sqrt(math.pi)
            ctx.unsupported["DiskLights (each lit as the square of its area, facing the same way)"].append(path)
        else:
            width = ctx.number(prim, "inputs:width", 1.0, minimum=0.0, strict=True)
            height = ctx.number(prim, "inputs:height", 1.0, minimum=0.0, strict=True)
        axis_u = world[:3, :3] @ np.array([width, 0.0, 0.0])
        axis_v = world[:3, :3] @ np.array([0.0, height, 0.0])
        if seed or _normalized(ctx, prim):
            colour = luminance
        else:
            colour = luminance * float(np.linalg.norm(np.cross(axis_u, axis_v)))
        lights.append(
            RectAreaLight(
                centre, _rgb(axis_u), _rgb(axis_v), _rgb(colour), _shadow_samples(ctx, prim), path, falloff,
                adaptive=_shadow_adaptive(ctx, prim), cell_samples=_shadow_cell_samples(ctx, prim), **terms,
            )
        )
        ctx.nodes.append((path, "RectAreaLight" + ("" if seed else " (UsdLux)")))


def _texture_mean(ctx: ReadContext, prim: Usd.Prim, asset) -> np.ndarray | None:
    """The mean radiance of a DomeLight's texture (OpenImageIO), over texels weighted by the
    solid angle they cover in a lat-long map (cos of the latitude), with a warning; None (and a
    problem) when it cannot be read."""
    from ..errors import PhongSceneError
    from ..images import read_image  # OpenImageIO: only for a scene with a textured dome

    path = asset.resolvedPath or asset.path
    why = not_regular(path)
    if why is not None:
        ctx.problem(prim, "inputs:texture:file", f"{path} {why}")
        return None
    try:
        image = read_image(path)
    except PhongSceneError as e:
        ctx.problem(prim, "inputs:texture:file", f"cannot read the texture: {e}")
        return None
    rows = image.shape[0]
    latitude = (np.arange(rows) + 0.5) / rows * math.pi - math.pi / 2
    weights = np.cos(latitude)[:, None] * np.ones(image.shape[1])
    mean = (image[..., :3] * weights[..., None]).sum(axis=(0, 1)) / weights.sum()
    ctx.unsupported["textured DomeLights (their mean radiance is the ambient light)"].append(
        f"{prim.GetPath()} (mean {', '.join(f'{c:.4g}' for c in mean)})"
    )
    return mean


# -- geometry -------------------------------------------------------------------------------


def _gprim(ctx: ReadContext, prim: Usd.Prim, world: np.ndarray, materials: MaterialReader, spheres: list, meshes: list) -> None:
    type_name = prim.GetTypeName()
    path = str(prim.GetPath())
    if type_name not in _GEOMETRY_TYPES:
        ctx.unsupported["unsupported geometry (ignored)"].append(f"{path} ({type_name})")
        return
    material = materials.for_gprim(prim)
    if type_name != "Mesh" and material.textures:
        # Only meshes carry st primvars here: the texture's fallback colour is used.
        ctx.unsupported["textures on prims without texture coordinates (the fallback colour is used)"].append(path)
        material = material.without_textures()
    if type_name == "Sphere":
        spheres.append(geometry.sphere(ctx, prim, world, material))
        ctx.nodes.append((path, "Sphere"))
        return
    if type_name == "Mesh":
        subsets = materials.face_subsets(prim)
        textured = [m for m in (material, *(m for _, m, _ in subsets)) if m.textures]
        st = materials.st_of.get(textured[0]) if textured else None
        if len({materials.st_of.get(m) for m in textured}) > 1:
            ctx.warn(f"{path}: its materials read different st primvars; all use {st.primvar!r}")
        built = geometry.mesh(ctx, prim, world, material, subsets, st)
    elif type_name == "Cylinder_1" or not geometry.tessellated(ctx, prim):
        # The exact surface (Intrinsic): it joins the meshes' list, in traversal order, and the
        # scene takes it out of there (in _read).
        shape = geometry.intrinsic(ctx, prim, world, material)
        if shape is not None:
            meshes.append(shape)
            ctx.nodes.append((path, f"Intrinsic ({shape.kind}{', infinite' if shape.infinite else ''})"))
        return
    else:
        built = geometry.primitive(ctx, prim, world, material)
        built = () if built is None else (built,)
    for mesh in built:
        meshes.append(mesh)
        ctx.nodes.append((mesh.source, f"TriangleMesh ({len(mesh.triangles)} triangles)"))


def _instances(
    ctx: ReadContext, instancer_prim: Usd.Prim, instancer_world: np.ndarray, materials, spheres, meshes, expanding=()
) -> None:
    """Expand a PointInstancer: each instance's prototype subtree, placed by the instance's
    transform (which includes the prototype root's own transform) and the instancer's.
    ``expanding`` are the instancers being expanded around this one: a prototype that contains
    one of them (or this one) would recurse forever, and is a problem."""
    instancer = UsdGeom.PointInstancer(instancer_prim)
    prototypes = instancer.GetPrototypesRel().GetForwardedTargets()
    expanding = (*expanding, instancer_prim.GetPath())
    for target in prototypes:
        if any(path.HasPrefix(target) for path in expanding):
            ctx.problem(instancer_prim, "prototypes", f"the prototype {target} contains this instancer (a cycle)")
            return
    proto_indices = instancer.GetProtoIndicesAttr().Get(ctx.time)
    if proto_indices is None or not prototypes:
        return
    proto_indices = np.asarray(proto_indices, dtype=np.int64)
    bad = (proto_indices < 0) | (proto_indices >= len(prototypes))
    if bad.any():
        ctx.problem(instancer_prim, "protoIndices", f"{int(bad.sum())} indices out of range [0, {len(prototypes)})")
        return
    transforms = instancer.ComputeInstanceTransformsAtTime(
        ctx.time, ctx.time, UsdGeom.PointInstancer.IncludeProtoXform, UsdGeom.PointInstancer.IgnoreMask
    )
    mask = instancer.ComputeMaskAtTime(ctx.time)

    for i, (proto_index, instance) in enumerate(zip(proto_indices, transforms)):
        if mask and not mask[i]:
            continue
        proto = ctx.stage.GetPrimAtPath(prototypes[proto_index])
        # instancer-world ← instance ← prototype-root-relative
        placed = instancer_world @ gf_to_numpy(instance)
        it = iter(Usd.PrimRange(proto, Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)))
        renderable = _Renderable(ctx)
        for prim in it:
            if not renderable(prim):
                it.PruneChildren()
                continue
            relative, _ = ctx.xforms.ComputeRelativeTransform(prim, proto)
            local = gf_to_numpy(relative) if prim != proto else np.eye(4)
            if prim.IsA(UsdGeom.PointInstancer):
                it.PruneChildren()
                _instances(ctx, prim, placed @ local, materials, spheres, meshes, expanding)
            elif prim.IsA(UsdGeom.Gprim):
                _gprim(ctx, prim, placed @ local, materials, spheres, meshes)
            elif prim.HasAPI(UsdLux.LightAPI):
                ctx.unsupported["lights inside PointInstancer prototypes (ignored)"].append(str(prim.GetPath()))
