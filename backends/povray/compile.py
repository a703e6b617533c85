# SPDX-License-Identifier: Apache-2.0
"""Compile a ``Scene`` to POV-Ray 3.7 SDL: a pure, deterministic function ``Scene -> str``
(``compile_pov``), or written to a stream as it is compiled (``write_pov``).

The reference is ``docs/povray-3.7-semantics.md`` (cited as "ref §n"). Two mappings:

``classic`` (the ``povray-classic`` convention): one idiomatic, hand-editable texture per
material, ``pigment { rgb cd } finish { ambient ka diffuse kd/π phong ks phong_size e }``, light
colours ``ls·cl``, ``ambient_light La``; one render pass. Its known differences from the seed
model (README: the shading model), all of them POV-Ray's ``phong`` (ref §4):

* the highlight has no n·l factor: POV adds ``ks·(r·wo)^e·Lj``, the seed ``ks·cs·(r·wo)^e·Lj·(n·l)``;
* the highlight is in the light's colour, not in cs (cs is ignored);
* e = 0: ``phong_size 0`` gives ``ks`` wherever r·wo > 0 (the seed gives ks·cs·(n·l) there), and,
  like every highlight here, it is gated by n·l ≥ 1e-10 on the light side only;
* POV drops the highlight when phong_size >= 60 and r·wo <= 0.0008 (a 1e-186 effect).

``exact`` (the ``seed`` convention), to POV-Ray's output precision (half float), ref §12:

* cs through the average-texture trick (A): ``average`` of a diffuse texture (ambient 2·ka, diffuse
  2·kd/π) and a layered specular texture (phong 2·ks under filter layers), so each half counts once;
* the specular n·l through a filter layer (B) whose pigment is ``slope { point_at <light> }``
  (``slope { <direction to the light> }`` for a directional light). Its value v = ½ + asin(n·l)/π
  (measured, both forms, with the viewer-facing normal), and ``NdotL_Map`` turns v back into
  n·l = sin(π(v − ½)) with 128 linear segments: a relative error below (π/256)²/8 ≈ 1.9e-5;
* this is exact for one light only, so the SDL renders ONE PASS PER LIGHT as animation frames
  (``frame_number``); the caller sums the linear pass images. Pass 0 also carries the ambient term
  and the background; the other passes have ``ambient_light 0`` and a black background;
* area lights shade from their centre (ref §5), so (B) with the centre is exact for them too.

Common to both: ``#version 3.7`` and ``assumed_gamma 1.0`` (linear output, ref §1), an explicit
``ambient`` in every finish (the default is 0.1), floats printed exactly (``numbers.sdl_float``),
the camera as an explicit right-handed basis (ref §3 recipe (b)), spheres as ``sphere`` (uniform
scale) or a unit sphere with a ``matrix`` (POV's row-vector convention: the 3×3 part transposed,
then the translation), meshes as ``mesh2`` (float32 data, ref §7), directional lights as
``parallel`` lights placed outside the scene bounds (objects behind a parallel light's plane cast
no shadow, ref §5). Names from USD never reach SDL: identifiers are generated, and prim paths only
appear in ``//`` comments after ``sanitize_comment``.
"""

from __future__ import annotations

import dataclasses
import hashlib
import io
import math
from collections.abc import Iterable, Iterator
from dataclasses import astuple, dataclass, replace
from typing import TextIO

import numpy as np

from phongscene.containment import INSIDE_VECTOR
from phongscene.errors import Problem, SceneError
from phongscene.scene import (
    CHECKER_SHIFT,
    AmbientLight,
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
    Texture,
    TriangleMesh,
)

from .mappings import (  # noqa: F401  (also re-exported: importers of the compiler's names)
    MAPPING_OF_SPECULAR,
    MAPPINGS,
    SPECULAR_OF_MAPPING,
    check_mapping,
    resolve_mapping,
    specular_of,
)
from .numbers import NonFiniteNumber, float32_vectors, int_vectors, sdl_color, sdl_float, sdl_float32, sdl_vector

# NdotL_Map resolution: 2**7 linear segments over v in [1/2, 1] (at most 256 colour_map entries).
NDOTL_SEGMENTS = 128
# A parallel light sits this many scene radii (plus one unit) behind the scene centre, so that no
# object lies behind its plane; shadow rays stay far below POV's MAX_DISTANCE (1e7) for scenes
# within POV's working range (ref §6, §10).
PARALLEL_LIGHT_DISTANCE_RADII = 2.0

# UsdLux's inverse-square falloff (model falloff "inverse-square") has no exact POV-Ray form; POV's
# fade 2/(1 + (d/fd)²) with the colour scaled by 1/(2·fd²) is I/(d² + fd²): relative error
# (fd/d)². fd = this fraction of the scene's radius keeps that below 1e-6 (far below half
# precision, 2⁻¹¹) for every point farther than 1e-3 radii from the light.
INVERSE_SQUARE_FADE_RADII = 1e-6
# A rect light's one-sided Lambertian emission, cos θ from its emitting side, is POV-Ray's
# spotlight with radius = falloff = 90° (no smooth edge inside the hemisphere) and tightness 1,
# whose attenuation is cos θ¹ measured from the light's centre (checked against the native tracer
# in tests/cross/test_cross_backend.py).
LAMBERT_SPOTLIGHT = "spotlight radius 90 falloff 90 tightness 1"


def _native_only(compiler, light) -> None:
    """POV-Ray has no cells estimator (the native tracer's own): an error naming the light."""
    if light.cell_samples is not None:
        raise compiler._error(
            light,
            "cell_samples",
            "the cells shadow estimator is the native tracer's own; POV-Ray "
            "renders the grid or 'adaptive n' (unset phong:shadowCellSamples)",
        )


def _adaptive(light) -> str:
    """POV-Ray's ``adaptive n`` of an area light (absent: every grid point, its default)."""
    return "" if light.adaptive is None else f" adaptive {int(light.adaptive)}"


# Characters copied verbatim into a comment; everything else becomes \xNN / \uNNNN / \UNNNNNNNN.
# '#', '"', '*', '\\' and all control characters are escaped, so a comment can neither end early
# nor carry a directive.
_COMMENT_SAFE = frozenset("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789/_.:-[]<>(), =+@")


# The wrap rules as numpy pad modes: the image extended by whole tiles is exactly what the rule
# samples there (np.pad "symmetric" repeats the edge texel: a mirror about the image edge).
PAD_MODES = {"repeat": "wrap", "clamp": "edge", "mirror": "symmetric", "black": "constant"}
# The most texels a texture may grow to when it is tiled to cover the scene's uvs (below):
# 2^26 (400 MB as a half RGB EXR). Beyond, POV-Ray samples the image itself with ``once``.
MAX_TILED_TEXELS = 2**26


@dataclass(frozen=True)
class UvFrame:
    """How the SDL's uvs and images relate to the model's. POV-Ray has only repeat and ``once``
    (clamp inside [0, 1]², clear outside, ref §16); every USD wrap rule, per axis, is exact in
    POV-Ray when each image is extended, by its own rules (PAD_MODES), over a box that holds
    every textured uv with a margin beyond the bilinear footprint (so the outer edge, where
    ``once`` clamps, is never blended), the uvs are mapped into [0, 1]² by the affine
    u' = (u − u_lo)/u_span (which commutes with the barycentric interpolation of the uvs, so the
    lookup between texel centres is unchanged), and ``once`` is used. The box's edges are
    multiples of 1/g, g the greatest common divisor of the textures' sides along that axis, so
    that every image grows by whole texels. The identity frame (no extension, no ``once``) when
    every texture repeats on both axes."""

    g_u: int = 1  # the box along u: [lo_u/g_u, (lo_u + n_u)/g_u]
    lo_u: int = 0
    n_u: int = 1
    g_v: int = 1  # along v: [lo_v/g_v, (lo_v + n_v)/g_v]
    lo_v: int = 0
    n_v: int = 1

    @property
    def identity(self) -> bool:
        return (self.lo_u, self.n_u, self.lo_v, self.n_v) == (0, self.g_u, 0, self.g_v)

    @property
    def origin(self) -> tuple[float, float]:
        """The model's (u, v) at the SDL's (0, 0)."""
        return (self.lo_u / self.g_u, self.lo_v / self.g_v)

    @property
    def span(self) -> tuple[float, float]:
        """The model's uv extent of the SDL's [0, 1]²."""
        return (self.n_u / self.g_u, self.n_v / self.g_v)

    def apply(self, uvs: np.ndarray) -> np.ndarray:
        """The SDL's uvs of the model's ``uvs``."""
        if self.identity:
            return uvs
        return (uvs - np.array(self.origin)) / np.array(self.span)

    def tile(self, texture: Texture) -> np.ndarray:
        """The texture's image extended over the frame's box by its own wrap rules (the image
        itself covers [0, 1]², which the box contains)."""
        h, w = texture.height, texture.width
        per_u, per_v = w // self.g_u, h // self.g_v  # texels per 1/g
        cols = (-self.lo_u * per_u, (self.lo_u + self.n_u) * per_u - w)
        rows = ((self.lo_v + self.n_v) * per_v - h, -self.lo_v * per_v)  # row 0 is the top (v high)
        image = np.pad(texture.image, (rows, (0, 0), (0, 0)), mode=PAD_MODES[texture.wrap_t])
        return np.pad(image, ((0, 0), cols, (0, 0)), mode=PAD_MODES[texture.wrap_s])


def all_meshes(scene: Scene) -> tuple[TriangleMesh, ...]:
    """The world's meshes, then each prototype's (once, however many copies it has)."""
    return (*scene.meshes, *(m for p in scene.prototypes for m in p.meshes))


def _uv_mapped(m: PhongMaterial) -> tuple[Texture, ...]:
    """The textures the SDL looks up on a mesh's uvs: the colours' and the cut-out mask."""
    return (*m.colour_textures, *((m.opacity_texture,) if m.opacity_texture is not None else ()))


def uv_frame(scene: Scene) -> UvFrame:
    """The scene's UvFrame: identity if every texture repeats (or none is used), else the box
    around every textured mesh's uvs and [0, 1]², widened by 1/g on each side (beyond the half
    texel a bilinear lookup reaches), unless an extended image would exceed MAX_TILED_TEXELS
    (then identity: POV-Ray's ``once`` is exact for clamp and mirror inside [0, 1]² only)."""
    textured = [m for m in all_meshes(scene) if _uv_mapped(m.material) and m.uvs is not None and len(m.triangles)]
    textures = {id(t): t for m in (*scene.spheres, *all_meshes(scene)) for t in _uv_mapped(m.material)}
    if all((t.wrap_s, t.wrap_t) == ("repeat", "repeat") for t in textures.values()) or not textured:
        return UvFrame()
    used = np.concatenate([m.uvs[np.unique(m.uv_indices)] for m in textured])
    g_u = math.gcd(*(t.width for t in textures.values()))
    g_v = math.gcd(*(t.height for t in textures.values()))
    with np.errstate(over="ignore", invalid="ignore"):
        lo = np.minimum(np.floor(used.min(axis=0) * (g_u, g_v)), 0.0) - 1.0
        hi = np.maximum(np.ceil(used.max(axis=0) * (g_u, g_v)), (g_u, g_v)) + 1.0
        n = hi - lo
        growth = float(n[0] / g_u * n[1] / g_v)  # the area of the box, in images
        largest = max(t.width * t.height for t in textures.values())
        if not (np.all(np.isfinite(n)) and growth * largest <= MAX_TILED_TEXELS):
            return UvFrame()
    return UvFrame(g_u, int(lo[0]), int(n[0]), g_v, int(lo[1]), int(n[1]))


@dataclass(frozen=True, slots=True)
class PovImage:
    """The image POV-Ray reads for a texture: the texture's own, or extended over a UvFrame.
    Made only when its file is written (``pixels``), one at a time: a scene's textures can be
    gigabytes, and each extended copy is as large as its texture."""

    texture: Texture
    frame: UvFrame
    # A cut-out mask: the first channel in all three, so that the image_pattern's grey value
    # (0.297 r + 0.589 g + 0.114 b, in double, rounded to float) is that channel exactly.
    grey: bool = False

    def pixels(self) -> np.ndarray:
        image = self.texture.image if self.frame.identity else self.frame.tile(self.texture)
        return np.repeat(image[..., :1], 3, axis=2) if self.grey else image

    def file_name(self) -> str:
        """The file name it is written to beside the SDL: from a hash of the texels and of how
        they are extended (which determine the pixels), so that it is deterministic and scenes
        batched into one run share equal images. The texels are hashed in place, not copied."""
        image = np.ascontiguousarray(self.texture.image)
        digest = hashlib.sha1(memoryview(image).cast("B"))
        digest.update(repr(image.shape).encode("ascii"))
        if not self.frame.identity:
            t = self.texture
            digest.update(repr((astuple(self.frame), t.wrap_s, t.wrap_t)).encode("ascii"))
        if self.grey:
            digest.update(b"grey")
        return f"phongscene-texture-{digest.hexdigest()[:16]}.exr"


def pov_images(scene: Scene) -> tuple[UvFrame, dict[int, tuple[str, PovImage]]]:
    """The scene's UvFrame and, by ``id(texture)``, the file name and image POV-Ray reads for
    each texture (extended over the frame when its file is written); the environment's, by
    ``id(scene.environment)``."""
    frame = uv_frame(scene)
    out: dict[int, tuple[str, PovImage]] = {}
    for obj in (*scene.spheres, *all_meshes(scene)):
        for t in obj.material.colour_textures:
            if id(t) not in out:
                image = PovImage(t, frame)
                out[id(t)] = (image.file_name(), image)
    for mesh in all_meshes(scene):  # the cut-out masks, grey, by ("mask", id(texture))
        t = mesh.material.opacity_texture
        if t is not None and ("mask", id(t)) not in out:
            image = PovImage(t, frame, grey=True)
            out[("mask", id(t))] = (image.file_name(), image)
    if scene.environment is not None:  # the sky_sphere's lat-long map, never extended: by id(environment)
        image = PovImage(scene.environment.texture, UvFrame())
        out[id(scene.environment)] = (image.file_name(), image)
    return frame, out


def texture_files(scene: Scene) -> dict[str, PovImage]:
    """The image files the SDL of ``scene`` reads (``image_map``), by file name: write each
    image there as a half-float EXR (``PovJob.write_textures``) before rendering."""
    return dict(pov_images(scene)[1].values())


def sanitize_comment(text: str) -> str:
    """``text`` made safe for a ``//`` comment: printable ASCII from a fixed set, the rest escaped."""
    out = []
    for ch in text:
        if ch in _COMMENT_SAFE:
            out.append(ch)
        elif ord(ch) < 0x100:
            out.append(f"\\x{ord(ch):02x}")
        elif ord(ch) < 0x10000:
            out.append(f"\\u{ord(ch):04x}")
        else:
            out.append(f"\\U{ord(ch):08x}")
    return "".join(out)


def pass_count(scene: Scene, mapping: str) -> int:
    """Render passes (animation frames) the SDL of ``mapping`` needs: one per light for
    ``exact`` (at least one, which carries the ambient term), one for ``classic``."""
    return max(1, len(scene.lights)) if mapping == "exact" else 1


def pass_scenes(scene: Scene, mapping: str) -> tuple[Scene, ...]:
    """What each render pass of ``mapping`` draws, as scenes whose linear images add up to the
    picture: for ``exact`` with several lights, one light each, pass 0 with the ambient light and
    the background (or environment), the others with neither (as the SDL's ``#switch (Pass)``); else the scene."""
    if pass_count(scene, mapping) == 1:
        return (scene,)
    dark = AmbientLight((0.0, 0.0, 0.0), scene.ambient.source)
    if any(any(m.material.emission) for m in all_meshes(scene)[len(scene.meshes) :]):
        scene = scene.flattened()  # emissive prototype meshes: darkened below as world meshes
    # Emission, like the ambient term, is drawn once, in pass 0.
    unlit = {}
    for obj in scene.objects:
        if any(obj.material.emission):
            unlit.setdefault(obj.material, replace(obj.material, emission=(0.0, 0.0, 0.0)))
    dark_spheres = tuple(replace(s, material=unlit.get(s.material, s.material)) for s in scene.spheres)
    dark_meshes = tuple(replace(m, material=unlit.get(m.material, m.material)) for m in scene.meshes)
    dark_intrinsics = tuple(replace(m, material=unlit.get(m.material, m.material)) for m in scene.intrinsics)
    dark_points = tuple(replace(p, material=unlit.get(p.material, p.material)) for p in scene.points)
    return tuple(
        replace(
            scene,
            lights=(light,),
            ambient=scene.ambient if i == 0 else dark,
            settings=scene.settings if i == 0 else replace(scene.settings, background=(0.0, 0.0, 0.0)),
            environment=scene.environment if i == 0 else None,
            spheres=scene.spheres if i == 0 or not unlit else dark_spheres,
            meshes=scene.meshes if i == 0 or not unlit else dark_meshes,
            intrinsics=scene.intrinsics if i == 0 or not unlit else dark_intrinsics,
            points=scene.points if i == 0 or not unlit else dark_points,
        )
        for i, light in enumerate(scene.lights)
    )


def compile_pov(scene: Scene, settings: RenderSettings | None = None, mapping: str | None = None) -> str:
    """Compile ``scene`` to POV-Ray 3.7 SDL, as one string (``write_pov`` streams it to a file,
    which is what a large scene needs: its SDL can be gigabytes).

    Args:
        scene: a validated scene (``phongscene.compile_pov`` validates first; here only
            numbers that are not finite in the SDL are rejected).
        settings: render settings (only the image aspect ratio and the background enter the
            SDL); default ``scene.settings``.
        mapping: "exact" (the seed model, one pass per light) or "classic" (one idiomatic
            ``finish`` per material); default from ``settings.specular`` ("seed" → "exact",
            "povray-classic" → "classic").

    Returns:
        The SDL text. For "exact" it renders ``pass_count(scene, "exact")`` animation frames
        whose linear images sum to the picture (see ``run.render``).

    Raises:
        SceneError: a number is not finite in the SDL (naming the prim and model field).
    """
    out = io.StringIO()
    write_pov(out, scene, settings, mapping)
    return out.getvalue()


def write_pov(out: TextIO, scene: Scene, settings: RenderSettings | None = None, mapping: str | None = None) -> None:
    """Write ``scene``'s SDL (``compile_pov``'s text) to ``out`` as it is compiled: the file is
    never held whole in memory. On a ``SceneError`` part of it has been written: write to a
    temporary file (``phongscene.files.atomic_path``)."""
    settings = scene.settings if settings is None else settings
    mapping = resolve_mapping(settings, mapping)
    source = sanitize_comment(scene.source_file) if scene.source_file else "(built in Python)"
    passes = pass_count(scene, mapping)
    header = [
        f"// phongscene: POV-Ray 3.7 scene, {mapping} mapping, from {source}",
        f"// Render passes (animation frames): {passes}"
        + (", one per light: sum the linear images of all frames." if passes > 1 else "."),
        "#version 3.7;",
    ]
    if mapping == "exact":
        header.append("#declare Pass = frame_number;")
    _SdlLines(out).extend(header)
    write_body(out, scene, settings, mapping)


def write_body(out: TextIO, scene: Scene, settings: RenderSettings, mapping: str) -> None:
    """Everything after ``#version``, written to ``out``; the exact mapping switches on the
    identifier ``Pass`` (0-based), which the caller declares (``run`` batches several scenes in
    one file).

    The scene is not range-checked here (validation is the caller's job, and POV-Ray renders
    out-of-range coefficients faithfully), but every number is checked for being finite as it is
    written: a NaN or inf (also a derived one) raises ``SceneError`` naming the prim and field.
    """
    _Compiler(scene, settings, mapping, _SdlLines(out)).run()


# mesh2 lists are formatted this many rows at a time (a multiple of int_vectors' four entries a
# line, so the text is the same as formatting all rows at once): ~13 MB of numpy intermediates
# and text per slice, where a whole list took ~200 bytes a vertex (S2's 0.5M: 100 MB).
MESH_ROWS_PER_PIECE = 1 << 16

# A line longer than this many characters (a mesh's vertex block: hundreds of megabytes on the
# chess set) is written in pieces of it: a text file encodes what it is given into one bytes
# object, and this bounds that copy.
SDL_WRITE_CHUNK = 1 << 26


def _int_pieces(indices: np.ndarray) -> Iterator[str]:
    """(M, 3) indices as mesh2 text, MESH_ROWS_PER_PIECE rows a piece."""
    for start in range(0, len(indices), MESH_ROWS_PER_PIECE):
        yield int_vectors(indices[start : start + MESH_ROWS_PER_PIECE])


class _SdlLines:
    """The SDL's lines, written to a text stream as the compiler appends them (each followed by
    a newline): a list's ``append`` and ``extend`` without the list, so the SDL of a scene with
    millions of triangles is never held whole (it was: the lines, their join, and the header
    joined to that, 12 GB at the peak on the chess set)."""

    def __init__(self, out: TextIO):
        self.out = out

    def append(self, line: str) -> None:
        for start in range(0, len(line), SDL_WRITE_CHUNK):
            self.out.write(line[start : start + SDL_WRITE_CHUNK])
        self.out.write("\n")

    def extend(self, lines: Iterable[str]) -> None:
        for line in lines:
            self.append(line)

    def block(self, opening: str, pieces: Iterable[str], closing: str) -> None:
        """``opening``, the pieces joined by ",\\n" (a mesh2 list formatted a slice of rows at
        a time, so not even one mesh's list is held whole), and ``closing``, on lines of their own."""
        self.append(opening)
        for k, piece in enumerate(pieces):
            if k:
                self.out.write(",\n")
            for start in range(0, len(piece), SDL_WRITE_CHUNK):
                self.out.write(piece[start : start + SDL_WRITE_CHUNK])
        self.out.write("\n")
        self.append(closing)


class _Compiler:
    def __init__(self, scene: Scene, settings: RenderSettings, mapping: str, lines: _SdlLines):
        self.scene = scene
        self.settings = settings
        self.exact = mapping == "exact"
        self.lines = lines
        self.materials: dict[PhongMaterial, str] = {}
        # Lights with diffuse/specular multipliers other than 1: the exact mapping declares them
        # per pass (Light_Diffuse, Light_Specular) and every finish scales its terms by them.
        self.light_terms = self.exact and any((l.diffuse, l.specular) != (1.0, 1.0) for l in scene.lights)
        # The geometry's bounds (a pass over every mesh point), for placing parallel lights and
        # scaling the inverse-square fade: computed once, not once per light and pass.
        with np.errstate(over="ignore", invalid="ignore"):
            self.bounds = scene.bounds()
        self.uv_frame, self.images = pov_images(scene)
        # Emissive materials: the exact mapping declares Emission per pass (1 in pass 0, else 0),
        # as the emitted light, like the ambient term, is counted once.
        # Every material an object wears: the world's and the instances' prototypes' meshes.
        worn = [o.material for o in (*scene.objects, *all_meshes(scene)[len(scene.meshes) :])]
        self.emission = any(any(m.emission) for m in worn)
        # Materials some object wears where a light does not illuminate it (light linking): an
        # ambient-and-emission-only texture, Material_k_Unlit, is declared beside them.
        self.unlit_materials = {
            o.material for o in scene.objects if any(not light.linking.lights(o.source) for light in scene.lights)
        }
        # Secondary rays (ref §18): only a scene with a reflective material gets the depth limit
        # (max_trace_level = max_depth + 1) and adc_bailout 0 (no weight cut-off), so the SDL of
        # every other scene is unchanged.
        self.reflective = any(m.reflects or m.transmits for m in worn)

    def trace_settings(self) -> str:
        """The global_settings items of secondary rays ("" for a scene that traces none)."""
        if not self.reflective:
            return ""
        depth = self.settings.max_depth
        if not isinstance(depth, (int, np.integer)) or isinstance(depth, bool) or depth < 0:
            raise self._error(self.settings, "max_depth", f"must be a non-negative integer, got {depth!r}")
        return f" max_trace_level {int(depth) + 1}"

    def transparency(self, m: PhongMaterial) -> float:
        """att = 1 − kt, the factor POV-Ray puts on the ambient and diffuse terms of a pigment
        that transmits kt (ref §4, §18), which the finish divides back out (1 when opaque)."""
        self.coef(m.kt, m, "kt")
        if not m.transmits:
            return 1.0
        att = 1.0 - m.kt
        if att <= 0.0 and (m.ka > 0 or m.kd > 0):
            raise self._error(
                m,
                "kt",
                "kt = 1 with ambient or diffuse terms: POV-Ray scales those by 1 − kt, so it "
                "cannot show them (lower kt, or set ka = kd = 0 as for glass)",
            )
        return att if att > 0.0 else 1.0

    def interior(self, m: PhongMaterial) -> str:
        """The object's ``interior { ior }`` of a transmissive material ("" otherwise)."""
        if not (m.transmits or (m.fresnel and m.reflects)):
            return ""
        fade = ""
        if m.transmits and tuple(m.interior_filter) != (1.0, 1.0, 1.0):
            # Beer-Lambert cf^d is POV-Ray's exponential fade (fade_power >= 1000, ref §18)
            # exp(−(d/fd)(1 − C)) with fd = 1 and C = 1 + ln cf (POV-Ray takes C < 0 as it is).
            colour = 1.0 + np.log(np.asarray(m.interior_filter, dtype=np.float64))
            fade = f" fade_distance 1 fade_power 1001 fade_color {self.rgb(colour, m, 'interior_filter')}"
        return f" interior {{ ior {self.coef(m.ior, m, 'ior')}{fade} }}"

    def reflection(self, m: PhongMaterial, scale: float = 1.0) -> str:
        """The finish item of the mirror term kr·cr (ref §18: POV-Ray adds ``reflection`` to the
        pigment's terms, unweighted, as the book's PerfectSpecular), times ``scale``; "" without one."""
        self.coef(m.kr, m, "kr")
        self.rgb(m.reflective_color, m, "reflective_color")
        if not m.reflects:
            return ""
        colour = np.asarray(m.reflective_color, dtype=np.float64) * (m.kr * scale)
        if not m.fresnel:
            return f" reflection rgb {self.rgb(colour, m, 'reflective_color')}"
        # The dielectric (ref §18): POV-Ray reflects min + (max − min)·F and, with
        # conserve_energy, transmits (1 − F) of kt: the model's split when the mirror weight is 1.
        if m.transmits and (m.kr != 1.0 or tuple(m.reflective_color) != (1.0, 1.0, 1.0)):
            raise self._error(
                m,
                "kr",
                "a transmissive fresnel material needs kr = 1 and a white cr in POV-Ray "
                "(its conserve_energy takes 1 − F of the transmitted light only then)",
            )
        conserve = " conserve_energy" if m.transmits else ""
        return f" reflection {{ 0, rgb {self.rgb(colour, m, 'reflective_color')} fresnel on }}{conserve}"

    # -- numbers, with the prim named when one is not finite ---------------------------------

    def num(self, x: float, node, attribute: str) -> str:
        try:
            return sdl_float(x)
        except NonFiniteNumber as e:
            raise self._error(node, attribute, f"is not finite in the SDL ({e})") from None

    def vec(self, v, node, attribute: str) -> str:
        try:
            return sdl_vector(v)
        except NonFiniteNumber as e:
            raise self._error(node, attribute, f"is not finite in the SDL ({e})") from None

    # Colours and finish coefficients: POV-Ray stores them as float32 (ref §2), so they are
    # printed as the shortest decimal of that float32 (hand-editable, the same stored value).

    def coef(self, x: float, node, attribute: str) -> str:
        try:
            return sdl_float32(x)
        except NonFiniteNumber as e:
            raise self._error(node, attribute, f"is not finite in the SDL ({e})") from None

    def rgb(self, v, node, attribute: str) -> str:
        try:
            return sdl_color(v)
        except NonFiniteNumber as e:
            raise self._error(node, attribute, f"is not finite in the SDL ({e})") from None

    def _error(self, node, field: str, message: str) -> SceneError:
        source = getattr(node, "source", "")
        return SceneError(Problem(message, source, field, self.scene.source_file, node=type(node).__name__))

    def comment(self, node, kind: str, index: int) -> None:
        self.lines.append(self.comment_text(node, kind, index))

    # -- the file ------------------------------------------------------------------------------

    def run(self) -> None:
        self.camera()
        if self.exact:
            self.exact_passes()
        else:
            self.lines.append(
                f"global_settings {{ assumed_gamma 1.0 ambient_light rgb {self.rgb(self.scene.ambient.color, self.scene.ambient, 'color')}"
                + (f" adc_bailout 0{self.trace_settings()}" if self.reflective else "")
                + " }"
            )
            self.lines.append(
                f"background {{ color rgb {self.rgb(self.settings.background, self.settings, 'background')} }}"
            )
            if self.scene.environment is not None:
                self.lines.append(self.sky_sphere())
            for i, light in enumerate(self.scene.lights):
                self.comment(light, "light", i)
                self.lines.append(self.light_source(light))
        self.declare_materials()
        for i, sphere in enumerate(self.scene.spheres):
            self.comment(sphere, "sphere", i)
            self.lines.append(self.sphere(sphere))
        for i, mesh in enumerate(self.scene.meshes):
            self.comment(mesh, "mesh", i)
            self.mesh(mesh)
        for i, intrinsic in enumerate(self.scene.intrinsics):
            self.comment(intrinsic, intrinsic.kind, i)
            self.lines.append(self.intrinsic(intrinsic))
        for i, points in enumerate(self.scene.points):
            self.comment(points, "points", i)
            self.lines.append(self.points(points))
        self.instances()

    def camera(self) -> None:
        cam = self.scene.camera
        width, height = self.settings.width, self.settings.height
        aspect = width / height
        forward = np.asarray(cam.forward, dtype=np.float64)
        up = np.asarray(cam.up, dtype=np.float64)
        right = np.asarray(cam.right, dtype=np.float64)
        # Ref §3 recipe (b): an explicit basis, no look_at/angle, so no handedness flip.
        if cam.projection == "orthographic":
            kind, direction = "orthographic", forward
            right_v, up_v = right * cam.ortho_width, up * (cam.ortho_width * height / width)
        else:
            kind = "perspective"
            direction = forward * (aspect / (2.0 * math.tan(math.radians(cam.horizontal_fov_deg) / 2.0)))
            right_v, up_v = right * aspect, up
        self.comment(cam, "camera", 0)
        self.lines.append(
            f"camera {{ {kind} location {self.vec(cam.position, cam, 'position')}"
            f" direction {self.vec(direction, cam, 'forward')}"
            f" right {self.vec(right_v, cam, 'forward')} up {self.vec(up_v, cam, 'up')} }}"
        )

    # -- lights --------------------------------------------------------------------------------

    def inverse_square_fade(self, light) -> tuple[str, str]:
        """(the scaled colour, the fade clause) that make POV's fade an inverse square."""
        with np.errstate(over="ignore", invalid="ignore"):
            bounds = self.bounds
            radius = 1.0 if bounds is None else float(np.linalg.norm(bounds[1] - bounds[0])) / 2 or 1.0
            fd = INVERSE_SQUARE_FADE_RADII * radius
            scaled = np.asarray(light.color, dtype=np.float64) / (2.0 * fd * fd)
        return self.rgb(scaled, light, "color"), f" fade_distance {self.num(fd, light, 'falloff')} fade_power 2"

    def light_source(self, light) -> str:
        if not self.exact and (light.diffuse, light.specular) != (1.0, 1.0):
            # Classic: one finish per material, so a light has one strength for both terms.
            if light.specular != light.diffuse:
                raise self._error(
                    light,
                    "specular",
                    "differs from the diffuse multiplier, which the classic mapping cannot express "
                    "(a POV-Ray light has one strength): use the exact mapping",
                )
            light = dataclasses.replace(
                light, color=tuple(c * light.diffuse for c in light.color), diffuse=1.0, specular=1.0
            )
        colour = self.rgb(light.color, light, "color")
        fade = ""
        if getattr(light, "falloff", "none") == "inverse-square":
            colour, fade = self.inverse_square_fade(light)
        if isinstance(light, PointLight):
            text = f"light_source {{ {self.vec(light.position, light, 'position')} color rgb {colour}"
            if light.fade_power > 0:
                text += (
                    f" fade_distance {self.num(light.fade_distance, light, 'fade_distance')}"
                    f" fade_power {self.num(light.fade_power, light, 'fade_power')}"
                )
            if light.cone is not None:
                # POV-Ray's spotlight: 1 inside `radius`, 0 outside `falloff`, a cubic (smoothstep)
                # in cos between, times cos^tightness (the cone's focus; 0 adds no factor).
                cone = light.cone
                target = np.asarray(light.position, dtype=np.float64) + np.asarray(cone.axis, dtype=np.float64)
                text += (
                    f" spotlight point_at {self.vec(target, light, 'cone')}"
                    f" radius {self.num(math.degrees(math.acos(cone.cos_inner)), light, 'cone')}"
                    f" falloff {self.num(math.degrees(math.acos(cone.cos_outer)), light, 'cone')}"
                    f" tightness {self.num(cone.focus, light, 'cone') if cone.focus > 0 else 0}"
                )
            return text + fade + " }"
        if isinstance(light, DirectionalLight):
            position = self.parallel_position(light)
            target = position + np.asarray(light.direction, dtype=np.float64)
            return (
                f"light_source {{ {self.vec(position, light, 'direction')} color rgb {colour}"
                f" parallel point_at {self.vec(target, light, 'direction')} }}"
            )
        if isinstance(light, RectAreaLight):
            _native_only(self, light)
            n = int(light.samples)
            # Without 'adaptive' POV's default level (100) subdivides fully, giving trapezoid
            # weights for n = 2^k + 1 (ref §5). No 'jitter' (not deterministic).
            spot = ""
            if light.falloff == "inverse-square":
                emit = -np.cross(light.axis_u, light.axis_v)
                target = np.asarray(light.center, dtype=np.float64) + emit / np.linalg.norm(emit)
                spot = f" {LAMBERT_SPOTLIGHT} point_at {self.vec(target, light, 'axis_v')}"
            return (
                f"light_source {{ {self.vec(light.center, light, 'center')} color rgb {colour}{spot}"
                f" area_light {self.vec(light.axis_u, light, 'axis_u')}, {self.vec(light.axis_v, light, 'axis_v')}, {n}, {n}"
                f"{_adaptive(light)}{fade} }}"
            )
        if isinstance(light, SphereAreaLight):
            _native_only(self, light)
            n = int(light.samples)
            d = self.num(2.0 * light.radius, light, "radius")
            return (
                f"light_source {{ {self.vec(light.center, light, 'center')} color rgb {colour}"
                f" area_light <{d}, 0, 0>, <0, {d}, 0>, {n}, {n}{_adaptive(light)} circular orient{fade} }}"
            )
        raise self._error(light, "lights", f"unknown light type {type(light).__name__}")

    def parallel_position(self, light: DirectionalLight) -> np.ndarray:
        direction = np.asarray(light.direction, dtype=np.float64)
        # Overflow (bounds near 1e308) gives inf here, which vec() then rejects naming the light.
        with np.errstate(over="ignore", invalid="ignore"):
            bounds = self.bounds
            if bounds is None:
                return -direction
            lo, hi = bounds
            centre = (lo + hi) / 2
            radius = float(np.linalg.norm(hi - lo)) / 2
            return centre - direction * (PARALLEL_LIGHT_DISTANCE_RADII * radius + 1.0)

    def ndotl_pigment(self, light) -> str:
        if isinstance(light, DirectionalLight):
            to_light = -np.asarray(light.direction, dtype=np.float64)
            pattern = f"slope {{ {self.vec(to_light, light, 'direction')} }}"
        else:
            centre = light.position if isinstance(light, PointLight) else light.center
            pattern = f"slope {{ point_at {self.vec(centre, light, 'center')} }}"
        return f"#declare NdotL = pigment {{ {pattern} color_map {{ NdotL_Map }} }}"

    def exact_passes(self) -> None:
        self.lines.append(f"global_settings {{ assumed_gamma 1.0 adc_bailout 0{self.trace_settings()} }}")
        self.lines.append(
            f"// n.l = sin(pi (v - 1/2)) of the slope value v, as a filter colour ({NDOTL_SEGMENTS} linear segments)."
        )
        entries = ["[0 rgbf <0, 0, 0, 1>]"]
        for k in range(NDOTL_SEGMENTS + 1):
            v = 0.5 + 0.5 * k / NDOTL_SEGMENTS
            s = sdl_float(math.sin(math.pi * (v - 0.5))) if k < NDOTL_SEGMENTS else "1.0"
            entries.append(f"[{sdl_float(v)} rgbf <{s}, {s}, {s}, 1>]")
        self.lines.append("#declare NdotL_Map = color_map {")
        self.lines.extend("  " + entry for entry in entries)
        self.lines.append("}")
        ambient = self.rgb(self.scene.ambient.color, self.scene.ambient, "color")
        background = self.rgb(self.settings.background, self.settings, "background")
        lights = self.scene.lights or (None,)
        self.lines.append("// One pass per light; pass 0 also carries the ambient term and the background.")
        self.lines.append("#switch (Pass)")
        for i, light in enumerate(lights):
            self.lines.append(f"#case ({i})")
            first = i == 0
            self.lines.append(f"  global_settings {{ ambient_light rgb {ambient if first else '<0, 0, 0>'} }}")
            self.lines.append(f"  background {{ color rgb {background if first else '<0, 0, 0>'} }}")
            if first and self.scene.environment is not None:
                self.lines.append("  " + self.sky_sphere())
            if self.emission:
                self.lines.append(f"  #declare Emission = {1 if first else 0};")
            if light is None:
                self.lines.append("  // no lights: the ambient term only")
                self.lines.append("  #declare NdotL = pigment { rgbf <0, 0, 0, 1> }")
            else:
                self.lines.append("  " + self.comment_text(light, "light", i))
                self.lines.append("  " + self.light_source(light))
                self.lines.append("  " + self.ndotl_pigment(light))
                if self.light_terms:
                    self.lines.append(
                        f"  #declare Light_Diffuse = {self.coef(light.diffuse, light, 'diffuse')};"
                        f" #declare Light_Specular = {self.coef(light.specular, light, 'specular')};"
                    )
            self.lines.append("#break")
        self.lines.append("#end")

    def sky_sphere(self) -> str:
        """The environment (model ``Environment``) as a sky_sphere, which replaces the background
        wherever a ray misses (ref §19): POV-Ray's spherical image map (``map_type 1``) takes the
        longitude from +X towards +Z and puts column 0 there, so the sphere's ``matrix`` M turns
        the dome's frame by M⁻¹ = P·dome_from_world, P: (x, y, z) → (−z, y, x), which lands UsdLux's
        column 0 (longitude +π, along −Z) on POV-Ray's. The scale is the sky_sphere's emission."""
        e = self.scene.environment
        to_povray = np.array([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
        m = np.eye(4)
        m[:3, :3] = (to_povray @ e.dome_from_world).T  # orthogonal: its inverse
        name = self.images[id(e)][0]
        comment = sanitize_comment(e.source) if e.source else "environment"
        return (
            f'sky_sphere {{ pigment {{ image_map {{ exr "{name}" map_type 1 interpolate 2 }} }} '
            f"emission rgb {self.rgb(e.scale, e, 'scale')} {self.matrix(e, m)} }}  // {comment}"
        )

    def comment_text(self, node, kind: str, index: int) -> str:
        source = getattr(node, "source", "")
        return f"// {sanitize_comment(source)}" if source else f"// ({kind} {index})"

    # -- materials -----------------------------------------------------------------------------

    def declare_materials(self) -> None:
        for obj in (*self.scene.objects, *(m for p in self.scene.prototypes for m in p.meshes)):
            self.declare_material(obj.material, unlit=obj.material in self.unlit_materials)

    def declare_material(self, m: PhongMaterial, unlit: bool = False) -> None:
        """``#declare Material_k`` for ``m`` (once), and its ``_Unlit`` texture where asked."""
        if m in self.materials:
            return
        name = f"Material_{len(self.materials)}"
        self.materials[m] = name
        self.lines.append(self.comment_text(m, "material", len(self.materials) - 1))
        texture = self.texture(m, name)
        if m.cut_out:
            self.lines.append(f"#declare {name}_Surface = {texture}")
            texture = self.cut_out(m, f"{name}_Surface")
        self.lines.append(f"#declare {name} = {texture}")
        if unlit:
            unlit_texture = self.unlit_texture(m)
            if m.cut_out:
                self.lines.append(f"#declare {name}_Unlit_Surface = {unlit_texture}")
                unlit_texture = self.cut_out(m, f"{name}_Unlit_Surface")
            self.lines.append(f"#declare {name}_Unlit = {unlit_texture}")

    def cut_out(self, m: PhongMaterial, surface: str) -> str:
        """The declared texture ``surface`` cut out by ``m``'s mask: a texture_map over the mask
        as an image_pattern (its grey value: the opacity, PovImage.grey) that steps from a clear
        texture (transmit 1: no ambient, diffuse, highlight or mirror term, the ray continues at
        its depth, a shadow ray passes) to ``surface`` at the threshold: with two entries of one
        value POV-Ray takes the first below it and the last from it on (pattern.cpp
        Search_Blend_Map), so the clear one where p < threshold, as the native tracer decides."""
        if m.transmits:
            raise self._error(
                m, "opacity_texture", "a cut-out mask on a transmissive material (kt > 0) is not modelled"
            )
        t = m.opacity_texture
        once = "" if self.uv_frame.identity and (t.wrap_s, t.wrap_t) == ("repeat", "repeat") else " once"
        name = self.images[("mask", id(t))][0]
        step = self.coef(m.opacity_threshold, m, "opacity_threshold")
        clear = "pigment { rgbt <0, 0, 0, 1> } finish { ambient 0 diffuse 0 }"  # an entry: a body
        return (
            f'texture {{ uv_mapping image_pattern {{ exr "{name}" interpolate 2{once} }} '
            f"texture_map {{ [{step} {clear}] [{step} {surface}] }} }}"
        )

    def diffuse_pigment(self, m: PhongMaterial) -> str:
        """cd as a pigment: a colour, or the texture as an ``image_map`` on the mesh's uvs. The
        image is a half-float EXR (linear: POV-Ray applies no gamma to EXR; it holds EXR maps
        as half floats anyway), looked up bilinearly between texel centres (interpolate 2),
        extended and wrapped as ``UvFrame`` says (ref §16)."""
        t = m.diffuse_texture
        if m.checkered:
            return self.checker_pigment(m)
        if m.transmits:  # POV-Ray's transmit: the refracted ray's weight (ref §18)
            kt = self.coef(m.kt, m, "kt")
            if t is None:
                return f"pigment {{ rgbt <{self.rgb(m.diffuse_color, m, 'diffuse_color')[1:-1]}, {kt}> }}"
            return f"pigment {{ {self.image_map(t, f' transmit all {kt}')} }}"
        if t is None:
            return f"pigment {{ rgb {self.rgb(m.diffuse_color, m, 'diffuse_color')} }}"
        return f"pigment {{ {self.image_map(t)} }}"

    def checker_pigment(self, m: PhongMaterial) -> str:
        """The book's Checker3D as POV-Ray's ``checker`` (value floor(x) + floor(y) + floor(z)
        of the pattern point, odd: the second colour; pattern.cpp), scaled by the cell size and
        moved by -CHECKER_SHIFT, so that its pattern point is (p + ε)/s as the book's is. The
        pigment is in world space: every object's texture follows its transform (see sphere)."""
        fields = [(m.diffuse_color, "diffuse_color"), (m.checker_color, "checker_color")]
        if m.checker_plane:
            fields.append((m.checker_outline_color, "checker_outline_color"))
        colours = [self.rgb(c, m, f) for c, f in fields]
        if m.transmits:  # POV-Ray's transmit, as for a plain colour (ref §18)
            kt = self.coef(m.kt, m, "kt")
            colours = [f"rgbt <{c[1:-1]}, {kt}>" for c in colours]
        else:
            colours = [f"rgb {c}" for c in colours]
        if m.checker_plane:
            return self.plane_checker_pigment(m, colours)
        entries = ", ".join(colours)
        size = self.num(m.checker_size, m, "checker_size")
        shift = self.num(-CHECKER_SHIFT, m, "checker_size")
        return f"pigment {{ checker {entries} scale {size} translate <{shift}, {shift}, {shift}> }}"

    def plane_checker_pigment(self, m: PhongMaterial, colours: list[str]) -> str:
        """The book's PlaneChecker as a function pigment over the world-space point (the texture
        follows every object's transform, see sphere): 0.875 on the outline, else 0.125 for an
        even cell and 0.5 for an odd one, each in a flat stretch of the colour map. POV-Ray's
        function VM computes in double; the native tracer does the same in POV-Ray's numerics
        (materials.hpp plane_checker_colour)."""
        s = self.num(m.checker_size, m, "checker_size")
        w = 0.5 * float(m.checker_outline_width) / float(m.checker_size)
        lo, hi = self.num(w, m, "checker_outline_width"), self.num(1.0 - w, m, "checker_outline_width")
        fx, fz = f"(x/{s} - floor(x/{s}))", f"(z/{s} - floor(z/{s}))"
        # (POV-Ray's | binds looser than -: the sum of the tests is parenthesised before the shift.)
        outline = f"({fx} < {lo}) | ({fx} > {hi}) | ({fz} < {lo}) | ({fz} > {hi})"
        cell = f"select(abs(mod(floor(x/{s}) + floor(z/{s}), 2)) - 0.5, 0.125, 0.5)"
        even, odd, line = colours
        return (
            f"pigment {{ function {{ select(({outline}) - 0.5, {cell}, 0.875) }} "
            f"color_map {{ [0 {even}] [0.25 {even}] [0.25 {odd}] [0.75 {odd}] [0.75 {line}] [1 {line}] }} }}"
        )

    def image_map(self, t: Texture, modifiers: str = "") -> str:
        """The texture's image map (see UvFrame): ``once`` unless the image simply repeats."""
        once = "" if self.uv_frame.identity and (t.wrap_s, t.wrap_t) == ("repeat", "repeat") else " once"
        name = self.images[id(t)][0]
        return f'uv_mapping image_map {{ exr "{name}" interpolate 2{once}{modifiers} }}'

    @property
    def diffuse_term(self) -> str:
        return " * Light_Diffuse" if self.light_terms else ""

    def emissive_entry(self, m: PhongMaterial, weight: int) -> str:
        """The texture_map entry, of ``weight``, that adds Le to an ``average`` of total weight
        2·``weight`` (it holds half of it): POV-Ray's emission is pigment·emission (ref §4), so the
        pigment is 2·Le (a power of 2: exact in float, as are the other entries' doubled
        coefficients). ``Emission`` is the exact mapping's per-pass switch."""
        colour = self.rgb(tuple(2.0 * c for c in m.emission), m, "emission")
        emission = "Emission" if self.exact else "1"
        return f"[{weight} pigment {{ rgb {colour} }} finish {{ ambient 0 diffuse 0 emission {emission} }}]"

    def with_emission(self, m: PhongMaterial, body: str, weight: int = 1) -> str:
        """A one-texture body (without 'texture') with Le added: the average of it, doubled, and
        the emissive entry; without emission the plain texture."""
        if not any(m.emission):
            return f"texture {{ {body} }}"
        return f"texture {{ average texture_map {{\n  [{weight} {body}]\n  {self.emissive_entry(m, weight)}\n}} }}"

    def unlit_texture(self, m: PhongMaterial) -> str:
        """What an object shows where a light does not illuminate it (light linking): its
        ambient term and emission only (the exact mapping's ambient, ka·cd·La, is the same float
        as its doubled-and-averaged one: scaling by 2 is exact)."""
        pigment = self.diffuse_pigment(m)
        k = 2 if any(m.emission) else 1
        ka = self.coef(k * m.ka / self.transparency(m), m, "ka")
        # The mirror term stays: a light link removes the light's direct terms only.
        return self.with_emission(m, f"{pigment} finish {{ ambient {ka} diffuse 0{self.reflection(m, k)} }}")

    def texture(self, m: PhongMaterial, name: str) -> str:
        self.rgb(m.diffuse_color, m, "diffuse_color")  # checked also when a texture replaces it
        self.rgb(m.emission, m, "emission")
        pigment = self.diffuse_pigment(m)
        e = self.coef(m.exponent, m, "exponent")
        self.coef(m.ks, m, "ks")  # checked even where no highlight is written
        emissive = any(m.emission)
        # With emission, every entry of the average carries twice its share (see emissive_entry).
        k = 2 if emissive else 1
        if emissive and m.transmits:
            raise self._error(
                m,
                "emission",
                "an emissive transmissive material: POV-Ray's average texture would "
                "halve its transmission (set emission or kt to 0)",
            )
        if self.exact and m.ks > 0 and m.transmits:
            raise self._error(
                m,
                "kt",
                "a transmissive material with a highlight: the exact mapping's average texture "
                "would split POV-Ray's total internal reflection among its entries; use the classic mapping",
            )
        if not self.exact or m.ks <= 0:
            # Classic: one idiomatic finish. Exact without a highlight: one plain texture is exact.
            phong = f" phong {self.coef(k * m.ks, m, 'ks')} phong_size {e}" if m.ks > 0 else ""
            att = self.transparency(m)
            return self.with_emission(
                m,
                f"{pigment} finish {{ ambient {self.coef(k * m.ka / att, m, 'ka')}"
                f" diffuse {self.coef(k * m.kd / math.pi / att, m, 'kd')}{self.diffuse_term}{phong}{self.reflection(m, k)} }}",
            )
        # (A) the average of a diffuse texture and a layered specular texture, each doubled.
        # (A texture_map entry cannot hold a layered texture inline: it is declared first.)
        # With emission, a third entry of weight 2 (Le): every share doubles again.
        phong = self.coef(2 * k * m.ks, m, "ks") + (" * Light_Specular" if self.light_terms else "")
        layers = [f"texture {{ pigment {{ rgb 0 }} finish {{ ambient 0 diffuse 0 phong {phong} phong_size {e} }} }}"]
        cs = self.rgb(m.specular_color, m, "specular_color")
        if m.specular_texture is not None:
            # cs per point: the image as a filter layer (filter all 1: rgbf <texel, 1>, ref §16).
            layers.append(
                f"texture {{ pigment {{ {self.image_map(m.specular_texture, ' filter all 1')} }} finish {{ ambient 0 diffuse 0 }} }}"
            )
        elif tuple(m.specular_color) != (1.0, 1.0, 1.0):
            layers.append(f"texture {{ pigment {{ rgbf <{cs[1:-1]}, 1> }} finish {{ ambient 0 diffuse 0 }} }}")
        # (B) the specular n.l of this pass's light.
        layers.append("texture { pigment { NdotL } finish { ambient 0 diffuse 0 } }")
        self.lines.append(f"#declare {name}_Specular =\n  " + "\n  ".join(layers))
        # (A texture_map entry holds a texture body without the 'texture' keyword.)
        # The mirror term rides on the diffuse half, doubled like its other terms.
        diffuse = (
            f"{pigment} finish {{ ambient {self.coef(2 * k * m.ka, m, 'ka')}"
            f" diffuse {self.coef(2 * k * m.kd / math.pi, m, 'kd')}{self.diffuse_term}{self.reflection(m, 2.0 * k)} }}"
        )
        emitted = f"\n  {self.emissive_entry(m, 2)}" if emissive else ""
        return f"texture {{ average texture_map {{\n  [1 {diffuse}]\n  [1 {name}_Specular]{emitted}\n}} }}"

    # -- light and shadow linking ---------------------------------------------------------------

    def linked(self, obj, material: PhongMaterial | None = None) -> tuple[str, str]:
        """(the texture an object wears, the modifiers after it) under its lights' linking.

        The exact mapping renders one light per pass, so linking is exact there: in a pass whose
        light does not illuminate the object it wears its ambient-and-emission-only texture
        (``_Unlit``), and in a pass whose light it does not shadow (inputs:shadow:enable off, or
        not in the light's collection:shadowLink) it is ``no_shadow`` (ref §6: no_shadow keeps
        the highlight; a ``shadowless`` light would drop it, ref §5). The classic mapping has all
        lights in one pass: an object can only be ``no_shadow`` for all of them, and every light
        must illuminate it; otherwise an error names the light and the collection. ``material``:
        the one it wears when not its own (an instance's copy with its own cd)."""
        name = self.materials[obj.material if material is None else material]
        lights = self.scene.lights
        unlit = [i for i, light in enumerate(lights) if not light.linking.lights(obj.source)]
        unshadowing = [i for i, light in enumerate(lights) if not light.linking.shadows_from(obj.source)]
        if not self.exact:
            if unlit:
                raise self._error(
                    lights[unlit[0]],
                    "collection:lightLink",
                    f"does not include {sanitize_comment(obj.source) or 'an object'}, which the other lights illuminate: "
                    "the classic mapping (one POV-Ray pass, all lights) cannot express light linking; use the exact mapping",
                )
            if unshadowing and len(unshadowing) != len(lights):
                light = lights[unshadowing[0]]
                attribute = "inputs:shadow:enable" if not light.linking.shadows else "collection:shadowLink"
                raise self._error(
                    light,
                    attribute,
                    f"leaves {sanitize_comment(obj.source) or 'an object'} without this light's shadow but other lights "
                    "keep it: the classic mapping (one POV-Ray pass, all lights) has only no_shadow for all lights; "
                    "use the exact mapping",
                )
            return name, " no_shadow" if unshadowing else ""

        def when(passes: list[int]) -> str:
            return " | ".join(f"Pass = {i}" for i in passes)

        texture = f"#if ({when(unlit)}) {name}_Unlit #else {name} #end" if unlit else name
        if not unshadowing:
            modifiers = ""
        elif len(unshadowing) == len(lights):
            modifiers = " no_shadow"
        else:
            modifiers = f" #if ({when(unshadowing)}) no_shadow #end"
        return texture, modifiers

    # -- geometry ------------------------------------------------------------------------------

    def sphere(self, s: Sphere) -> str:
        m = s.world_from_object
        texture, modifiers = self.linked(s)
        a, t = m[:3, :3], m[:3, 3]
        r = float(a[0, 0])
        if r > 0 and np.array_equal(a, np.diag([r, r, r])):
            return (
                f"sphere {{ {self.vec(t, s, 'world_from_object')}, {self.num(r, s, 'world_from_object')}"
                f" texture {{ {texture} }}{self.interior(s.material)}{modifiers} }}"
            )
        # POV's matrix is row-vector: p' = p·M with M's first three rows the images of x, y, z
        # (the columns of our column-vector 3×3) and the translation as the fourth row.
        numbers = ", ".join(self.num(x, s, "world_from_object") for x in (*a.T.reshape(-1), *t))
        # The texture comes after the matrix, so it is not transformed (world-space slope).
        return f"sphere {{ <0, 0, 0>, 1 matrix <{numbers}> texture {{ {texture} }}{self.interior(s.material)}{modifiers} }}"

    def points(self, p: Points) -> str:
        """A Points set as one ``union`` of ``sphere { <c>, r }`` with one texture: the numbers
        ``sphere()`` writes for each ``Sphere.at(c, r)`` (exact float64 text), the texture, interior
        and linking once. Formatted by ``repr`` over Python floats, not ``sdl_float`` per number:
        a million spheres in about a second."""
        texture, modifiers = self.linked(p)
        if not (np.isfinite(p.centers).all() and np.isfinite(p.radii).all()):
            raise self._error(p, "centers", "is not finite in the SDL")
        # + 0.0 turns -0.0 into 0.0, as sdl_float does.
        rows = np.column_stack([p.centers, p.radii]) + 0.0
        body = "\n".join(f" sphere {{ <{x!r}, {y!r}, {z!r}>, {r!r} }}" for x, y, z, r in rows.tolist())
        return f"union {{\n{body}\n texture {{ {texture} }}{self.interior(p.material)}{modifiers} }}"

    def matrix(self, node, m: np.ndarray) -> str:
        """POV's row-vector ``matrix`` of a column-vector affine map (the 3×3 part transposed,
        then the translation)."""
        a, t = m[:3, :3], m[:3, 3]
        return "matrix <" + ", ".join(self.num(x, node, "world_from_object") for x in (*a.T.reshape(-1), *t)) + ">"

    def intrinsic(self, i: Intrinsic) -> str:
        """An intrinsic prim as POV-Ray's own shape in the canonical frame (model ``Intrinsic``)
        under its ``matrix``; the texture after the matrix stays in world space (the exact
        mapping's slope), as for spheres."""
        texture, modifiers = self.linked(i)
        tail = (
            f" {self.matrix(i, i.world_from_object)} texture {{ {texture} }}{self.interior(i.material)}{modifiers} }}"
        )
        if i.kind == "cube":
            return "box { <-1, -1, -1>, <1, 1, 1>" + tail
        if i.kind == "plane":
            if i.infinite:
                return "plane { z, 0" + tail
            return "polygon { 4, <-1, -1, 0>, <1, -1, 0>, <1, 1, 0>, <-1, 1, 0>" + tail
        if i.kind == "cylinder":
            r0, r1 = (
                self.num(r, i, f"radius_{end}") for r, end in ((i.radius_bottom, "bottom"), (i.radius_top, "top"))
            )
            if i.radius_bottom == i.radius_top:
                return f"cylinder {{ <0, 0, -1>, <0, 0, 1>, {r0}" + tail
            return f"cone {{ <0, 0, -1>, {r0}, <0, 0, 1>, {r1}" + tail
        # A capsule: the open side and the end spheres (Intrinsic.capsule_ends), one object
        # (union) for the texture.
        h = self.num(i.half_height, i, "half_height")
        rb, rt = (self.num(r, i, f"radius_{end}") for r, end in ((i.radius_bottom, "bottom"), (i.radius_top, "top")))
        ends = "".join(
            f" sphere {{ <0, 0, {self.num(z, i, 'half_height')}>, {self.num(r, i, 'radius_bottom')} }}"
            for z, r in i.capsule_ends()
        )
        if i.half_height == 0:
            side = ""
        elif i.radius_bottom == i.radius_top:
            side = f" cylinder {{ <0, 0, -{h}>, <0, 0, {h}>, {rb} open }}"
        else:
            side = f" cone {{ <0, 0, -{h}>, {rb}, <0, 0, {h}>, {rt} open }}"
        return f"union {{{ends}{side}" + tail

    def float32_pieces(self, mesh: TriangleMesh, attribute: str, values: np.ndarray) -> Iterator[str]:
        """``values`` as mesh2 vectors at float32 precision, MESH_ROWS_PER_PIECE rows a piece."""
        for start in range(0, len(values), MESH_ROWS_PER_PIECE):
            try:
                yield float32_vectors(values[start : start + MESH_ROWS_PER_PIECE])
            except NonFiniteNumber as e:
                raise self._error(mesh, attribute, f"cannot be written to mesh2: {e}") from None

    def uv_pieces(self, mesh: TriangleMesh) -> Iterator[str]:
        """The mesh's uvs in the SDL's frame, each number exactly, MESH_ROWS_PER_PIECE a piece."""
        for start in range(0, len(mesh.uvs), MESH_ROWS_PER_PIECE):
            rows = self.uv_frame.apply(mesh.uvs[start : start + MESH_ROWS_PER_PIECE])
            try:
                yield ",\n".join(f"<{sdl_float(u)}, {sdl_float(v)}>" for u, v in rows)
            except NonFiniteNumber as e:
                raise self._error(mesh, "uvs", f"cannot be written to mesh2: {e}") from None

    def instances(self) -> None:
        """Each prototype's meshes ``#declare``d once (without a texture), then one ``object``
        per copy and mesh with the copy's ``matrix`` and the mesh's texture after it (so the
        texture is not transformed: the exact mapping's slope pigment is in world space, as on
        every other object; a uv-mapped image follows the mesh's uvs either way)."""
        declared: dict[int, list[tuple[str, TriangleMesh]]] = {}
        for p, prototype in enumerate(self.scene.prototypes):
            names = []
            for j, mesh in enumerate(prototype.meshes):
                if not len(mesh.triangles):
                    continue
                name = f"Prototype_{p}_{j}"
                self.comment(mesh, "prototype mesh", j)
                self.mesh(mesh, declare=name)
                names.append((name, mesh))
            declared[id(prototype)] = names
        for group in self.scene.instances:
            names = declared[id(group.prototype)]
            if not names:
                continue
            self.lines.append(
                f"// {len(group)} instances of {sanitize_comment(group.prototype.source) or '(a prototype)'}"
            )
            m = group.world_from_prototype
            # POV's matrix is row-vector (see sphere): the columns of the 3×3 part, then the translation.
            rows = np.concatenate([m[:, :3, :3].transpose(0, 2, 1).reshape(-1, 9), m[:, :3, 3]], axis=1)
            if not np.all(np.isfinite(rows)):
                k = int(np.flatnonzero(~np.isfinite(rows).all(axis=1))[0])
                raise self._error(group, "world_from_prototype", f"copy {k} is not finite in the SDL")
            for k in range(len(group)):
                matrix = ", ".join(map(sdl_float, rows[k]))
                for name, mesh in names:
                    # Linking cannot tell the copies apart here (the reader flattens those it would).
                    # A per-instance cd (instance_color) wears its own declared texture.
                    material = group.material_of(mesh, k)
                    if material is not mesh.material:
                        self.declare_material(material, unlit=mesh.material in self.unlit_materials)
                    texture, modifiers = self.linked(mesh, material)
                    self.lines.append(
                        f"object {{ {name} matrix <{matrix}> texture {{ {texture} }}"
                        f"{self.interior(mesh.material)}{modifiers} }}"
                    )

    def mesh(self, mesh: TriangleMesh, declare: str | None = None) -> None:
        """A mesh2 with its texture, or with ``declare``: ``#declare declare = mesh2 {...}``
        without one (its instances add it)."""
        if len(mesh.triangles) == 0:
            self.lines.append("// (no triangles)")
            return
        origin = mesh.local_origin()
        points = mesh.points - origin if origin.any() else mesh.points
        out = self.lines
        out.append(f"#declare {declare} = mesh2 {{" if declare else "mesh2 {")
        out.block(f"  vertex_vectors {{ {len(mesh.points)},", self.float32_pieces(mesh, "points", points), "  }")
        same_indices = (
            mesh.normals is not None
            and len(mesh.normals) == len(mesh.points)
            and np.array_equal(mesh.normal_indices, mesh.triangles)
        )
        if mesh.normals is not None:
            out.block(
                f"  normal_vectors {{ {len(mesh.normals)},", self.float32_pieces(mesh, "normals", mesh.normals), "  }"
            )
        if mesh.uvs is not None:
            out.block(f"  uv_vectors {{ {len(mesh.uvs)},", self.uv_pieces(mesh), "  }")
        out.block(f"  face_indices {{ {len(mesh.triangles)},", _int_pieces(mesh.triangles), "  }")
        if mesh.normals is not None and not same_indices:
            # Without normal_indices POV uses the face indices (ref §7); only write them when they differ.
            out.block(f"  normal_indices {{ {len(mesh.triangles)},", _int_pieces(mesh.normal_indices), "  }")
        if mesh.uvs is not None:
            out.block(f"  uv_indices {{ {len(mesh.triangles)},", _int_pieces(mesh.uv_indices), "  }")
        if mesh.material.transmits:
            # A mesh has an inside (for its interior's refraction) only with an inside_vector;
            # any direction does for a closed mesh (POV-Ray counts crossings along it). It is part
            # of the mesh2 body: before any transform (the parser refuses it after one).
            out.append(f"  inside_vector <{', '.join(map(str, INSIDE_VECTOR))}>")
        if origin.any():
            # Local coordinates keep float32 precision far from the origin; the translate comes
            # before the texture, so the texture (the exact mapping's slope) stays in world space.
            out.append(f"  translate {self.vec(origin, mesh, 'points')}")
        if not declare:
            texture, modifiers = self.linked(mesh)
            out.append(f"  texture {{ {texture} }}{self.interior(mesh.material)}{modifiers}")
        out.append("}")
