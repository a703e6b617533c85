# SPDX-License-Identifier: Apache-2.0
"""Native backend: the C++ ray tracer extension (``_native``) and its thin Python wrapper.

``render(scene)`` turns a validated :class:`phongscene.Scene` into the extension's objects:
materials, lights, camera and settings as the bound C++ structs (``_native.Material``,
``_native.PointLight``, ...), and the geometry as numpy arrays: the sphere matrices and their
inverses, and each mesh's own arrays (the model's, handed over without a copy). C++ reads them in
place into its leaf-order copies and builds a SAH BVH with the GIL released, then renders on a
thread pool. This module is the only code that knows both sides.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING

import numpy as np

from phongscene.scene import (
    Camera,
    DirectionalLight,
    Intrinsic,
    Light,
    PhongMaterial,
    PointLight,
    RectAreaLight,
    RenderSettings,
    Scene,
    SphereAreaLight,
)

from . import _native

if TYPE_CHECKING:
    from phongscene.backends.povray.compile import UvFrame

__all__ = ["PreparedRender", "build", "prepare", "render", "scene_arrays", "_native"]

_SAMPLE_PATTERNS = {
    "grid": _native.SamplePattern.grid,
    "povray-am1": _native.SamplePattern.povray_am1,
    "povray-am2": _native.SamplePattern.povray_am2,
    "stratified": _native.SamplePattern.stratified,
    "adaptive": _native.SamplePattern.adaptive,
}
# The C++ lights' `adaptive` for "every grid point" (lights.hpp: kFullSubdivision).
_FULL_SUBDIVISION = -1
_NUMERICS = {
    "scale-invariant": _native.Numerics.scale_invariant,
    "povray": _native.Numerics.povray,
    "povray-shadow-cache": _native.Numerics.povray_shadow_cache,
}
_SPECULAR_CONVENTIONS = {
    "seed": _native.SpecularConvention.seed,
    "povray-classic": _native.SpecularConvention.povray_classic,
}


def _material(m: PhongMaterial) -> _native.Material:
    native = _native.Material(
        ka=m.ka, kd=m.kd, ks=m.ks, exponent=m.exponent, diffuse_color=m.diffuse_color, specular_color=m.specular_color
    )
    if any(m.emission):
        native.emission = m.emission
    native.kr = m.kr
    native.reflective_color = m.reflective_color
    native.kt = m.kt
    native.ior = m.ior
    native.fresnel = bool(m.fresnel)
    native.interior_filter = m.interior_filter
    if m.checkered:
        native.checker_size = m.checker_size
        native.checker_color = m.checker_color
        if m.checker_plane:
            native.checker_plane = True
            native.checker_outline_width = m.checker_outline_width
            native.checker_outline_color = m.checker_outline_color
    native.instance_color = bool(m.instance_color)
    return native


def _materials(models) -> list[_native.Material]:
    """The native materials, each textured one numbered by its texture's position in
    ``textures(scene)`` (first use in material order)."""
    out, texture_ids = [], {}
    for m in models:
        native = _material(m)
        if m.diffuse_texture is not None:
            native.diffuse_texture = texture_ids.setdefault(id(m.diffuse_texture), len(texture_ids))
        if m.specular_texture is not None:
            native.specular_texture = texture_ids.setdefault(id(m.specular_texture), len(texture_ids))
        if m.normal_texture is not None:
            native.normal_texture = texture_ids.setdefault(id(m.normal_texture), len(texture_ids))
        if m.opacity_texture is not None:
            native.opacity_texture = texture_ids.setdefault(id(m.opacity_texture), len(texture_ids))
            native.opacity_threshold = m.opacity_threshold
        out.append(native)
    return out


_WRAPS = {
    "repeat": _native.Wrap.repeat,
    "clamp": _native.Wrap.clamp,
    "mirror": _native.Wrap.mirror,
    "black": _native.Wrap.black,
}


def texture_arrays(scene: Scene, *, half_texels: bool = False, frame: UvFrame | None = None) -> dict | None:
    """The arguments of ``_native.Scene.set_textures``, or None without textures: the textures
    in the order ``_materials`` numbers them (materials in first-use order, spheres then
    meshes), and each triangle's corner uvs (zeros for meshes without uvs).

    In POV-Ray numerics, as POV-Ray holds them: ``half_texels``, texels rounded to half floats
    (an EXR image map, ref §16); ``frame``, the corner uvs as the SDL writes them, mapped into
    the compiler's UvFrame, with the frame's origin and span to map a hit's uv back (POV-Ray
    weighs the SDL's uvs, and a few ulps decide the texel at an edge: src/povray_triangle.hpp
    ``povray_mesh_uv``)."""
    models: dict[PhongMaterial, None] = {}
    for obj in scene.objects:
        models.setdefault(obj.material, None)
    textures: dict[int, object] = {}
    for m in models:
        for t in m.textures:  # diffuse, specular, normal, opacity: as _materials numbers them
            textures.setdefault(id(t), t)
    if not textures:
        return None
    # One (T, 3, 2) array filled mesh by mesh (no per-mesh arrays to concatenate: 48 bytes a
    # triangle, 614 MB for the chess set's 12.8M triangles), held by C++ without a copy.
    corner_uv = np.zeros((sum(len(m.triangles) for m in scene.meshes), 3, 2))
    start = 0
    for m in scene.meshes:
        if m.uvs is not None:
            np.take(
                m.uvs if frame is None else frame.apply(m.uvs),
                m.uv_indices,
                axis=0,
                out=corner_uv[start : start + len(m.triangles)],
            )
        start += len(m.triangles)
    out = {
        # The model's arrays, held by C++ (no copy); rounded to half floats there when asked.
        "images": [np.ascontiguousarray(t.image, dtype=np.float32) for t in textures.values()],
        "half_texels": half_texels,
        "wrap_s": [_WRAPS[t.wrap_s] for t in textures.values()],
        "wrap_t": [_WRAPS[t.wrap_t] for t in textures.values()],
        "corner_uv": corner_uv,
    }
    if frame is not None:
        out["uv_origin"], out["uv_span"] = frame.origin, frame.span
    return out


def _light(light: Light):
    native = _native_light(light)
    if (light.diffuse, light.specular) != (1.0, 1.0):
        native.terms = _native.LightTerms(diffuse=light.diffuse, specular=light.specular)
    return native


def _native_light(light: Light):
    if isinstance(light, PointLight):
        native = _native.PointLight(
            position=light.position,
            color=light.color,
            fade_distance=light.fade_distance,
            fade_power=light.fade_power,
            inverse_square=light.falloff == "inverse-square",
        )
        if light.cone is not None:
            native.cone_axis = light.cone.axis
            native.cone_cos_outer, native.cone_cos_inner = light.cone.cos_outer, light.cone.cos_inner
            native.cone_focus = light.cone.focus
        return native
    if isinstance(light, DirectionalLight):
        return _native.DirectionalLight(direction=light.direction, color=light.color)
    if isinstance(light, RectAreaLight):
        native = _native.RectAreaLight(
            center=light.center,
            axis_u=light.axis_u,
            axis_v=light.axis_v,
            color=light.color,
            samples=light.samples,
            inverse_square=light.falloff == "inverse-square",
        )
        native.adaptive = _FULL_SUBDIVISION if light.adaptive is None else int(light.adaptive)
        native.cell_samples = 0 if light.cell_samples is None else int(light.cell_samples)
        return native
    if isinstance(light, SphereAreaLight):
        native = _native.SphereAreaLight(
            center=light.center,
            radius=light.radius,
            color=light.color,
            samples=light.samples,
            inverse_square=light.falloff == "inverse-square",
        )
        native.adaptive = _FULL_SUBDIVISION if light.adaptive is None else int(light.adaptive)
        native.cell_samples = 0 if light.cell_samples is None else int(light.cell_samples)
        return native
    # A validated scene has only the model's light types.
    raise TypeError(f"unsupported light {type(light).__name__}")


def _camera(camera: Camera) -> _native.CameraDescription:
    return _native.CameraDescription(
        position=camera.position,
        forward=camera.forward,
        up=camera.up,
        orthographic=camera.projection == "orthographic",
        horizontal_fov_deg=camera.horizontal_fov_deg,
        ortho_width=camera.ortho_width,
    )


def _settings(s: RenderSettings) -> _native.RenderSettings:
    native = _native.RenderSettings(
        width=s.width,
        height=s.height,
        samples=s.samples,
        sample_pattern=_SAMPLE_PATTERNS[s.sample_pattern],
        threads=s.threads,
        background=s.background,
        specular_convention=_SPECULAR_CONVENTIONS[s.specular],
        numerics=_NUMERICS[s.numerics],
    )
    native.aa_threshold = float(s.aa_threshold)
    native.max_depth = int(s.max_depth)
    native.transmission_convention = (
        _native.TransmissionConvention.book if s.transmission == "book" else _native.TransmissionConvention.povray
    )
    return native


# The C++ part kinds (intrinsics.hpp: IntrinsicKind).
_BOX, _FRUSTUM, _DISK, _SQUARE, _PLANE, _SPHERE = range(6)


def _parts(intrinsic: Intrinsic) -> list[tuple[int, np.ndarray, float, float, float]]:
    """The parts the tracer intersects for one intrinsic prim: (kind, world_from_object of the
    part, r0, r1, z0) in intrinsics.hpp's canonical shapes."""
    m = intrinsic.world_from_object
    if intrinsic.kind == "cube":
        return [(_BOX, m, 1.0, 1.0, 0.0)]
    if intrinsic.kind == "plane":
        return [(_PLANE if intrinsic.infinite else _SQUARE, m, 1.0, 1.0, 0.0)]
    if intrinsic.kind == "cylinder":
        r0, r1 = intrinsic.radius_bottom, intrinsic.radius_top
        parts = [(_FRUSTUM, m, r0, r1, 0.0)]
        parts += [(_DISK, m, r, r, z) for r, z in ((r0, -1.0), (r1, 1.0)) if r > 0]
        return parts
    # A capsule: the side (unless of zero height) and the end spheres (Intrinsic.capsule_ends).
    rb, rt, h = intrinsic.radius_bottom, intrinsic.radius_top, intrinsic.half_height
    parts = []
    if h > 0 and rb == rt:  # one radius: a unit cylinder scaled to it
        parts.append((_FRUSTUM, m @ np.diag([rb, rb, h, 1.0]), 1.0, 1.0, 0.0))
    elif h > 0:
        parts.append((_FRUSTUM, m @ np.diag([1.0, 1.0, h, 1.0]), rb, rt, 0.0))
    for z, r in intrinsic.capsule_ends():
        end = np.diag([r, r, r, 1.0])
        end[2, 3] = z
        parts.append((_SPHERE, m @ end, 1.0, 1.0, 0.0))
    return parts


def _part_box(kind: int, r0: float, r1: float, z0: float) -> tuple[np.ndarray, np.ndarray]:
    """A part's object-space box."""
    if kind == _FRUSTUM:
        r = max(r0, r1)
        return np.array([-r, -r, -1.0]), np.array([r, r, 1.0])
    if kind == _DISK:
        return np.array([-r0, -r0, z0]), np.array([r0, r0, z0])
    if kind in (_SQUARE, _PLANE):
        return np.array([-1.0, -1.0, 0.0]), np.array([1.0, 1.0, 0.0])
    return -np.ones(3), np.ones(3)


def intrinsic_parts(scene: Scene, material_id) -> list:
    """The scene's intrinsic prims as the C++ parts (``_native.IntrinsicShape``), each with its
    world box (a sphere's exact: centre ± the row norms) and its object number (spheres, meshes,
    then intrinsics: light linking's numbering)."""
    out = []
    first = len(scene.spheres) + len(scene.meshes)
    for i, intrinsic in enumerate(scene.intrinsics):
        material = material_id(intrinsic.material)
        for kind, m, r0, r1, z0 in _parts(intrinsic):
            if kind == _SPHERE:
                centre, half = m[:3, 3], np.sqrt((m[:3, :3] ** 2).sum(axis=1))
            else:
                lo, hi = _part_box(kind, r0, r1, z0)
                centre = m[:3, :3] @ ((lo + hi) / 2) + m[:3, 3]
                half = np.abs(m[:3, :3]) @ ((hi - lo) / 2)
            object_from_world = np.linalg.inv(m)[:3].reshape(-1)
            out.append(
                _native.IntrinsicShape(
                    kind=kind,
                    object_from_world=[float(x) for x in object_from_world],
                    bounds_lo=tuple(map(float, centre - half)),
                    bounds_hi=tuple(map(float, centre + half)),
                    r0=float(r0),
                    r1=float(r1),
                    z0=float(z0),
                    material=material,
                    object=first + i,
                )
            )
    return out


def scene_arrays(scene: Scene) -> dict:
    """The arguments ``_native.Scene`` takes, by keyword: the spheres as numpy arrays, each mesh's
    own arrays (the model's, read in place by C++: lists with one entry per mesh), the materials
    (indexed by ``sphere_material`` and ``mesh_material``), the lights and the ambient colour."""
    material_ids: dict[PhongMaterial, int] = {}

    def material_id(m: PhongMaterial) -> int:
        return material_ids.setdefault(m, len(material_ids))

    spheres = scene.spheres
    world_from_object = np.array([s.world_from_object for s in spheres], dtype=np.float64).reshape(-1, 4, 4)
    object_from_world = np.linalg.inv(world_from_object) if len(spheres) else world_from_object.copy()
    sphere_material = np.array([material_id(s.material) for s in spheres], dtype=np.int32)

    def c(a, dtype):
        return np.ascontiguousarray(a, dtype=dtype)

    meshes = scene.meshes
    no_rows3 = np.zeros((0, 3), np.int32)
    return {
        "sphere_world_from_object": c(world_from_object, np.float64),
        "sphere_object_from_world": c(object_from_world, np.float64),
        "sphere_material": c(sphere_material, np.int32),
        # The model's arrays are already C-contiguous float64 / int32 (scene._readonly): no copies.
        "points": [c(m.points, np.float64) for m in meshes],
        "triangles": [c(m.triangles, np.int32) for m in meshes],
        "normals": [c(np.zeros((0, 3)) if m.normals is None else m.normals, np.float64) for m in meshes],
        "normal_indices": [no_rows3 if m.normals is None else c(m.normal_indices, np.int32) for m in meshes],
        "mesh_material": np.array([material_id(m.material) for m in meshes], dtype=np.int32),
        # Each mesh's frame: only POV-Ray's mesh2 numerics use it (_as_povray_stores sets it),
        # and finding it takes a pass over the points (26 ms of S2's 1M-triangle build).
        "mesh_origins": np.zeros((len(meshes), 3)),
        "intrinsics": intrinsic_parts(scene, material_id),
        # Points sets: the model's arrays, read in place; each set one object after the intrinsics.
        "ball_centers": [c(p.centers, np.float64) for p in scene.points],
        "ball_radii": [c(p.radii, np.float64) for p in scene.points],
        "ball_material": [material_id(p.material) for p in scene.points],
        "ball_object": [
            len(scene.spheres) + len(scene.meshes) + len(scene.intrinsics) + k for k in range(len(scene.points))
        ],
        "materials": _materials(material_ids),
        "lights": [_light(light) for light in scene.lights],
        "ambient": scene.ambient.color,
    }


def light_link_arrays(scene: Scene) -> dict | None:
    """The arguments of ``_native.Scene.set_light_links``, or None when every light lights and is
    shadowed by everything: per light its shadow switch and, over the objects (spheres, then
    meshes, each named by its ``source``), which it illuminates and which cast its shadows
    (empty arrays: all of them)."""
    if all(light.linking.default for light in scene.lights):
        return None
    sources = [obj.source for obj in scene.objects]
    everything = np.zeros(0, np.uint8)

    def flags(members):
        if members is None:
            return everything
        return np.array([source in members for source in sources], dtype=np.uint8)

    return {
        "shadows": np.array([light.linking.shadows for light in scene.lights], dtype=np.uint8),
        "lit": [flags(light.linking.illuminates) for light in scene.lights],
        "casts": [flags(light.linking.shadowed_by) for light in scene.lights],
    }


def _finish(native: _native.Scene, scene: Scene, *, povray_numerics: bool = False) -> _native.Scene:
    """Textures, the environment and light links onto a built C++ scene."""
    if povray_numerics:
        # The uvs the SDL holds are the compiler's to say (imported here: a plain render needs
        # no POV-Ray compiler, tests/cli/test_startup_costs.py).
        from phongscene.backends.povray.compile import uv_frame

        textures = texture_arrays(scene, half_texels=True, frame=uv_frame(scene))
    else:
        textures = texture_arrays(scene)
    if textures is not None:
        native.set_textures(**textures)
    environment = scene.environment
    if environment is not None:
        native.set_environment(
            # The model's array, held by C++ (no copy); in POV-Ray numerics rounded to half
            # floats there, as POV-Ray reads the EXR the compiler writes.
            image=np.ascontiguousarray(environment.texture.image, dtype=np.float32),
            scale=environment.scale,
            dome_from_world=[float(x) for x in environment.dome_from_world.reshape(-1)],
            half_texels=povray_numerics,
        )
    links = light_link_arrays(scene)
    if links is not None:
        native.set_light_links(**links)
    return native


def linkable(scene: Scene) -> Scene:
    """``scene``, flattened when a light's lightLink or shadowLink names geometry and the scene
    has instances: the C++ links number world objects only (the USD reader already flattens the
    instances a link tells apart, docs/instancing.md; this covers scenes built in Python)."""
    if scene.instances and any(
        light.linking.illuminates is not None or light.linking.shadowed_by is not None for light in scene.lights
    ):
        return scene.flattened()
    return scene


@contextmanager
def build_threads(threads: int) -> Iterator[None]:
    """Scene builds inside use at most ``threads`` threads (0: every core), as a render's
    ``RenderSettings.threads`` caps its render (the cap is the extension's, process-wide)."""
    _native.set_build_threads(max(0, int(threads)))
    try:
        yield
    finally:
        _native.set_build_threads(0)


def build(scene: Scene, threads: int = 0) -> _native.Scene:
    """The C++ scene (geometry, materials, lights and BVH) of a validated ``scene``, built on at
    most ``threads`` threads (0: every core)."""
    scene = linkable(scene)
    with build_threads(threads):
        native = _finish(_native.Scene(**scene_arrays(scene)), scene)
        add_instances(native, scene, "scale-invariant")
    return native


def add_instances(native: _native.Scene, scene: Scene, numerics: str) -> None:
    """Give ``native`` the scene's instances: each prototype built once as a C++ scene of its
    own (its meshes in prototype space, with its BVH, in the same numerics as the world's) and
    placed by every transform that refers to it (the two-level BVH: src/instances.hpp)."""
    groups: dict[int, list] = {}
    for group in scene.instances:
        groups.setdefault(id(group.prototype), []).append(group)
    for n, same in enumerate(groups.values()):
        prototype = same[0].prototype
        part = Scene(meshes=prototype.meshes, source_file=scene.source_file)
        arrays = scene_arrays(part)
        if numerics != "scale-invariant":
            arrays = _as_povray_stores(arrays, part)
        built = _native.Scene(**arrays)
        # An instance's uvs stay the model's: its hits interpolate barycentrically (povray_mesh_uv
        # takes a world mesh's POV-Ray triangle).
        textures = texture_arrays(part, half_texels=numerics != "scale-invariant")
        if textures is not None:
            built.set_textures(**textures)
        transforms = np.ascontiguousarray(np.concatenate([g.world_from_prototype for g in same]), dtype=np.float64)
        colors = None
        if any(g.colors is not None for g in same):  # a group without colours: NaN, its meshes' own cd
            colors = np.concatenate([g.colors if g.colors is not None else np.full((len(g), 3), np.nan) for g in same])
        # the top level once, at the end
        native.add_instances(built, transforms, rebuild=n == len(groups) - 1, colors=colors)


def render(
    scene: Scene,
    settings: RenderSettings | None = None,
    *,
    progress: Callable[[int, int], None] | None = None,
) -> np.ndarray:
    """Render ``scene`` with the native tracer.

    Args:
        scene: a validated scene.
        settings: image size, samples, sample pattern, threads, background and specular
            convention; defaults to ``scene.settings``.
        progress: called as ``progress(tiles_done, tiles_total)`` from the calling thread
            while rendering (and once at the end). An exception it raises stops the render
            and propagates. Its ``phase(text)`` method, if it has one, is called before the
            BVH is built.

    Returns:
        The image: float32 (height, width, 3), linear RGB, row 0 at the top.

    Raises:
        KeyboardInterrupt: on Ctrl-C, promptly (the workers stop at their next tile).
    """
    return prepare(scene, settings, progress=progress)()


class PreparedRender:
    """A render whose C++ scene (with its BVH) is built: calling it renders. It holds no
    reference to the model, whose arrays C++ has copied, so a caller that drops the model can
    free them before the render (the CLI does: phongscene.cli)."""

    def __init__(
        self,
        native: _native.Scene,
        camera: _native.CameraDescription,
        settings: _native.RenderSettings,
        progress: Callable[[int, int], None] | None,
    ):
        self._native, self._camera, self._settings, self._progress = native, camera, settings, progress

    def __call__(self, camera: Camera | None = None) -> np.ndarray:
        """The image, from the scene's camera or from ``camera`` (the same eye point: the
        interiors the camera rays start in were found for it; ``diff`` turns the camera by
        2⁻²⁴ rad, phongscene.conditioning)."""
        chosen = self._camera if camera is None else _camera(camera)
        return self._native.render(camera=chosen, settings=self._settings, progress=self._progress)


def prepare(
    scene: Scene,
    settings: RenderSettings | None = None,
    *,
    progress: Callable[[int, int], None] | None = None,
) -> PreparedRender:
    """``render``'s first half: the C++ scene of ``scene`` in the numerics of ``settings``
    (default ``scene.settings``), built now; the returned object renders when called."""
    s = scene.settings if settings is None else settings
    scene = linkable(scene)
    # Building the BVH of a big mesh takes seconds and reports no fraction: say so
    # (phongscene.progress.report_phase: a progress callable may have a phase method).
    phase = getattr(progress, "phase", None)
    if callable(phase):
        phase(
            f"building the BVH ({scene.triangle_count} triangles"
            + (f", {scene.instance_count} instances" if scene.instances else "")
            + ")"
            if scene.meshes or scene.instances
            else "building the BVH"
        )
    arrays = scene_arrays(scene)
    if s.numerics != "scale-invariant":
        arrays = _as_povray_stores(arrays, scene)
    with build_threads(s.threads):  # the render's thread count caps its build too
        native = _finish(_native.Scene(**arrays), scene, povray_numerics=s.numerics != "scale-invariant")
        add_instances(native, scene, s.numerics)
    settings_ = _settings(s)
    if s.transmission == "povray":
        # Camera rays start in the interiors of the transparent objects around the camera (POV-Ray).
        from phongscene.containment import containing_interiors

        inside = containing_interiors(scene, scene.camera.position)
        if inside:
            order = list(dict.fromkeys(o.material for o in scene.objects))
            assert len(order) == len(arrays["materials"])  # scene_arrays numbers them so
            settings_.camera_interiors = [(k, order.index(m)) for k, m in inside]
    return PreparedRender(native, _camera(scene.camera), settings_, progress)


# POV-Ray's mesh2 shades a triangle smoothly only when its vertex normals differ by more than
# this (squared distance); otherwise flat, with the geometric normal.
POVRAY_SMOOTH_NORMAL_DIFFERENCE = 1e-10


def _as_povray_stores(arrays: dict, scene: Scene) -> dict:
    """The mesh data as POV-Ray's mesh2 holds it (the compiler writes it so): vertices rounded to
    float32 in each mesh's local frame (``TriangleMesh.local_origin``), normals rounded to float32
    and renormalised (at parse time), triangles whose three normals are equal shaded flat
    (normal index -1), and triangles tested as mesh2 tests them (``povray_triangles``: a plane
    with a float32 normal, not watertight; src/povray_triangle.hpp)."""
    origins = np.array([m.local_origin() for m in scene.meshes]).reshape(-1, 3)
    out = dict(arrays, povray_triangles=True, mesh_origins=origins)
    out["points"] = [
        np.ascontiguousarray((m.points - o).astype(np.float32).astype(np.float64) + o)
        for m, o in zip(scene.meshes, origins)
    ]
    out["normals"], out["normal_indices"] = [], []
    for normals, ni in zip(arrays["normals"], arrays["normal_indices"]):
        normals = normals.astype(np.float32).astype(np.float64)
        if len(normals) and len(ni):
            normals /= np.linalg.norm(normals, axis=1, keepdims=True)
            ni = ni.copy()
            smooth = ni[:, 0] >= 0
            n3 = normals[np.where(smooth[:, None], ni, 0)]
            same = (((n3[:, 0] - n3[:, 1]) ** 2).sum(axis=1) <= POVRAY_SMOOTH_NORMAL_DIFFERENCE) & (
                ((n3[:, 0] - n3[:, 2]) ** 2).sum(axis=1) <= POVRAY_SMOOTH_NORMAL_DIFFERENCE
            )
            ni[smooth & same] = -1
        elif len(normals):
            normals /= np.linalg.norm(normals, axis=1, keepdims=True)
        out["normals"].append(np.ascontiguousarray(normals))
        out["normal_indices"].append(ni)
    return out
