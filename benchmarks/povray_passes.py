# SPDX-License-Identifier: Apache-2.0
"""Peak memory of a POV-Ray render against its light count (issue 29, item 4): the ``exact``
mapping renders one pass (an animation frame) per light and adds the linear images. Each case
runs ``phongscene.backends.povray.render`` in a child process under ``/usr/bin/time -v`` and
reports its maximum resident set size, next to the light-free size of the image.

    .venv/bin/python benchmarks/povray_passes.py [--size 512] [--lights 1 8 32]

Figures: benchmarks/README.md.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys

CHILD = """
import sys
import numpy as np
from phongscene import Camera, PhongMaterial, PointLight, RenderSettings, Scene, Sphere
from phongscene.backends import povray

size, lights = int(sys.argv[1]), int(sys.argv[2])
ring = [(4 * np.cos(a), 3.0, 4 * np.sin(a) + 2) for a in np.linspace(0, 2 * np.pi, lights, endpoint=False)]
scene = Scene(
    camera=Camera.look_at((0.0, 1.0, 6.0), (0.0, 0.0, 0.0)),
    spheres=(Sphere.at((0.0, 0.0, 0.0), 1.0, PhongMaterial(kd=0.6, ks=0.3, exponent=20.0)),),
    lights=tuple(PointLight(tuple(float(c) for c in p), (0.8 / lights,) * 3) for p in ring),
    settings=RenderSettings(width=size, height=size, threads=2),
)
image = povray.render(scene, mapping="exact")
print(float(image.sum()))
"""


def peak_rss_mib(size: int, lights: int) -> tuple[float, float]:
    """(peak resident MiB, wall seconds) of one render in a child process."""
    proc = subprocess.run(
        ["/usr/bin/time", "-v", sys.executable, "-c", CHILD, str(size), str(lights)],
        capture_output=True,
        text=True,
        check=True,
    )
    rss = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", proc.stderr).group(1)) / 1024
    wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): (\S+)", proc.stderr).group(1)
    minutes, seconds = wall.rsplit(":", 1)
    return rss, float(minutes.split(":")[-1]) * 60 + float(seconds)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--size", type=int, default=512, help="image side, pixels (default 512)")
    parser.add_argument("--lights", type=int, nargs="+", default=[1, 8, 32], help="light counts (default 1 8 32)")
    args = parser.parse_args()
    frame = args.size * args.size * 12 / 2**20
    print(f"{args.size}² image: {frame:.0f} MiB as float32 RGB, {2 * frame:.0f} MiB as float64")
    print("| lights | peak RSS MiB | wall s |")
    print("|---:|---:|---:|")
    for n in args.lights:
        rss, wall = peak_rss_mib(args.size, n)
        print(f"| {n} | {rss:.0f} | {wall:.1f} |")


if __name__ == "__main__":
    main()
