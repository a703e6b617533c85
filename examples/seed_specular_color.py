# SPDX-License-Identifier: Apache-2.0
"""Specular colour: a white highlight (cs = 1, plastic-like) next to one in the diffuse colour
(cs = cd, metal-like), same ka, kd, ks, e. Regenerates seed_specular_color.usda."""

from _seed import row_of_spheres, seed_scene, write

from phongscene.scene import PhongMaterial

RED = (0.8, 0.1, 0.1)


def build():
    materials = [
        (
            "WhiteHighlight",
            PhongMaterial(0.25, 0.6, 0.5, 20.0, RED, (1.0, 1.0, 1.0), source="/World/Looks/WhiteHighlight/Phong"),
        ),
        (
            "DiffuseColoredHighlight",
            PhongMaterial(0.25, 0.6, 0.5, 20.0, RED, RED, source="/World/Looks/DiffuseColoredHighlight/Phong"),
        ),
    ]
    return seed_scene(row_of_spheres(materials, spacing=2.6), fov_deg=40.0)


if __name__ == "__main__":
    write(build(), "seed_specular_color")
