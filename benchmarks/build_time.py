# SPDX-License-Identifier: Apache-2.0
"""Wall seconds of the native scene build (``native.build``: BVH, collapse, leaf-order copies) of a
benchmark scene: the first build of the process, which is the one a command-line render pays
(fresh memory from the kernel), and the best of --repeat. CPU time (render_cpu_time.py) sums
the threads, so it cannot show what a second thread buys; wall time can, but varies between
processes on a shared machine: alternate the builds being compared, one process each, several
rounds, and compare medians:

    for i in $(seq 10); do for so in /tmp/a.so /tmp/b.so; do
        .venv/bin/python benchmarks/build_time.py S2 --threads 2 --repeat 1 --extension $so; done; done

Instructions of one build, load-independent (the last build of the process, under callgrind with
instrumentation switched on around it only; one thread, so that the count is the same each run):

    valgrind --tool=callgrind --instr-atstart=no --callgrind-out-file=cg.build.out \\
        .venv/bin/python benchmarks/build_time.py S2 --threads 1 --repeat 1 --callgrind-build
    callgrind_annotate cg.build.out | grep 'PROGRAM TOTALS'
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from render_cpu_time import _callgrind_instrumentation
from run import scene_path, use_extension


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene", help="S1, S2, S3 or S2-10k / S2-100k")
    parser.add_argument("--threads", type=int, default=0, help="build threads (default: every core)")
    parser.add_argument("--repeat", type=int, default=5, help="builds in this process (default: 5)")
    parser.add_argument("--extension", type=Path, metavar="SO", help="another build of the _native extension")
    parser.add_argument(
        "--callgrind-build", action="store_true", help="under callgrind: count the last build's instructions only"
    )
    args = parser.parse_args()
    if args.extension:
        use_extension(args.extension)
    from phongscene.backends import native
    from phongscene.usd import load_usd

    scene = load_usd(scene_path(args.scene))
    seconds = []
    for run in range(args.repeat):
        counted = args.callgrind_build and run == args.repeat - 1
        if counted:
            _callgrind_instrumentation("on")
        start = time.perf_counter()
        built = native.build(scene, threads=args.threads)
        seconds.append(time.perf_counter() - start)
        if counted:
            _callgrind_instrumentation("off")
        del built  # freed before the next build, as a process that renders once would have it
    name = args.extension.name if args.extension else "installed"
    print(f"{args.scene} {name} threads={args.threads}: first build {seconds[0]:.3f} s, best {min(seconds):.3f} s")


if __name__ == "__main__":
    main()
