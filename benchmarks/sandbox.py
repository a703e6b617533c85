# SPDX-License-Identifier: Apache-2.0
"""The cost of reading a scene in the sandbox (``phongscene.sandbox``): ``read_usd`` in this
process against ``read_usd_sandboxed`` (a child process), side by side in one run, best of R,
on a small example and a ~1M-triangle ``.usdc`` mesh; and the child's peak resident memory,
which the sandbox's memory limit must leave room for.

    .venv/bin/python benchmarks/sandbox.py [--repeat R] [--triangles N]
"""

from __future__ import annotations

import argparse
import resource
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from load_mesh import write_mesh

from phongscene.sandbox import default_memory_limit, memory_limit_for, read_usd_sandboxed
from phongscene.usd import read_usd

REPO = Path(__file__).resolve().parents[1]


def best(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--triangles", type=int, default=1_000_000)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        mesh = Path(tmp) / "torus.usdc"
        write_mesh(mesh, args.triangles)
        cases = [
            ("small: examples/seed_exponents.usda", REPO / "examples" / "seed_exponents.usda"),
            (f"{args.triangles:,}-triangle mesh (.usdc, {mesh.stat().st_size / 2**20:.1f} MiB)", mesh),
        ]
        print(f"default memory limit of this machine: {default_memory_limit() / 2**30:.1f} GiB")
        print("| scene | in process | sandboxed | overhead | child peak RSS | limit for the file |")
        print("|---|---:|---:|---:|---:|---:|")
        for name, path in cases:
            read_usd(path)  # warm: USD's plugins and the file cache
            inside = best(lambda: read_usd(path), args.repeat)
            before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
            sandboxed = best(lambda: read_usd_sandboxed(path), args.repeat)
            peak = max(before, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss) / 2**20  # kB -> GiB
            print(
                f"| {name} | {inside:.3f} s | {sandboxed:.3f} s | {sandboxed - inside:+.3f} s "
                f"({sandboxed / inside:.1f}x) | {peak:.2f} GiB | {memory_limit_for(path) / 2**30:.1f} GiB |"
            )


if __name__ == "__main__":
    main()
