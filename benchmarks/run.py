# SPDX-License-Identifier: Apache-2.0
"""Time the native tracer and POV-Ray side by side on the benchmark scenes (same machine, same
moment, same thread count) and print the speed ratios.

Both are timed end to end from the loaded Scene to the image in memory: native = flatten +
BVH build + render; POV-Ray = compile SDL + write + parse + render + read the EXR back (through
``phongscene.backends.povray.render``). Each figure is the best of --repeat runs. The images are
compared too (max |native − POV-Ray| relative to the image's max), so a fast wrong answer shows.

    .venv/bin/python benchmarks/make_scenes.py       # once: writes benchmarks/scenes/*.usd*
    .venv/bin/python benchmarks/run.py [--threads 0] [--repeat 3] [--mapping classic] [S1 S2 S3]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import time
from pathlib import Path

import numpy as np

from phongscene.backends import native, povray
from phongscene.rendering import SPECULAR_OF_MAPPING
from phongscene.usd import load_usd

HERE = Path(__file__).resolve().parent


def best_time(fn, repeat: int) -> tuple[float, np.ndarray]:
    best, image = float("inf"), None
    for _ in range(repeat):
        start = time.perf_counter()
        image = fn()
        best = min(best, time.perf_counter() - start)
    return best, image


def main() -> None:
    sys.path.insert(0, str(HERE))
    from make_scenes import FILES, make

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scenes", nargs="*", metavar="SCENE", help=f"any of {', '.join(FILES)} (default: all)")
    parser.add_argument("--threads", type=int, default=0, help="threads for both renderers (0 = all cores)")
    parser.add_argument("--repeat", type=int, default=3, help="runs per renderer; the best counts")
    parser.add_argument("--mapping", choices=tuple(SPECULAR_OF_MAPPING), default="classic",
                        help="POV-Ray mapping (classic = one idiomatic pass; exact = one pass per light)")
    args = parser.parse_args()
    args.scenes = args.scenes or list(FILES)
    if unknown := set(args.scenes) - set(FILES):
        parser.error(f"unknown scenes {sorted(unknown)}")
    threads = args.threads or os.cpu_count() or 1

    missing = [name for name in args.scenes if not (HERE / "scenes" / FILES[name]).exists()]
    if missing:
        make(which=tuple(missing))
    print(f"threads {threads}, mapping {args.mapping}, best of {args.repeat}")
    print(f"{'scene':<6}{'pixels':>12}{'triangles':>11}{'native s':>10}{'povray s':>10}{'speed-up':>10}{'max rel diff':>14}")
    for name in args.scenes:
        scene = load_usd(HERE / "scenes" / FILES[name])
        settings = dataclasses.replace(scene.settings, threads=threads, specular=SPECULAR_OF_MAPPING[args.mapping])
        t_native, img_native = best_time(lambda: native.render(scene, settings), args.repeat)
        t_povray, img_povray = best_time(lambda: povray.render(scene, settings, mapping=args.mapping), args.repeat)
        diff = float(np.abs(img_native - img_povray).max() / max(float(np.abs(img_povray).max()), 1e-30))
        print(f"{name:<6}{settings.width:>6}x{settings.height:<5}{scene.triangle_count:>11}"
              f"{t_native:>10.3f}{t_povray:>10.3f}{t_povray / t_native:>9.1f}x{diff:>14.2e}")


if __name__ == "__main__":
    main()
