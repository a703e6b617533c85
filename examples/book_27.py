# SPDX-License-Identifier: Apache-2.0
"""Figures of Suffern, Ray Tracing from the Ground Up, ch. 27 (transparency), from the book's build
functions (BuildFigure27_XX): the Transparent material, Phong (ka = kd = 0, a highlight) plus a
PerfectSpecular kr·cr and a PerfectTransmitter kt of index ior (kt/η² on the refracted radiance,
total internal reflection at full weight), and the ch. 28 Dielectric (Fresnel, a cf_in filter)
where a figure uses it. Most figures share one scene: a glass object before a red Reflective
sphere (kr 0.25) on a Checker3D-textured SV_Matte rectangle, two point lights and a directional
one, all casting shadows, ambient 0.25, background (0, 0.3, 0.25), the book's pinhole (pixel size
1, 600 x 600) and its regular sampler. Regenerates book_27_XX.usda, one per figure (docs/book.md:
the mapping, and how close they render to the book's own code). Figure 27.19(a), a glass
SolidCylinder, is left out: that copy of the code turns the cylinder's wall normal towards the ray,
so its glass never refracts out, which the model does not reproduce (docs/book.md):

    cd examples && python book_27.py && cd ..
"""

import math

import numpy as np
from _seed import write
from pxr import Usd, UsdGeom

import phongscene
from phongscene.scene import (
    AmbientLight,
    Camera,
    DirectionalLight,
    Intrinsic,
    Linking,
    PhongMaterial,
    PointLight,
    RenderSettings,
    Scene,
    Sphere,
    TriangleMesh,
)

BACKGROUND = (0.0, 0.3, 0.25)


def transparent(ior: float, ks: float = 0.2, name: str = "Glass") -> PhongMaterial:
    """The book's Transparent: Phong with ka = kd = 0 (its defaults; the figures set only ks and
    exp), cs white, a PerfectSpecular kr 0.1 (cr white) and a PerfectTransmitter kt 0.9."""
    return PhongMaterial(
        ka=0.0,
        kd=0.0,
        ks=ks,
        exponent=2000.0,
        diffuse_color=(0.0, 0.0, 0.0),
        kr=0.1,
        kt=0.9,
        ior=ior,
        source=f"/World/Looks/{name}/Phong",
    )


def dielectric(ks: float, exponent: float, eta_in: float, cf_in, name: str = "Dielectric") -> PhongMaterial:
    """The ch. 28 Dielectric: Phong with ka = kd = 0 and a highlight, the Fresnel pair (kr = kt = 1
    split by F) and Beer-Lambert inside (cf_in; eta_out 1 and cf_out white: nothing outside)."""
    return PhongMaterial(
        ka=0.0,
        kd=0.0,
        ks=ks,
        exponent=exponent,
        diffuse_color=(0.0, 0.0, 0.0),
        kr=1.0,
        kt=1.0,
        ior=eta_in,
        fresnel=True,
        interior_filter=cf_in,
        source=f"/World/Looks/{name}/Phong",
    )


# The red sphere of the two-sphere scene: Reflective ka 0.3, kd 0.3, red, ks 0.2, exp 2000, kr 0.25.
RED = PhongMaterial(
    ka=0.3, kd=0.3, ks=0.2, exponent=2000.0, diffuse_color=(1.0, 0.0, 0.0), kr=0.25, source="/World/Looks/Red/Phong"
)
# SV_Matte (ka 0.5, kd 0.35) with a Checker3D (size 4, color1 0.75 grey, color2 white).
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
# The canonical +Z axis onto the world's +Y (Intrinsic's frame), rotation only.
Z_TO_Y = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])


def placed(linear: np.ndarray, translation) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = linear, translation
    return m


def pinhole(eye, lookat, distance: float, width: int = 600) -> Camera:
    # `width` pixels of size 1 at the view distance: the horizontal field of view.
    fov = math.degrees(2.0 * math.atan(0.5 * width / distance))
    return phongscene.look_at(eye, lookat, fov, source="/World/Camera")


def settings(samples: int, max_depth: int, background=BACKGROUND) -> RenderSettings:
    # vp.set_samples(samples²) with the Regular sampler: a samples x samples grid in each pixel.
    return RenderSettings(
        width=600,
        height=600,
        samples=samples,
        sample_pattern="grid",
        background=background,
        max_depth=max_depth,
        source="/Render/Settings",
    )


def rectangle(y: float = 0.0) -> TriangleMesh:
    # The book's Rectangle(p0, a, b): p0 (-20, y, -100), a (0, 0, 120), b (40, 0, 0); normal a x b = +y.
    # Two triangles, as book_28_5.py writes the same floor.
    p0, a, b = (-20.0, y, -100.0), (0.0, 0.0, 120.0), (40.0, 0.0, 0.0)
    corners = [p0, tuple(p + q for p, q in zip(p0, a)), tuple(p + q + r for p, q, r in zip(p0, a, b))]
    corners.append(tuple(p + r for p, r in zip(p0, b)))
    return TriangleMesh(corners, [(0, 1, 2), (0, 2, 3)], material=CHECKER, source="/World/Geometry/Rectangle")


def two_spheres(
    glass_object: Sphere, camera: Camera, samples: int = 4, max_depth: int = 5, floor_y: float = 0.0
) -> Scene:
    """The common scene of 27.12-27.15, 27.24 and 27.28: the glass object, the red sphere at
    (4, 4, -6), radius 3, and the floor; three lights of ls 4.5 with set_shadows(true)."""
    return Scene(
        camera=camera,
        ambient=AmbientLight((0.25, 0.25, 0.25), source="/World/Lights/Ambient"),
        lights=(
            PointLight((40.0, 50.0, 0.0), (4.5, 4.5, 4.5), source="/World/Lights/Point1"),
            PointLight((-10.0, 20.0, 10.0), (4.5, 4.5, 4.5), source="/World/Lights/Point2"),
            # set_direction(-1, 0, 0) is the direction to the light: it travels along +x.
            DirectionalLight((1.0, 0.0, 0.0), (4.5, 4.5, 4.5), source="/World/Lights/Directional"),
        ),
        spheres=(glass_object, Sphere.at((4.0, 4.0, -6.0), 3.0, RED, source="/World/Geometry/Red")),
        meshes=(rectangle(floor_y),),
        settings=settings(samples, max_depth),
    )


# The camera of 27.13-27.15: eye (-8, 5.5, 40), lookat (1, 4, 0), d = 2400.
FRONT = pinhole((-8.0, 5.5, 40.0), (1.0, 4.0, 0.0), 2400.0)


def glass_ball(material: PhongMaterial) -> Sphere:
    return Sphere.at((0.0, 4.5, 0.0), 3.0, material, source="/World/Geometry/Glass")


def figure_27_12() -> Scene:
    """BuildFigure27_12: the scene seen from straight above (eye (2, 50, -3), lookat (2, 0, -3),
    d = 1800), ior 1.5, depth 5, the rectangle at y = -0.001 (as in the Java port, the only full
    source). The book's compute_uvw hardwires u = (0, 0, 1), v = (1, 0, 0), w = (0, 1, 0) for a
    camera looking straight down (up (0, 1, 0) is parallel to the view): look_at cannot make that
    frame, so the camera is written out: forward -w, up v (right = forward x up = u)."""
    camera = Camera(
        position=(2.0, 50.0, -3.0),
        forward=(0.0, -1.0, 0.0),
        up=(1.0, 0.0, 0.0),
        horizontal_fov_deg=math.degrees(2.0 * math.atan(300.0 / 1800.0)),
        source="/World/Camera",
    )
    return two_spheres(glass_ball(transparent(1.5)), camera, floor_y=-0.001)


def figure_27_13(max_depth: int) -> Scene:
    """BuildFigure27_13: ior 1.0 (refraction bends nothing), depth 2, 4 and 5 for (a), (b), (c)
    (the C++ copies' comments; the Java port sets 2, then 5)."""
    return two_spheres(glass_ball(transparent(1.0)), FRONT, max_depth=max_depth)


def figure_27_14(ior: float) -> Scene:
    """BuildFigure27_14: ior 1.1 (a) and 1.5 (b), depth 5."""
    return two_spheres(glass_ball(transparent(ior)), FRONT)


def figure_27_15b() -> Scene:
    """BuildFigure27_15b, Suffern's C++ "new version": the ch. 28 Dielectric (ks 0.5, exp 10000,
    eta_in 0.75, cf_in (0.9, 1, 0.5)), whose yellow-green interior shows the region of total
    internal reflection. The file the book's author wrote himself, hence the figure's name."""
    glass = dielectric(0.5, 10000.0, 0.75, (0.9, 1.0, 0.5))
    return two_spheres(glass_ball(glass), FRONT)


def figure_27_15b_transparent() -> Scene:
    """BuildFigure15B of the Java port: Transparent ior 0.75 and the rectangle at y = -0.001. Which
    of the two the printed figure is, is not known: both are written."""
    return two_spheres(glass_ball(transparent(0.75)), FRONT, floor_y=-0.001)


def ellipsoid(ior: float) -> Sphere:
    """Instance(Sphere((0, 0, 0), 1)) with scale(6, 2, 3), rotate_x(90), translate(0, 3, 0): the
    forward matrix T·Rx(90°)·S, semi-axes 6 (x), 3 (y), 2 (z) about (0, 3, 0), resting on the floor."""
    rx90 = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
    m = placed(rx90 @ np.diag([6.0, 2.0, 3.0]), (0.0, 3.0, 0.0))
    return Sphere(m, transparent(ior), source="/World/Geometry/Ellipsoid")


def figure_27_24a() -> Scene:
    """BuildFigure27_24a: the transparent ellipsoid (ior 1.5), eye (-8, 5.5, 40), lookat (0, 4, 0),
    d = 1800; one sample per pixel (the pixel's centre), depth 5."""
    return two_spheres(ellipsoid(1.5), pinhole((-8.0, 5.5, 40.0), (0.0, 4.0, 0.0), 1800.0), samples=1)


def figure_27_28() -> Scene:
    """BuildFigure27_28: the same ellipsoid of ior 0.75 (total internal reflection), 4 x 4 grid."""
    return two_spheres(ellipsoid(0.75), pinhole((-8.0, 5.5, 40.0), (0.0, 4.0, 0.0), 1800.0))


def figure_27_23(eye_z: float, distance: float) -> Scene:
    """BuildFigure27_23a/b ("uses the Dielectric material from Chapter 28"): a unit Dielectric
    sphere (ks 0.15, exp 100, eta_in 1.5, cf_in (0.47, 0.86, 0.74)) above a black-and-white Checker3D
    plane (size 4) at y = -5, one point light without shadows (set_shadows(false)), ambient 0.5,
    background 0.75 grey, a 5 x 5 grid, depth 3. (a): eye (0, 0, 20), d = 4500; (b): eye
    (0, 0, 1.25), d = 180 (the Java port's BuildFigure23B)."""
    floor = PhongMaterial(
        ka=0.25,
        kd=0.65,
        ks=0.0,
        exponent=1.0,
        diffuse_color=(1.0, 1.0, 1.0),
        checker_size=4.0,
        checker_color=(0.0, 0.0, 0.0),
        source="/World/Looks/Checker/Phong",
    )
    plane = Intrinsic("plane", placed(Z_TO_Y, (0.0, -5.0, 0.0)), floor, "/World/Geometry/Plane", infinite=True)
    glass = dielectric(0.15, 100.0, 1.5, (0.47, 0.86, 0.74))
    return Scene(
        camera=pinhole((0.0, 0.0, eye_z), (0.0, 0.0, 0.0), distance),
        ambient=AmbientLight((0.5, 0.5, 0.5), source="/World/Lights/Ambient"),
        lights=(
            PointLight((0.0, 50.0, 0.0), (4.5, 4.5, 4.5), source="/World/Lights/Point", linking=Linking(shadows=False)),
        ),
        spheres=(Sphere.at((0.0, 0.0, 0.0), 1.0, glass, source="/World/Geometry/Dielectric"),),
        intrinsics=(plane,),
        settings=settings(5, 3, background=(0.75, 0.75, 0.75)),
    )


FIGURES = {
    "book_27_12": figure_27_12,
    "book_27_13a": lambda: figure_27_13(2),
    "book_27_13b": lambda: figure_27_13(4),
    "book_27_13c": lambda: figure_27_13(5),
    "book_27_14a": lambda: figure_27_14(1.1),
    "book_27_14b": lambda: figure_27_14(1.5),
    "book_27_15b": figure_27_15b,
    "book_27_15b_transparent": figure_27_15b_transparent,
    "book_27_23a": lambda: figure_27_23(20.0, 4500.0),
    "book_27_23b": lambda: figure_27_23(1.25, 180.0),
    "book_27_24a": figure_27_24a,
    "book_27_28": figure_27_28,
}


def write_figure(scene: Scene, name: str) -> None:
    """Write the scene, then its camera as docs/book.md maps the book's pinhole: focalLength = d and
    the apertures 600 (pixel size 1 times the resolution), exact in float, where the writer's
    focal length 50 would round the aperture 50·600/d to a float (16.666666 for d = 1800)."""
    path = write(scene, name)
    distance = 300.0 / math.tan(math.radians(scene.camera.horizontal_fov_deg) / 2)
    stage = Usd.Stage.Open(str(path))
    camera = UsdGeom.Camera(stage.GetPrimAtPath("/World/Camera"))
    camera.GetFocalLengthAttr().Set(float(round(distance)))  # every figure's d is a whole number
    camera.GetHorizontalApertureAttr().Set(600.0)
    camera.GetVerticalApertureAttr().Set(600.0)
    stage.Save()


if __name__ == "__main__":
    for name, build in FIGURES.items():
        write_figure(build(), name)
