# SPDX-License-Identifier: Apache-2.0
"""Validation of a ``Scene``: every problem at once, each naming prim, model field and file.

Backends assume a validated scene (their own checks are assertions). Problems name the model's
fields (``ks``, ``samples``) and carry the node type; the USD layer translates them into the
attributes of the file a scene was read from (``phongscene.usd.names.in_usd_terms``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from .errors import Problem, SceneError

# The bounds every size, count and sample knob has (phongscene/limits.py, which the CLI imports
# without numpy).
from .limits import (
    MAX_ADAPTIVE,
    MAX_CELL_SAMPLES,
    MAX_COORDINATE,
    MAX_DEPTH,
    MAX_IMAGE_SIDE,
    MAX_ORTHO_WIDTH,
    MAX_PIXELS,
    MAX_SAMPLES,
    MAX_SHADOW_SAMPLES,
    MAX_STRATIFIED_SAMPLES,
    MAX_TEXEL,
    MAX_TEXTURE_SIDE,
    MAX_THREADS,
    MIN_ORTHO_WIDTH,
)
from .scene import (
    INTRINSIC_KINDS,
    NUMERICS,
    SAMPLE_PATTERNS,
    TRANSMISSION_CONVENTIONS,
    WRAPS,
    AmbientLight,
    Camera,
    Cone,
    DirectionalLight,
    Environment,
    Instances,
    Intrinsic,
    Linking,
    PhongMaterial,
    PointLight,
    Points,
    Prototype,
    RectAreaLight,
    RenderSettings,
    Scene,
    Sphere,
    SphereAreaLight,
    Texture,
    TriangleMesh,
)
from .tolerances import SINGULAR_RELATIVE_DET, UNIT_TOLERANCE, is_singular


class _Collector:
    def __init__(self, file: str):
        self.file = file
        self.problems: list[Problem] = []

    def add(self, node, field: str, message: str) -> None:
        source = getattr(node, "source", "")
        self.problems.append(Problem(message, prim=source, attribute=field, file=self.file, node=type(node).__name__))

    # -- generic checks --------------------------------------------------------------------

    def finite(self, node, field: str, value) -> bool:
        try:
            arr = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError):  # a string, None, a ragged list: a Python API mistake
            self.add(node, field, f"must be a number or numbers, got {value!r:.80}")
            return False
        if arr.size and not np.all(np.isfinite(arr)):
            self.add(node, field, f"must be finite, got {_show(value)}")
            return False
        return True

    def real(self, node, field: str, value) -> bool:
        """One finite real number (a bool, a string, an array or None is a problem naming the field)."""
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
            self.add(node, field, f"must be a number, got {_show(value)}")
            return False
        if not np.isfinite(value):
            self.add(node, field, f"must be finite, got {_show(value)}")
            return False
        return True

    def one_of(self, node, field: str, choices: tuple[str, ...]) -> bool:
        value = getattr(node, field)
        if isinstance(value, str) and value in choices:
            return True
        self.add(node, field, f"must be one of {', '.join(choices)}, got {_show(value)}")
        return False

    def triple(self, node, field: str, value) -> bool:
        """3 real numbers (strings that look like numbers, complex numbers, bools are not)."""
        if not _is_triple(value) or not all(_number(v) for v in value):
            self.add(node, field, f"must be 3 numbers, got {_show(value)}")
            return False
        return True

    def position(self, node, field: str, value) -> bool:
        """3 finite numbers within ±MAX_COORDINATE."""
        return self.triple(node, field, value) and self.coordinates(node, field, value)

    def coordinates(self, node, field: str, value) -> bool:
        """Finite numbers (any array of them) within ±MAX_COORDINATE."""
        if not self.finite(node, field, value):
            return False
        arr = np.asarray(value, dtype=np.float64)
        if arr.size and float(np.max(np.abs(arr))) > MAX_COORDINATE:
            self.add(
                node,
                field,
                f"coordinates must be within ±{MAX_COORDINATE:g} (so that distances and their "
                f"squares stay finite), got {float(np.max(np.abs(arr))):.3g}",
            )
            return False
        return True

    def colour(self, node, field: str) -> None:
        value = getattr(node, field)
        if self.triple(node, field, value) and self.finite(node, field, value) and min(value) < 0:
            self.add(node, field, f"must be >= 0 in every channel, got {_show(value)}")

    def vector(self, node, field: str, unit: bool) -> np.ndarray | None:
        value = getattr(node, field)
        if not self.triple(node, field, value) or not self.finite(node, field, value):
            return None
        v = np.asarray(value, dtype=np.float64)
        length = float(np.linalg.norm(v))
        if length == 0:
            self.add(node, field, "must not be the zero vector")
            return None
        if unit and abs(length - 1) > UNIT_TOLERANCE:
            self.add(node, field, f"must be a unit vector, got length {length:.9g}")
            return None
        return v

    def unit_interval(self, node, field: str) -> None:
        value = getattr(node, field)
        if self.real(node, field, value) and not 0 <= value <= 1:
            self.add(node, field, f"must be in [0, 1], got {_show(value)}")

    def samples_2k1(self, node) -> None:
        n = node.samples
        if not isinstance(n, (int, np.integer)) or n < 3 or n > MAX_SHADOW_SAMPLES or (n - 1) & (n - 2):
            self.add(
                node,
                "samples",
                f"must be 2^k + 1 with 1 <= k <= 8 (3, 5, 9, 17, ..., {MAX_SHADOW_SAMPLES}), got {_show(n)}",
            )

    def adaptive(self, node) -> None:
        a = node.adaptive
        if a is not None and (
            isinstance(a, bool) or not isinstance(a, (int, np.integer)) or not 0 <= a <= MAX_ADAPTIVE
        ):
            self.add(
                node,
                "adaptive",
                f"must be an integer in 0..{MAX_ADAPTIVE} (or unset: every grid point), got {_show(a)}",
            )
        k = node.cell_samples
        if k is None:
            return
        # a power of 2: the (0,2)-sequence's k² points then stratify the cell evenly
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 2 <= k <= MAX_CELL_SAMPLES or k & (k - 1):
            self.add(node, "cell_samples", f"must be a power of 2 in 2..{MAX_CELL_SAMPLES} (or unset), got {_show(k)}")


def _is_triple(value) -> bool:
    """A sequence of length 3 (of anything: ``finite`` then checks the numbers)."""
    return not isinstance(value, (str, bytes)) and hasattr(value, "__len__") and len(value) == 3


# The node types each field of a Scene holds: a scene built in Python with something else (a
# light that is a tuple, a mesh that is a dict) is one problem naming the field, not an
# AttributeError deep in a check or a backend.
_NODE_TYPES = {
    "camera": Camera,
    "ambient": AmbientLight,
    "settings": RenderSettings,
}
_ITEM_TYPES = {
    "lights": (PointLight, DirectionalLight, RectAreaLight, SphereAreaLight),
    "spheres": (Sphere,),
    "meshes": (TriangleMesh,),
    "intrinsics": (Intrinsic,),
    "instances": (Instances,),
    "points": (Points,),
}


def _wrong_types(scene: Scene) -> list[Problem]:
    """A problem for every field of ``scene`` that holds the wrong kind of node."""
    out = []
    for name, kind in _NODE_TYPES.items():
        value = getattr(scene, name)
        if not isinstance(value, kind):
            out.append(
                Problem(
                    f"must be {_a(kind.__name__)}, got {type(value).__name__}", attribute=name, file=scene.source_file
                )
            )
    for name, kinds in _ITEM_TYPES.items():
        items = getattr(scene, name)
        if not isinstance(items, (tuple, list)):
            out.append(Problem(f"must be a tuple, got {type(items).__name__}", attribute=name, file=scene.source_file))
            continue
        expected = " or ".join(_a(k.__name__) for k in kinds)
        for i, item in enumerate(items):
            if not isinstance(item, kinds):
                out.append(
                    Problem(
                        f"must be {expected}, got {type(item).__name__}",
                        attribute=f"{name}[{i}]",
                        file=scene.source_file,
                    )
                )
            elif name == "instances":
                if not isinstance(item.prototype, Prototype) or not all(
                    isinstance(m, TriangleMesh) for m in item.prototype.meshes
                ):
                    out.append(
                        Problem(
                            "must be a Prototype of TriangleMeshes",
                            prim=item.source,
                            attribute=f"{name}[{i}]",
                            file=scene.source_file,
                        )
                    )
            elif name != "lights" and not isinstance(item.material, PhongMaterial):
                out.append(
                    Problem(
                        f"must be a PhongMaterial, got {type(item.material).__name__}",
                        prim=_text(item.source),
                        attribute="material",
                        file=scene.source_file,
                    )
                )
    if out:
        return out
    # Every node's ``source`` names its prim in every later message: it must be text.
    nodes = [scene.camera, scene.ambient, scene.settings, *scene.lights, *scene.spheres, *scene.meshes, *scene.points]
    nodes += [n.material for n in (*scene.spheres, *scene.meshes, *scene.points)]
    for node in nodes:
        if not isinstance(node.source, str):
            out.append(
                Problem(
                    f'must be a str (the USD prim path, or ""), got {type(node.source).__name__}',
                    attribute="source",
                    file=scene.source_file,
                    node=type(node).__name__,
                )
            )
    if not isinstance(scene.source_file, str):
        out.append(Problem(f"must be a str, got {type(scene.source_file).__name__}", attribute="source_file"))
    environment = scene.environment
    if environment is not None and not (
        isinstance(environment, Environment) and isinstance(environment.texture, Texture)
    ):
        out.append(
            Problem(
                f"must be an Environment with a Texture (or None), got {type(environment).__name__}",
                attribute="environment",
                file=scene.source_file,
            )
        )
    return out


def _text(value) -> str:
    return value if isinstance(value, str) else repr(value)


def _a(name: str) -> str:
    return ("an " if name[0] in "AEIOU" else "a ") + name


def _show(value) -> str:
    if isinstance(value, (tuple, list)) and all(_number(v) for v in value):
        return "(" + ", ".join(f"{float(v):.9g}" for v in value) + ")"
    if isinstance(value, np.ndarray):
        return f"array of shape {value.shape}"
    if isinstance(value, np.generic):  # a numpy scalar: its Python value, not "np.float64(...)"
        return repr(value.item())
    return f"{value!r:.80}"


def _number(value) -> bool:
    """A single real number (not a bool)."""
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))


def validate(scene: Scene) -> list[Problem]:
    """Every problem in ``scene``: ranges, non-finite numbers, degenerate vectors, indices.

    Args:
        scene: the scene to check.

    Returns:
        The problems found (empty when the scene is valid), each naming the node's prim
        (``source``), the attribute and ``scene.source_file``.
    """
    if not isinstance(scene, Scene):
        raise TypeError(f"expected a phongscene Scene (phongscene.load_usd reads a file), got {type(scene).__name__}")
    wrong = _wrong_types(scene)
    if wrong:  # the checks below assume the node types
        return wrong
    c = _Collector(scene.source_file)
    _check_camera(c, scene.camera)
    _check_settings(c, scene.settings)
    c.colour(scene.ambient, "color")
    if scene.environment is not None:
        _check_environment(c, scene.environment)
    for light in scene.lights:
        _check_light(c, light)
    materials: list[PhongMaterial] = []
    for sphere in scene.spheres:
        _check_sphere(c, sphere)
        materials.append(sphere.material)
        if sphere.material.textures:
            c.add(sphere, "material", "a textured material needs texture coordinates, which only meshes carry")
    for group in scene.points:
        _check_points(c, group)
        materials.append(group.material)
        if group.material.textures:
            c.add(group, "material", "a textured material needs texture coordinates, which only meshes carry")
    for group in scene.instances:
        _check_instances(c, group)
    prototype_meshes = [m for p in scene.prototypes for m in p.meshes]
    for mesh in (*scene.meshes, *prototype_meshes):
        _check_mesh(c, mesh)
        materials.append(mesh.material)
        if mesh.material.textures and mesh.uvs is None:
            c.add(mesh, "uvs", "a mesh with a textured material needs texture coordinates (uvs)")
    for intrinsic in scene.intrinsics:
        _check_intrinsic(c, intrinsic)
        materials.append(intrinsic.material)
        if intrinsic.material.textures:
            c.add(intrinsic, "material", "a textured material needs texture coordinates, which only meshes carry")
    for material in _unique(materials):
        _check_material(c, material)
    transmission = getattr(scene.settings, "transmission", None)  # a hostile value: reported below
    filtered_shadows = isinstance(transmission, str) and transmission == "povray"
    if filtered_shadows and any(_number(m.kt) and m.kt > 0 for m in materials):  # a bad kt: reported above
        # POV-Ray's convention filters shadows through transmissive objects: an area light's grid
        # samples are filtered (all of them, or POV-Ray's `adaptive n` recursion on their colours);
        # the native cells estimator, which answers visibility only, does not apply. (In the
        # book's convention glass casts opaque shadows: visibility is the whole answer.)
        for light in scene.lights:
            if isinstance(light, (RectAreaLight, SphereAreaLight)) and light.cell_samples is not None:
                c.add(
                    light,
                    "cell_samples",
                    "in POV-Ray's transmission convention an area light's shadows through transmissive "
                    "materials (kt > 0) are filtered at its grid samples, which the cells estimator does "
                    "not do: unset it, or render in the book's convention (glass casts opaque shadows)",
                )
    if any(m.opacity_texture is not None for m in materials):
        # Light passes a mask's cut-out texels: shadow rays go surface by surface, which an area
        # light's grid samples do and the cells estimator (visibility of whole cells) does not.
        for light in scene.lights:
            if isinstance(light, (RectAreaLight, SphereAreaLight)) and light.cell_samples is not None:
                c.add(
                    light,
                    "cell_samples",
                    "light passes the cut-out texels of a material's mask (opacity_texture), which the "
                    "cells estimator does not see: unset it (the area light's grid is traced instead)",
                )
    return c.problems


def check(scene: Scene) -> Scene:
    """Raise one ``SceneError`` listing every problem in ``scene``; return it when valid."""
    problems = validate(scene)
    if problems:
        raise SceneError(problems)
    return scene


def _unique(materials: Iterable[PhongMaterial]) -> list[PhongMaterial]:
    # Shared materials are reported once. Equality (not identity): frozen dataclasses, hashed
    # so that thousands of distinct materials (one per displayColor gprim) cost linear time.
    # A material built in Python with an unhashable field (a list colour) is compared by hand.
    unique: list[PhongMaterial] = []
    seen: set[PhongMaterial] = set()
    unhashable: list[PhongMaterial] = []
    for m in materials:
        try:
            if m in seen:
                continue
            seen.add(m)
        except TypeError:
            if any(m is u or m == u for u in unhashable):
                continue
            unhashable.append(m)
        unique.append(m)
    return unique


def _check_material(c: _Collector, m: PhongMaterial) -> None:
    for field in ("ka", "kd", "ks"):
        c.unit_interval(m, field)
    if c.real(m, "exponent", m.exponent) and m.exponent < 0:
        c.add(m, "exponent", f"must be >= 0, got {_show(m.exponent)}")
    c.colour(m, "diffuse_color")
    c.colour(m, "specular_color")
    c.colour(m, "emission")
    c.unit_interval(m, "kr")
    c.colour(m, "reflective_color")
    c.unit_interval(m, "kt")
    if c.real(m, "ior", m.ior) and not m.ior > 0:
        c.add(m, "ior", f"must be > 0, got {_show(m.ior)}")
    c.colour(m, "interior_filter")
    f = m.interior_filter
    if _is_triple(f) and all(_number(x) and np.isfinite(x) for x in f) and not all(0 < x <= 1 for x in f):
        c.add(m, "interior_filter", f"must be in (0, 1] per channel, got {_show(f)}")
    if not isinstance(m.fresnel, (bool, np.bool_)):
        c.add(m, "fresnel", f"must be True or False, got {_show(m.fresnel)}")
    if not isinstance(m.instance_color, (bool, np.bool_)):
        c.add(m, "instance_color", f"must be True or False, got {_show(m.instance_color)}")
    if c.real(m, "checker_size", m.checker_size) and not m.checker_size >= 0:
        c.add(m, "checker_size", f"must be >= 0 (0: no checker), got {_show(m.checker_size)}")
    c.colour(m, "checker_color")
    if not isinstance(m.checker_plane, (bool, np.bool_)):
        c.add(m, "checker_plane", f"must be True or False, got {_show(m.checker_plane)}")
    if c.real(m, "checker_outline_width", m.checker_outline_width) and not m.checker_outline_width >= 0:
        c.add(m, "checker_outline_width", f"must be >= 0 (0: no outline), got {_show(m.checker_outline_width)}")
    c.colour(m, "checker_outline_color")
    if _number(m.checker_size) and m.checker_size > 0 and m.diffuse_texture is not None:
        c.add(m, "checker_size", "a checker and a diffuse texture both give cd: use one of them")
    if c.real(m, "opacity_threshold", m.opacity_threshold):
        if m.opacity_texture is not None and not 0.0 < m.opacity_threshold <= 1.0:
            c.add(
                m, "opacity_threshold", f"must be in (0, 1] with an opacity_texture, got {_show(m.opacity_threshold)}"
            )
        elif m.opacity_texture is None and m.opacity_threshold != 0.0:
            c.add(m, "opacity_threshold", "needs an opacity_texture (the mask it thresholds)")
    if m.opacity_texture is not None and _number(m.kt) and m.kt > 0:
        c.add(m, "opacity_texture", "a cut-out mask on a transmissive material (kt > 0) is not modelled")
    for field in ("diffuse_texture", "specular_texture", "normal_texture", "opacity_texture"):
        t = getattr(m, field)
        if t is None:
            continue
        if isinstance(t, Texture):
            _check_texture(c, t, signed=field == "normal_texture")
        else:
            c.add(m, field, f"must be a Texture (or None), got {type(t).__name__}")


def _check_texture(c: _Collector, t, signed: bool = False) -> None:
    """A texture's wraps, size and texels: colours in [0, MAX_TEXEL]; a normal map's (``signed``)
    tangent-space vectors in [-MAX_TEXEL, MAX_TEXEL] (the tracer normalises them)."""
    for field in ("wrap_s", "wrap_t"):
        c.one_of(t, field, WRAPS)
    if max(t.image.shape[:2]) > MAX_TEXTURE_SIDE:
        c.add(t, "image", f"sides must be at most {MAX_TEXTURE_SIDE} texels, got {t.width} x {t.height}")
    image = t.image
    # min and max propagate NaN and show an infinity: all texels are finite when both are, and
    # finding it out allocates nothing (np.isfinite of a 16K texture would be 800 MB of booleans).
    low, high = (float(image.min()), float(image.max())) if image.size else (0.0, 0.0)
    if not (math.isfinite(low) and math.isfinite(high)):
        c.add(t, "image", f"{int(np.count_nonzero(~np.isfinite(image)))} texel values are not finite")
    elif (low < (-MAX_TEXEL if signed else 0)) or high > MAX_TEXEL:
        lowest = f"-{MAX_TEXEL:g}" if signed else "0"
        c.add(t, "image", f"texel values must be in [{lowest}, {MAX_TEXEL:g}], got {low:g}..{high:g}")


def _check_environment(c: _Collector, e: Environment) -> None:
    """The dome's image (as a texture's), its scale (a colour) and its frame: a rotation, or a
    mirrored one (orthogonal to UNIT_TOLERANCE: the lookup takes the direction as it is)."""
    _check_texture(c, e.texture)
    c.colour(e, "scale")
    m = e.dome_from_world
    if not np.all(np.isfinite(m)):
        c.add(e, "dome_from_world", "must be finite")
    elif np.max(np.abs(m @ m.T - np.eye(3))) > UNIT_TOLERANCE:
        c.add(e, "dome_from_world", "must be orthogonal (a rotation, possibly mirrored)")


def _check_camera(c: _Collector, cam: Camera) -> None:
    c.position(cam, "position", cam.position)
    forward = c.vector(cam, "forward", unit=True)
    up = c.vector(cam, "up", unit=True)
    if forward is not None and up is not None and abs(float(forward @ up)) > UNIT_TOLERANCE:
        c.add(cam, "up", f"must be orthogonal to forward, got forward·up = {float(forward @ up):.9g}")
    # Both extents reach the backends whatever the projection: both must be numbers; the one
    # the projection uses must be in range.
    fov_ok = c.real(cam, "horizontal_fov_deg", cam.horizontal_fov_deg)
    width_ok = c.real(cam, "ortho_width", cam.ortho_width)
    if not c.one_of(cam, "projection", ("perspective", "orthographic")):
        pass
    elif cam.projection == "perspective":
        if fov_ok and not 0 < cam.horizontal_fov_deg < 180:
            c.add(cam, "horizontal_fov_deg", f"must be in (0, 180) degrees, got {_show(cam.horizontal_fov_deg)}")
    elif width_ok and not MIN_ORTHO_WIDTH <= cam.ortho_width <= MAX_ORTHO_WIDTH:
        c.add(
            cam,
            "ortho_width",
            f"the orthographic view window must be {MIN_ORTHO_WIDTH:g}..{MAX_ORTHO_WIDTH:g} "
            f"world units wide, got {_show(cam.ortho_width)}",
        )


def _check_settings(c: _Collector, s: RenderSettings) -> None:
    sides_ok = True
    for field in ("width", "height"):
        value = getattr(s, field)
        if not isinstance(value, (int, np.integer)) or not 1 <= value <= MAX_IMAGE_SIDE:
            c.add(s, field, f"must be an integer in 1..{MAX_IMAGE_SIDE}, got {_show(value)}")
            sides_ok = False
    if sides_ok and s.width * s.height > MAX_PIXELS:
        c.add(s, "width", f"width × height must be at most {MAX_PIXELS} pixels, got {s.width} × {s.height}")
    pattern = s.sample_pattern if isinstance(s.sample_pattern, str) else None
    most = MAX_STRATIFIED_SAMPLES if pattern in ("stratified", "adaptive") else MAX_SAMPLES
    if not isinstance(s.samples, (int, np.integer)) or not 1 <= s.samples <= most:
        c.add(s, "samples", f"must be an integer in 1..{most}, got {_show(s.samples)}")
    elif pattern == "adaptive" and s.samples & (s.samples - 1):
        # its cells halve down to 1/samples of a pixel
        c.add(s, "samples", f"must be a power of 2 for the adaptive pattern (1, 2, 4, 8, 16), got {_show(s.samples)}")
    c.one_of(s, "sample_pattern", SAMPLE_PATTERNS)
    c.unit_interval(s, "aa_threshold")  # POV-Ray clips +A to [0, 1]
    c.one_of(s, "specular", ("seed", "povray-classic"))
    c.one_of(s, "numerics", NUMERICS)
    if not isinstance(s.threads, (int, np.integer)) or not 0 <= s.threads <= MAX_THREADS:
        c.add(s, "threads", f"must be an integer in 0..{MAX_THREADS}, got {_show(s.threads)}")
    c.colour(s, "background")
    if (
        not isinstance(s.max_depth, (int, np.integer))
        or isinstance(s.max_depth, bool)
        or not 0 <= s.max_depth <= MAX_DEPTH
    ):
        c.add(s, "max_depth", f"must be an integer in 0..{MAX_DEPTH}, got {_show(s.max_depth)}")
    c.one_of(s, "transmission", TRANSMISSION_CONVENTIONS)


FALLOFFS = ("none", "inverse-square")


def _check_linking(c: _Collector, light) -> None:
    linking = getattr(light, "linking", None)
    if not isinstance(linking, Linking):
        c.add(light, "linking", f"must be a Linking, got {type(linking).__name__}")
        return
    if not isinstance(linking.shadows, (bool, np.bool_)):
        c.add(light, "linking.shadows", f"must be True or False, got {_show(linking.shadows)}")
    for field in ("illuminates", "shadowed_by"):
        members = getattr(linking, field)
        if members is not None and not (isinstance(members, frozenset) and all(isinstance(m, str) for m in members)):
            c.add(light, f"linking.{field}", f"must be None or a frozenset of prim paths, got {type(members).__name__}")


def _check_light(c: _Collector, light) -> None:
    _check_linking(c, light)
    c.colour(light, "color")
    for term in ("diffuse", "specular"):
        value = getattr(light, term, 1.0)
        if c.real(light, term, value) and value < 0:
            c.add(light, term, f"must be >= 0, got {_show(value)}")
    fade_power = getattr(light, "fade_power", 0.0)
    if hasattr(light, "falloff") and not c.one_of(light, "falloff", FALLOFFS):
        pass
    elif getattr(light, "falloff", "none") != "none" and _number(fade_power) and fade_power > 0:
        c.add(light, "fade_power", "must be 0 with falloff 'inverse-square' (the fade is POV-Ray's alternative)")
    if isinstance(light, PointLight):
        c.position(light, "position", light.position)
        cone = light.cone
        if cone is not None and not isinstance(cone, Cone):
            c.add(light, "cone", f"must be a Cone (or None), got {type(cone).__name__}")
        elif cone is not None and not all(_number(x) for x in (cone.cos_outer, cone.cos_inner, cone.focus)):
            c.add(
                light,
                "cone",
                "cos_outer, cos_inner and focus must be numbers, got "
                f"{_show(cone.cos_outer)}, {_show(cone.cos_inner)}, {_show(cone.focus)}",
            )
        elif cone is not None:
            axis = np.asarray(cone.axis if _is_triple(cone.axis) and all(_number(x) for x in cone.axis) else [np.nan])
            if (
                axis.shape != (3,)
                or not np.all(np.isfinite(axis))
                or abs(float(np.linalg.norm(axis)) - 1) > UNIT_TOLERANCE
            ):
                c.add(light, "cone", f"the cone's axis must be a finite unit vector, got {_show(cone.axis)}")
            if not (
                np.isfinite(cone.cos_outer)
                and np.isfinite(cone.cos_inner)
                and 0 < cone.cos_outer <= cone.cos_inner <= 1
            ):
                c.add(
                    light,
                    "cone",
                    f"must have 0 < cos_outer <= cos_inner <= 1, got {_show(cone.cos_outer)}, {_show(cone.cos_inner)}",
                )
            if not (np.isfinite(cone.focus) and cone.focus >= 0):
                c.add(light, "cone", f"the cone's focus must be finite and >= 0, got {_show(cone.focus)}")
        fd_ok = c.real(light, "fade_distance", light.fade_distance)
        if c.real(light, "fade_power", light.fade_power):
            if light.fade_power < 0:
                c.add(light, "fade_power", f"must be >= 0, got {_show(light.fade_power)}")
            elif light.fade_power > 0 and fd_ok and light.fade_distance <= 0:
                c.add(light, "fade_distance", f"must be > 0 when fade_power > 0, got {_show(light.fade_distance)}")
    elif isinstance(light, DirectionalLight):
        c.vector(light, "direction", unit=True)
    elif isinstance(light, RectAreaLight):
        c.position(light, "center", light.center)
        u = c.vector(light, "axis_u", unit=False)
        v = c.vector(light, "axis_v", unit=False)
        if u is not None and v is not None:
            cross = float(np.linalg.norm(np.cross(u, v)))
            if cross <= SINGULAR_RELATIVE_DET * float(np.linalg.norm(u) * np.linalg.norm(v)):
                c.add(light, "axis_v", "must not be parallel to axis_u (the rectangle has no area)")
        c.samples_2k1(light)
        c.adaptive(light)
    elif isinstance(light, SphereAreaLight):
        c.position(light, "center", light.center)
        if c.real(light, "radius", light.radius) and light.radius <= 0:
            c.add(light, "radius", f"must be > 0, got {_show(light.radius)}")
        c.samples_2k1(light)
        c.adaptive(light)
    else:
        c.add(light, "lights", f"unknown light type {type(light).__name__}")


def _check_sphere(c: _Collector, s: Sphere) -> None:
    m = s.world_from_object
    if not c.finite(s, "world_from_object", m):
        return
    if not np.array_equal(m[3], [0.0, 0.0, 0.0, 1.0]):
        c.add(s, "world_from_object", f"must be affine (last row 0 0 0 1), got {_show(tuple(m[3]))}")
    if is_singular(m[:3, :3]):
        c.add(s, "world_from_object", "is singular (zero radius or a zero/degenerate scale)")
    else:
        # Its bounds (centre ± the row norms of the 3×3 part) must be representable too.
        with np.errstate(over="ignore"):
            reach = float(np.max(np.abs(m[:3, 3]) + np.sqrt((m[:3, :3] ** 2).sum(axis=1))))
        if not reach <= MAX_COORDINATE:
            c.add(
                s,
                "world_from_object",
                f"the sphere must lie within ±{MAX_COORDINATE:g} (so that distances and "
                f"their squares stay finite), it reaches {reach:.3g}",
            )


def _check_points(c: _Collector, p: Points) -> None:
    """As ``_check_sphere`` of each ``Sphere.at(center, radius)``, in whole arrays."""
    if len(p.centers) != len(p.radii):
        c.add(p, "radii", f"has {len(p.radii)} values for {len(p.centers)} centers")
        return
    if not (c.finite(p, "centers", p.centers) and c.finite(p, "radii", p.radii)):
        return
    with np.errstate(under="ignore"):
        # Sphere's "singular": the radius cubed (its matrix's determinant) is not positive.
        bad = np.flatnonzero(~(p.radii**3 > 0))
    if len(bad):
        c.add(
            p,
            "radii",
            f"must be > 0 (and not so small that r³ underflows): {len(bad)} are not, the first "
            f"radii[{bad[0]}] = {p.radii[bad[0]]:.9g}",
        )
        return
    with np.errstate(over="ignore"):
        reach = float(np.max(np.abs(p.centers) + p.radii[:, None])) if len(p) else 0.0
    if not reach <= MAX_COORDINATE:
        c.add(p, "centers", f"the spheres must lie within ±{MAX_COORDINATE:g}, they reach {reach:.3g}")


def _check_intrinsic(c: _Collector, i: Intrinsic) -> None:
    if i.kind not in INTRINSIC_KINDS:
        c.add(i, "kind", f"must be one of {', '.join(INTRINSIC_KINDS)}, got {_show(i.kind)}")
        return
    m = i.world_from_object
    if c.finite(i, "world_from_object", m):
        if not np.array_equal(m[3], [0.0, 0.0, 0.0, 1.0]):
            c.add(i, "world_from_object", f"must be affine (last row 0 0 0 1), got {_show(tuple(m[3]))}")
        elif is_singular(m[:3, :3]):
            c.add(i, "world_from_object", "is singular (a zero size or a zero/degenerate scale)")
        elif not i.infinite:
            with np.errstate(over="ignore", invalid="ignore"):
                lo, hi = i.world_bounds()
                reach = float(np.max(np.abs(np.concatenate([lo, hi]))))
            if not reach <= MAX_COORDINATE:
                c.add(
                    i, "world_from_object", f"the {i.kind} must lie within ±{MAX_COORDINATE:g}, it reaches {reach:.3g}"
                )
    for field in ("radius_bottom", "radius_top", "half_height"):
        value = getattr(i, field)
        if c.finite(i, field, value) and value < 0:
            c.add(i, field, f"must be >= 0, got {_show(value)}")
    if i.kind in ("cylinder", "capsule") and i.radius_bottom == 0 and i.radius_top == 0:
        c.add(i, "radius_bottom", f"a {i.kind} needs a radius > 0 at one end at least")
    if i.kind == "capsule" and isinstance(i.material, PhongMaterial) and i.material.transmits:
        # The native tracer's capsule is the union of a tube and two spheres, whose inner parts
        # would refract a ray that crosses them.
        c.add(i, "material", "a transmissive capsule is not supported (tessellate it: phong:tessellate)")
    if i.infinite and i.kind != "plane":
        c.add(i, "infinite", f"only a plane can be infinite, not a {i.kind}")


def _check_instances(c: _Collector, group: Instances) -> None:
    """Each copy's transform: finite, affine (last row 0 0 0 1) and invertible (a ray is
    carried into the prototype's space by its inverse); one problem per group, counting them."""
    m = group.world_from_prototype
    if not m.size:
        return
    finite = np.isfinite(m).all(axis=(1, 2))
    affine = np.all(m[:, 3, :] == (0.0, 0.0, 0.0, 1.0), axis=1)
    a = np.where(finite[:, None, None], m[:, :3, :3], 1.0)
    # is_singular, for all copies at once (the same scale-invariant test).
    scale = np.prod(np.linalg.norm(a, axis=1), axis=1)
    singular = (scale == 0) | (np.abs(np.linalg.det(a)) <= SINGULAR_RELATIVE_DET * scale)
    bad = ~finite | ~affine | singular
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        what = (
            "not finite"
            if not finite[k]
            else "not affine"
            if not affine[k]
            else "singular (a zero or degenerate scale)"
        )
        c.add(
            _Copy(group.source_of(k)),
            "world_from_prototype",
            f"{int(bad.sum())} of {len(m)} instance transforms are invalid, e.g. copy {k}: {what}",
        )
    colors = group.colors
    if colors is not None and len(colors):
        bad = ~(np.isfinite(colors) & (colors >= 0)).all(axis=1)
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            c.add(
                _Copy(group.source_of(k)),
                "colors",
                f"{int(bad.sum())} of {len(colors)} instance colours are not finite and >= 0, "
                f"e.g. copy {k}: {tuple(float(x) for x in colors[k])}",
            )


@dataclass(frozen=True)
class _Copy:
    """An instance as a node problems can name (its prim)."""

    source: str


def _check_mesh(c: _Collector, mesh: TriangleMesh) -> None:
    c.coordinates(mesh, "points", mesh.points)
    n_points = len(mesh.points)
    tri = mesh.triangles
    if tri.size and (tri.min() < 0 or tri.max() >= n_points):
        bad = int(np.count_nonzero((tri < 0) | (tri >= n_points)))
        example = int(tri[(tri < 0) | (tri >= n_points)][0])
        c.add(mesh, "triangles", f"indices must be in [0, {n_points}): {bad} are not, e.g. {example}")
    if mesh.uvs is not None:
        c.finite(mesh, "uvs", mesh.uvs)
        ui, n_uvs = mesh.uv_indices, len(mesh.uvs)
        if ui.shape != tri.shape:
            c.add(mesh, "uv_indices", f"must have one row per triangle ({tri.shape}), got {ui.shape}")
        elif ui.size and (ui.min() < 0 or ui.max() >= n_uvs):
            c.add(
                mesh,
                "uv_indices",
                f"indices must be in [0, {n_uvs}): {int(np.count_nonzero((ui < 0) | (ui >= n_uvs)))} are not",
            )
    if mesh.normals is None:
        return
    if c.finite(mesh, "normals", mesh.normals):
        lengths = np.linalg.norm(mesh.normals, axis=1)
        zero = np.flatnonzero(lengths == 0)
        if zero.size:
            c.add(mesh, "normals", f"{zero.size} zero-length normals, e.g. row {int(zero[0])}")
        else:
            off = np.flatnonzero(np.abs(lengths - 1) > UNIT_TOLERANCE)
            if off.size:
                c.add(
                    mesh,
                    "normals",
                    f"{off.size} normals are not unit length, e.g. row {int(off[0])}: {lengths[off[0]]:.9g}",
                )
    ni = mesh.normal_indices
    if ni.shape != tri.shape:
        c.add(mesh, "normal_indices", f"must have one row per triangle ({tri.shape}), got {ni.shape}")
    k = len(mesh.normals)
    if ni.size and (ni.min() < 0 or ni.max() >= k):
        bad = int(np.count_nonzero((ni < 0) | (ni >= k)))
        c.add(mesh, "normal_indices", f"indices must be in [0, {k}): {bad} are not")
