# SPDX-License-Identifier: Apache-2.0
"""The build-up of the Phong equation, as three spheres in ONE scene (same light, camera and
exposure, so the terms compare pixel for pixel in one image): ambient only (kd = ks = 0),
ambient + diffuse (ks = 0), ambient + diffuse + specular. Regenerates seed_buildup.usda."""

from _seed import row_of_spheres, seed_scene, write

from phongscene.scene import PhongMaterial

CD = (0.8, 0.5, 0.1)


def build():
    materials = [
        ("Ambient", PhongMaterial(0.25, 0.0, 0.0, 20.0, CD, source="/World/Looks/Ambient/Phong")),
        ("AmbientDiffuse", PhongMaterial(0.25, 0.6, 0.0, 20.0, CD, source="/World/Looks/AmbientDiffuse/Phong")),
        (
            "AmbientDiffuseSpecular",
            PhongMaterial(0.25, 0.6, 0.3, 20.0, CD, source="/World/Looks/AmbientDiffuseSpecular/Phong"),
        ),
    ]
    return seed_scene(row_of_spheres(materials), fov_deg=50.0)


if __name__ == "__main__":
    write(build(), "seed_buildup")
