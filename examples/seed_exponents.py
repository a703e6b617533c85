# SPDX-License-Identifier: Apache-2.0
"""The seed's exponent series: ka = 0.25, kd = 0.6, ks = 0.2 and e = 5, 20, 100, 1000 — the
highlight shrinks and sharpens as e grows. Run it to regenerate seed_exponents.usda."""

from _seed import row_of_spheres, seed_scene, write

from phongscene.scene import PhongMaterial

EXPONENTS = (5, 20, 100, 1000)


def build():
    materials = [
        (
            f"Exponent{e}",
            PhongMaterial(
                0.25, 0.6, 0.2, float(e), (0.8, 0.3, 0.1), (1.0, 1.0, 1.0), source=f"/World/Looks/Exponent{e}/Phong"
            ),
        )
        for e in EXPONENTS
    ]
    return seed_scene(row_of_spheres(materials), fov_deg=55.0)


if __name__ == "__main__":
    write(build(), "seed_exponents")
