# SPDX-License-Identifier: Apache-2.0
"""e = 2 next to e = 20, lit from a low angle. The wide e = 2 lobe still has r·wo > 0 where the
light grazes the surface, so its highlight spreads towards the terminator — the lobe that
"penetrates the surface" (the seed's n·l factor is what fades it out). Regenerates seed_lobe.usda."""

from _seed import row_of_spheres, seed_scene, write

from phongscene.scene import PhongMaterial


def build():
    materials = [
        (
            f"Exponent{e}",
            PhongMaterial(
                0.25, 0.6, 0.4, float(e), (0.2, 0.3, 0.8), (1.0, 1.0, 1.0), source=f"/World/Looks/Exponent{e}/Phong"
            ),
        )
        for e in (2, 20)
    ]
    return seed_scene(row_of_spheres(materials, spacing=2.6), key=(-8.0, 2.5, 1.0), fov_deg=40.0)


if __name__ == "__main__":
    write(build(), "seed_lobe")
