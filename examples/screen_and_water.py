# SPDX-License-Identifier: Apache-2.0
"""Nested media and cut-out masks: a glass ball (ior 1.5) holding a ball of water (ior 1.33),
refracting by the ratio of the two where they meet (POV-Ray's interior list: the "povray"
transmission convention), and a green screen with round holes cut out of a quad by a mask
texture (opacity below 0.5: no surface there; light and rays pass, its shadow has the same holes), before a row of
coloured spheres. Regenerates screen_and_water.usda and its mask image (docs/reflection.md)."""

import dataclasses

import numpy as np
from _seed import SETTINGS, seed_scene, write

from phongscene.scene import PhongMaterial, Sphere, Texture, TriangleMesh

# No highlight on the glass and the water: the exact mapping renders them too.
GLASS = PhongMaterial(
    0.0,
    0.0,
    0.0,
    1.0,
    (1.0, 1.0, 1.0),
    kr=1.0,
    kt=1.0,
    ior=1.5,
    fresnel=True,
    interior_filter=(0.97, 0.98, 0.96),
    source="/World/Looks/Glass/Phong",
)
WATER = dataclasses.replace(GLASS, ior=1.33, interior_filter=(0.8, 0.93, 0.97), source="/World/Looks/Water/Phong")
MASK_SIDE = 64  # texels of the screen's mask


def screen_mask() -> Texture:
    """Opacity 0 in a grid of round holes, 1 around them (bilinear: soft-edged discs that the
    threshold cuts round)."""
    y, x = (np.mgrid[0:MASK_SIDE, 0:MASK_SIDE] + 0.5) / MASK_SIDE * 4.0  # 4 x 4 holes
    d = np.hypot(x - np.floor(x) - 0.5, y - np.floor(y) - 0.5)
    opacity = np.clip((d - 0.34) * 12.0 + 0.5, 0.0, 1.0).astype(np.float32)
    return Texture(np.repeat(opacity[..., None], 3, axis=2), source="/World/Looks/Screen/Mask")


def screen() -> TriangleMesh:
    """A 2.4 x 2.4 quad standing right of the centre, facing the camera, uv the unit square."""
    material = PhongMaterial(
        0.2,
        0.7,
        0.2,
        20.0,
        (0.2, 0.6, 0.15),
        opacity_texture=screen_mask(),
        opacity_threshold=0.5,
        source="/World/Looks/Screen/Phong",
    )
    x0, x1, y0, y1, z = 0.8, 3.2, 0.05, 2.45, 0.6
    return TriangleMesh(
        [(x0, y0, z), (x1, y0, z), (x1, y1, z), (x0, y1, z)],
        [(0, 1, 2), (0, 2, 3)],
        uvs=[(0, 0), (1, 0), (1, 1), (0, 1)],
        uv_indices=[(0, 1, 2), (0, 2, 3)],
        material=material,
        source="/World/Geometry/Screen",
    )


def coloured(name: str, cd) -> PhongMaterial:
    return PhongMaterial(0.25, 0.6, 0.3, 30.0, cd, source=f"/World/Looks/{name}/Phong")


def build():
    spheres = (
        Sphere.at((-1.6, 1.2, 0.5), 1.2, GLASS, source="/World/Geometry/Glass"),
        Sphere.at((-1.6, 1.2, 0.5), 0.75, WATER, source="/World/Geometry/Water"),
    )
    back = [("Red", (0.85, 0.15, 0.1)), ("Green", (0.15, 0.7, 0.2)), ("Blue", (0.15, 0.3, 0.85))]
    spheres += tuple(
        Sphere.at(((i - 1) * 2.4, 0.8, -3.4), 0.8, coloured(name, cd), source=f"/World/Geometry/{name}")
        for i, (name, cd) in enumerate(back)
    )
    scene = seed_scene(spheres, eye=(0.0, 3.6, 9.0), fov_deg=45.0)
    settings = dataclasses.replace(SETTINGS, max_depth=8, transmission="povray")
    return dataclasses.replace(scene, meshes=(*scene.meshes, screen()), settings=settings)


if __name__ == "__main__":
    write(build(), "screen_and_water")
