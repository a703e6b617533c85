# SPDX-License-Identifier: Apache-2.0
"""Read a USD stage into a validated ``Scene``: open it, choose the time to read, walk its
renderable prims (visibility, purpose, instancing) and build the model, then validate it.

Every problem found (unreadable file, wrong types, NaN, out-of-range values and indices,
unknown ``phong:`` attributes) is collected and raised as ONE ``SceneError``, each naming the
file, the prim path and the attribute; then ``validate()`` runs on the result. Things the model
cannot represent become warnings, one per kind, listing the prims.

Each concept has its module: ``lights`` (UsdLux lights, in UsdLux's units: ``inputs:normalize``
and each type's area factor applied), ``camera`` (camera and render settings), ``geometry``,
``materials``, ``stage_checks`` (what is checked whatever the time) and ``scene_checks``
(warnings about the scene as read).
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass, field, replace

import numpy as np
from pxr import Tf, Usd, UsdGeom, UsdLux

from ..errors import Problem, SceneError, SceneFileNotFoundError
from ..limits import MAX_SUBDIVISION_LEVEL
from ..scene import (
    AmbientLight,
    Camera,
    Environment,
    Intrinsic,
    Points,
    RenderSettings,
    Scene,
    framing_camera,
    head_light,
)
from ..validate import validate
from . import curves, geometry
from .camera import choose_camera, conform_to_aperture, read_camera, read_render_settings
from .context import ReadContext, tf_error_text
from .diagnostics import as_warnings, usd_output
from .instancing import Instancing
from .layers import preflight
from .lights import read_light
from .linking import link_lights
from .materials import MaterialReader
from .names import TESSELLATE, in_usd_terms
from .read_cache import KeptRead, ReadCache
from .read_parts import EveryPart, RecordParts, Redo
from .scene_checks import warn_clipping_lights, warn_single_sided
from .stage_checks import check_stage

_GEOMETRY_TYPES = {
    "Sphere",
    "Mesh",
    "Cube",
    "Plane",
    "Cylinder",
    "Cylinder_1",
    "Cone",
    "Capsule",
    "Capsule_1",
    "Points",
    "BasisCurves",
}
# Intrinsic prims with two radii: always their exact surface (no tessellation is written for them).
TWO_RADIUS_TYPES = ("Cylinder_1", "Capsule_1")


@dataclass
class ReadResult:
    """What ``read_usd`` found: the scene, the warnings, and which prim became which node."""

    scene: Scene
    warnings: list[str] = field(default_factory=list)
    nodes: list[tuple[str, str]] = field(default_factory=list)  # (prim path, model node)
    cameras: list[str] = field(default_factory=list)  # every Camera prim that renders, in stage order


def load_usd(source, time: float | None = None, camera: str | None = None, *, sandbox: bool | None = None) -> Scene:
    """Read a USD file (.usda/.usdc/.usdz) or an open ``Usd.Stage`` into a validated Scene.

    Args:
        source: the file's path, or an open stage.
        time: the USD time code to read every value at (camera, lights, materials, visibility,
            transforms; USD interpolates between time samples). None: the stage's start time
            when it is animated (with a warning), else its default values.
        camera: the path of the Camera prim to render through; None: the RenderSettings'
            camera, else the stage's first (with a warning when it has more than one).
        sandbox: None (default): a file USD might crash on (binary, or naming other files) is
            read in a child process with a memory limit, others in this one
            (``phongscene.scene_files``); True / False: always / never in the child.

    Raises:
        SceneError: listing every problem found, each with file, prim path and attribute (also
            when USD crashed or ran out of memory in the child).
    """
    from ..scene_files import read_scene_file

    return read_scene_file(source, time, sandbox=sandbox, camera=camera).scene


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


def read_usd(
    source, time: float | None = None, camera: str | None = None, subdivision_level: int | None = None
) -> ReadResult:
    """Like ``load_usd`` but also returns the warnings and the prim → node mapping. ``source``
    may also be an ``OpenStage`` (``open_stage``): read at a time, a stage nothing of which
    varies in time gives its first read again (``read_cache``), and one where only lights' and
    gprims' own inputs vary reads only those again (``read_parts``). ``camera``: the path of the
    Camera prim to render through (the CLI's --camera; None: the RenderSettings' camera, else the
    stage's first, with a warning when it has more than one); ``subdivision_level``: every
    subdivision surface's refinement level (the CLI's --subdivision-level; None: each prim's
    phong:subdivisionLevel or the default). Reads with either are not cached."""
    if subdivision_level is not None and not (
        isinstance(subdivision_level, int) and 0 <= subdivision_level <= MAX_SUBDIVISION_LEVEL
    ):
        raise ValueError(f"subdivision_level must be an int in 0..{MAX_SUBDIVISION_LEVEL}, got {subdivision_level!r}")
    chosen = camera is None and subdivision_level is None
    cache = source.reads if isinstance(source, OpenStage) and chosen else None
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
                    result = _read(opened, code, parts or EveryPart(), camera, subdivision_level)
                except Redo:
                    parts = None
                    result = _read(opened, code, EveryPart(), camera, subdivision_level)
            except Tf.ErrorException as e:
                # A value USD itself cannot produce while we read it (where no prim-level check
                # caught it first): one error naming the file, not a traceback.
                raise SceneError(Problem(f"USD could not read a value: {tf_error_text(e)}", file=file)) from None
    read_text = "".join(texts)
    if kept is not None:
        result = ReadResult(kept.scene, list(kept.warnings), list(kept.nodes), list(kept.cameras))
        read_text = kept.usd_text + read_text
    elif assets is not None:
        cache.keep(
            code,
            KeptRead(
                result.scene, tuple(result.warnings), tuple(result.nodes), read_text, assets, tuple(result.cameras)
            ),
        )
        if isinstance(parts, RecordParts):
            cache.keep_parts(code, parts, assets)
    # As a read of the file gives them: which time is read first, USD's diagnostics last.
    result.warnings[:0] = [said] if said else []
    result.warnings.extend(as_warnings(opened.usd_output + read_text))
    return result


def _read(
    opened: OpenStage,
    code: Usd.TimeCode,
    parts: EveryPart,
    chosen: str | None = None,
    subdivision_level: int | None = None,
) -> ReadResult:
    stage, file = opened.stage, opened.file
    ctx = ReadContext(stage, file, code, opened.types)
    ctx.subdivision_level = subdivision_level
    if opened.checks is None:
        problems, warnings = len(ctx.problems), len(ctx.warnings)
        check_stage(ctx)
        opened.checks = (ctx.problems[problems:], ctx.warnings[warnings:])
    else:
        ctx.problems.extend(opened.checks[0])
        ctx.warnings.extend(opened.checks[1])
    settings, camera_prim = read_render_settings(ctx)
    named_camera = camera_prim is not None  # the RenderSettings' camera
    camera, lights, ambient, spheres, meshes, cameras = None, [], [], [], [], []
    environments: list[Environment] = []  # textured domes that can be the environment
    # Each light and gprim is read through ``parts``: anew, or replayed from a stage's first read.
    materials = parts.materials(ctx)
    parts.start(ctx, (lights, ambient, spheres, meshes, environments))

    it = iter(Usd.PrimRange(stage.GetPseudoRoot(), Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)))
    renderable = _Renderable(ctx)
    instancing = Instancing(
        ctx,
        lambda prim, world, spheres, meshes: _gprim(ctx, prim, world, materials, spheres, meshes),
        lambda: _Renderable(ctx),
        materials,
    )
    for prim in it:
        if not renderable(prim):
            it.PruneChildren()
            continue
        _warm_transform(ctx, prim)
        if prim.IsInstance() and instancing.keeps_instanced(prim):
            it.PruneChildren()  # the prototype is read once, for every instance
            parts.read(prim, lambda: instancing.instance(prim, ctx.world(prim)), keep=False)
        elif prim.IsA(UsdGeom.Camera):
            cameras.append(str(prim.GetPath()))
            if camera_prim is None:
                camera_prim = prim
        elif prim.HasAPI(UsdLux.LightAPI):
            parts.read(prim, lambda: read_light(ctx, prim, lights, ambient, environments))
        elif prim.IsA(UsdGeom.PointInstancer):
            it.PruneChildren()  # its prototypes may be anywhere: read at every time
            parts.read(prim, lambda: instancing.instancer(prim, ctx.world(prim)), keep=False)
        elif prim.IsA(UsdGeom.Gprim):
            parts.read(prim, lambda: _gprim(ctx, prim, ctx.world(prim), materials, spheres, meshes))

    if chosen is not None:
        camera_prim = choose_camera(ctx, chosen, cameras)
    elif len(cameras) > 1 and not named_camera:
        ctx.warn(
            f"the stage has {len(cameras)} cameras ({', '.join(cameras[:5])}{' ...' if len(cameras) > 5 else ''}) "
            f"and none is chosen: using the first, {camera_prim.GetPath()} (choose one with --camera PATH, or "
            "a RenderSettings camera)"
        )
    instances = instancing.build(spheres, meshes)
    if camera_prim is not None:
        camera = read_camera(ctx, camera_prim)
        if camera is not None:
            settings = conform_to_aperture(ctx, camera_prim, settings)
    ambient_color = tuple(float(sum(a.color[i] for a in ambient)) for i in range(3)) if ambient else (0.0, 0.0, 0.0)
    environment = None
    if (
        ambient
        and settings.background == RenderSettings().background
        and any(o.material.reflects or o.material.transmits for o in (*spheres, *meshes))
    ):
        # A DomeLight is the environment at infinity: what a mirror or a glass (and a camera ray
        # that misses) sees there, as every USD renderer shows it. Only scenes with secondary rays
        # (and no phong:background of their own) get it, so that no other image changes. A
        # textured dome, the only one, is seen texel by texel (model Environment); otherwise
        # the domes' summed radiance (a textured one's mean) is the background colour.
        if len(ambient) == 1 and len(environments) == 1 and environments[0].source == ambient[0].source:
            environment = environments[0]
        else:
            settings = replace(settings, background=ambient_color)
            for e in environments:
                ctx.unsupported["textured DomeLights beside other DomeLights (their mean is the background)"].append(
                    e.source
                )
    scene = Scene(
        camera=camera or Camera(),
        ambient=AmbientLight(ambient_color, ambient[0].source if len(ambient) == 1 else ""),
        lights=tuple(lights),
        spheres=tuple(s for s in spheres if not isinstance(s, Points)),
        meshes=tuple(m for m in meshes if not isinstance(m, Intrinsic)),
        intrinsics=tuple(m for m in meshes if isinstance(m, Intrinsic)),
        settings=settings,
        source_file=file,
        instances=instances,
        points=tuple(s for s in spheres if isinstance(s, Points)),
        environment=environment,
    )
    if camera is None:
        scene = replace(scene, camera=framing_camera(scene))
        ctx.warn("no camera: using a default framing camera (phongscene.scene.framing_camera)")
    if not lights:
        scene = replace(scene, lights=(head_light(scene.camera),))
        ctx.warn("no point, distant or area light: using a head light at the camera (phongscene.scene.head_light)")
    scene = link_lights(ctx, stage, scene)
    warn_single_sided(ctx, stage, scene)
    warn_clipping_lights(ctx, scene)
    ctx.flush_unsupported()

    # Validation of the model, in the file's terms. The reader replaced each value it found wrong
    # by its default, so the model does not report it again; a problem both found on the same
    # attribute is listed once.
    reported = {(p.prim, p.attribute) for p in ctx.problems}
    found = [in_usd_terms(p) for p in validate(scene)]
    problems = ctx.problems + [p for p in found if (p.prim, p.attribute) not in reported]
    if problems:
        raise SceneError(problems)
    return ReadResult(scene, ctx.warnings, ctx.nodes, cameras)


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
        said = (
            f"time {time:g} is outside the stage's time codes {start:g} to {end:g}: USD holds the nearest sample"
            if outside
            else ""
        )
        return Usd.TimeCode(float(time)), said
    # A range alone animates nothing (49 public files author start/end codes and no sample):
    # such a stage reads the same at every time, so it is read at its start without a word.
    if ranged and end > start and _earliest_time_sample(stage) is not None:
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
    message = (specific or messages or [text.strip()])[-1].strip()
    # USD quotes the offending bytes: a control character among them (a fuzzed '#usda\x1c1.0'
    # header) would break our one error line in two (str.splitlines splits at \x1c), so escaped.
    message = "".join(c if c.isprintable() else repr(c)[1:-1] for c in message)
    if len(message) > MAX_USD_MESSAGE_CHARS:  # a corrupt crate lists every invalid spec: the start says it
        message = message[:MAX_USD_MESSAGE_CHARS] + f"... ({len(message) - MAX_USD_MESSAGE_CHARS} more characters)"
    return message


# USD's message about a file it cannot open, at most this long in our one error line (a corrupt
# .usdz listed 2,900 characters of "spec ... has invalid spec type"; the first specs say it).
MAX_USD_MESSAGE_CHARS = 400


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


# -- geometry -------------------------------------------------------------------------------


def _gprim(
    ctx: ReadContext, prim: Usd.Prim, world: np.ndarray, materials: MaterialReader, spheres: list, meshes: list
) -> None:
    type_name = prim.GetTypeName()
    path = str(prim.GetPath())
    if type_name not in _GEOMETRY_TYPES:
        ctx.unsupported["unsupported geometry (ignored)"].append(f"{path} ({type_name})")
        return
    # A projective transform (a matrix whose last column, in USD's row-vector convention, is not
    # 0 0 0 1) maps points by a division by w, which neither backend's geometry can carry. Products
    # of affine matrices keep that column exactly, so the comparison is exact.
    if np.all(np.isfinite(world)) and not np.array_equal(world[3], [0.0, 0.0, 0.0, 1.0]):
        ctx.problem(
            prim,
            "xformOpOrder",
            "the world transform is projective (its matrix's last column is "
            f"{tuple(float(x) for x in world[3])}, not (0, 0, 0, 1)): only affine transforms can be rendered",
        )
        return
    material = materials.for_gprim(prim)
    if material.source in materials.cut_out:
        # UsdPreviewSurface's opacityThreshold above its constant opacity: nothing of it is hit,
        # by any ray, so neither backend is given the surface.
        ctx.nodes.append((path, "cut out (opacity below opacityThreshold)"))
        return
    if type_name != "Mesh" and material.textures:
        # Only meshes carry st primvars here: the texture's fallback colour is used.
        ctx.unsupported["textures on prims without texture coordinates (the fallback colour is used)"].append(path)
        material = material.without_textures()
    if type_name == "Sphere":
        spheres.append(geometry.sphere(ctx, prim, world, material))
        ctx.nodes.append((path, "Sphere"))
        return
    if type_name == "Points":
        placed = geometry.points(ctx, prim, world, material)
        if isinstance(placed, Points):  # the scene takes it out of the spheres' list (in _read)
            spheres.append(placed)
        elif placed:  # ellipsoids under a non-uniform transform: a Sphere each
            spheres.extend(placed)
        ctx.nodes.append((path, f"Points ({len(placed) if placed else 0} spheres)"))
        return
    if type_name == "BasisCurves":
        tubes = curves.basis_curves(ctx, prim, world, material)
        meshes.extend(tubes)  # Intrinsics join the meshes' list, as below
        ctx.nodes.append((path, f"BasisCurves ({len(tubes)} tube segments)"))
        return
    if type_name == "Mesh":
        subsets = materials.face_subsets(prim)
        textured = [m for m in (material, *(m for _, m, _ in subsets)) if m.textures]
        st = materials.st_of.get(textured[0]) if textured else None
        if len({materials.st_of.get(m) for m in textured}) > 1:
            ctx.warn(f"{path}: its materials read different st primvars; all use {st.primvar!r}")
        built = geometry.mesh(ctx, prim, world, material, subsets, st)
    elif type_name in TWO_RADIUS_TYPES or not geometry.tessellated(ctx, prim):
        if type_name in TWO_RADIUS_TYPES and geometry.tessellated(ctx, prim):
            ctx.unsupported[f"{TESSELLATE} on {type_name} (the exact surface is traced)"].append(path)
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
