# SPDX-License-Identifier: Apache-2.0
"""Beyond the Phong chapter, in the style of Suffern's ch. 24, 27 and 28 figures: on a mirror
floor, a chrome sphere (ch. 24, PerfectSpecular: kr = 0.9), a transparent sphere (ch. 27,
PerfectTransmitter: kt = 0.9, ior 1.5) and a dielectric sphere (ch. 28: kr = kt = 1 split by
Fresnel, ior 1.5), before a row of coloured spheres that they reflect and refract. Regenerates
chapters_24_27_28.usda (docs/reflection.md)."""

import dataclasses

from _seed import GROUND, SETTINGS, seed_scene, write

from phongscene.scene import PhongMaterial, Sphere

CHROME = PhongMaterial(
    0.05,
    0.1,
    0.4,
    60.0,
    (0.9, 0.9, 0.9),
    kr=0.9,
    reflective_color=(1.0, 0.95, 0.85),
    source="/World/Looks/Chrome/Phong",
)
# No highlight on the transparent ones: POV-Ray's exact mapping cannot give a transmissive material one.
GLASS = PhongMaterial(0.0, 0.0, 0.0, 1.0, (1.0, 1.0, 1.0), kr=0.1, kt=0.9, ior=1.5, source="/World/Looks/Glass/Phong")
DIELECTRIC = PhongMaterial(
    0.0, 0.0, 0.0, 1.0, (1.0, 1.0, 1.0), kr=1.0, kt=1.0, ior=1.5, fresnel=True, source="/World/Looks/Dielectric/Phong"
)
MIRROR_FLOOR = dataclasses.replace(GROUND, kr=0.35, source="/World/Looks/Ground/Phong")


def coloured(name: str, cd) -> PhongMaterial:
    return PhongMaterial(0.25, 0.6, 0.3, 30.0, cd, source=f"/World/Looks/{name}/Phong")


def build():
    front = [("Chrome", CHROME), ("Glass", GLASS), ("Dielectric", DIELECTRIC)]
    back = [
        ("Red", (0.85, 0.15, 0.1)),
        ("Green", (0.15, 0.7, 0.2)),
        ("Blue", (0.15, 0.3, 0.85)),
        ("Yellow", (0.9, 0.75, 0.1)),
    ]
    spheres = tuple(
        Sphere.at(((i - 1) * 2.3, 1.0, 0.0), 1.0, m, source=f"/World/Geometry/{name}")
        for i, (name, m) in enumerate(front)
    )
    spheres += tuple(
        Sphere.at(((i - 1.5) * 2.3, 0.8, -3.6), 0.8, coloured(name, cd), source=f"/World/Geometry/{name}")
        for i, (name, cd) in enumerate(back)
    )
    scene = seed_scene(spheres, eye=(0.0, 4.8, 9.0), fov_deg=50.0)
    floor = dataclasses.replace(scene.meshes[0], material=MIRROR_FLOOR)
    return dataclasses.replace(scene, meshes=(floor,), settings=dataclasses.replace(SETTINGS, max_depth=6))


if __name__ == "__main__":
    write(build(), "chapters_24_27_28")
