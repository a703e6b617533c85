# SPDX-License-Identifier: Apache-2.0
"""Memory per point of ``UsdGeom.Points`` (issue 23.3): peak RSS and wall time of whole
``phongscene render`` processes on one Points prim of N random spheres (N = 0 ... 1M) at
320×180, native, 2 threads; bytes per point = (RSS(N) - RSS(0)) / N. Peak RSS from
``/usr/bin/time -v`` (``instances.measure``).

    .venv/bin/python benchmarks/points_memory.py [--n 0 10000 100000 1000000]

Scenes are written with raw pxr (a camera looking at the unit cube, one distant light) into a
temporary folder, as ``.usdc`` so the file is not the measured cost.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from instances import measure


def points_stage(path: Path, n: int, seed: int = 1) -> Path:
    from pxr import Gf, Usd, UsdGeom, UsdLux, Vt

    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    camera = UsdGeom.Camera.Define(stage, "/Camera")
    camera.AddTranslateOp().Set(Gf.Vec3d(0.5, 0.5, 3.0))
    UsdLux.DistantLight.Define(stage, "/Sun").CreateIntensityAttr(1.0)
    if n:
        rng = np.random.default_rng(seed)
        points = UsdGeom.Points.Define(stage, "/World/Cloud")
        points.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(rng.random((n, 3), dtype=np.float32)))
        # Diameters so the cloud covers the view at any N (mean spacing n^(-1/3)).
        points.CreateWidthsAttr(Vt.FloatArray.FromNumpy(np.full(n, 0.5 * n ** (-1 / 3), dtype=np.float32)))
    stage.GetRootLayer().Save()
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--n", type=int, nargs="*", default=[0, 10_000, 100_000, 1_000_000], help="point counts")
    parser.add_argument("--threads", type=int, default=2)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        tmp = Path(folder)
        base = None
        print(f"{'points':>10}  {'peak RSS MiB':>12}  {'wall s':>7}  {'bytes per point':>15}")
        for n in sorted(set([0] + args.n)):
            scene = points_stage(tmp / f"points_{n}.usdc", n)
            try:
                rss, wall = measure(scene, "native", tmp / f"points_{n}.png", args.threads)
            except SystemExit as failed:  # e.g. over the sandbox's memory limit: say so, go on
                error = next((line for line in str(failed).splitlines() if line.startswith("error:")), "failed")
                print(f"{n:>10}  {error}", flush=True)
                continue
            base = rss if n == 0 else base
            per = f"{(rss - base) * 2**20 / n:15.0f}" if n else f"{'-':>15}"
            print(f"{n:>10}  {rss:12.0f}  {wall:7.2f}  {per}", flush=True)


if __name__ == "__main__":
    main()
