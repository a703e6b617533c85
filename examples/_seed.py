# SPDX-License-Identifier: Apache-2.0
"""Shared set-up of the seed examples: a ground plane, a camera, a key light and an ambient
DomeLight (Suffern's lecture scenes). Light strength π: a head-on Lambert surface with kd = 1
then reflects exactly cd (kd·cd/π · π), so kd = 0.6 gives a sensible 0.6·cd."""

from __future__ import annotations

import math
from pathlib import Path

import phongscene
from phongscene.scene import (
    AmbientLight,
    Camera,
    PhongMaterial,
    PointLight,
    RenderSettings,
    Scene,
    Sphere,
    TriangleMesh,
)
from phongscene.usd import write_usd

HERE = Path(__file__).resolve().parent
GROUND = PhongMaterial(
    ka=0.25, kd=0.6, ks=0.0, exponent=1.0, diffuse_color=(0.5, 0.5, 0.5), source="/World/Looks/Ground/Phong"
)
SETTINGS = RenderSettings(width=320, height=240, source="/Render/Settings")


def look_at(eye, target, fov_deg: float = 45.0) -> Camera:
    """A perspective camera at ``eye`` looking at ``target`` with +Y as the up hint."""
    return phongscene.look_at(eye, target, fov_deg, source="/World/Camera")


def ground(half_size: float = 10.0) -> TriangleMesh:
    """A square at y = 0, front face up (+Y)."""
    s = half_size
    points = [(-s, 0.0, -s), (-s, 0.0, s), (s, 0.0, s), (s, 0.0, -s)]
    return TriangleMesh(points, [(0, 1, 2), (0, 2, 3)], material=GROUND, source="/World/Geometry/Ground")


def row_of_spheres(materials: list[tuple[str, PhongMaterial]], spacing: float = 2.3) -> tuple[Sphere, ...]:
    """Unit spheres resting on the ground, centred on x = 0, named after their materials."""
    offset = (len(materials) - 1) / 2
    return tuple(
        Sphere.at(((i - offset) * spacing, 1.0, 0.0), 1.0, m, source=f"/World/Geometry/{name}")
        for i, (name, m) in enumerate(materials)
    )


def seed_scene(spheres, eye=(0.0, 3.0, 10.0), key=(-5.0, 8.0, 6.0), fov_deg: float = 45.0) -> Scene:
    return Scene(
        camera=look_at(eye, (0.0, 0.8, 0.0), fov_deg),
        ambient=AmbientLight((1.0, 1.0, 1.0), source="/World/Lights/Ambient"),
        lights=(PointLight(key, (math.pi, math.pi, math.pi), source="/World/Lights/Key"),),
        spheres=spheres,
        meshes=(ground(),),
        settings=SETTINGS,
    )


def write(scene: Scene, name: str) -> Path:
    path = write_usd(scene, HERE / f"{name}.usda")
    print(f"wrote {path}")
    return path
