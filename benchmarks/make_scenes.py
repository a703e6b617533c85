# SPDX-License-Identifier: Apache-2.0
"""Build the three benchmark scenes and write them as USD (1280×720, 1 spp, 60° horizontal FOV,
hard shadows, ground = a big quad):

* S1 ``s1_spheres.usda``: four spheres (radii 0.6–0.9, exponents 5/20/100/1000), two point lights;
* S2 ``s2_torus.usdc``: a smooth-shaded displaced torus of ~1M triangles over the ground, one
  point light (≈ 60 MB: generated on demand, not committed);
* S3 ``s3_area.usda``: S1 with one light replaced by a 2×2 area light sampled on a 9×9 grid.

    .venv/bin/python benchmarks/make_scenes.py [--outdir benchmarks/scenes] [--triangles 1000000]
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from phongscene.scene import (
    AmbientLight,
    Camera,
    PhongMaterial,
    PointLight,
    RectAreaLight,
    RenderSettings,
    Scene,
    Sphere,
    TriangleMesh,
)
from phongscene.usd import write_usd

HERE = Path(__file__).resolve().parent
SETTINGS = RenderSettings(width=1280, height=720, samples=1, background=(0.05, 0.06, 0.08))
GROUND = PhongMaterial(ka=0.2, kd=0.8, ks=0.0, exponent=1.0, diffuse_color=(0.6, 0.6, 0.58))


def camera(position, target) -> Camera:
    return Camera.look_at(position, target, 60.0)


def ground(height: float = 0.0, half: float = 50.0) -> TriangleMesh:
    corners = [(-half, height, -half), (half, height, -half), (half, height, half), (-half, height, half)]
    return TriangleMesh(points=corners, triangles=[(0, 2, 1), (0, 3, 2)], material=GROUND, source="/World/Ground")


def s1_spheres() -> Scene:
    colours = [(0.85, 0.25, 0.2), (0.25, 0.7, 0.3), (0.25, 0.35, 0.85), (0.9, 0.75, 0.3)]
    radii, exponents, xs = [0.6, 0.7, 0.8, 0.9], [5.0, 20.0, 100.0, 1000.0], [-3.0, -1.2, 0.8, 3.0]
    spheres = tuple(
        Sphere.at(
            (x, r, 0.3 * i - 0.5),
            r,
            PhongMaterial(ka=0.15, kd=0.75, ks=0.5, exponent=e, diffuse_color=c),
            source=f"/World/Sphere{i}",
        )
        for i, (x, r, e, c) in enumerate(zip(xs, radii, exponents, colours))
    )
    return Scene(
        camera=camera((0.0, 2.6, 7.5), (0.0, 0.6, 0.0)),
        ambient=AmbientLight((0.25, 0.25, 0.28)),
        lights=(PointLight((5.0, 8.0, 6.0), (2.4, 2.3, 2.2)), PointLight((-6.0, 5.0, 3.0), (0.9, 1.0, 1.2))),
        spheres=spheres,
        meshes=(ground(),),
        settings=SETTINGS,
    )


def s3_area() -> Scene:
    s1 = s1_spheres()
    area = RectAreaLight(
        center=(5.0, 8.0, 6.0), axis_u=(2.0, 0.0, 0.0), axis_v=(0.0, 0.0, 2.0), color=(2.4, 2.3, 2.2), samples=9
    )
    return Scene(
        camera=s1.camera,
        ambient=s1.ambient,
        lights=(area, s1.lights[1]),
        spheres=s1.spheres,
        meshes=s1.meshes,
        settings=SETTINGS,
    )


def displaced_torus(triangles: int) -> TriangleMesh:
    """A torus whose tube radius ripples, with smooth normals from the parametric surface."""
    n_v = int(math.sqrt(triangles / 4))  # n_u = 2·n_v quads around the ring
    n_u = 2 * n_v
    u, v = np.meshgrid(
        np.linspace(0, 2 * np.pi, n_u, endpoint=False), np.linspace(0, 2 * np.pi, n_v, endpoint=False), indexing="ij"
    )

    def surface(u, v):
        r = 0.45 + 0.04 * np.sin(14 * u) * np.cos(9 * v)
        return np.stack(
            [(1.5 + r * np.cos(v)) * np.cos(u), 1.0 + r * np.sin(v), (1.5 + r * np.cos(v)) * np.sin(u)], axis=-1
        )

    points = surface(u, v)
    h = 1e-6  # central differences of the smooth parametric surface give the smooth normals
    du = surface(u + h, v) - surface(u - h, v)
    dv = surface(u, v + h) - surface(u, v - h)
    normals = np.cross(dv, du)
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    i, j = np.meshgrid(np.arange(n_u), np.arange(n_v), indexing="ij")

    def ids(a, b):
        return (a % n_u) * n_v + (b % n_v)

    a, b, c, d = ids(i, j), ids(i, j + 1), ids(i + 1, j + 1), ids(i + 1, j)
    tris = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    return TriangleMesh(
        points=points.reshape(-1, 3),
        triangles=tris,
        normals=normals.reshape(-1, 3),
        normal_indices=tris,
        material=PhongMaterial(ka=0.15, kd=0.7, ks=0.6, exponent=60.0, diffuse_color=(0.8, 0.55, 0.3)),
        source="/World/Torus",
    )


def s2_torus(triangles: int = 1_000_000) -> Scene:
    return Scene(
        camera=camera((0.0, 3.2, 5.2), (0.0, 0.9, 0.0)),
        ambient=AmbientLight((0.2, 0.2, 0.22)),
        lights=(PointLight((4.0, 7.0, 5.0), (2.6, 2.5, 2.4)),),
        meshes=(ground(), displaced_torus(triangles)),
        settings=SETTINGS,
    )


FILES = {
    "S1": "s1_spheres.usda",
    "S2": "s2_torus.usdc",
    "S3": "s3_area.usda",
    # S2 with fewer triangles, for run.py's scaling table (not made by default)
    "S2-10k": "s2_torus_10k.usdc",
    "S2-100k": "s2_torus_100k.usdc",
}


def make(outdir: Path = HERE / "scenes", triangles: int = 1_000_000, which=("S1", "S2", "S3")) -> dict[str, Path]:
    builders = {
        "S1": s1_spheres,
        "S2": lambda: s2_torus(triangles),
        "S3": s3_area,
        "S2-10k": lambda: s2_torus(10_000),
        "S2-100k": lambda: s2_torus(100_000),
    }
    outdir.mkdir(parents=True, exist_ok=True)
    return {name: write_usd(builders[name](), outdir / FILES[name]) for name in which}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--outdir", type=Path, default=HERE / "scenes")
    parser.add_argument("--triangles", type=int, default=1_000_000, help="S2's triangle count")
    args = parser.parse_args()
    for name, path in make(args.outdir, args.triangles).items():
        print(f"{name}: {path} ({path.stat().st_size / 1e6:.1f} MB)")


if __name__ == "__main__":
    main()
