# SPDX-License-Identifier: Apache-2.0
"""The scene model: the one in-memory representation between USD and both backends.

Plain, typed, immutable dataclasses. Every node keeps ``source``, the USD prim path it came
from ("" when built in Python), so every later error can name it. Numpy arrays are copied,
made C-contiguous with a fixed dtype, and set read-only.

Conventions:

* World space is right-handed, +Y up (a Z-up stage is rotated to Y-up by the reader).
* Colours are linear RGB. A light's ``color`` is its strength ``ls·cl`` (USD:
  ``intensity · 2^exposure · color``): no area or ``normalize`` factor in this model.
* Matrices use the column-vector convention: ``p_world = world_from_object @ [p, 1]``.
* Shading (Suffern's Phong, the ``seed`` convention), for a visible point with normal n
  (flipped to face the viewer), viewer direction wo, and each light j with n·l_j > 0 and
  not in shadow::

      L = Le + ka·cd·La + Σ_j [ kd·cd/π + ks·cs·max(0, r_j·wo)^e ] · Lj · (n·l_j)
      r_j = −l_j + 2(n·l_j) n

  Le is the material's emission (0 unless a scene asks); the sum runs over the lights whose
  ``Linking`` illuminates the object, each unshadowed unless its linking says otherwise.

  The ``povray-classic`` convention is what a plain POV-Ray ``finish { phong ks phong_size e }``
  computes: the specular term has no n·l factor and is coloured by the light, not by cs::

      L = ka·cd·La + Σ_j [ kd·cd/π·(n·l_j) + ks·(r_j·wo)^e ] · Lj      (r_j·wo > 0)

* Mirror reflection (Suffern ch. 24, PerfectSpecular on top of Phong; POV-Ray's ``reflection``
  adds it the same way, ref §18): a material with kr > 0 adds ``kr·cr·L(p, r)``, the radiance
  traced along the mirror direction r = −wo + 2(n·wo)n (a miss: the background). The camera ray
  has depth 0, a reflected ray one more than its parent; a ray deeper than
  ``RenderSettings.max_depth`` returns black (the book's Whitted tracer and POV-Ray's
  ``max_trace_level max_depth + 1`` agree). kr = 0 traces no secondary ray.
* Transparency (Suffern ch. 27, PerfectTransmitter): a material with kt > 0 is the surface of an
  interior of index ``ior`` (relative to the outside; the unflipped normal points out). A ray
  crossing it is refracted by Snell's law into direction t with η = ior entering, 1/ior leaving,
  and adds ``kt/η²·L(p, t)`` (``transmission`` "book") or ``kt·L(p, t)`` ("povray": POV-Ray has
  no η² factor, ref §18); under total internal reflection it adds instead the mirror ray's
  ``L(p, r)`` at full weight and no kr term (the book and POV-Ray agree). Shadows: in the "book"
  convention every object blocks shadow rays, transparent ones too (Suffern's Whitted tracer);
  in the "povray" one they go straight through transmissive objects, × kt per surface crossed
  (POV-Ray's shadows, ref §18). Inside an interior every ray (also a shadow ray) keeps interior_filter^d of
  its radiance over a distance d (Beer-Lambert); interiors are not nested: a refracted ray
  enters or leaves the one of the surface it crosses.

POV-Ray facts cite ``docs/povray-3.7-semantics.md`` as "ref §n".
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Literal, Union

import numpy as np

from .errors import InvalidValueError, Problem

Vec3 = tuple[float, float, float]
RGB = tuple[float, float, float]

SpecularConvention = Literal["seed", "povray-classic"]
# The radiance a refracted ray carries: "book" kt/η² (Suffern ch. 27), "povray" kt (POV-Ray
# applies no η² factor, ref §18; ``diff`` renders the native image in this convention).
TransmissionConvention = Literal["book", "povray"]
TRANSMISSION_CONVENTIONS: tuple[str, ...] = ("book", "povray")
SamplePattern = Literal["grid", "povray-am1", "povray-am2", "stratified", "adaptive"]
SAMPLE_PATTERNS: tuple[str, ...] = ("grid", "povray-am1", "povray-am2", "stratified", "adaptive")
# The patterns POV-Ray has ("stratified" is the native tracer's own).
POVRAY_SAMPLE_PATTERNS: tuple[str, ...] = ("grid", "povray-am1", "povray-am2")
# The native tracer's ray tolerances: "scale-invariant" (relative to the scene's size, so a scene
# renders the same in any units), "povray" (POV-Ray's absolute 1e-4 / 1e-3 and its mesh2 data:
# float32, flat where a triangle's normals are equal, to reproduce POV-Ray's images; ``diff``
# uses it) or "povray-shadow-cache" (the same with the 1e-4 window of POV-Ray's shadow cache:
# ``diff`` explains pixels with it).
Numerics = Literal["scale-invariant", "povray", "povray-shadow-cache"]
NUMERICS: tuple[str, ...] = ("scale-invariant", "povray", "povray-shadow-cache")
Projection = Literal["perspective", "orthographic"]
# How a point, sphere or rect light's strength reaches a surface at distance d from its centre:
# "none" is the seed's (Suffern's) light, ``color`` arrives unchanged; "inverse-square" is UsdLux's,
# ``color`` is the radiant intensity and ``color / d²`` arrives (a rect light: also × max(0, cos θ)
# of the angle from its emitting side, a one-sided Lambertian panel).
Falloff = Literal["none", "inverse-square"]
# How a texture is sampled outside [0, 1] along one axis (UsdUVTexture wrapS / wrapT):
# "repeat" tiles it, "clamp" extends its edge texels, "mirror" tiles it mirrored, "black" is 0
# (the bilinear lookup blends the edge texels with black texels beyond the edge).
Wrap = Literal["repeat", "clamp", "mirror", "black"]
WRAPS: tuple[str, ...] = ("repeat", "clamp", "mirror", "black")


def _bad_value(node: str, field: str, source: str, message: str) -> InvalidValueError:
    return InvalidValueError(Problem(message, prim=source, attribute=field, node=node))


def _real_array(array, node: str, field: str, source: str, expected: str = "real numbers") -> np.ndarray:
    """``array`` as a numpy array of real numbers (integer or floating point): text, booleans,
    complex numbers (numpy would drop the imaginary part with only a warning) and objects that
    are not numbers are an error naming the field."""
    try:
        source_array = np.asarray(array)
        if source_array.dtype == object:  # a list mixing numbers and None, say: numbers or an error
            source_array = np.asarray(array, dtype=np.float64)
    except (TypeError, ValueError) as e:  # a ragged list, a string that is not a number
        raise _bad_value(
            node, field, source, f"expected an array of {expected}, got {_describe(array)} ({e})"
        ) from None
    if source_array.size and source_array.dtype.kind not in "iuf":
        raise _bad_value(node, field, source, f"expected an array of {expected}, got an array of {source_array.dtype}")
    return source_array


# Rows per block of the whole-array passes over a Points set (bounds, the image checks): their
# temporaries stay ~24 MB a block however big the set.
POINTS_BLOCK = 1_000_000


def row_blocks(*arrays: np.ndarray):
    """The arrays' rows in blocks of POINTS_BLOCK, side by side."""
    for start in range(0, len(arrays[0]), POINTS_BLOCK):
        yield tuple(a[start : start + POINTS_BLOCK] for a in arrays)


def _readonly(array, dtype, shape_tail: tuple[int, ...], node: str, field: str, source: str) -> np.ndarray:
    """``array`` as a read-only C-contiguous array of ``dtype`` shaped (N, *shape_tail): a copy,
    unless it already is one that owns its memory.
    Into an integer dtype only whole numbers that fit go: numpy's cast would wrap an int64
    index >= 2^31 (2^32 + 2 becomes 2) and truncate 1.5 to 1 without a word. A wrong type or
    shape is an ``InvalidValueError`` (a SceneError) naming ``node``'s ``field``."""
    integer = np.issubdtype(dtype, np.integer)
    source_array = _real_array(array, node, field, source, "integer indices" if integer else "real numbers")
    if integer and source_array.size:
        if source_array.dtype.kind == "f":
            if not np.all(np.isfinite(source_array)) or np.any(source_array != np.round(source_array)):
                raise _bad_value(
                    node, field, source, "expected whole-number indices, got fractional or non-finite values"
                )
        info = np.iinfo(dtype)
        if source_array.size and (source_array.min() < info.min or source_array.max() > info.max):
            bad = source_array.max() if source_array.max() > info.max else source_array.min()
            raise _bad_value(
                node,
                field,
                source,
                f"index {int(bad)} does not fit the model's {np.dtype(dtype).name} indices ({info.min}..{info.max})",
            )
    if (
        source_array.dtype == dtype
        and source_array.flags.c_contiguous
        and not source_array.flags.writeable
        and source_array.base is None
    ):
        # Frozen and its own (the reader hands its arrays over so): nothing can write it behind
        # the model's back, so it is kept, not copied (a 10M-triangle mesh: 240 MB).
        out = source_array
    else:
        out = np.array(source_array, dtype=dtype, order="C", copy=True)
    if out.ndim != 1 + len(shape_tail) or out.shape[1:] != shape_tail:
        raise _bad_value(
            node, field, source, f"expected an array of shape (N, {', '.join(map(str, shape_tail))}), got {out.shape}"
        )
    out.setflags(write=False)
    return out


def _matrix(m, node: str, field: str, source: str) -> np.ndarray:
    out = np.array(_real_array(m, node, field, source), dtype=np.float64, order="C", copy=True)
    if out.shape != (4, 4):
        raise _bad_value(node, field, source, f"expected a 4x4 matrix, got shape {out.shape}")
    out.setflags(write=False)
    return out


def _describe(value) -> str:
    return f"{type(value).__name__} {value!r:.60}"


def _as_triples(node, *fields: str) -> None:
    """Store each of ``node``'s 3-vector fields (a colour, a point, a direction) given as a numpy
    array or a list of 3 as a tuple (of Python floats when they are real numbers): the tuple the
    model documents, hashable and comparable. What is not 3 real numbers is left for
    ``validate`` to report ("must be 3 numbers") with every other problem of the scene."""
    for name in fields:
        value = getattr(node, name)
        if type(value) is tuple and len(value) == 3 and all(type(x) is float for x in value):
            continue  # the common case, untouched
        if isinstance(value, np.ndarray) and value.shape == (3,):
            value = tuple(value.tolist())
        elif isinstance(value, list) and len(value) == 3:
            value = tuple(value)
        if isinstance(value, tuple) and len(value) == 3:
            if all(
                isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, (bool, np.bool_))
                for x in value
            ):
                value = tuple(float(x) for x in value)
            object.__setattr__(node, name, value)  # hashable either way


def _arrays_equal(a: np.ndarray | None, b: np.ndarray | None) -> bool:
    if a is None or b is None:
        return a is b
    return a.shape == b.shape and bool(np.array_equal(a, b))


# --------------------------------------------------------------------------------------------
# Textures and materials


@dataclass(frozen=True, slots=True, eq=False)
class Texture:
    """An immutable image a material samples at a surface point's (u, v), and how.

    ``image`` is linear float32 RGB, (H, W, 3), row 0 at the top: v = 1 is the top edge, v = 0
    the bottom (USD's st convention; the file's colour space, channel selection, ``scale`` and
    ``bias`` are already applied by the reader, as they commute with the lookup). The lookup is
    bilinear between texel centres: texel (i, j) (column i, row j) sits at
    u = (i + ½)/W, v = 1 − (j + ½)/H, which is POV-Ray's ``image_map { interpolate 2 }`` on
    ``uv_mapping`` (ref §16). Textures compare and hash by identity (the reader shares one per
    file and sampling rules)."""

    image: np.ndarray  # (H, W, 3) float32, linear, >= 0
    wrap_s: Wrap = "repeat"  # along u (image columns)
    wrap_t: Wrap = "repeat"  # along v (image rows)
    source: str = ""  # USD prim path of the texture shader
    file: str = ""  # the image file it was read from (resolved path)

    def __post_init__(self) -> None:
        image = self.image
        # A read-only float32 array that owns its data is taken as it is (the USD reader builds
        # one: a copy of a 16K texture would be 3.2 GB more, if only for a moment); anything else
        # is copied, so that the caller's array cannot change the model.
        owned = (
            isinstance(image, np.ndarray)
            and image.dtype == np.float32
            and image.flags.c_contiguous
            and image.flags.owndata
            and not image.flags.writeable
        )
        if not owned:
            with np.errstate(over="ignore"):  # beyond float32: inf, which validate reports as texels not finite
                image = np.array(
                    _real_array(image, "Texture", "image", self.source), dtype=np.float32, order="C", copy=True
                )
        if image.ndim != 3 or image.shape[2] != 3 or image.shape[0] < 1 or image.shape[1] < 1:
            raise _bad_value(
                "Texture", "image", self.source, f"expected a texture image of shape (H, W, 3), got {image.shape}"
            )
        image.setflags(write=False)
        object.__setattr__(self, "image", image)

    @property
    def width(self) -> int:
        return int(self.image.shape[1])

    @property
    def height(self) -> int:
        return int(self.image.shape[0])


@dataclass(frozen=True, slots=True)
class PhongMaterial:
    """Suffern's Phong material: ambient + Lambert diffuse + glossy specular ``ks·cs·(r·wo)^e``."""

    ka: float = 0.1  # ambient coefficient, [0, 1]
    kd: float = 0.6  # diffuse coefficient, [0, 1] (the BRDF is kd·cd/π)
    ks: float = 0.3  # specular coefficient, [0, 1]
    exponent: float = 32.0  # specular exponent e, >= 0
    diffuse_color: RGB = (0.8, 0.8, 0.8)  # cd, linear RGB, >= 0
    specular_color: RGB = (1.0, 1.0, 1.0)  # cs, linear RGB, >= 0
    source: str = ""  # USD prim path of the shader (or material) it came from
    # cd as a function of the surface point: the texture at the mesh's (u, v) replaces
    # diffuse_color (meshes with uvs only; diffuse_color stays the fallback USD authored).
    diffuse_texture: Texture | None = None
    # cs likewise (the seed convention's highlight colour; povray-classic ignores cs).
    specular_texture: Texture | None = None
    # Le, emitted radiance added to the shaded colour wherever the surface is seen, lit or not
    # (Suffern's Emissive material, ch. 14; USD: our shader's emissiveColor, UsdPreviewSurface's
    # emissiveColor; POV-Ray's finish { emission }). Linear RGB, >= 0. An emissive surface lights
    # nothing else: only lights do (a RectLight or SphereLight is the emitter that casts light).
    emission: RGB = (0.0, 0.0, 0.0)
    # Mirror reflection (Suffern ch. 24): kr·cr times the radiance along the mirror direction,
    # added to the Phong terms. kr in [0, 1]; 0 (the default) traces no reflected ray.
    kr: float = 0.0
    reflective_color: RGB = (1.0, 1.0, 1.0)  # cr, linear RGB, >= 0
    # Transparency (Suffern ch. 27): kt times the radiance along the refracted direction, into an
    # interior of index ior relative to the outside. kt in [0, 1]; 0 traces no refracted ray.
    kt: float = 0.0
    ior: float = 1.0  # > 0
    # The dielectric (Suffern ch. 28; POV-Ray ``reflection { 0, cr fresnel on } conserve_energy``):
    # the mirror weight kr·cr becomes F·kr·cr and kt becomes (1 − F)·kt, F the unpolarised Fresnel
    # reflectance of the crossing (((ior − 1)/(ior + 1))² at normal incidence). kr = kt = 1 is the
    # book's Dielectric; an opaque fresnel material reflects as the surface of an ior interior.
    fresnel: bool = False
    # Beer-Lambert (Suffern ch. 28's cf_in; POV-Ray's exponential interior fade): the fraction of
    # each channel a ray keeps per unit distance inside the interior, (0, 1] (white: none absorbed).
    interior_filter: RGB = (1.0, 1.0, 1.0)
    # A tangent-space normal map (UsdPreviewSurface ``normal``, MaterialX ``normalmap``): the texel
    # is the shading normal in the frame (T, B, N) of the point — T, B along increasing u and v
    # (the triangle's dP/du, dP/dv made orthonormal to N), N the interpolated normal — so its
    # texels are signed, (0, 0, 1) the unperturbed normal. Meshes with uvs only. POV-Ray 3.7 has
    # no such map (its bump_map is a height field in a world-fixed frame): the SDL leaves it out.
    normal_texture: Texture | None = None
    # A cut-out mask (UsdPreviewSurface's masked mode: ``opacity`` from a texture, ``opacityThreshold``
    # > 0): where the texture's first channel, looked up as the colours are, is below
    # opacity_threshold the surface is not there: rays pass it unchanged, at their depth, and
    # shadow rays too. Meshes with uvs only. POV-Ray: a texture_map stepping from a clear texture
    # to the surface's at the threshold, over the mask as an image_pattern.
    opacity_texture: Texture | None = None
    opacity_threshold: float = 0.0  # in (0, 1] with an opacity_texture (0: none)
    # The book's Checker3D (Suffern's 3D checker texture, the cd of its SV_Matte and SV_Phong
    # materials): cd is diffuse_color (its color1) or checker_color (color2) by the parity of
    # floor((x + ε)/s) + floor((y + ε)/s) + floor((z + ε)/s) at the world-space hit point,
    # s = checker_size, ε = CHECKER_SHIFT (even: diffuse_color). checker_size 0 (the default):
    # no checker. POV-Ray: ``pigment { checker }`` (the same parity), scaled and shifted to match.
    checker_size: float = 0.0
    checker_color: RGB = (0.5, 0.5, 0.5)  # the book's default color2
    # The book's PlaneChecker instead (ch. 24's floors): cells of the x–z plane, by the parity of
    # floor(x/s) + floor(z/s) at the world-space hit point (no ε), and an outline: where
    # x/s − floor(x/s) or z/s − floor(z/s) is below w or above 1 − w, w = ½·width/s, cd is
    # checker_outline_color. The book's code does this in float; the native tracer does too, but in
    # POV-Ray's numerics in double, as POV-Ray's function pigment (the two differ only within a
    # float's rounding of an edge). POV-Ray: ``pigment { function { ... } color_map }``.
    checker_plane: bool = False
    checker_outline_width: float = 0.0  # >= 0 (the book's outline_width; 0: no outline)
    checker_outline_color: RGB = (0.0, 0.0, 0.0)  # the book's default: black
    # cd varies per instance (a primvar reader on the diffuse colour, reading a per-instance
    # primvar: a PointInstancer's one-per-instance array, or a constant primvar on each
    # instanceable prim): on a prototype's mesh, copy k's cd is its ``Instances.colors[k]``;
    # elsewhere, or in a group without colours, diffuse_color (the reader's fallback).
    instance_color: bool = False

    @property
    def checkered(self) -> bool:
        """Whether cd is the 3D checker (checker_size > 0)."""
        return self.checker_size > 0

    @property
    def transmits(self) -> bool:
        """Whether the material traces a refracted ray (kt > 0)."""
        return self.kt > 0

    @property
    def reflects(self) -> bool:
        """Whether the material traces a reflected ray (kr > 0 and cr not black)."""
        return self.kr > 0 and any(c > 0 for c in self.reflective_color)

    def __post_init__(self) -> None:
        _as_triples(
            self,
            "diffuse_color",
            "specular_color",
            "reflective_color",
            "interior_filter",
            "checker_color",
            "checker_outline_color",
        )

    @property
    def cut_out(self) -> bool:
        """Whether a texture masks the surface out where its opacity is below the threshold."""
        return self.opacity_texture is not None

    @property
    def textures(self) -> tuple[Texture, ...]:
        """The textures the material samples (diffuse, specular, normal, opacity)."""
        return tuple(
            t
            for t in (self.diffuse_texture, self.specular_texture, self.normal_texture, self.opacity_texture)
            if t is not None
        )

    @property
    def colour_textures(self) -> tuple[Texture, ...]:
        """The textures that colour the surface (diffuse, specular): not the normal map."""
        return tuple(t for t in (self.diffuse_texture, self.specular_texture) if t is not None)

    def without_textures(self) -> PhongMaterial:
        """The same material with its constant colours only (the textures' fallbacks)."""
        return replace(
            self,
            diffuse_texture=None,
            specular_texture=None,
            normal_texture=None,
            opacity_texture=None,
            opacity_threshold=0.0,
        )


DEFAULT_MATERIAL = PhongMaterial()

# The book's Checker3D adds ε = -0.000187453738 (its "small random number") to each coordinate
# before the floor, so that a surface at a whole multiple of the size (a ground plane at y = 0)
# lies inside one row of cells, not on their boundary where rounding would decide. Both backends
# add the same (native materials.hpp kCheckerShift; POV-Ray: the pigment's translate).
CHECKER_SHIFT = -0.000187453738


# --------------------------------------------------------------------------------------------
# Camera


@dataclass(frozen=True, slots=True)
class Camera:
    """A pinhole (perspective) or orthographic camera looking along ``forward``.

    The image's horizontal extent is given (``horizontal_fov_deg`` or ``ortho_width``); the
    vertical extent follows from the image aspect ratio (square pixels), as in POV-Ray with
    ``right -x*W/H up y``. ``right = forward × up`` (right-handed).
    """

    position: Vec3 = (0.0, 0.0, 0.0)  # eye point, world units
    forward: Vec3 = (0.0, 0.0, -1.0)  # unit view direction (USD cameras look down local −Z)
    up: Vec3 = (0.0, 1.0, 0.0)  # unit, orthogonal to forward
    projection: Projection = "perspective"
    horizontal_fov_deg: float = 60.0  # perspective only: full horizontal FOV, degrees, (0, 180)
    ortho_width: float = 2.0  # orthographic only: width of the view window, world units, > 0
    source: str = ""

    def __post_init__(self) -> None:
        _as_triples(self, "position", "forward", "up")

    @staticmethod
    def look_at(
        position: Vec3,
        target: Vec3,
        horizontal_fov_deg: float = 60.0,
        up_hint: Vec3 = (0.0, 1.0, 0.0),
        source: str = "",
    ) -> Camera:
        """A perspective camera at ``position`` looking at ``target``; ``up`` is ``up_hint``
        made orthogonal to the view direction (Gram-Schmidt) and unit."""
        eye = np.asarray(position, dtype=np.float64)
        forward = np.asarray(target, dtype=np.float64) - eye
        forward /= np.linalg.norm(forward)
        up = np.asarray(up_hint, dtype=np.float64)
        up = up - forward * (up @ forward)
        up /= np.linalg.norm(up)
        return Camera(
            position=tuple(map(float, eye)),
            forward=tuple(map(float, forward)),
            up=tuple(map(float, up)),
            horizontal_fov_deg=horizontal_fov_deg,
            source=source,
        )

    @property
    def right(self) -> Vec3:
        f, u = self.forward, self.up
        return (f[1] * u[2] - f[2] * u[1], f[2] * u[0] - f[0] * u[2], f[0] * u[1] - f[1] * u[0])


# --------------------------------------------------------------------------------------------
# Lights


@dataclass(frozen=True, slots=True)
class AmbientLight:
    """Ambient light La (USD: an untextured DomeLight). Not occluded."""

    color: RGB = (0.0, 0.0, 0.0)  # ls_a·cl_a, linear RGB
    source: str = ""

    def __post_init__(self) -> None:
        _as_triples(self, "color")


@dataclass(frozen=True, slots=True, eq=False)
class Environment:
    """The environment at infinity (USD: a textured DomeLight): the radiance a ray that hits
    nothing sees along its direction d, in place of ``RenderSettings.background``.

    ``texture.image`` is a lat-long map in the OpenEXR layout UsdLux specifies: in the dome's
    frame, d_dome = ``dome_from_world`` · d, longitude φ = atan2(x, z) (0 along +Z, π/2 along
    +X) and latitude θ = asin(y) (+Y the top pole). The lookup is ``texture``'s bilinear one
    at u = ½ − φ/2π (the left edge is φ = +π, the centre column +Z), v = ½ + θ/π (the top row
    is +Y), repeating around the longitude and clamped at the poles; the result is scaled by
    ``scale`` (UsdLux's color · intensity · 2^exposure). Compares and hashes by identity."""

    texture: Texture  # the lat-long image (its wraps are not used: see above)
    scale: RGB = (1.0, 1.0, 1.0)  # linear RGB multiplier, >= 0
    # (3, 3) float64, orthogonal: the dome's frame from world space (the inverse, the transpose,
    # of the rotation of its transform)
    dome_from_world: np.ndarray = field(default_factory=lambda: np.eye(3))
    source: str = ""  # the DomeLight prim

    def __post_init__(self) -> None:
        _as_triples(self, "scale")
        m = np.array(_real_array(self.dome_from_world, "Environment", "dome_from_world", self.source), dtype=np.float64)
        if m.shape != (3, 3):
            raise _bad_value(
                "Environment", "dome_from_world", self.source, f"expected a 3x3 matrix, got shape {m.shape}"
            )
        m.setflags(write=False)
        object.__setattr__(self, "dome_from_world", m)


@dataclass(frozen=True, slots=True)
class Cone:
    """A spot light's cone (UsdLux ShapingAPI): along unit ``axis`` the light is unchanged where
    cos θ >= ``cos_inner``, zero where cos θ <= ``cos_outer``, and smoothstep in cos θ between
    (t = (cos θ − cos_outer)/(cos_inner − cos_outer), t²(3 − 2t): POV-Ray's spotlight edge),
    times cos θ^``focus`` inside the cone (UsdLux shaping:focus, "an off-axis cosine power
    exponent"; POV-Ray's spotlight ``tightness``). 0 < cos_outer <= cos_inner <= 1 (a cone
    narrower than a hemisphere), focus >= 0."""

    axis: Vec3
    cos_outer: float
    cos_inner: float
    focus: float = 0.0

    def __post_init__(self) -> None:
        _as_triples(self, "axis")


@dataclass(frozen=True, slots=True)
class Linking:
    """Which geometry a light reaches, as UsdLux says it: ``shadows`` is ShadowAPI's
    ``inputs:shadow:enable`` (False: the light casts no shadow rays, everything it illuminates is
    lit as if nothing were in the way); ``illuminates`` the light's ``collection:lightLink`` and
    ``shadowed_by`` its ``collection:shadowLink``, each as the ``source`` paths of the geometry
    the collection includes (None: all geometry, USD's default includeRoot). A node is in a set
    when its ``source`` is; geometry built in Python names itself by its ``source`` too."""

    shadows: bool = True
    illuminates: frozenset[str] | None = None  # geometry the light illuminates; None: all
    shadowed_by: frozenset[str] | None = None  # geometry that casts its shadows; None: all

    def lights(self, source: str) -> bool:
        """Whether the light illuminates the geometry whose prim is ``source``."""
        return self.illuminates is None or source in self.illuminates

    def shadows_from(self, source: str) -> bool:
        """Whether the geometry whose prim is ``source`` casts this light's shadows."""
        return self.shadows and (self.shadowed_by is None or source in self.shadowed_by)

    @property
    def default(self) -> bool:
        """True for a light that lights everything and is shadowed by everything."""
        return self.shadows and self.illuminates is None and self.shadowed_by is None


NO_LINKING = Linking()


@dataclass(frozen=True, slots=True)
class PointLight:
    """A point light. No distance falloff unless ``fade_power > 0`` (POV-Ray's fade rule:
    ``color · 2 / (1 + (d / fade_distance)^fade_power)``)."""

    position: Vec3
    color: RGB  # ls·cl, linear RGB (falloff "inverse-square": the radiant intensity)
    fade_distance: float = 0.0  # > 0 when fade_power > 0, world units
    fade_power: float = 0.0  # 0 = no fade (the default, as in Suffern and POV-Ray)
    source: str = ""
    falloff: Falloff = "none"  # "inverse-square": color / d² (then no fade)
    cone: Cone | None = None  # a spot light's cone
    # Multipliers of this light's diffuse and specular terms (UsdLux's inputs:diffuse and
    # inputs:specular; >= 0, 1 = the seed's light).
    diffuse: float = 1.0
    specular: float = 1.0
    linking: Linking = NO_LINKING  # shadows on or off, light and shadow linking

    def __post_init__(self) -> None:
        _as_triples(self, "position", "color")


@dataclass(frozen=True, slots=True)
class DirectionalLight:
    """A light at infinity (USD DistantLight, POV-Ray ``parallel``)."""

    direction: Vec3  # unit direction the light travels (USD: the light's −Z axis)
    color: RGB
    source: str = ""
    diffuse: float = 1.0  # multipliers of the two terms, as on PointLight
    specular: float = 1.0
    linking: Linking = NO_LINKING  # as on PointLight

    def __post_init__(self) -> None:
        _as_triples(self, "direction", "color")


@dataclass(frozen=True, slots=True)
class RectAreaLight:
    """A rectangular area light with POV-Ray's semantics (ref §5): shading is computed
    once from ``center`` like a point light; only the shadow fraction comes from a
    ``samples × samples`` grid spanning ``center ± axis_u/2 ± axis_v/2`` (edges included),
    weighted by full 4-corner subdivision (trapezoid weights for samples = 2^k + 1)."""

    center: Vec3
    axis_u: Vec3  # full edge vector (USD: width along local X)
    axis_v: Vec3  # full edge vector (USD: height along local Y)
    color: RGB
    samples: int = 9  # grid points per axis, 2^k + 1 (k >= 1)
    source: str = ""
    # "inverse-square": color · max(0, cos θ) / d², θ from the emitting side −(axis_u × axis_v)
    # (UsdLux's RectLight emits along its local −Z).
    falloff: Falloff = "none"
    diffuse: float = 1.0  # multipliers of the two terms, as on PointLight
    specular: float = 1.0
    # POV-Ray's ``adaptive n`` (ref §5): the grid is subdivided n levels deep, deeper only where
    # two adjacent corners' light colours differ by more than 0.1; None: every grid point is
    # traced (POV-Ray's default).
    adaptive: int | None = None
    # The native tracer's cells estimator (POV-Ray has none): the grid points (all of them, or
    # with ``adaptive`` those POV-Ray's recursion reaches), and in each grid cell whose 4 corners
    # disagree (a partial shadow) cell_samples² points of a shifted (0,2)-sequence instead of the
    # corners' mean; a cell whose corners agree counts as wholly lit or shadowed. None: POV-Ray's
    # estimators. A power of 2 in 2..16.
    cell_samples: int | None = None
    linking: Linking = NO_LINKING  # as on PointLight

    def __post_init__(self) -> None:
        _as_triples(self, "center", "axis_u", "axis_v", "color")


@dataclass(frozen=True, slots=True)
class SphereAreaLight:
    """A spherical area light (USD SphereLight with radius > 0): POV-Ray's
    ``area_light <2r,0,0>, <0,2r,0>, n, n circular orient`` — a disc of radius r facing each
    shaded point; shading from the centre, shadow fraction from the disc grid."""

    center: Vec3
    radius: float  # > 0
    color: RGB
    samples: int = 9  # grid points per axis, 2^k + 1 (k >= 1)
    source: str = ""
    falloff: Falloff = "none"  # "inverse-square": color / d²
    diffuse: float = 1.0  # multipliers of the two terms, as on PointLight
    specular: float = 1.0
    adaptive: int | None = None  # as RectAreaLight.adaptive
    cell_samples: int | None = None  # as RectAreaLight.cell_samples
    linking: Linking = NO_LINKING  # as on PointLight

    def __post_init__(self) -> None:
        _as_triples(self, "center", "color")


Light = Union[PointLight, DirectionalLight, RectAreaLight, SphereAreaLight]  # noqa: UP007 (a runtime alias)


# --------------------------------------------------------------------------------------------
# Geometry


@dataclass(frozen=True, slots=True, eq=False)
class Sphere:
    """A unit sphere at the origin mapped to the world by an affine ``world_from_object``
    (so any radius, translation, rotation and non-uniform scale)."""

    world_from_object: np.ndarray  # (4, 4) float64, column vectors, invertible affine
    material: PhongMaterial = DEFAULT_MATERIAL
    source: str = ""

    def __post_init__(self) -> None:
        object.__setattr__(
            self, "world_from_object", _matrix(self.world_from_object, "Sphere", "world_from_object", self.source)
        )

    @staticmethod
    def at(center: Vec3, radius: float, material: PhongMaterial = DEFAULT_MATERIAL, source: str = "") -> Sphere:
        m = np.diag([radius, radius, radius, 1.0])
        m[:3, 3] = center
        return Sphere(m, material, source)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Sphere):
            return NotImplemented
        return (
            _arrays_equal(self.world_from_object, other.world_from_object)
            and self.material == other.material
            and self.source == other.source
        )

    __hash__ = None  # type: ignore[assignment]


@dataclass(frozen=True, slots=True, eq=False)
class Points:
    """Many spheres of one material (a ``UsdGeom.Points`` prim): sphere k has world-space centre
    ``centers[k]`` and radius ``radii[k]`` (> 0). 32 bytes a sphere, where a ``Sphere`` each
    would hold a 4×4 matrix and a Python object: a million points fit. Sphere k traces exactly
    as ``Sphere.at(centers[k], radii[k], material, source)`` (the same numbers in both backends),
    and the whole set is one object for light linking, named by ``source``."""

    centers: np.ndarray  # (N, 3) float64, world space
    radii: np.ndarray  # (N,) float64, > 0
    material: PhongMaterial = DEFAULT_MATERIAL
    source: str = ""

    def __post_init__(self) -> None:
        object.__setattr__(self, "centers", _readonly(self.centers, np.float64, (3,), "Points", "centers", self.source))
        object.__setattr__(self, "radii", _readonly(self.radii, np.float64, (), "Points", "radii", self.source))

    def __len__(self) -> int:
        return len(self.radii)

    def spheres(self) -> tuple[Sphere, ...]:
        """The same spheres as ``Sphere`` nodes (for tools that want them one by one, and tests)."""
        return tuple(
            Sphere.at(c, float(r), self.material, self.source) for c, r in zip(self.centers.tolist(), self.radii)
        )

    def bounds(self) -> tuple[np.ndarray, np.ndarray] | None:
        if not len(self):
            return None
        # Block by block: the whole set's temporaries (3M points: 2 x 72 MB) added to the
        # render's peak, which the C++ scene is part of by then (benchmarks/README.md).
        blocks = [((c - r).min(axis=0), (c + r).max(axis=0)) for c, r in row_blocks(self.centers, self.radii[:, None])]
        return np.min([lo for lo, _ in blocks], axis=0), np.max([hi for _, hi in blocks], axis=0)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Points):
            return NotImplemented
        return (
            _arrays_equal(self.centers, other.centers)
            and _arrays_equal(self.radii, other.radii)
            and self.material == other.material
            and self.source == other.source
        )

    __hash__ = None  # type: ignore[assignment]


@dataclass(frozen=True, slots=True, eq=False)
class TriangleMesh:
    """A triangle mesh in world space.

    ``triangles`` index ``points``; winding is counter-clockwise seen from the front (USD
    ``rightHanded``), although shading is two-sided. Optional smooth normals: ``normals``
    holds unit vectors and ``normal_indices`` gives, per triangle corner, the row of
    ``normals`` to use (for USD ``vertex`` interpolation it equals ``triangles``). Without
    normals the mesh is flat-shaded with the geometric normal.
    """

    points: np.ndarray  # (N, 3) float64, world units
    triangles: np.ndarray  # (M, 3) int32, indices into points
    normals: np.ndarray | None = None  # (K, 3) float64, unit length
    normal_indices: np.ndarray | None = None  # (M, 3) int32, indices into normals
    material: PhongMaterial = DEFAULT_MATERIAL
    source: str = ""
    uvs: np.ndarray | None = None  # (L, 2) float64, texture coordinates (u, v)
    uv_indices: np.ndarray | None = None  # (M, 3) int32, indices into uvs

    def __post_init__(self) -> None:
        for array, partner in (("uvs", "uv_indices"), ("normals", "normal_indices")):
            if (getattr(self, array) is None) != (getattr(self, partner) is None):
                raise _bad_value(
                    "TriangleMesh",
                    partner if getattr(self, partner) is None else array,
                    self.source,
                    f"{array} and {partner} go together",
                )
        for name, dtype, tail in (
            ("points", np.float64, (3,)),
            ("triangles", np.int32, (3,)),
            ("normals", np.float64, (3,)),
            ("normal_indices", np.int32, (3,)),
            ("uvs", np.float64, (2,)),
            ("uv_indices", np.int32, (3,)),
        ):
            if getattr(self, name) is None and name in ("points", "triangles"):
                raise _bad_value("TriangleMesh", name, self.source, "is required, got None")
            if getattr(self, name) is not None:
                object.__setattr__(
                    self, name, _readonly(getattr(self, name), dtype, tail, "TriangleMesh", name, self.source)
                )

    def local_origin(self) -> np.ndarray:
        """The origin of a frame in which a float32 copy of the mesh (POV-Ray's mesh2 storage)
        keeps its precision: the centre of the mesh's bounds when the mesh lies farther from the
        world origin than its own size (float32 world coordinates would then round its features
        away), else the world origin, so that meshes near the origin are stored as they are."""
        if not len(self.points):
            return np.zeros(3)
        lo, hi = self.points.min(axis=0), self.points.max(axis=0)
        with np.errstate(over="ignore", invalid="ignore"):  # coordinates near 1e308: no local frame helps
            centre = (lo + hi) / 2
            far = bool(np.linalg.norm(centre) > np.linalg.norm(hi - lo))
        return centre if far else np.zeros(3)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, TriangleMesh):
            return NotImplemented
        return (
            _arrays_equal(self.points, other.points)
            and _arrays_equal(self.triangles, other.triangles)
            and _arrays_equal(self.normals, other.normals)
            and _arrays_equal(self.normal_indices, other.normal_indices)
            and _arrays_equal(self.uvs, other.uvs)
            and _arrays_equal(self.uv_indices, other.uv_indices)
            and self.material == other.material
            and self.source == other.source
        )

    __hash__ = None  # type: ignore[assignment]


IntrinsicKind = Literal["cube", "cylinder", "capsule", "plane"]
INTRINSIC_KINDS: tuple[str, ...] = ("cube", "cylinder", "capsule", "plane")


@dataclass(frozen=True, slots=True, eq=False)
class Intrinsic:
    """A UsdGeom intrinsic prim traced as its exact surface (not tessellated): a canonical shape
    along the object's +Z axis, mapped to the world by an affine ``world_from_object`` (the prim's
    transform, its axis and its size; the reader puts USD's X or Y axis onto Z):

    * ``cube``: the cube [−1, 1]³ (POV-Ray ``box``).
    * ``cylinder``: the side x² + y² = r(z)², |z| <= 1, r linear from ``radius_bottom`` at z = −1
      to ``radius_top`` at z = +1, closed by discs of those radii (USD Cylinder, Cylinder_1;
      a Cone is ``radius_top`` 0; POV-Ray ``cylinder`` or ``cone``).
    * ``capsule``: the side of the cylinder above over |z| <= ``half_height`` (radii
      ``radius_bottom`` at z = −``half_height``, ``radius_top`` at +``half_height``) closed by
      the two spheres tangent to it there (``capsule_ends``): USD Capsule (one radius: spheres
      of that radius centred at z = ±``half_height``) and Capsule_1 (two radii, the ends'
      spheres as UsdGeom's capsule mesh generator places them); POV-Ray the union of the three.
    * ``plane``: the square |x|, |y| <= 1 at z = 0, both sides (USD Plane; POV-Ray ``polygon``),
      or with ``infinite`` the whole plane z = 0 (POV-Ray ``plane``), which no bounds include, so
      the scale-aware tolerances stay those of the finite geometry.
    """

    kind: IntrinsicKind
    world_from_object: np.ndarray  # (4, 4) float64, column vectors, invertible affine
    material: PhongMaterial = DEFAULT_MATERIAL
    source: str = ""
    radius_bottom: float = 1.0  # cylinder, capsule: >= 0, not both radii 0
    radius_top: float = 1.0
    half_height: float = 1.0  # capsule: >= 0
    infinite: bool = False  # plane only

    def __post_init__(self) -> None:
        object.__setattr__(
            self, "world_from_object", _matrix(self.world_from_object, "Intrinsic", "world_from_object", self.source)
        )

    def object_box(self) -> tuple[np.ndarray, np.ndarray]:
        """The object-space box that holds the shape (the unbounded plane: its unit square)."""
        if self.kind == "cylinder":
            r = max(self.radius_bottom, self.radius_top)
            return np.array([-r, -r, -1.0]), np.array([r, r, 1.0])
        if self.kind == "capsule":
            ends = self.capsule_ends() or [(0.0, 0.0)]  # no radius > 0: validation says so
            r = max(radius for _, radius in ends)
            lo, hi = min(z - radius for z, radius in ends), max(z + radius for z, radius in ends)
            return np.array([-r, -r, lo]), np.array([r, r, hi])
        if self.kind == "plane":
            return np.array([-1.0, -1.0, 0.0]), np.array([1.0, 1.0, 0.0])
        return -np.ones(3), np.ones(3)

    def capsule_ends(self) -> list[tuple[float, float]]:
        """A capsule's end spheres, (centre z, radius) in object space, those of radius > 0.
        The side's slope s = (r_b − r_t) / 2h; the sphere tangent to it along the circle of
        radius r at z = z₀ has its centre at z₀ − s·r and radius r·√(1 + s²) (similar
        triangles; UsdGeom's capsule generator places its caps so). With one radius (s = 0):
        spheres of that radius at z = ±h. With h = 0 and two radii the shape is the larger
        sphere (the side has no height to join them)."""
        h, rb, rt = self.half_height, self.radius_bottom, self.radius_top
        if rb == rt:
            ends = [(-h, rb), (h, rt)]
        elif h == 0:
            ends = [(0.0, max(rb, rt))]
        else:
            s = (rb - rt) / (2.0 * h)
            grow = math.sqrt(1.0 + s * s)
            ends = [(-h - s * rb, rb * grow), (h - s * rt, rt * grow)]
        return [(z, r) for z, r in ends if r > 0]

    def world_bounds(self) -> tuple[np.ndarray, np.ndarray] | None:
        """World AABB of the object box under the affine map (exact for a cube); None for an
        infinite plane."""
        if self.infinite:
            return None
        lo, hi = self.object_box()
        m = self.world_from_object
        centre = m[:3, :3] @ ((lo + hi) / 2) + m[:3, 3]
        half = np.abs(m[:3, :3]) @ ((hi - lo) / 2)
        return centre - half, centre + half

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Intrinsic):
            return NotImplemented
        return (
            self.kind == other.kind
            and _arrays_equal(self.world_from_object, other.world_from_object)
            and (self.radius_bottom, self.radius_top, self.half_height, self.infinite)
            == (other.radius_bottom, other.radius_top, other.half_height, other.infinite)
            and self.material == other.material
            and self.source == other.source
        )

    __hash__ = None  # type: ignore[assignment]


# --------------------------------------------------------------------------------------------
# Instancing


@dataclass(frozen=True, slots=True, eq=False)
class Prototype:
    """Geometry read once and placed many times (a PointInstancer prototype, or the prototype
    USD shares among instanceable references): its meshes in the prototype's own space. Spheres
    are not kept here: an analytic sphere is already a transform of the unit sphere, so the
    reader places each one in the world (``Scene.spheres``), which costs no more than an
    instance. Prototypes compare and hash by identity (one per prototype read)."""

    meshes: tuple[TriangleMesh, ...]
    source: str = ""  # USD prim path of the prototype (a PointInstancer's target, or the first instance)

    @property
    def triangle_count(self) -> int:
        return sum(len(m.triangles) for m in self.meshes)

    def bounds(self) -> tuple[np.ndarray, np.ndarray] | None:
        """Prototype-space axis-aligned bounds of its points, or None without any."""
        points = [m.points for m in self.meshes if len(m.points)]
        if not points:
            return None
        return np.min([p.min(axis=0) for p in points], axis=0), np.max([p.max(axis=0) for p in points], axis=0)


@dataclass(frozen=True, slots=True, eq=False)
class Instances:
    """Copies of one prototype: ``world_from_prototype[k]`` places copy k (column vectors, an
    invertible affine 4×4). One array for all copies, so 10,000 instances cost 1.25 MiB, not
    10,000 meshes. ``sources[k]`` names copy k's prim (an instanceable prim's path, or the
    PointInstancer's path with ``[id]``) for errors; empty when built in Python."""

    prototype: Prototype
    world_from_prototype: np.ndarray  # (K, 4, 4) float64
    source: str = ""  # the PointInstancer, or "" for instanceable references (see sources)
    sources: tuple[str, ...] = ()
    # (K, 3) linear RGB >= 0, or None: copy k's cd on the prototype's meshes whose material has
    # instance_color (a per-instance primvar's values); the other meshes keep their own cd.
    colors: np.ndarray | None = None

    def __post_init__(self) -> None:
        m = np.array(self.world_from_prototype, dtype=np.float64, order="C", copy=True)
        if m.ndim != 3 or m.shape[1:] != (4, 4):
            raise ValueError(f"expected transforms of shape (K, 4, 4), got {m.shape}")
        m.setflags(write=False)
        object.__setattr__(self, "world_from_prototype", m)
        if self.colors is not None:
            c = np.array(self.colors, dtype=np.float64, order="C", copy=True)
            if c.shape != (len(m), 3):
                raise ValueError(f"expected colors of shape ({len(m)}, 3), one per copy, got {c.shape}")
            c.setflags(write=False)
            object.__setattr__(self, "colors", c)

    def material_of(self, mesh: TriangleMesh, k: int) -> PhongMaterial:
        """Copy k's material on the prototype's ``mesh``: its own, or with cd the copy's colour
        (instance_color)."""
        m = mesh.material
        if not m.instance_color or self.colors is None:
            return m
        return replace(m, diffuse_color=tuple(float(c) for c in self.colors[k]), instance_color=False)

    def __len__(self) -> int:
        return len(self.world_from_prototype)

    def source_of(self, k: int) -> str:
        return self.sources[k] if k < len(self.sources) else self.source

    def bounds(self) -> tuple[np.ndarray, np.ndarray] | None:
        """World-space bounds of every copy (the prototype's box under each transform: exact for
        the box, an upper bound for the points)."""
        b = self.prototype.bounds()
        if b is None or not len(self):
            return None
        lo, hi = b
        centre, half = (lo + hi) / 2, (hi - lo) / 2
        a = self.world_from_prototype[:, :3, :3]
        c = np.einsum("kij,j->ki", a, centre) + self.world_from_prototype[:, :3, 3]
        r = np.einsum("kij,j->ki", np.abs(a), half)
        return (c - r).min(axis=0), (c + r).max(axis=0)

    def placed_meshes(self, k: int) -> tuple[TriangleMesh, ...]:
        """Copy k's meshes in world space (what flattening it would give)."""
        m = self.world_from_prototype[k]
        a, t = m[:3, :3], m[:3, 3]
        out = []
        for mesh in self.prototype.meshes:
            normals = mesh.normals
            if normals is not None:
                normals = normals @ np.linalg.inv(a)
                normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
            out.append(replace(mesh, points=mesh.points @ a.T + t, normals=normals, material=self.material_of(mesh, k)))
        return tuple(out)


# --------------------------------------------------------------------------------------------
# Render settings and the scene


@dataclass(frozen=True, slots=True)
class RenderSettings:
    """How to render, independent of the backend."""

    width: int = 320  # pixels, >= 1
    height: int = 240  # pixels, >= 1
    samples: int = 1  # anti-aliasing: n per axis (1 = the pixel centre only), 1..9
    # "grid": an n×n cell-centred grid, box filtered (POV-Ray: render n× larger with -A and
    # average n×n blocks). "povray-am1": POV-Ray's +AM1 +A0.0 +R n -J, i.e. the pixel centre
    # plus the n×n grid, divided by n²+1 (ref §8), in pixels where the colour changes by at least
    # ``aa_threshold`` (every pixel at 0). "povray-am2": POV-Ray's +AM2 +A t +R n -J, the pixel's
    # corners, then 4-corner subdivision down to 2^(n−1) cells per side where the corners differ by
    # at least ``aa_threshold`` (the full grid, trapezoid weights, at 0). "stratified" (native
    # only): 4, 16, 64, … points of a per-pixel scrambled Sobol' (0,2)-sequence, up to n², while
    # the estimate still changes by at least ``aa_threshold`` (linear |Δr|+|Δg|+|Δb|; all n² at 0).
    # "adaptive" (native only): the pixel's corners, then 4-way splits of a cell of side s while
    # its corners' spread (linear, summed over channels) times s^1.5 is at least ``aa_threshold``,
    # down to 1/n of a pixel (n a power of 2); samples shared across the pixels of a tile.
    sample_pattern: SamplePattern = "grid"
    # POV-Ray's +A: compared with |Δr|+|Δg|+|Δb| of colours encoded as c^(1/2.5), [0, 1].
    aa_threshold: float = 0.0
    threads: int = 0  # native backend: worker threads, 0 = all cores
    background: RGB = (0.0, 0.0, 0.0)  # colour of rays that hit nothing, linear RGB
    specular: SpecularConvention = "seed"
    source: str = ""  # the UsdRender.Settings prim, if any
    numerics: Numerics = "scale-invariant"  # native only (POV-Ray always has its own)
    # The deepest secondary ray traced (the book's max_depth): the camera ray has depth 0, each
    # reflection adds 1, and a ray deeper than this returns black (POV-Ray: max_trace_level
    # max_depth + 1, ref §18). Only scenes with reflective materials trace secondary rays.
    max_depth: int = 5
    transmission: TransmissionConvention = "book"  # the radiance of refracted rays (above)

    def __post_init__(self) -> None:
        _as_triples(self, "background")


@dataclass(frozen=True, slots=True)
class Scene:
    """Everything a backend needs. Build it in Python or with ``phongscene.load_usd``."""

    camera: Camera = field(default_factory=Camera)
    ambient: AmbientLight = field(default_factory=AmbientLight)
    lights: tuple[Light, ...] = ()
    spheres: tuple[Sphere, ...] = ()
    meshes: tuple[TriangleMesh, ...] = ()
    settings: RenderSettings = field(default_factory=RenderSettings)
    intrinsics: tuple[Intrinsic, ...] = ()  # Cube, Cylinder, Cone, Capsule, Plane: exact surfaces
    source_file: str = ""  # the file the scene was read from ("" when built in Python)
    # Prototypes placed by transforms (instancing): their meshes are in prototype space.
    instances: tuple[Instances, ...] = ()
    points: tuple[Points, ...] = ()  # UsdGeom.Points: many spheres each, compactly
    # What rays that hit nothing see, by direction (None: settings.background, one colour).
    environment: Environment | None = None

    @property
    def triangle_count(self) -> int:
        """Triangles stored: the world meshes' and each prototype's once."""
        return sum(len(m.triangles) for m in self.meshes) + sum(p.triangle_count for p in self.prototypes)

    @property
    def prototypes(self) -> tuple[Prototype, ...]:
        """The distinct prototypes the instances refer to, in first-use order."""
        return tuple({id(i.prototype): i.prototype for i in self.instances}.values())

    @property
    def instance_count(self) -> int:
        return sum(len(i) for i in self.instances)

    @property
    def instanced_triangle_count(self) -> int:
        """Triangles the scene draws: the world meshes' plus every copy's."""
        return sum(len(m.triangles) for m in self.meshes) + sum(
            len(i) * i.prototype.triangle_count for i in self.instances
        )

    def flattened(self) -> Scene:
        """The same scene with every instance written out as world-space meshes (for tools
        that do not know instances, and to check that instancing changes nothing)."""
        if not self.instances:
            return self
        meshes = list(self.meshes)
        for group in self.instances:
            for k in range(len(group)):
                meshes.extend(group.placed_meshes(k))
        return replace(self, meshes=tuple(meshes), instances=())

    def with_material(self, path: str, **changes) -> Scene:
        """This scene with the material at ``path`` changed: ``scene.with_material(
        "/World/Looks/Red", ks=0.5, diffuse_color=(1, 0, 0))``. ``path`` is a material's (its
        shader's or its Material prim's path, every object bound to it changes) or an object's
        (that object's material only). Keywords are ``PhongMaterial`` fields; the scene is
        validated when it renders.

        Raises:
            TypeError: a keyword that is not a PhongMaterial field.
            KeyError: nothing in the scene has that path (the message lists the materials).
        """
        import dataclasses
        import difflib

        known = [f.name for f in dataclasses.fields(PhongMaterial) if f.name != "source"]
        for name in changes:
            if name not in known:
                close = difflib.get_close_matches(name, known, n=1)
                raise TypeError(
                    f"with_material: {name!r} is not a PhongMaterial field"
                    + (f" (did you mean {close[0]!r}?)" if close else f"; the fields: {', '.join(known)}")
                )

        def matches(obj) -> bool:
            source = obj.material.source
            return obj.source == path or source == path or (bool(source) and source.startswith(path.rstrip("/") + "/"))

        found = [obj for obj in (*self.spheres, *self.meshes, *self.points) if matches(obj)]
        if not found:
            materials = sorted(
                {o.material.source for o in (*self.spheres, *self.meshes, *self.points) if o.material.source}
            )
            raise KeyError(
                f"with_material: no material or object at {path!r}; the materials: "
                f"{', '.join(materials) or '(none named)'}"
            )

        def changed(obj):
            return (
                dataclasses.replace(obj, material=dataclasses.replace(obj.material, **changes)) if matches(obj) else obj
            )

        return dataclasses.replace(
            self,
            spheres=tuple(map(changed, self.spheres)),
            meshes=tuple(map(changed, self.meshes)),
            points=tuple(map(changed, self.points)),
        )

    @property
    def normal_mapped(self) -> bool:
        """Whether a mesh (a world one or a prototype's) has a normal-mapped material."""
        meshes = (*self.meshes, *(m for p in self.prototypes for m in p.meshes))
        return any(m.material.normal_texture is not None for m in meshes)

    def without_normal_maps(self) -> Scene:
        """The same scene with every normal map left out (what POV-Ray 3.7 renders of it; the
        instances written out as meshes where a prototype has one)."""
        if not self.normal_mapped:
            return self
        import dataclasses

        in_prototypes = any(m.material.normal_texture is not None for p in self.prototypes for m in p.meshes)
        scene = self.flattened() if in_prototypes else self
        plain: dict[PhongMaterial, PhongMaterial] = {}

        def unmapped(mesh):
            if mesh.material.normal_texture is None:
                return mesh
            material = plain.setdefault(mesh.material, dataclasses.replace(mesh.material, normal_texture=None))
            return dataclasses.replace(mesh, material=material)

        return dataclasses.replace(scene, meshes=tuple(map(unmapped, scene.meshes)))

    @property
    def objects(self) -> tuple:
        """Every geometry node, in the order the backends number them: spheres, meshes, intrinsics,
        points (the last, so that adding them renumbers nothing before)."""
        return (*self.spheres, *self.meshes, *self.intrinsics, *self.points)

    def bounds(self) -> tuple[np.ndarray, np.ndarray] | None:
        """World-space axis-aligned bounds of all geometry but infinite planes, or None for an
        empty scene."""
        lows, highs = [], []
        for i in self.intrinsics:
            b = i.world_bounds()
            if b is not None:
                lows.append(b[0])
                highs.append(b[1])
        for m in self.meshes:
            if len(m.points):
                lows.append(m.points.min(axis=0))
                highs.append(m.points.max(axis=0))
        for group in (*self.instances, *self.points):
            b = group.bounds()
            if b is not None:
                lows.append(b[0])
                highs.append(b[1])
        for s in self.spheres:
            # Exact AABB of an affinely transformed unit sphere: centre ± row norms of the 3×3 part.
            c = s.world_from_object[:3, 3]
            r = np.sqrt((s.world_from_object[:3, :3] ** 2).sum(axis=1))
            lows.append(c - r)
            highs.append(c + r)
        if not lows:
            return None
        return np.min(lows, axis=0), np.max(highs, axis=0)


# A scene whose bounds are a single point still gets a camera at a positive distance.
FRAMING_MIN_RADIUS = 1e-12


def framing_camera(scene: Scene, horizontal_fov_deg: float = 60.0) -> Camera:
    """The default camera for a scene without one: looking down −Z (slightly from above) at the
    centre of the bounds, far enough back that the bounding sphere fits the narrower FOV."""
    b = scene.bounds()
    if b is None:
        return Camera(horizontal_fov_deg=horizontal_fov_deg)
    lo, hi = b
    centre = (lo + hi) / 2
    radius = max(float(np.linalg.norm(hi - lo)) / 2, FRAMING_MIN_RADIUS)
    aspect = scene.settings.width / scene.settings.height
    half_h = math.radians(horizontal_fov_deg) / 2
    half_v = math.atan(math.tan(half_h) / aspect)
    distance = radius / math.sin(min(half_h, half_v))
    forward = np.array([0.0, -0.25, -1.0])
    forward /= np.linalg.norm(forward)
    up = np.array([0.0, 1.0, 0.0]) - forward * forward[1]
    up /= np.linalg.norm(up)
    position = centre - forward * distance
    return Camera(
        position=tuple(map(float, position)),
        forward=tuple(map(float, forward)),
        up=tuple(map(float, up)),
        horizontal_fov_deg=horizontal_fov_deg,
        source="(default framing camera)",
    )


def head_light(camera: Camera, color: RGB = (math.pi, math.pi, math.pi)) -> PointLight:
    """The default light for a scene without lights: a point light at the eye. Its strength π
    makes a head-on Lambert surface with kd = 1 reflect exactly cd."""
    return PointLight(position=camera.position, color=color, source="(default head light)")
