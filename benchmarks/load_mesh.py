# SPDX-License-Identifier: Apache-2.0
"""Time `load_usd` on a ~1M-triangle mesh (a displaced torus grid, written once to a temp dir).

.venv/bin/python benchmarks/load_mesh.py [--triangles N] [--repeat R]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
from pxr import Usd, UsdGeom, Vt

from phongscene.usd import load_usd


def torus_grid(n_u: int, n_v: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points, quad faces (counts, indices) of a torus with a bumpy (displaced) tube."""
    u, v = np.meshgrid(
        np.linspace(0, 2 * np.pi, n_u, endpoint=False), np.linspace(0, 2 * np.pi, n_v, endpoint=False), indexing="ij"
    )
    r = 0.3 + 0.02 * np.sin(12 * u) * np.cos(9 * v)
    points = np.stack(
        [(1 + r * np.cos(v)) * np.cos(u), r * np.sin(v), (1 + r * np.cos(v)) * np.sin(u)], axis=-1
    ).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(n_u), np.arange(n_v), indexing="ij")
    ids = lambda a, b: (a % n_u) * n_v + (b % n_v)  # noqa: E731
    quads = np.stack([ids(i, j), ids(i, j + 1), ids(i + 1, j + 1), ids(i + 1, j)], axis=-1).reshape(-1, 4)
    return points, np.full(len(quads), 4, dtype=np.int32), quads.ravel().astype(np.int32)


def write_mesh(path: Path, triangles: int, normals: bool = False) -> None:
    """The torus grid of about ``triangles`` triangles as a polygon mesh; with ``normals``, a
    vertex-interpolated normal per point (away from the tube's centre line: smooth shading)."""
    n = int(np.sqrt(triangles / 2))
    points, counts, indices = torus_grid(n, n)
    stage = Usd.Stage.CreateNew(str(path))
    mesh = UsdGeom.Mesh.Define(stage, "/Torus")
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points.astype(np.float32)))
    if normals:
        ring = points * [1.0, 0.0, 1.0]
        ring /= np.linalg.norm(ring, axis=1, keepdims=True)
        away = points - ring
        mesh.CreateNormalsAttr(
            Vt.Vec3fArray.FromNumpy((away / np.linalg.norm(away, axis=1, keepdims=True)).astype(np.float32))
        )
        mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(counts))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(indices))
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    stage.Save()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--triangles", type=int, default=1_000_000)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--format", choices=("usdc", "usda"), default="usdc")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"torus.{args.format}"
        write_mesh(path, args.triangles)
        times = []
        for _ in range(args.repeat):
            start = time.perf_counter()
            scene = load_usd(path)
            times.append(time.perf_counter() - start)
        print(
            f"load_usd: {scene.triangle_count} triangles ({args.format}) in {min(times):.3f} s "
            f"(best of {args.repeat}; all: {', '.join(f'{t:.3f}' for t in times)})"
        )


if __name__ == "__main__":
    main()
