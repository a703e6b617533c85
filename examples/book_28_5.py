# SPDX-License-Identifier: Apache-2.0
"""Figures 28.5(a) and (b) of Suffern, Ray Tracing from the Ground Up (ch. 28, the dielectric),
from the book's build functions (BuildFigure28_05a/b): a dielectric sphere (Fresnel, eta_in 1.5 in
(a), 0.75 in (b), a highlight ks 0.2, e = 2000) before a red Reflective sphere (kr 0.25), on a
Checker3D-textured SV_Matte rectangle, two point lights and a directional one, all casting
shadows, ambient 0.25, the book's pinhole (d = 2400, pixel size 1, 600 x 600), its regular 4 x 4
sampler, Whitted depth 5. Regenerates book_28_5a.usda and book_28_5b.usda (docs/book.md: the
mapping, and how close they render to the book's own code)."""

import dataclasses
import math

from _seed import write

import phongscene
from phongscene.scene import (
    AmbientLight,
    DirectionalLight,
    PhongMaterial,
    PointLight,
    RenderSettings,
    Scene,
    Sphere,
    TriangleMesh,
)

# Dielectric: Phong with ka = kd = 0 (the book's defaults), its highlight, and the Fresnel pair
# (kr = kt = 1 split by F; eta_out 1, cf_in = cf_out white: nothing filtered).
DIELECTRIC = PhongMaterial(
    ka=0.0,
    kd=0.0,
    ks=0.2,
    exponent=2000.0,
    diffuse_color=(0.0, 0.0, 0.0),
    kr=1.0,
    kt=1.0,
    ior=1.5,
    fresnel=True,
    source="/World/Looks/Dielectric/Phong",
)
RED = PhongMaterial(
    ka=0.3, kd=0.3, ks=0.2, exponent=2000.0, diffuse_color=(1.0, 0.0, 0.0), kr=0.25, source="/World/Looks/Red/Phong"
)
# SV_Matte with a Checker3D (size 4, color1 0.75 grey, color2 white): no highlight.
CHECKER = PhongMaterial(
    ka=0.5,
    kd=0.35,
    ks=0.0,
    exponent=1.0,
    diffuse_color=(0.75, 0.75, 0.75),
    checker_size=4.0,
    checker_color=(1.0, 1.0, 1.0),
    source="/World/Looks/Checker/Phong",
)


def build(eta_in: float) -> Scene:
    # The book's Rectangle(p0, a, b): p0 (-20, 0, -100), a (0, 0, 120), b (40, 0, 0); normal a x b = +y.
    p0, a, b = (-20.0, 0.0, -100.0), (0.0, 0.0, 120.0), (40.0, 0.0, 0.0)
    corners = [p0, tuple(p + q for p, q in zip(p0, a)), tuple(p + q + r for p, q, r in zip(p0, a, b))]
    corners.append(tuple(p + r for p, r in zip(p0, b)))
    floor = TriangleMesh(corners, [(0, 1, 2), (0, 2, 3)], material=CHECKER, source="/World/Geometry/Rectangle")
    glass = dataclasses.replace(DIELECTRIC, ior=eta_in)
    # 600 pixels of size 1 at distance 2400: the horizontal field of view.
    fov = math.degrees(2.0 * math.atan(300.0 / 2400.0))
    return Scene(
        camera=phongscene.look_at((-8.0, 5.5, 40.0), (1.0, 4.0, 0.0), fov, source="/World/Camera"),
        ambient=AmbientLight((0.25, 0.25, 0.25), source="/World/Lights/Ambient"),
        lights=(
            PointLight((40.0, 50.0, 0.0), (4.5, 4.5, 4.5), source="/World/Lights/Point1"),
            PointLight((-10.0, 20.0, 10.0), (4.5, 4.5, 4.5), source="/World/Lights/Point2"),
            # set_direction(-1, 0, 0) is the direction to the light: it travels along +x.
            DirectionalLight((1.0, 0.0, 0.0), (4.5, 4.5, 4.5), source="/World/Lights/Directional"),
        ),
        spheres=(
            Sphere.at((0.0, 4.5, 0.0), 3.0, glass, source="/World/Geometry/Dielectric"),
            Sphere.at((4.0, 4.0, -6.0), 3.0, RED, source="/World/Geometry/Red"),
        ),
        meshes=(floor,),
        settings=RenderSettings(
            width=600,
            height=600,
            samples=4,
            sample_pattern="grid",
            background=(0.0, 0.3, 0.25),
            max_depth=5,
            source="/Render/Settings",
        ),
    )


if __name__ == "__main__":
    write(build(1.5), "book_28_5a")
    write(build(0.75), "book_28_5b")
