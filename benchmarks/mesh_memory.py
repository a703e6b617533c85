# SPDX-License-Identifier: Apache-2.0
"""Memory per triangle of one big mesh (issue 23.4): peak RSS and wall time of whole
``phongscene render`` processes on a displaced torus grid of N triangles (load_mesh.py's, quads
split by the reader, ``subdivisionScheme = "none"``), 320×180, native, 2 threads; bytes per
triangle = (RSS(N) − RSS(0)) / N, RSS(0) a scene of one tiny mesh. Peak RSS from
``/usr/bin/time -v`` (``instances.measure``). The scene is a temporary ``.usdc``; the default
framing camera and head light see it.

    .venv/bin/python benchmarks/mesh_memory.py [--triangles 1000000 10000000] [--normals]

With --normals the mesh carries a vertex normal per point (smooth shading: the model's normals
and the tracer's normal rows, 12 bytes a triangle, come in).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from instances import measure
from load_mesh import write_mesh


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--triangles", type=int, nargs="*", default=[1_000_000, 10_000_000])
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--normals", action="store_true", help="a vertex normal per point")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        tmp = Path(folder)
        print(f"{'triangles':>11}  {'peak RSS MiB':>12}  {'wall s':>7}  {'bytes per triangle':>18}")
        base = None
        for n in [200, *sorted(args.triangles)]:
            scene = tmp / f"mesh_{n}.usdc"
            write_mesh(scene, n, normals=args.normals)
            try:
                rss, wall = measure(scene, "native", tmp / f"mesh_{n}.png", args.threads)
            except SystemExit as failed:  # e.g. over the sandbox's memory limit: say so, go on
                error = next((line for line in str(failed).splitlines() if line.startswith("error:")), "failed")
                print(f"{n:>11}  {error}", flush=True)
                continue
            base = rss if base is None else base
            per = f"{(rss - base) * 2**20 / n:18.0f}" if n > 200 else f"{'(base)':>18}"
            print(f"{n:>11}  {rss:12.0f}  {wall:7.2f}  {per}", flush=True)


if __name__ == "__main__":
    main()
