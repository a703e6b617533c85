# SPDX-License-Identifier: Apache-2.0
"""Figures 24.6(a, b) and 24.7(a, b) of Suffern, Ray Tracing from the Ground Up (ch. 24, mirror
reflection), from the book's build functions (BuildFigure24_06a/b, 24_07a/b): three Reflective
objects (a yellow sphere, a black mirror sphere, a cyan solid cylinder; kr 0.75) beside two
Matte ones (an orange sphere, a long green box) on a plane whose SV_Matte takes its colour from a
PlaneChecker (cells of 20, white on white, outlined in black, width 2): the floor's grid of lines.
One point light casting shadows, ambient 0.5, background 0.15 grey, the book's pinhole (pixel
size 1, 600 x 400) and its regular 4 x 4 sampler. 24.6(a) traces no secondary ray (max depth 0),
24.6(b) one bounce, 24.7(a) ten; 24.7(b) is 24.7(a) seen from far above (d = 45000). Regenerates
book_24_6a/b.usda and book_24_7a/b.usda (docs/book.md: how close they render to the book's own
code)."""

import math

import numpy as np
from _seed import write

import phongscene
from phongscene.scene import AmbientLight, Intrinsic, PhongMaterial, PointLight, RenderSettings, Scene, Sphere


def reflective(ka, kd, cd, ks, exponent, name) -> PhongMaterial:
    """The book's Reflective: Phong plus a perfect mirror, kr 0.75 and cr white."""
    return PhongMaterial(
        ka=ka, kd=kd, ks=ks, exponent=exponent, diffuse_color=cd, kr=0.75, source=f"/World/Looks/{name}/Phong"
    )


def matte(ka, kd, cd, name) -> PhongMaterial:
    return PhongMaterial(ka=ka, kd=kd, ks=0.0, exponent=1.0, diffuse_color=cd, source=f"/World/Looks/{name}/Phong")


YELLOW = reflective(0.25, 0.5, (0.75, 0.75, 0.0), 0.15, 100.0, "Yellow")
MIRROR = reflective(0.35, 0.75, (0.0, 0.0, 0.0), 0.0, 1.0, "Mirror")
CYAN = reflective(0.35, 0.5, (0.0, 0.5, 0.75), 0.2, 100.0, "Cyan")
ORANGE = matte(0.45, 0.75, (0.75, 0.25, 0.0), "Orange")
GREEN = matte(0.15, 0.5, (0.75, 1.0, 0.75), "Green")
# SV_Matte (ka 0.3, kd 0.9) with the PlaneChecker: color1 = color2 = white, a black outline.
FLOOR = PhongMaterial(
    ka=0.3,
    kd=0.9,
    ks=0.0,
    exponent=1.0,
    diffuse_color=(1.0, 1.0, 1.0),
    checker_size=20.0,
    checker_color=(1.0, 1.0, 1.0),
    checker_plane=True,
    checker_outline_width=2.0,
    checker_outline_color=(0.0, 0.0, 0.0),
    source="/World/Looks/Floor/Phong",
)
# The canonical +Z axis onto the world's +Y (Intrinsic's frame), rotation only.
Z_TO_Y = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])


def placed(linear: np.ndarray, translation) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = linear, translation
    return m


def build(max_depth: int, eye=(75.0, 40.0, 100.0), lookat=(-10.0, 39.0, 0.0), distance: float = 360.0) -> Scene:
    # 600 pixels of size 1 at the view distance: the horizontal field of view.
    fov = math.degrees(2.0 * math.atan(300.0 / distance))
    # SolidCylinder(bottom 0, top 85, radius 22) about +y; Box((-35, 0, -110), (-25, 60, 65)); the
    # plane through the origin with normal +y.
    cylinder = Intrinsic(
        "cylinder",
        placed(Z_TO_Y @ np.diag([1.0, 1.0, 42.5]), (0.0, 42.5, 0.0)),
        CYAN,
        "/World/Geometry/Cylinder",
        radius_bottom=22.0,
        radius_top=22.0,
    )
    box = Intrinsic("cube", placed(np.diag([5.0, 30.0, 87.5]), (-30.0, 30.0, -22.5)), GREEN, "/World/Geometry/Box")
    ground = Intrinsic("plane", placed(Z_TO_Y, (0.0, 0.0, 0.0)), FLOOR, "/World/Geometry/Ground", infinite=True)
    return Scene(
        camera=phongscene.look_at(eye, lookat, fov, source="/World/Camera"),
        ambient=AmbientLight((0.5, 0.5, 0.5), source="/World/Lights/Ambient"),
        lights=(PointLight((150.0, 150.0, 0.0), (3.0, 3.0, 3.0), source="/World/Lights/Point"),),
        spheres=(
            Sphere.at((38.0, 23.0, -25.0), 23.0, YELLOW, source="/World/Geometry/Yellow"),
            Sphere.at((-7.0, 10.0, 42.0), 20.0, ORANGE, source="/World/Geometry/Orange"),
            Sphere.at((-30.0, 59.0, 35.0), 20.0, MIRROR, source="/World/Geometry/Mirror"),
        ),
        intrinsics=(cylinder, box, ground),
        settings=RenderSettings(
            width=600,
            height=400,
            samples=4,
            sample_pattern="grid",
            background=(0.15, 0.15, 0.15),
            max_depth=max_depth,
            source="/Render/Settings",
        ),
    )


if __name__ == "__main__":
    write(build(0), "book_24_6a")
    write(build(1), "book_24_6b")
    write(build(10), "book_24_7a")
    write(build(10, eye=(2000.0, 4000.0, -1000.0), lookat=(38.0, 75.0, -20.0), distance=45000.0), "book_24_7b")
