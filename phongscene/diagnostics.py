# SPDX-License-Identifier: Apache-2.0
"""Images that explain themselves: after a render, a warning when nothing is in view, when no
light reaches what the camera sees, and when the image is too dark (with the exposure change that
would fit, as the reader's too-bright warning has), each naming its cause where the scene shows it.

Two steps, so that a caller may free the scene before it renders (the CLI does, for memory):

- ``ImageChecks.of(scene, settings, reader_warnings)`` looks at the model before the render, with
  cheap checks only: each object's bounds against the camera's view (behind it, beside it, or so far
  that the scene spans less than a pixel), each light against the geometry (below every surface,
  inside a sphere, a cone or a RectLight facing away, a radius larger than the scene, how bright it
  makes a white surface, an input the reader warned is misspelt) and the materials (all black).
  It keeps what it found, a few strings and numbers.
- ``checks.warnings(image)`` then reads the image's statistics: which pixels show anything (differ
  from the background), how many are black, how bright the brightest of what the camera sees is;
  and returns the warnings, each with the model's causes.

The reader's warnings are text; a misspelt light input is recognised by the wording of
``phongscene.usd.typos`` (``/Light.inputs:intensty: not an input of SphereLight (ignored) (did you
mean inputs:intensity?)``), which tests/test_diagnostics.py holds to.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from .scene import DirectionalLight, RectAreaLight, RenderSettings, Scene, SphereAreaLight, row_blocks

# A pixel is black when an sRGB PNG stores it as 0: its largest channel encodes below half a code
# step, 0.5/255, which on the sRGB curve's linear segment (slope 12.92) is this linear value.
BLACK_RADIANCE = 0.5 / 255 / 12.92
# An image is too dark when the brightest of what the camera sees stays 4 stops under white: an
# sRGB PNG shows it at code 71/255 at most, which reads as near-black on a screen, and no scene
# of this project (lit as a Phong scene is, to about white) keeps its highlights that low.
DARK_RADIANCE = 2.0**-4
# "The brightest of what the camera sees": this percentile of the largest channel over the pixels
# that show anything, so a few hot pixels (a highlight's centre, an anti-aliased edge) do not
# hide a dark image; "the brightest 1 %" in the warnings.
BRIGHT_PERCENTILE = 99.0
# The exposure hint brings that brightest 1 % to white, as the reader's hint brings a clipping
# light's median to 1.
EXPOSURE_TARGET = 1.0
# A dark image with no single cause names the light and the materials together when a surface of
# the most reflective material, facing the brightest light, would return less than this many
# times DARK_RADIANCE (two stops): surfaces the light meets at an angle (cos θ ~ 0.5-0.7), the
# usual case in a view, then stay near or under DARK_RADIANCE.
DIM_LIGHT_ON_GREY = 4.0
# A scene whose bounds span less than this many pixels across is too far away to be seen.
SUBPIXEL_SPAN = 1.0
# An area light larger than the scene's bounding sphere (radius ratio) is named as a cause of a
# dark image: with inputs:normalize its intensity is spread over its area, so a light sized in
# metres in a centimetre scene is dim by the square of 100.
HUGE_LIGHT_RATIO = 1.0
# Points of the geometry sampled to judge what a light reaches (as the reader's clip warning
# samples: a fixed, evenly spaced selection, deterministic).
SAMPLE_POINTS = 1024

# The reader's warning for a light input no schema defines (phongscene.usd.typos.check_names).
_TYPO = re.compile(
    r"^(?P<prim>/\S*?)\.(?P<name>inputs:\S+): not an input of \S+ \(ignored\)"
    r"(?: \(did you mean (?P<meant>\S+)\?\))?$"
)


@dataclass(frozen=True)
class ImageChecks:
    """What the model says about the image to come (``of``), and the checks of it (``warnings``)."""

    background: tuple[float, float, float]
    nothing_in_view: str = ""  # why the camera sees no object ("" when it may see one)
    causes: tuple[str, ...] = ()  # what in the scene makes what the camera sees dark
    light_count: int = 0
    # Rays that miss see the environment (model Environment), not the background colour: every
    # pixel shows something, and which show an object cannot be told from their colour.
    environment: bool = False

    @staticmethod
    def of(scene: Scene, settings: RenderSettings | None = None, reader_warnings=()) -> ImageChecks:
        """The checks of an image of ``scene`` rendered with ``settings`` (default: the scene's);
        ``reader_warnings``: the USD reader's (they name misspelt light inputs)."""
        settings = scene.settings if settings is None else settings
        # Heuristics over a valid but possibly extreme scene (a degenerate light, a huge
        # intensity): an overflow or 0/0 there makes a check inconclusive (inf, nan compare
        # false), never a warning or an error of its own.
        with np.errstate(all="ignore"):
            spheres = _Spheres.of(scene)
            boxes = _object_bounds(scene, spheres)
            causes = (
                _camera_causes(scene, spheres)
                + _light_causes(scene, boxes, spheres, reader_warnings)
                + _material_causes(scene)
            )
            if not causes:  # no one cause: a dim light and grey surfaces together?
                causes = _light_and_material_cause(scene, spheres)
            nothing_in_view = _nothing_in_view(scene, settings, boxes)
        return ImageChecks(
            background=tuple(map(float, settings.background)),
            nothing_in_view=nothing_in_view,
            causes=tuple(causes),
            light_count=len(scene.lights),
            environment=scene.environment is not None,
        )

    def model_warnings(self) -> list[str]:
        """What the model alone shows (for ``compile``, which renders nothing): nothing in view."""
        return [f"nothing in view: {self.nothing_in_view}"] if self.nothing_in_view else []

    def warnings(self, image) -> list[str]:
        """The warnings for ``image`` (linear (H, W, 3), as rendered): nothing in view, no light
        on what the camera sees, or too dark; [] for an image that shows a lit scene."""
        pixels = np.asarray(image, dtype=np.float32)
        largest = pixels.max(axis=2)
        black = 100.0 * float(np.count_nonzero(largest < BLACK_RADIANCE)) / largest.size
        if self.environment:
            shows = np.ones(largest.shape, dtype=bool)
        else:
            shows = np.any(pixels != np.asarray(self.background, dtype=np.float32), axis=2)
        if self.nothing_in_view:
            seen = 0 if self.environment else int(np.count_nonzero(shows))
            detail = f" ({seen} of {largest.size} pixels show anything)" if seen else ""
            return [f"nothing in view{detail}: {self.nothing_in_view}"]
        bright = _percentile(largest[shows], BRIGHT_PERCENTILE) if shows.any() else 0.0
        if bright >= DARK_RADIANCE:
            return []
        if bright == 0:
            what = f"no light reaches what the camera sees: {black:.3g} % of the image is black"
        elif bright < BLACK_RADIANCE:
            what = (
                f"what the camera sees is black: {black:.3g} % of the image is black (the brightest 1 % of what "
                f"the camera sees reaches {bright:.2g}, which a PNG stores as 0)"
            )
        else:
            what = (
                f"the image is too dark: {black:.3g} % of it is black and the brightest 1 % of what the camera "
                f"sees reaches {bright:.2g} (sRGB {_srgb_code(bright)}/255)"
            )
        if bright > 0:
            what += (
                f"; inputs:exposure {math.log2(EXPOSURE_TARGET / bright):+.2f} on every light would bring it "
                f"to {EXPOSURE_TARGET:g}"
            )
        causes = self.causes or (
            "no cause found in the camera, the lights or the materials (shadows? surfaces "
            "that face away from every light?)",
        )
        return [f"{what}. " + "; ".join(causes)]


def explain_image(scene: Scene, image, settings: RenderSettings | None = None, reader_warnings=()) -> list[str]:
    """The warnings for ``image``, a render of ``scene`` with ``settings``: ``ImageChecks`` in one step."""
    return ImageChecks.of(scene, settings, reader_warnings).warnings(image)


# ----------------------------------------------------------------------------------------------
# The model's side


def _percentile(values: np.ndarray, q: float) -> float:
    """The ``q``-th percentile (nearest rank) of ``values``, with np.partition: np.percentile
    and np.median import numpy.ma, which a render's start-up does without (issue 15)."""
    k = min(len(values) - 1, max(0, math.ceil(q / 100 * len(values)) - 1))
    return float(np.partition(values, k)[k])


def _srgb_code(linear: float) -> int:
    """The 8-bit sRGB code a PNG stores for ``linear`` (the sRGB transfer curve)."""
    encoded = 12.92 * linear if linear <= 0.0031308 else 1.055 * linear ** (1 / 2.4) - 0.055
    return int(round(255 * min(1.0, max(0.0, encoded))))


@dataclass(frozen=True)
class _Spheres:
    """The scene's spheres as arrays (a Points prim may make a million of them): their
    ``world_from_object`` matrices (N, 4, 4) and names."""

    matrices: np.ndarray
    names: tuple[str, ...]
    points: tuple = ()  # the scene's Points sets (centres and radii: no matrices)

    @staticmethod
    def of(scene: Scene) -> _Spheres:
        points = tuple(getattr(scene, "points", ()))
        if not scene.spheres:
            return _Spheres(np.zeros((0, 4, 4)), (), points)
        return _Spheres(
            np.stack([s.world_from_object for s in scene.spheres]), tuple(s.source for s in scene.spheres), points
        )

    def containing(self, point) -> list[str]:
        """The names of the spheres ``point`` is inside of."""
        p = np.asarray(point, dtype=np.float64)
        out = []
        if len(self.matrices):
            offset = p - self.matrices[:, :3, 3]
            local = np.linalg.solve(self.matrices[:, :3, :3], offset[:, :, None])[:, :, 0]
            out = [self.names[i] or "a sphere" for i in np.flatnonzero((local**2).sum(axis=1) < 1.0)]
        for group in self.points:
            inside = sum(
                np.count_nonzero(((p - c) ** 2).sum(axis=1) < r**2) for c, r in row_blocks(group.centers, group.radii)
            )
            out += [group.source or "a points set"] * int(inside)
        return out

    def sample_points(self, about: int) -> np.ndarray:
        """Every ``stride``-th row (stride = max(1, rows // about)) of the spheres' centres, then
        their tops (object +Y poles), then each Points set's centres and tops, all in a row. Only
        the rows taken are made: the whole arrays of a 3M-point set were 290 MB at the render's
        peak (benchmarks/README.md, memory per point)."""
        centres = self.matrices[:, :3, 3]
        parts = [(len(centres), lambda i: centres[i]), (len(centres), lambda i: centres[i] + self.matrices[i, :3, 1])]
        for group in self.points:
            parts += [
                (len(group), lambda i, g=group: g.centers[i]),
                (len(group), lambda i, g=group: g.centers[i] + g.radii[i, None] * (0.0, 1.0, 0.0)),
            ]
        stride = max(1, sum(n for n, _ in parts) // about)
        out, offset = [], 0
        for n, rows in parts:
            first = -offset % stride  # the first row of this part on the stride
            out.append(rows(np.arange(first, n, stride)))
            offset += n
        return np.concatenate(out)


def _object_bounds(scene: Scene, spheres: _Spheres) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """(lows (N, 3), highs (N, 3), names) of every object's world-space bounds."""
    meshes = [m for m in scene.meshes if len(m.points)]
    lows = [np.array([m.points.min(axis=0) for m in meshes]).reshape(-1, 3)]
    highs = [np.array([m.points.max(axis=0) for m in meshes]).reshape(-1, 3)]
    if len(spheres.matrices):
        # Exact bounds of an affinely mapped unit sphere: centre ± the row norms of its 3×3 part.
        centres, radii = spheres.matrices[:, :3, 3], np.sqrt((spheres.matrices[:, :3, :3] ** 2).sum(axis=2))
        lows.append(centres - radii)
        highs.append(centres + radii)
    names = [m.source for m in meshes] + list(spheres.names)
    # Exact surfaces (Cube, Cylinder, Capsule, tubes of curves, ...); an infinite plane has none.
    finite = [(shape, shape.world_bounds()) for shape in scene.intrinsics]
    finite = [(shape, b) for shape, b in finite if b is not None]
    if finite:
        lows.append(np.array([b[0] for _, b in finite]))
        highs.append(np.array([b[1] for _, b in finite]))
        names.extend(shape.source for shape, _ in finite)
    for group in spheres.points:
        b = group.bounds()
        if b is not None:
            lows.append(b[0][None])
            highs.append(b[1][None])
            names.append(group.source)
    for group in getattr(scene, "instances", ()):
        boxes = _copy_boxes(group)
        if boxes is not None:
            lows.append(boxes[0] - boxes[1])
            highs.append(boxes[0] + boxes[1])
            names.extend([group.source] * len(group))
    return np.concatenate(lows), np.concatenate(highs), names


def _copy_boxes(group) -> tuple[np.ndarray, np.ndarray] | None:
    """(centres (K, 3), half sizes (K, 3)) of the world-space box of each copy of an
    ``Instances`` group (its prototype's box under each transform), or None without points."""
    b = group.prototype.bounds()
    if b is None or not len(group):
        return None
    centre, half = (b[0] + b[1]) / 2, (b[1] - b[0]) / 2
    a = group.world_from_prototype[:, :3, :3]
    return np.einsum("kij,j->ki", a, centre) + group.world_from_prototype[:, :3, 3], np.einsum(
        "kij,j->ki", np.abs(a), half
    )


def _vector(v) -> str:
    """A point or direction to 3 digits, rounding away what is rounding error beside its largest
    coordinate (a rotation's 1e-16) and the sign of zero."""
    v = np.asarray(v, dtype=np.float64)
    v = np.where(np.abs(v) < 1e-9 * max(float(np.max(np.abs(v))), 1e-300), 0.0, v) + 0.0
    return "(" + ", ".join(f"{float(c):.3g}" for c in v) + ")"


def _nothing_in_view(scene: Scene, settings: RenderSettings, boxes) -> str:
    """Why the camera sees no object, or "" when it may see one. Each object's bounds are tested
    against the view's planes (out when all 8 corners are beyond one: a conservative test, so a
    reason given is certain); the objects in view must together span a pixel."""
    lows, highs, _ = boxes
    if not len(lows):
        # An infinite plane has no bounds but is in view of nearly any camera: no verdict.
        return "" if any(shape.infinite for shape in scene.intrinsics) else "the scene has no geometry"
    cam = scene.camera
    eye = np.asarray(cam.position, dtype=np.float64)
    forward, up, right = (np.asarray(v, dtype=np.float64) for v in (cam.forward, cam.up, cam.right))
    pick = np.array([[(i >> axis) & 1 for axis in range(3)] for i in range(8)], dtype=bool)  # the 8 corners
    corners = np.where(pick[None, :, :], highs[:, None, :], lows[:, None, :]) - eye
    z, x, y = corners @ forward, corners @ right, corners @ up
    aspect = settings.height / settings.width
    perspective = cam.projection == "perspective"
    if perspective:
        half_x = math.tan(math.radians(cam.horizontal_fov_deg) / 2)
        reach_x, reach_y = z * half_x, z * half_x * aspect
    else:
        half_x = cam.ortho_width / 2
        reach_x = reach_y = np.full_like(z, half_x)
        reach_y = reach_y * aspect
    behind = np.all(z <= 0, axis=1)
    outside = (
        behind
        | np.all(x > reach_x, axis=1)
        | np.all(x < -reach_x, axis=1)
        | np.all(y > reach_y, axis=1)
        | np.all(y < -reach_y, axis=1)
    )
    lo, hi = lows.min(axis=0), highs.max(axis=0)
    centre = (lo + hi) / 2
    where = f"the camera{' ' + cam.source if cam.source else ''} at {_vector(eye)} looks along {_vector(forward)}"
    to_centre = centre - eye
    off_axis = math.degrees(
        math.acos(max(-1.0, min(1.0, float(to_centre @ forward) / max(np.linalg.norm(to_centre), 1e-300))))
    )
    if np.all(behind):
        return (
            f"the camera faces away from every object, all of them are behind it ({where}; the scene's centre "
            f"{_vector(centre)} is {off_axis:.0f}° off its view axis)"
        )
    if np.all(outside):
        if perspective:
            view = f"the view spans {cam.horizontal_fov_deg:.3g}° across"
            off = f"{off_axis:.0f}° off its view axis"
        else:
            view = f"the view is {cam.ortho_width:.3g} units wide"
            off = f"{float(np.linalg.norm(to_centre - (to_centre @ forward) * forward)):.3g} units off its view axis"
        return f"every object is outside the view ({where}; {view}, the scene's centre {_vector(centre)} is {off})"
    # The objects that may be in view, together: too far to span a pixel?
    inside = ~outside
    lo, hi = lows[inside].min(axis=0), highs[inside].max(axis=0)
    centre, radius = (lo + hi) / 2, float(np.linalg.norm(hi - lo)) / 2
    distance = float(np.linalg.norm(centre - eye))
    if perspective:
        if distance <= radius:
            return ""  # the camera is among the objects
        span = radius * settings.width / (distance * half_x)
    else:
        span = 2 * radius * settings.width / cam.ortho_width
    if span >= SUBPIXEL_SPAN:
        return ""
    hint = ""
    if perspective:
        half = min(math.atan(half_x), math.atan(half_x * aspect))
        hint = f"; a camera {radius / math.sin(half):.3g} units from its centre would frame it"
    return (
        f"the scene is too far from the camera to be seen: its bounds (radius {radius:.3g}, centre "
        f"{_vector(centre)}) are {distance:.3g} units away and span {span:.2g} pixel across{hint}"
    )


def _camera_causes(scene: Scene, spheres: _Spheres) -> list[str]:
    """The camera inside a sphere: it sees the sphere's inside, where no light outside reaches."""
    inside = spheres.containing(scene.camera.position)
    return (
        [f"the camera is inside {inside[0]}" + (f" (and {len(inside) - 1} more spheres)" if len(inside) > 1 else "")]
        if inside
        else []
    )


def _sample_points(scene: Scene, spheres: _Spheres) -> np.ndarray:
    """Points of the geometry (mesh points, evenly strided to about SAMPLE_POINTS; the centres
    and tops of the spheres, likewise), as the reader's clip warning samples them."""
    groups = [g for g in getattr(scene, "instances", ()) if _copy_boxes(g) is not None]
    parts = len(scene.meshes) + (1 if len(spheres.matrices) or spheres.points else 0) + len(groups)
    per_part = max(1, SAMPLE_POINTS // max(1, parts))
    points = [m.points[:: max(1, len(m.points) // per_part)] for m in scene.meshes if len(m.points)]
    if len(spheres.matrices) or spheres.points:
        points.append(spheres.sample_points(per_part))
    for group in groups:  # each copy's centre
        centres = _copy_boxes(group)[0]
        points.append(centres[:: max(1, len(centres) // per_part)])
    return np.concatenate(points) if points else np.zeros((0, 3))


def white_radiance(light, points: np.ndarray) -> np.ndarray:
    """The radiance each of ``points`` gets from ``light`` on a white Lambert surface facing it,
    shadows ignored: ``irradiance / π`` (the light's falloff, a spot's cone and a RectLight's
    one-sided emission applied)."""
    colour = float(np.max(light.color)) * light.diffuse
    if isinstance(light, DirectionalLight):
        return np.full(len(points), colour / math.pi)
    centre = np.asarray(getattr(light, "position", getattr(light, "center", None)), dtype=np.float64)
    to_point = points - centre
    d2 = np.maximum((to_point**2).sum(axis=1), 1e-300)
    irradiance = np.full(len(points), colour) if light.falloff == "none" else colour / d2
    cone = getattr(light, "cone", None)
    if cone is not None:
        cos = (to_point @ np.asarray(cone.axis, dtype=np.float64)) / np.sqrt(d2)
        t = np.clip((cos - cone.cos_outer) / max(cone.cos_inner - cone.cos_outer, 1e-300), 0.0, 1.0)
        irradiance = irradiance * t * t * (3 - 2 * t) * np.maximum(cos, 0.0) ** cone.focus
    if isinstance(light, RectAreaLight) and light.falloff == "inverse-square":
        normal = -np.cross(np.asarray(light.axis_u, dtype=np.float64), np.asarray(light.axis_v, dtype=np.float64))
        irradiance = irradiance * np.maximum(to_point @ (normal / np.linalg.norm(normal)) / np.sqrt(d2), 0.0)
    return irradiance / math.pi


def _typos(reader_warnings) -> dict[str, list[tuple[str, str | None]]]:
    """prim path → [(misspelt input, the input meant or None)] from the reader's warnings."""
    found: dict[str, list[tuple[str, str | None]]] = {}
    for text in reader_warnings:
        m = _TYPO.match(text)
        if m:
            found.setdefault(m["prim"], []).append((m["name"], m["meant"]))
    return found


def _light_causes(scene: Scene, boxes, spheres: _Spheres, reader_warnings) -> list[str]:
    """What about each light makes the surfaces dark (see the module's doc)."""
    lows, highs, _ = boxes
    if not scene.lights:
        return ["the scene has no lights" + (" (only ambient light)" if any(scene.ambient.color) else "")]
    if not len(lows):
        return []
    points = _sample_points(scene, spheres)
    lo, hi = lows.min(axis=0), highs.max(axis=0)
    scene_radius = float(np.linalg.norm(hi - lo)) / 2
    eye_height = float(scene.camera.position[1])
    typos = _typos(reader_warnings)
    causes = []
    for i, light in enumerate(scene.lights):
        name = light.source or f"light {i}"
        said = []
        for typo, meant in typos.get(light.source, ()) if light.source else ():
            if meant:
                said.append(
                    f"{name} has no {meant} ({name}.{typo} is not an input: did you mean {meant}?)"
                    + (", so it has UsdLux's default intensity 1" if meant == "inputs:intensity" else "")
                )
            else:
                said.append(f"{name}.{typo} is not an input of the light (ignored)")
        position = (
            None
            if isinstance(light, DirectionalLight)
            else np.asarray(getattr(light, "position", getattr(light, "center", None)), dtype=np.float64)
        )
        if position is not None and position[1] < lo[1] and eye_height > lo[1]:
            said.append(
                f"{name} is below every surface (y = {position[1]:.3g}, the lowest at y = {lo[1]:.3g}): "
                "only their undersides face it, and the camera is above them"
            )
        if isinstance(light, DirectionalLight) and light.direction[1] > 0 and eye_height > lo[1]:
            said.append(
                f"{name} shines upward (direction {_vector(light.direction)}): only the undersides of "
                "the surfaces face it, and the camera is above them"
            )
        inside = spheres.containing(position) if position is not None else []
        if inside:
            said.append(f"{name} is inside {inside[0]}, which hides it from everything outside")
        if isinstance(light, SphereAreaLight) and light.radius > HUGE_LIGHT_RATIO * scene_radius:
            said.append(
                f"{name} has a radius ({light.radius:.3g}) larger than the whole scene (bounding radius "
                f"{scene_radius:.3g}): a light sized in metres in a scene in centimetres? (with inputs:normalize "
                "its intensity is divided by its area)"
            )
        if isinstance(light, RectAreaLight):
            size = max(float(np.linalg.norm(light.axis_u)), float(np.linalg.norm(light.axis_v)))
            if size > HUGE_LIGHT_RATIO * 2 * scene_radius:
                said.append(
                    f"{name} is larger ({size:.3g} across) than the whole scene ({2 * scene_radius:.3g} "
                    "across): a light sized in metres in a scene in centimetres? (with inputs:normalize its "
                    "intensity is divided by its area)"
                )
        radiance = white_radiance(light, points) if len(points) else np.zeros(0)
        if len(radiance) and not np.any(radiance > 0):
            if isinstance(light, RectAreaLight) and light.falloff == "inverse-square":
                said.append(f"{name} faces away from every object (a RectLight emits along its local −Z)")
            elif getattr(light, "cone", None) is not None:
                said.append(f"{name}'s cone points away from every object")
            elif light.diffuse == 0:
                said.append(f"{name} has inputs:diffuse = 0")
            else:
                said.append(f"{name} has intensity 0")
        elif len(radiance):
            median = float(np.partition(radiance, len(radiance) // 2)[len(radiance) // 2])
            if 0 < median < DARK_RADIANCE:
                said.append(
                    f"{name} lights a white surface to radiance {median:.2g} at the median point of the "
                    f"geometry: inputs:exposure {math.log2(EXPOSURE_TARGET / median):+.2f} would bring it to "
                    f"{EXPOSURE_TARGET:g}"
                )
        causes.extend(said)
    return causes


def _light_and_material_cause(scene: Scene, spheres: _Spheres) -> list[str]:
    """Neither the light nor the materials dark enough alone, the two together: the brightest
    light's white-surface radiance (at the median point of the geometry, as _light_causes takes
    it) times the largest diffuse reflectance kd·cd of any material, plus its ambient term, within
    DIM_LIGHT_ON_GREY of DARK_RADIANCE. (What a Phong surface facing that light returns by its
    diffuse and ambient terms, highlights aside; shadows ignored.)"""
    points = _sample_points(scene, spheres)
    if not scene.lights or not len(points):
        return []
    levels = [
        (float(np.partition(r, len(r) // 2)[len(r) // 2]), light)
        for light in scene.lights
        if len(r := white_radiance(light, points))
    ]
    brightest, light = max(levels, key=lambda level: level[0])
    objects = (*scene.spheres, *scene.meshes, *scene.points, *scene.intrinsics)
    materials = {id(o.material): o.material for o in objects}.values()
    ambient = float(np.max(scene.ambient.color))

    def colour(m) -> float:
        return max(
            float(np.max(m.diffuse_texture.image)) if m.diffuse_texture is not None else 0.0, max(m.diffuse_color)
        )

    best = max(materials, key=lambda m: (m.kd * brightest + m.ka * ambient) * colour(m), default=None)
    if best is None or not brightest > 0:
        return []
    most = (best.kd * brightest + best.ka * ambient) * colour(best)
    if not 0 < most < DIM_LIGHT_ON_GREY * DARK_RADIANCE:
        return []
    name = f"{light.source} (the brightest light)" if light.source else "the brightest light"
    return [
        f"{name} lights a white surface facing it to radiance {brightest:.2g} at the median point of the "
        f"geometry, and the most reflective material returns {100 * best.kd * colour(best):.0f} % of that "
        f"({best.source or 'a material'}: kd {best.kd:g} × diffuse colour {colour(best):.3g}): {most:.2g} at most "
        "with its ambient term, less where the light strikes at an angle — a dim light on grey surfaces"
    ]


def _material_causes(scene: Scene) -> list[str]:
    """Every material black: no light makes it brighter than black."""
    materials = {id(o.material): o.material for o in (*scene.spheres, *scene.meshes, *scene.points)}.values()
    if not materials:
        return []

    def reflects(m) -> float:
        cd = max(float(np.max(m.diffuse_texture.image)) if m.diffuse_texture is not None else 0.0, max(m.diffuse_color))
        cs = max(
            float(np.max(m.specular_texture.image)) if m.specular_texture is not None else 0.0, max(m.specular_color)
        )
        # A mirror or a glass shows what it reflects or transmits (kr, kt), not black.
        return (m.ka + m.kd) * cd + m.ks * cs + m.kr + m.kt

    if all(reflects(m) == 0 for m in materials):
        return ["every material is black (ka, kd, ks, kr and kt times their colours are 0)"]
    return []
