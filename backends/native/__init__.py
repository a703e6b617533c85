# SPDX-License-Identifier: Apache-2.0
"""Native backend: the C++ ray tracer extension (``_native``) and its thin Python wrapper.

``render(scene)`` flattens a validated :class:`phongscene.Scene` into a few numpy arrays
(meshes concatenated with index offsets, per-primitive material ids, sphere matrices and their
inverses) with vectorised numpy only, hands them to C++ (which copies them and builds a SAH BVH
with the GIL released) and renders on a thread pool. This module is the only code that knows
both sides; the row layouts match ``src/scene.hpp``.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from phongscene.scene import (
    DirectionalLight,
    PhongMaterial,
    PointLight,
    RectAreaLight,
    RenderSettings,
    Scene,
    SphereAreaLight,
)

from . import _native

__all__ = ["build", "render", "scene_arrays", "_native"]

# Light row layout (src/scene.hpp): kind, position|center (1-3), direction (4-6), color (7-9),
# fade_distance (10), fade_power (11), axis_u (12-14), axis_v (15-17), radius (18), samples (19).
_POINT, _DIRECTIONAL, _RECT, _SPHERE = 0, 1, 2, 3
assert _native.LIGHT_COLUMNS == 20 and _native.MATERIAL_COLUMNS == 10


def _material_row(m: PhongMaterial) -> list[float]:
    return [m.ka, m.kd, m.ks, m.exponent, *m.diffuse_color, *m.specular_color]


def _light_row(light) -> np.ndarray:
    row = np.zeros(_native.LIGHT_COLUMNS)
    row[7:10] = light.color
    if isinstance(light, PointLight):
        row[0] = _POINT
        row[1:4] = light.position
        row[10:12] = light.fade_distance, light.fade_power
    elif isinstance(light, DirectionalLight):
        row[0] = _DIRECTIONAL
        row[4:7] = light.direction
    elif isinstance(light, RectAreaLight):
        row[0] = _RECT
        row[1:4] = light.center
        row[12:15] = light.axis_u
        row[15:18] = light.axis_v
        row[19] = light.samples
    elif isinstance(light, SphereAreaLight):
        row[0] = _SPHERE
        row[1:4] = light.center
        row[18] = light.radius
        row[19] = light.samples
    else:  # a validated scene has only the model's light types
        raise TypeError(f"unsupported light {type(light).__name__}")
    return row


def scene_arrays(scene: Scene) -> dict[str, np.ndarray]:
    """The flat arrays ``_native.Scene`` takes (keyword names match its constructor)."""
    material_ids: dict[PhongMaterial, int] = {}

    def material_id(m: PhongMaterial) -> int:
        return material_ids.setdefault(m, len(material_ids))

    spheres = scene.spheres
    world_from_object = np.array([s.world_from_object for s in spheres], dtype=np.float64).reshape(-1, 4, 4)
    object_from_world = np.linalg.inv(world_from_object) if len(spheres) else world_from_object.copy()
    sphere_material = np.array([material_id(s.material) for s in spheres], dtype=np.int32)

    meshes = scene.meshes
    point_offsets = np.cumsum([0] + [len(m.points) for m in meshes])
    normal_offsets = np.cumsum([0] + [0 if m.normals is None else len(m.normals) for m in meshes])
    points = np.concatenate([m.points for m in meshes]) if meshes else np.zeros((0, 3))
    triangles = (
        np.concatenate([m.triangles + np.int32(off) for m, off in zip(meshes, point_offsets)])
        if meshes
        else np.zeros((0, 3), np.int32)
    )
    triangle_material = (
        np.concatenate([np.full(len(m.triangles), material_id(m.material), np.int32) for m in meshes])
        if meshes
        else np.zeros(0, np.int32)
    )
    with_normals = [m for m in meshes if m.normals is not None]
    normals = np.concatenate([m.normals for m in with_normals]) if with_normals else np.zeros((0, 3))
    normal_indices = (
        np.concatenate(
            [
                np.full((len(m.triangles), 3), -1, np.int32)
                if m.normals is None
                else m.normal_indices + np.int32(off)
                for m, off in zip(meshes, normal_offsets)
            ]
        )
        if meshes
        else np.zeros((0, 3), np.int32)
    )
    materials = np.array([_material_row(m) for m in material_ids], dtype=np.float64).reshape(-1, _native.MATERIAL_COLUMNS)
    lights = np.array([_light_row(light) for light in scene.lights], dtype=np.float64).reshape(-1, _native.LIGHT_COLUMNS)

    def c(a, dtype):
        return np.ascontiguousarray(a, dtype=dtype)

    return {
        "sphere_world_from_object": c(world_from_object, np.float64),
        "sphere_object_from_world": c(object_from_world, np.float64),
        "sphere_material": c(sphere_material, np.int32),
        "points": c(points, np.float64),
        "triangles": c(triangles, np.int32),
        "triangle_material": c(triangle_material, np.int32),
        "normals": c(normals, np.float64),
        "normal_indices": c(normal_indices, np.int32),
        "materials": c(materials, np.float64),
        "lights": c(lights, np.float64),
        "ambient": c(scene.ambient.color, np.float64),
    }


def build(scene: Scene) -> _native.Scene:
    """The C++ scene (geometry, materials, lights and BVH) of a validated ``scene``."""
    return _native.Scene(**scene_arrays(scene))


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
            and propagates.

    Returns:
        The image: float32 (height, width, 3), linear RGB, row 0 at the top.

    Raises:
        KeyboardInterrupt: on Ctrl-C, promptly (the workers stop at their next tile).
    """
    s = scene.settings if settings is None else settings
    native_scene = build(scene)
    cam = scene.camera
    return native_scene.render(
        position=np.array(cam.position, np.float64),
        forward=np.array(cam.forward, np.float64),
        up=np.array(cam.up, np.float64),
        orthographic=cam.projection == "orthographic",
        horizontal_fov_deg=float(cam.horizontal_fov_deg),
        ortho_width=float(cam.ortho_width),
        width=int(s.width),
        height=int(s.height),
        samples=int(s.samples),
        pattern=s.sample_pattern,
        threads=int(s.threads),
        background=np.array(s.background, np.float64),
        specular=s.specular,
        progress=progress,
    )
