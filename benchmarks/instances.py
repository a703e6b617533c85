# SPDX-License-Identifier: Apache-2.0
"""Instancing at scale: peak RSS and wall time of whole ``phongscene render`` processes on K
copies of one 10,000-triangle torus (a PointInstancer, K = 100 ... 10,000) and on 2,000
instanceable references of it, at 320×180, native beside POV-Ray (``--backend povray``: one
``#declare``d mesh2 and an ``object`` per copy). Peak RSS from ``/usr/bin/time -v``.

    .venv/bin/python benchmarks/instances.py [--k 100 1000 3000 10000] [--refs 2000] [--no-povray]

Scenes are written with raw pxr (tests/support/instanced_stages.py) into a temporary folder.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))

from support.instanced_stages import point_instancer_stage, reference_stage  # noqa: E402

RINGS, SIDES = 100, 50  # 2·100·50 = 10,000 triangles per copy
WIDTH, HEIGHT = 320, 180


def measure(scene: Path, backend: str, out: Path, threads: int) -> tuple[float, float]:
    """(peak RSS in MiB, wall seconds) of one ``phongscene render`` process."""
    command = [
        "/usr/bin/time",
        "-v",
        str(REPO / ".venv" / "bin" / "phongscene"),
        "render",
        str(scene),
        "-o",
        str(out),
        "--backend",
        backend,
        "--width",
        str(WIDTH),
        "--height",
        str(HEIGHT),
        "--threads",
        str(threads),
    ]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed:\n{done.stderr[-2000:]}")
    rss = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", done.stderr).group(1)) / 1024
    wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): (?:(\d+):)?(\d+):([\d.]+)", done.stderr)
    seconds = int(wall.group(1) or 0) * 3600 + int(wall.group(2)) * 60 + float(wall.group(3))
    return rss, seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--k", type=int, nargs="*", default=[100, 1000, 3000, 10000], help="PointInstancer copies")
    parser.add_argument("--refs", type=int, default=2000, help="instanceable references (0: none)")
    parser.add_argument("--no-povray", action="store_true")
    parser.add_argument("--threads", type=int, default=2)
    args = parser.parse_args()
    backends = ["native"] + ([] if args.no_povray else ["povray"])
    with tempfile.TemporaryDirectory() as folder:
        tmp = Path(folder)
        cases = [
            (
                f"PointInstancer, K = {k}",
                lambda k=k: point_instancer_stage(
                    tmp / f"pi_{k}.usdc", k, RINGS, SIDES, 1.2, width=WIDTH, height=HEIGHT
                ),
            )
            for k in args.k
        ]
        if args.refs:
            cases.append(
                (
                    f"instanceable references, K = {args.refs}",
                    lambda: reference_stage(
                        tmp / f"refs_{args.refs}.usdc", args.refs, RINGS, SIDES, 1.2, width=WIDTH, height=HEIGHT
                    ),
                )
            )
        print(
            f"| scene ({2 * RINGS * SIDES} triangles per copy, {WIDTH}x{HEIGHT}, {args.threads} threads) | "
            + " | ".join(f"{b} peak RSS | {b} wall" for b in backends)
            + " |"
        )
        print("| --- |" + " --- | --- |" * len(backends))
        for name, make in cases:
            scene = Path(make())
            cells = []
            for backend in backends:
                rss, seconds = measure(scene, backend, tmp / f"{scene.stem}_{backend}.exr", args.threads)
                cells += [f"{rss:.0f} MiB", f"{seconds:.1f} s"]
            print(f"| {name} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
