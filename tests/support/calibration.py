# SPDX-License-Identifier: Apache-2.0
"""Calibration scenes: small, deterministic scenes with one idea each, built with the scene model.

Both backends render every scene here and compare with ``tests/support/oracle.py`` (and with each other),
under both specular conventions (``classic_variant``). Rules every scene follows:

* 48×36 … 96×72 pixels; every pixel value stays below ~4 (POV-Ray's half-float EXR is the target);
* no silhouette, shadow boundary or ground-quad diagonal passes through a pixel centre (or an
  area-light sample line) by construction — sizes and positions are deliberately "generic"
  numbers — except in ``pixel_centres``, which is built around pixel centres on purpose;
* the ground, where there is one, is a big two-triangle quad (the model has no plane).

POV-Ray facts cite ``docs/povray-3.7-semantics.md`` as "ref §n".
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable

import numpy as np

from phongscene.scene import (
    AmbientLight,
    Camera,
    Cone,
    DirectionalLight,
    PhongMaterial,
    PointLight,
    RectAreaLight,
    RenderSettings,
    Scene,
    Sphere,
    SphereAreaLight,
    Texture,
    TriangleMesh,
)

# ---------------------------------------------------------------------------------------------
# Building blocks


def look_at(position, target, horizontal_fov_deg: float = 50.0, up_hint=(0.0, 1.0, 0.0)) -> Camera:
    """A perspective camera at ``position`` looking at ``target`` with an orthonormal (forward, up)."""
    return Camera.look_at(position, target, horizontal_fov_deg, up_hint)


def _vec(a) -> tuple[float, float, float]:
    return (float(a[0]), float(a[1]), float(a[2]))


def rotation(axis, angle_deg: float) -> np.ndarray:
    """4×4 rotation about ``axis`` (right-handed, Rodrigues)."""
    k = np.asarray(axis, dtype=np.float64)
    k /= np.linalg.norm(k)
    a = math.radians(angle_deg)
    cross = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    m = np.eye(4)
    m[:3, :3] = np.eye(3) + math.sin(a) * cross + (1 - math.cos(a)) * (cross @ cross)
    return m


def translation(offset) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = offset
    return m


def scaling(factors) -> np.ndarray:
    return np.diag([*factors, 1.0])


def ground_quad(height: float, material: PhongMaterial) -> TriangleMesh:
    """A big horizontal quad (two triangles) at y = height. The corners are asymmetric so that the
    shared diagonal passes through no pixel centre of any camera here."""
    corners = [(-41.3, height, -63.7), (38.9, height, -61.1), (43.7, height, 37.3), (-39.1, height, 41.9)]
    return TriangleMesh(points=corners, triangles=[(0, 2, 1), (0, 3, 2)], material=material)


def icosphere(subdivisions: int, center, radius: float, material: PhongMaterial, smooth: bool) -> TriangleMesh:
    """A trimesh icosphere; with ``smooth`` the vertex normals are the exact sphere normals."""
    import trimesh  # test-only dependency, imported where needed

    base = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
    unit = np.asarray(base.vertices, dtype=np.float64)
    unit /= np.linalg.norm(unit, axis=1, keepdims=True)
    points = unit * radius + np.asarray(center, dtype=np.float64)
    faces = np.asarray(base.faces, dtype=np.int32)
    if smooth:
        return TriangleMesh(points=points, triangles=faces, normals=unit, normal_indices=faces, material=material)
    return TriangleMesh(points=points, triangles=faces, material=material)


GROUND = PhongMaterial(ka=0.15, kd=0.7, ks=0.0, exponent=1.0, diffuse_color=(0.62, 0.6, 0.55))
RED = PhongMaterial(ka=0.12, kd=0.75, ks=0.35, exponent=24.0, diffuse_color=(0.85, 0.18, 0.12))
GREEN = PhongMaterial(ka=0.12, kd=0.7, ks=0.3, exponent=40.0, diffuse_color=(0.2, 0.75, 0.25))
BLUE = PhongMaterial(ka=0.12, kd=0.7, ks=0.4, exponent=12.0, diffuse_color=(0.15, 0.3, 0.85))
GOLD = PhongMaterial(
    ka=0.1, kd=0.6, ks=0.5, exponent=18.0, diffuse_color=(0.8, 0.6, 0.2), specular_color=(1.0, 0.9, 0.6)
)

BACKGROUND = (0.05, 0.07, 0.1)


def _settings(width: int = 64, height: int = 48, **kw) -> RenderSettings:
    return RenderSettings(width=width, height=height, background=BACKGROUND, **kw)


def _studio_camera(fov: float = 50.0) -> Camera:
    return look_at((0.37, 2.13, 5.71), (0.05, 0.63, -0.21), fov)


def _sphere_on_ground(light, settings: RenderSettings | None = None, material: PhongMaterial = RED) -> Scene:
    """The workhorse: a sphere floating just above a ground quad, one light, a little ambient."""
    return Scene(
        camera=_studio_camera(),
        ambient=AmbientLight((0.18, 0.19, 0.21)),
        lights=(light,),
        spheres=(Sphere.at((0.07, 1.08, -0.13), 1.03, material),),
        meshes=(ground_quad(0.0, GROUND),),
        settings=settings or _settings(),
    )


# ---------------------------------------------------------------------------------------------
# The scenes


def handedness() -> Scene:
    """Camera at the origin looking down −Z: the red sphere at +X must appear on the image's
    right, the green one at +Y at the top, the blue one (on the axis) in the middle (ref §3)."""
    return Scene(
        camera=Camera(position=(0, 0, 0), forward=(0, 0, -1), up=(0, 1, 0), horizontal_fov_deg=60.0),
        ambient=AmbientLight((0.3, 0.3, 0.3)),
        lights=(PointLight((0.31, 0.52, 1.07), (3.0, 3.0, 3.0)),),
        spheres=(
            Sphere.at((1.5, 0.0, -5.0), 0.5137, RED),
            Sphere.at((0.0, 1.5, -5.0), 0.5137, GREEN),
            Sphere.at((0.0, 0.0, -5.0), 0.5137, BLUE),
        ),
        settings=_settings(64, 48),
    )


PIXEL_CENTRES_SIZE = (49, 37)
PIXEL_CENTRES_COLUMNS = (7, 24, 40)  # pixel columns whose centres the vertical strips cover
PIXEL_CENTRES_ROWS = (5, 18)  # pixel rows whose centres the horizontal strips cover
PIXEL_CENTRES_HALF_WIDTH_PX = 0.15  # strip half-width in pixels: corners (±0.5 px) always miss


def pixel_centres() -> Scene:
    """Thin strips (0.3 px wide) centred on chosen pixel-centre columns and rows, on an odd-sized
    image: sampling at pixel centres sees every strip in every covered pixel; sampling at pixel
    corners (or any offset > 0.15 px) sees none. Vertical strips lie in front of the horizontal
    ones, so the crossings are not ambiguous."""
    width, height = PIXEL_CENTRES_SIZE
    fov = 50.0
    camera = Camera(position=(0, 0, 0), forward=(0, 0, -1), up=(0, 1, 0), horizontal_fov_deg=fov)
    aspect = width / height
    d_len = aspect / (2 * math.tan(math.radians(fov) / 2))  # |D| with |R| = W/H, |U| = 1 (ref §3)
    meshes = []
    mat_v = PhongMaterial(ka=0.5, kd=0.6, ks=0.2, exponent=10.0, diffuse_color=(0.9, 0.8, 0.1))
    mat_h = PhongMaterial(ka=0.5, kd=0.6, ks=0.2, exponent=10.0, diffuse_color=(0.1, 0.7, 0.9))
    z_v, z_h = -4.0, -4.5
    for col in PIXEL_CENTRES_COLUMNS:
        # Pixel-centre u → world x on the plane z = z_v: x = u·|R|/|D|·depth.
        depth = -z_v
        x = ((col + 0.5) / width - 0.5) * aspect / d_len * depth
        half = PIXEL_CENTRES_HALF_WIDTH_PX / width * aspect / d_len * depth
        y = 10.0
        pts = [(x - half, -y, z_v), (x + half, -y, z_v), (x + half, y, z_v), (x - half, y, z_v)]
        meshes.append(TriangleMesh(points=pts, triangles=[(0, 1, 2), (0, 2, 3)], material=mat_v))
    for row in PIXEL_CENTRES_ROWS:
        depth = -z_h
        y = (0.5 - (row + 0.5) / height) / d_len * depth
        half = PIXEL_CENTRES_HALF_WIDTH_PX / height / d_len * depth
        x = 10.0
        pts = [(-x, y - half, z_h), (x, y - half, z_h), (x, y + half, z_h), (-x, y + half, z_h)]
        meshes.append(TriangleMesh(points=pts, triangles=[(0, 1, 2), (0, 2, 3)], material=mat_h))
    return Scene(
        camera=camera,
        ambient=AmbientLight((0.4, 0.4, 0.4)),
        lights=(
            DirectionalLight(
                _vec(np.array([-0.21, -0.33, -0.92]) / np.linalg.norm([-0.21, -0.33, -0.92])), (2.5, 2.5, 2.5)
            ),
        ),
        meshes=tuple(meshes),
        settings=_settings(width, height),
    )


def point_light() -> Scene:
    """One point light: diffuse, highlight, attached and cast shadow on the ground."""
    return _sphere_on_ground(PointLight((3.41, 5.07, 2.93), (3.2, 3.0, 2.8)))


def directional_light() -> Scene:
    """One directional light: parallel shadow, shadow rays to MAX_DISTANCE."""
    direction = np.array([-0.43, -1.0, -0.31])
    return _sphere_on_ground(DirectionalLight(_vec(direction / np.linalg.norm(direction)), (3.0, 2.9, 2.7)))


def rect_area_light() -> Scene:
    """A 9×9 rectangular area light: shading from its centre, trapezoid-weighted soft shadow."""
    light = RectAreaLight(
        center=(2.37, 4.11, 1.63), axis_u=(1.7, 0.0, 0.3), axis_v=(-0.2, 0.1, 1.3), color=(3.2, 3.1, 2.9), samples=9
    )
    return _sphere_on_ground(light, material=BLUE)


def sphere_area_light() -> Scene:
    """A 5×5 spherical area light (POV ``circular orient``): a disc facing every shaded point."""
    light = SphereAreaLight(center=(-2.13, 3.61, 2.27), radius=0.63, color=(3.1, 3.0, 3.2), samples=5)
    return _sphere_on_ground(light, material=GREEN)


def inverse_square_lights() -> Scene:
    """UsdLux falloff: a point light and a spherical light fall off as I/d², a tilted rect light
    as I·cos θ/d² (one-sided Lambertian panel), a spot light's cone edge is a smoothstep in cos θ,
    a focused spot's light is × cos θ^focus inside its cone, each with its shadows."""
    scene = _sphere_on_ground(
        PointLight((3.41, 5.07, 2.93), (61.0, 57.0, 52.0), falloff="inverse-square"), material=GOLD
    )
    rect = RectAreaLight(
        center=(-2.41, 3.93, 1.17),
        axis_u=(1.2, 0.0, 0.2),
        axis_v=(0.1, 0.3, -1.0),
        color=(48.0, 50.0, 55.0),
        samples=5,
        falloff="inverse-square",
    )
    disc = SphereAreaLight(
        center=(0.37, 4.61, -2.9), radius=0.41, color=(20.0, 26.0, 31.0), samples=3, falloff="inverse-square"
    )
    spot_axis = np.array([0.3, -1.0, -0.2]) / np.linalg.norm([0.3, -1.0, -0.2])
    spot = PointLight(
        (-0.8, 3.9, 0.9),
        (16.0, 14.0, 12.0),
        falloff="inverse-square",
        cone=Cone(_vec(spot_axis), math.cos(math.radians(21.0)), math.cos(math.radians(14.0))),
    )
    focused_axis = np.array([-0.4, -1.0, 0.3]) / np.linalg.norm([-0.4, -1.0, 0.3])
    focused = PointLight(
        (1.9, 3.3, 1.4),
        (13.0, 15.0, 11.0),
        falloff="inverse-square",
        cone=Cone(_vec(focused_axis), math.cos(math.radians(33.0)), math.cos(math.radians(27.0)), 7.5),
    )
    return dataclasses.replace(scene, lights=(*scene.lights, rect, disc, spot, focused))


def ambient_only() -> Scene:
    """No lights at all: every hit is ka·cd·La exactly, misses are the background."""
    scene = _sphere_on_ground(PointLight((0, 5, 0), (1, 1, 1)))
    return dataclasses.replace(
        scene,
        lights=(),
        ambient=AmbientLight((0.8, 0.7, 0.6)),
        meshes=(*scene.meshes, icosphere(1, (-1.63, 0.57, 0.71), 0.49, GOLD, smooth=True)),
    )


def transformed_spheres() -> Scene:
    """Ellipsoids from rotation + non-uniform scale + translation (normals via (M⁻¹)ᵀ)."""
    a = translation((-1.41, 0.93, 0.12)) @ rotation((0.3, 1.0, 0.2), 37.0) @ scaling((0.47, 0.91, 0.63))
    b = translation((0.631, 0.713, -0.37)) @ rotation((1.0, 0.1, -0.4), -52.0) @ scaling((1.13, 0.39, 0.71))
    c = translation((1.73, 1.21, 0.83)) @ rotation((0.0, 0.2, 1.0), 71.0) @ scaling((0.29, 0.83, 0.37))
    return Scene(
        camera=_studio_camera(),
        ambient=AmbientLight((0.17, 0.17, 0.17)),
        lights=(PointLight((2.91, 4.63, 3.37), (3.0, 3.0, 3.0)),),
        spheres=(Sphere(a, RED), Sphere(b, GREEN), Sphere(c, GOLD)),
        meshes=(ground_quad(0.0, GROUND),),
        settings=_settings(),
    )


def smooth_mesh() -> Scene:
    """A low-poly (80-triangle) icosphere with exact vertex normals: interpolated shading,
    polygonal silhouette, the usual smooth-normal terminator."""
    return Scene(
        camera=_studio_camera(),
        ambient=AmbientLight((0.16, 0.16, 0.16)),
        lights=(PointLight((3.13, 4.87, 3.53), (3.0, 3.0, 3.0)),),
        meshes=(icosphere(1, (0.07, 1.08, -0.13), 1.03, GOLD, smooth=True), ground_quad(0.0, GROUND)),
        settings=_settings(),
    )


FAR_OFFSET = (5.0e4, 0.0, 0.0)  # float32 world coordinates there round by 4e-3: features vanish


def far_from_origin() -> Scene:
    """The smooth-mesh scene moved 5e4 units along x (camera and light too): POV-Ray's float32
    mesh2 keeps its precision only in the mesh's local frame, which the compiler writes."""
    scene = smooth_mesh()
    offset = np.array(FAR_OFFSET)
    camera = dataclasses.replace(scene.camera, position=_vec(np.asarray(scene.camera.position) + offset))
    lights = tuple(dataclasses.replace(l, position=_vec(np.asarray(l.position) + offset)) for l in scene.lights)
    ground = scene.meshes[1]
    meshes = (
        dataclasses.replace(scene.meshes[0], points=scene.meshes[0].points + offset),
        # The ground is kept small (±8) so that the mesh, not the ground, sets the scene's size.
        dataclasses.replace(ground, points=np.clip(ground.points, -8.0, 8.0) + offset),
    )
    return dataclasses.replace(scene, camera=camera, lights=lights, meshes=meshes)


def flat_mesh() -> Scene:
    """A 20-triangle icosahedron, flat shaded, every other triangle wound the other way (the
    normal flip makes winding irrelevant), next to an 80-triangle one."""
    ico = icosphere(0, (-0.71, 1.03, -0.17), 0.97, RED, smooth=False)
    triangles = np.array(ico.triangles)
    triangles[::2] = triangles[::2, ::-1]
    mixed = TriangleMesh(points=ico.points, triangles=triangles, material=RED)
    return Scene(
        camera=_studio_camera(),
        ambient=AmbientLight((0.16, 0.16, 0.16)),
        lights=(PointLight((3.13, 4.87, 3.53), (3.0, 3.0, 3.0)), PointLight((-4.1, 2.3, 3.1), (0.7, 0.8, 1.0))),
        meshes=(mixed, icosphere(1, (1.27, 0.63, 0.41), 0.61, BLUE, smooth=False), ground_quad(0.0, GROUND)),
        settings=_settings(),
    )


def back_faces() -> Scene:
    """An open, gently bent 6×4 patch wound to face away from the camera, lit only from behind
    by a directional light: the viewer-facing normal makes n·l < 0 everywhere, so every patch
    pixel is ambient only (ka·cd·La), with no highlight."""
    xs = np.linspace(-1.83, 1.91, 7)
    ys = np.linspace(-1.17, 1.29, 5)
    gx, gy = np.meshgrid(xs, ys, indexing="xy")
    gz = -0.11 * gx * gx - 0.07 * gy - 0.3
    points = np.stack([gx.ravel(), gy.ravel(), gz.ravel()], axis=1)
    tris = []
    nx = len(xs)
    for j in range(len(ys) - 1):
        for i in range(nx - 1):
            a, b, c, d = j * nx + i, j * nx + i + 1, (j + 1) * nx + i + 1, (j + 1) * nx + i
            tris += [(a, c, b), (a, d, c)]  # clockwise seen from +Z: the back faces the camera
    material = PhongMaterial(ka=0.4, kd=0.8, ks=0.6, exponent=8.0, diffuse_color=(0.3, 0.8, 0.5))
    return Scene(
        camera=look_at((0.23, 0.31, 4.9), (0.0, 0.0, -0.3), 55.0),
        ambient=AmbientLight((0.9, 0.85, 0.8)),
        lights=(
            DirectionalLight(_vec(np.array([0.1, 0.05, 1.0]) / np.linalg.norm([0.1, 0.05, 1.0])), (3.0, 3.0, 3.0)),
        ),
        meshes=(TriangleMesh(points=points, triangles=tris, material=material),),
        settings=_settings(),
    )


def shadows_two_lights() -> Scene:
    """Two coloured point lights: two coloured shadows, overlapping where both are blocked."""
    scene = _sphere_on_ground(PointLight((3.41, 5.07, 2.93), (2.2, 1.3, 0.7)), material=GOLD)
    return dataclasses.replace(
        scene,
        lights=(*scene.lights, PointLight((-3.7, 4.3, 1.9), (0.6, 1.1, 2.1))),
        spheres=(*scene.spheres, Sphere.at((-1.23, 0.47, 1.31), 0.43, GREEN)),
    )


def coloured_specular() -> Scene:
    """cs differs from white and from cd: the seed convention tints the highlight by cs."""
    material = PhongMaterial(
        ka=0.1, kd=0.55, ks=0.7, exponent=22.0, diffuse_color=(0.2, 0.3, 0.8), specular_color=(1.0, 0.55, 0.1)
    )
    scene = _sphere_on_ground(PointLight((2.63, 4.31, 4.07), (2.9, 2.9, 2.9)), material=material)
    return dataclasses.replace(scene, lights=(*scene.lights, PointLight((-3.9, 1.7, 2.6), (0.9, 1.0, 1.2))))


def fade() -> Scene:
    """POV-Ray fade: Lc·2/(1 + (d/fade_distance)^fade_power), powers 2 and 1."""
    return Scene(
        camera=_studio_camera(),
        ambient=AmbientLight((0.12, 0.12, 0.12)),
        lights=(
            PointLight((1.93, 2.71, 1.87), (1.6, 1.5, 1.4), fade_distance=2.7, fade_power=2.0),
            PointLight((-2.6, 1.9, 0.7), (0.5, 0.6, 0.8), fade_distance=1.9, fade_power=1.0),
        ),
        spheres=(Sphere.at((0.07, 1.08, -0.13), 1.03, RED), Sphere.at((-1.23, 0.47, 1.31), 0.43, GREEN)),
        meshes=(ground_quad(0.0, GROUND),),
        settings=_settings(),
    )


def orthographic() -> Scene:
    """An orthographic camera looking obliquely down: parallel rays, origins on the image plane."""
    base = look_at((4.13, 5.27, 6.91), (0.05, 0.63, -0.21))
    camera = dataclasses.replace(base, projection="orthographic", ortho_width=6.3)
    scene = transformed_spheres()
    return dataclasses.replace(
        scene, camera=camera, meshes=(*scene.meshes, icosphere(1, (-1.1, 0.45, 1.6), 0.44, BLUE, smooth=True))
    )


def aa_grid() -> Scene:
    """Anti-aliasing with a 3×3 cell-centred grid, plain mean (ref §8)."""
    scene = point_light()
    return dataclasses.replace(scene, settings=_settings(48, 36, samples=3, sample_pattern="grid"))


def aa_povray() -> Scene:
    """POV-Ray's +AM1 +A0.0 +R3 -J: (centre + 3×3 grid)/10 (ref §8)."""
    scene = point_light()
    return dataclasses.replace(scene, settings=_settings(48, 36, samples=3, sample_pattern="povray-am1"))


def classic_convention() -> Scene:
    """The povray-classic convention: white (light-coloured) highlight without n·l."""
    return classic_variant(coloured_specular())


def exponent_zero() -> Scene:
    """e = 0: seed counts (r·wo)^0 = 1 wherever r·wo > 0 (a sharp edge where r·wo crosses 0);
    classic counts it wherever r·l > 0 (ref §10, §12.4)."""
    material = PhongMaterial(
        ka=0.1, kd=0.5, ks=0.25, exponent=0.0, diffuse_color=(0.7, 0.4, 0.3), specular_color=(0.9, 0.9, 1.0)
    )
    return _sphere_on_ground(PointLight((3.41, 5.07, 2.93), (2.6, 2.6, 2.6)), material=material)


def huge_exponent() -> Scene:
    """e = 1e4: a sub-pixel highlight. Light at the eye and the sphere on the axis of an
    odd-sized image, so the centre pixel sits on the peak (value ka·cd·La + (kd·cd/π + ks·cs)·L)
    and its neighbours see almost nothing; no overflow or NaN anywhere."""
    material = PhongMaterial(
        ka=0.1, kd=0.4, ks=0.9, exponent=1e4, diffuse_color=(0.5, 0.5, 0.6), specular_color=(1.0, 1.0, 1.0)
    )
    return Scene(
        camera=Camera(position=(0, 0, 4.3), forward=(0, 0, -1), up=(0, 1, 0), horizontal_fov_deg=45.0),
        ambient=AmbientLight((0.2, 0.2, 0.2)),
        lights=(PointLight((0.0, 0.0, 4.3), (2.5, 2.5, 2.5)),),
        spheres=(Sphere.at((0.0, 0.0, 0.0), 1.07, material),),
        settings=_settings(49, 37),
    )


def povray_golden() -> Scene:
    """Reference §15's golden scene in model terms (classic convention).

    POV's ``diffuse 0.6`` is kd/π = 0.6, i.e. kd = 0.6π, outside the model's kd ∈ [0, 1]. The
    classic model is linear in the lights, so the same image comes from lights π× brighter with
    kd = 0.6 and ks = 0.5/π: diffuse kd·cd/π·(πL) = 0.6·cd·L and phong (ks)·(πL) = 0.5·L, as in POV.

    POV's camera ``location <0,1,-6> look_at 0 right -x*4/3 up y sky y angle 40`` looks toward +Z;
    with ``right -x`` (ref §3 recipe a) it is the right-handed camera forward = (0,−1,6)/√37,
    up = (0,6,1)/√37 (= D̂ × R̂), right = forward × up = −X, horizontal FOV 40°: +X appears on
    the image's left. The plane y = −1 becomes a big quad (it differs only at the horizon).
    """
    forward = np.array([0.0, -1.0, 6.0]) / math.sqrt(37.0)
    up = np.array([0.0, 6.0, 1.0]) / math.sqrt(37.0)
    camera = Camera(position=(0.0, 1.0, -6.0), forward=_vec(forward), up=_vec(up), horizontal_fov_deg=40.0)
    kd = 0.6
    big = PhongMaterial(ka=0.1, kd=kd, ks=0.5 / math.pi, exponent=40.0, diffuse_color=(0.9, 0.4, 0.2))
    small = PhongMaterial(ka=0.1, kd=kd, ks=0.0, exponent=40.0, diffuse_color=(0.2, 0.5, 0.9))
    plane = PhongMaterial(ka=0.1, kd=kd, ks=0.0, exponent=40.0, diffuse_color=(0.7, 0.7, 0.7))
    half = 1e4
    ground = TriangleMesh(
        points=[(-half, -1.0, -half), (half, -1.0, -half), (half, -1.0, half), (-half, -1.0, half)],
        triangles=[(0, 1, 2), (0, 2, 3)],
        material=plane,
    )
    return Scene(
        camera=camera,
        ambient=AmbientLight((1.0, 1.0, 1.0)),
        lights=(
            PointLight((4.0, 6.0, -5.0), _vec(math.pi * np.array([0.8, 0.8, 0.8]))),
            PointLight((-5.0, 2.0, -4.0), _vec(math.pi * np.array([0.2, 0.25, 0.3]))),
        ),
        spheres=(Sphere.at((0.0, 0.0, 0.0), 1.0, big), Sphere.at((1.6, -0.6, -0.6), 0.4, small)),
        meshes=(ground,),
        settings=RenderSettings(width=64, height=48, background=(0.1, 0.2, 0.3), specular="povray-classic"),
    )


@functools.cache
def checker_texture(wrap_s: str = "repeat", wrap_t: str = "repeat", seed: int = 7) -> Texture:
    """A 5 × 3 texture of distinct random colours (a non-square, non-power-of-two image, so
    that a swapped axis, a flipped row order or a half-texel shift all show). Cached: textures
    compare by identity, and a calibration scene built twice must be equal."""
    rng = np.random.default_rng(seed)
    return Texture(
        rng.uniform(0.05, 1.0, (3, 5, 3)).astype(np.float32), wrap_s, wrap_t, source="/Looks/Checker/Texture"
    )


def textured_quad(texture: Texture, uv_lo: float, uv_hi: float, height: float = 0.0) -> TriangleMesh:
    """The ground quad with texture coordinates from uv_lo to uv_hi across it, per corner
    (separate uv indices, as a faceVarying st primvar gives)."""
    quad = ground_quad(height, dataclasses.replace(GROUND, diffuse_texture=texture, ks=0.3, exponent=20.0))
    uvs = [(uv_lo, uv_lo), (uv_hi, uv_lo * 0.7), (uv_hi * 1.1, uv_hi), (uv_lo * 0.8, uv_hi)]
    return dataclasses.replace(quad, uvs=uvs, uv_indices=[(0, 2, 1), (0, 3, 2)])


def texture_repeat() -> Scene:
    """A textured glossy ground (repeat wrap, uvs from -2.3 to 3.1: tiles, seams, negative uvs)
    under a point light, with the sphere's shadow on it."""
    scene = point_light()
    return dataclasses.replace(scene, meshes=(textured_quad(checker_texture(), -2.3, 3.1),))


def texture_clamp() -> Scene:
    """Clamp along u and mirror along v with uvs inside [0, 1]: the edge texels extend to the
    quad's border (POV-Ray: ``once``, no tiling needed)."""
    scene = point_light()
    return dataclasses.replace(scene, meshes=(textured_quad(checker_texture("clamp", "mirror"), 0.0, 0.9),))


@functools.cache
def _specular_checker() -> Texture:
    return Texture(checker_texture(seed=11).image * 3.0, "repeat", "repeat", source="/Looks/Checker/Specular")


def texture_specular() -> Scene:
    """A textured highlight colour (cs) beside a textured cd, on a glossy ground, under two lights
    (the exact mapping's per-light passes each carry the cs filter layer)."""
    scene = shadows_two_lights()
    quad = textured_quad(checker_texture(), -0.6, 1.7)
    material = dataclasses.replace(quad.material, specular_texture=_specular_checker(), ks=0.9, exponent=3.0)
    return dataclasses.replace(scene, meshes=(dataclasses.replace(quad, material=material),))


# ---------------------------------------------------------------------------------------------
# Mirror reflection (Suffern ch. 24; ref §18)

MIRROR_FLOOR = dataclasses.replace(GROUND, kr=0.6, reflective_color=(0.9, 0.8, 1.0))
CHROME = PhongMaterial(
    ka=0.05, kd=0.1, ks=0.4, exponent=40.0, diffuse_color=(0.9, 0.9, 0.9), kr=0.8, reflective_color=(1.0, 0.9, 0.7)
)


def mirror_floor() -> Scene:
    """A reflective floor under the red sphere and a chrome sphere, two lights: the floor shows
    both spheres, the chrome sphere the floor and the red sphere (and itself in the floor),
    with their shadows; max_depth 3 cuts the chains between the floor and the chrome sphere."""
    scene = shadows_two_lights()
    return dataclasses.replace(
        scene,
        spheres=(Sphere.at((0.07, 1.08, -0.13), 1.03, RED), Sphere.at((-1.6, 0.7, 0.9), 0.7, CHROME)),
        meshes=(ground_quad(0.0, MIRROR_FLOOR),),
        settings=dataclasses.replace(scene.settings, max_depth=3),
    )


def facing_mirrors() -> Scene:
    """Two parallel mirror walls (x = ±2.1) with a gold sphere between, seen at an angle, so
    that rays bounce between the walls until max_depth (4) ends them in black."""
    scene = shadows_two_lights()
    wall = PhongMaterial(ka=0.1, kd=0.3, ks=0.0, exponent=1.0, diffuse_color=(0.3, 0.35, 0.4), kr=0.85)

    def wall_at(x: float) -> TriangleMesh:
        corners = [(x, -0.1, -40.3), (x, -0.1, 39.7), (x, 9.7, 40.1), (x, 9.9, -39.9)]
        return TriangleMesh(points=corners, triangles=[(0, 1, 2), (0, 2, 3)], material=wall)

    return dataclasses.replace(
        scene,
        lights=(PointLight((0.61, 5.07, 2.93), (3.2, 3.0, 2.8)),),  # between the walls
        spheres=(Sphere.at((0.31, 0.9, -0.6), 0.8, GOLD),),
        meshes=(ground_quad(0.0, GROUND), wall_at(-2.1), wall_at(2.3)),
        settings=dataclasses.replace(scene.settings, max_depth=4),
    )


# Transparency (Suffern ch. 27; ref §18). No highlight on the glass: the exact mapping cannot
# express a transmissive material with one (backends/povray/compile.py), and these scenes run
# under both mappings.

GLASS = PhongMaterial(ka=0.0, kd=0.0, ks=0.0, exponent=1.0, diffuse_color=(1.0, 1.0, 1.0), kr=0.08, kt=0.9, ior=1.5)


def box_mesh(lo, hi, material: PhongMaterial) -> TriangleMesh:
    """A closed box, outward normals (counter-clockwise seen from outside)."""
    import trimesh  # test-only dependency, imported where needed

    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    box = trimesh.creation.box(extents=hi - lo)
    box.apply_translation((lo + hi) / 2)
    return TriangleMesh(
        points=np.asarray(box.vertices), triangles=np.asarray(box.faces, dtype=np.int32), material=material
    )


def checker() -> Scene:
    """The book's Checker3D: the ground quad at y = 0, a whole multiple of its cell size (the
    book's ε puts the plane inside one row of cells, not on their boundary), and the sphere in a
    3D checker of smaller cells (its cells cut the curved surface), under the point light."""
    scene = point_light()
    floor = dataclasses.replace(GROUND, checker_size=0.43, checker_color=(0.12, 0.16, 0.3))
    ball = dataclasses.replace(RED, checker_size=0.2371, checker_color=(0.85, 0.78, 0.2))
    sphere = dataclasses.replace(scene.spheres[0], material=ball)
    return dataclasses.replace(scene, spheres=(sphere,), meshes=(ground_quad(0.0, floor),))


def glass_sphere() -> Scene:
    """A glass sphere (kt 0.9, ior 1.5, a little kr) in front of the red sphere: the red sphere
    seen through it upside down, total internal reflection near its rim, its shadow on the
    ground filtered by kt twice (two crossings)."""
    scene = point_light()
    return dataclasses.replace(
        scene,
        spheres=(*scene.spheres, Sphere.at((-0.9, 0.75, 1.6), 0.7, GLASS)),
        settings=dataclasses.replace(scene.settings, max_depth=6),
    )


def glass_slab() -> Scene:
    """A closed glass box (a mesh: its winding says where its inside is) before the red sphere:
    the sphere shifted by refraction through the slab, a filtered shadow."""
    scene = point_light()
    slab = box_mesh((-1.9, 0.05, 1.2), (1.3, 1.6, 1.65), dataclasses.replace(GLASS, kr=0.0, kt=0.85))
    return dataclasses.replace(
        scene, meshes=(*scene.meshes, slab), settings=dataclasses.replace(scene.settings, max_depth=6)
    )


def glass_smooth_mesh() -> Scene:
    """glass_sphere's ball as a smooth-shaded icosphere mesh (320 triangles, vertex normals):
    near its silhouette the interpolated normal turns away from rays that enter, where the two
    transmission conventions decide entering and leaving differently (by the normal, or, as
    POV-Ray does, by the interiors the ray is in)."""
    import trimesh

    scene = glass_sphere()
    ball = trimesh.creation.icosphere(subdivisions=2, radius=0.7)
    mesh = TriangleMesh(
        ball.vertices + np.array([-0.9, 0.75, 1.6]),
        np.asarray(ball.faces),
        normals=np.asarray(ball.vertex_normals),
        normal_indices=np.asarray(ball.faces),
        material=GLASS,
        source="/GlassBall",
    )
    return dataclasses.replace(scene, spheres=scene.spheres[:-1], meshes=(*scene.meshes, mesh))


def _povray_transmission(scene: Scene) -> Scene:
    """The scene in the "povray" transmission convention, whose shadow rays are filtered by the
    transmissive objects they cross (the book's are blocked by them): what a filtered-shadow
    scene tests against the oracle too, not only against POV-Ray."""
    return dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, transmission="povray"))


def glass_under_rect_light() -> Scene:
    """glass_sphere lit by a 5 × 5 rect area light instead of its point light, in the "povray"
    transmission convention: the soft shadow of the glass ball on the ground is each grid sample's
    ray filtered by kt per crossing."""
    scene = glass_sphere()
    light = RectAreaLight(
        center=(-1.5, 4.5, 2.5), axis_u=(1.5, 0.0, 0.0), axis_v=(0.0, 0.0, 1.5), color=(3.0, 3.0, 3.0), samples=5
    )
    return _povray_transmission(dataclasses.replace(scene, lights=(light,)))


def glass_under_sphere_light() -> Scene:
    """The same under a sphere light (its disc faces each shaded point: `orient`)."""
    scene = glass_sphere()
    light = SphereAreaLight(center=(-1.5, 4.5, 2.5), radius=0.6, color=(3.0, 3.0, 3.0), samples=5)
    return _povray_transmission(dataclasses.replace(scene, lights=(light,)))


def glass_far_box() -> Scene:
    """A small glass box farther from the origin than its size, so POV-Ray's mesh2 holds it in a
    local frame (a ``translate``, TriangleMesh.local_origin): its ``inside_vector`` must come
    before that translate (POV-Ray's parser refuses it after one)."""
    scene = point_light()
    box = box_mesh((-0.5, 0.3, 1.25), (0.0, 0.75, 1.65), dataclasses.replace(GLASS, kr=0.0, kt=0.85))
    assert box.local_origin().any()
    return dataclasses.replace(
        scene, meshes=(*scene.meshes, box), settings=dataclasses.replace(scene.settings, max_depth=6)
    )


def dielectric_sphere() -> Scene:
    """The book's dielectric (ch. 28; kr = kt = 1, fresnel): a glass sphere that reflects F and
    transmits 1 − F at every crossing, and a fresnel (opaque, ior 1.5) red sphere beside it."""
    scene = glass_sphere()
    dielectric = dataclasses.replace(GLASS, kr=1.0, kt=1.0, fresnel=True)
    coated = dataclasses.replace(RED, kr=1.0, fresnel=True, ior=1.5)
    return dataclasses.replace(
        scene,
        spheres=(
            dataclasses.replace(scene.spheres[0], material=coated),
            dataclasses.replace(scene.spheres[1], material=dielectric),
        ),
    )


def tinted_glass() -> Scene:
    """Beer-Lambert (ch. 28's cf_in): the glass sphere and slab absorb towards blue-green inside,
    more where their rays travel farther (the sphere's centre, the slab's ends), and so do the
    shadows through them."""
    scene = glass_slab()
    tint = (0.45, 0.8, 0.9)
    slab = dataclasses.replace(
        scene.meshes[1], material=dataclasses.replace(scene.meshes[1].material, interior_filter=tint)
    )
    sphere = Sphere.at(
        (1.2, 0.55, 2.4), 0.5, dataclasses.replace(GLASS, interior_filter=(0.9, 0.5, 0.3), fresnel=True, kr=1.0, kt=1.0)
    )
    return dataclasses.replace(scene, meshes=(scene.meshes[0], slab), spheres=(*scene.spheres, sphere))


def classic_variant(scene: Scene) -> Scene:
    """The same scene under the ``povray-classic`` specular convention."""
    return dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, specular="povray-classic"))


SCENES: dict[str, Callable[[], Scene]] = {
    "handedness": handedness,
    "pixel_centres": pixel_centres,
    "point_light": point_light,
    "directional_light": directional_light,
    "rect_area_light": rect_area_light,
    "sphere_area_light": sphere_area_light,
    "inverse_square_lights": inverse_square_lights,
    "ambient_only": ambient_only,
    "transformed_spheres": transformed_spheres,
    "smooth_mesh": smooth_mesh,
    "far_from_origin": far_from_origin,
    "flat_mesh": flat_mesh,
    "back_faces": back_faces,
    "shadows_two_lights": shadows_two_lights,
    "coloured_specular": coloured_specular,
    "fade": fade,
    "orthographic": orthographic,
    "aa_grid": aa_grid,
    "aa_povray": aa_povray,
    "classic_convention": classic_convention,
    "exponent_zero": exponent_zero,
    "huge_exponent": huge_exponent,
    "povray_golden": povray_golden,
    "texture_repeat": texture_repeat,
    "texture_clamp": texture_clamp,
    "texture_specular": texture_specular,
    "checker": checker,
    "mirror_floor": mirror_floor,
    "facing_mirrors": facing_mirrors,
    "glass_sphere": glass_sphere,
    "glass_slab": glass_slab,
    "glass_far_box": glass_far_box,
    "glass_smooth_mesh": glass_smooth_mesh,
    "glass_under_rect_light": glass_under_rect_light,
    "glass_under_sphere_light": glass_under_sphere_light,
    "dielectric_sphere": dielectric_sphere,
    "tinted_glass": tinted_glass,
}


# ---------------------------------------------------------------------------------------------
# POV-Ray's adaptive estimators (ref §5 `adaptive n`, §8 +AM1/+AM2 with a threshold). Not in
# SCENES: the oracle models the full grids only; these are cross-validated against POV-Ray.


def adaptive_rect_light_levels() -> Scene:
    """`adaptive 1` on a 17×17 rect light too dim (|r|+|g|+|b| = 0.09 <= 0.1) for its corners to
    ever differ enough: only the first split happens, so each quadrant is the mean of its 4
    corners (9 grid points used of 289)."""
    scene = rect_area_light()
    light = dataclasses.replace(scene.lights[0], color=(0.031, 0.03, 0.029), samples=17, adaptive=1)
    return dataclasses.replace(scene, lights=(light,))


def adaptive_sphere_light_threshold() -> Scene:
    """`adaptive 0` on a 9×9 spherical light: regions split only where two adjacent corners
    differ (bright light: any visibility change is > 0.1), so partial shadows inside a region
    whose corners agree are missed exactly as POV-Ray misses them."""
    scene = sphere_area_light()
    light = dataclasses.replace(scene.lights[0], samples=9, adaptive=0)
    return dataclasses.replace(scene, lights=(light,))


def adaptive_am1() -> Scene:
    """+AM1 +A0.1 +R3: only pixels whose encoded colour differs from the left or top neighbour
    by >= 0.1 are supersampled, decided per 32×32 POV-Ray block (80×60: 3×2 blocks)."""
    scene = point_light()
    return dataclasses.replace(
        scene, settings=_settings(80, 60, samples=3, sample_pattern="povray-am1", aa_threshold=0.1)
    )


def adaptive_am2() -> Scene:
    """+AM2 +A0.1 +R3: pixel corners, then 4-corner subdivision (down to 4×4 cells) where the
    corners differ pairwise by >= 0.1."""
    scene = point_light()
    return dataclasses.replace(
        scene, settings=_settings(80, 60, samples=3, sample_pattern="povray-am2", aa_threshold=0.1)
    )


def adaptive_am1_two_lights() -> Scene:
    """+AM1 +A0.1 +R3 with two lights: under the exact mapping POV-Ray renders one pass per light
    and decides supersampling per pass (crossvalidation.render_native_as_povray does the same)."""
    scene = shadows_two_lights()
    return dataclasses.replace(
        scene, settings=_settings(80, 60, samples=3, sample_pattern="povray-am1", aa_threshold=0.1)
    )


# A light whose colour sum (0.3) puts POV-Ray's 0.1 between its two kinds of shadow edge: an
# opaque occluder's changes the arriving colour by 0.3 (> 0.1: the region splits), the glass
# ball's (kt 0.9, twice: 1 - 0.81) by 0.057 (< 0.1: it does not), so the colour rule decides.
DIM_FOR_GLASS = (0.1, 0.1, 0.1)


def adaptive_glass_rect_light() -> Scene:
    """glass_under_rect_light with `adaptive 1` on a 9×9 grid under DIM_FOR_GLASS: after the
    first split the recursion compares the corners' filtered colours (kt per crossing of the
    glass ball), which split regions across the red ball's shadow edge but not the glass ball's."""
    scene = glass_under_rect_light()
    light = dataclasses.replace(scene.lights[0], color=DIM_FOR_GLASS, samples=9, adaptive=1)
    return dataclasses.replace(scene, lights=(light,))


def adaptive_glass_sphere_light() -> Scene:
    """The same under a 9×9 sphere light with `adaptive 0`: regions split only where two
    adjacent corners' filtered colours differ by more than 0.1."""
    scene = glass_under_sphere_light()
    light = dataclasses.replace(scene.lights[0], color=DIM_FOR_GLASS, samples=9, adaptive=0)
    return dataclasses.replace(scene, lights=(light,))


ADAPTIVE_SCENES: dict[str, Callable[[], Scene]] = {
    "adaptive_glass_rect_light": adaptive_glass_rect_light,
    "adaptive_glass_sphere_light": adaptive_glass_sphere_light,
    "adaptive_am1_two_lights": adaptive_am1_two_lights,
    "adaptive_rect_light_levels": adaptive_rect_light_levels,
    "adaptive_sphere_light_threshold": adaptive_sphere_light_threshold,
    "adaptive_am1": adaptive_am1,
    "adaptive_am2": adaptive_am2,
}
