# SPDX-License-Identifier: Apache-2.0
"""CPU seconds (process_time: every thread of this process) of the native build and render of a
benchmark scene, best of --repeat, with the installed extension or --extension SO.
On a shared machine CPU time is disturbed far less than wall time; alternate two builds to
compare them:

    for i in 1 2; do for so in /tmp/baseline/_native.*.so INSTALLED.so; do
        .venv/bin/python benchmarks/render_cpu_time.py S2 --extension $so; done; done

One run of it is also what an instruction profiler measures (counts, unlike times, do not
depend on what else the machine runs):

    valgrind --tool=callgrind --callgrind-out-file=cg.S1.out \\
        .venv/bin/python benchmarks/render_cpu_time.py S1 --width 320 --height 180 --repeat 1 [--extension SO]
    callgrind_annotate --inclusive=yes cg.S1.out | grep 'phong::'

The installed extension is stripped; for function names, profile a build with symbols
(benchmarks/README.md, "Profiling") through --extension.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from run import scene_path, use_extension


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene", help="S1, S2, S3 or S2-10k / S2-100k")
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--width", type=int, help="image width (default: the scene's)")
    parser.add_argument("--height", type=int, help="image height (default: the scene's)")
    parser.add_argument("--extension", type=Path, metavar="SO", help="another build of the _native extension")
    args = parser.parse_args()
    if args.extension:
        use_extension(args.extension)
    from phongscene.backends import native
    from phongscene.backends.povray import SPECULAR_OF_MAPPING
    from phongscene.usd import load_usd

    scene = load_usd(scene_path(args.scene))
    settings = dataclasses.replace(
        scene.settings,
        threads=args.threads,
        specular=SPECULAR_OF_MAPPING["classic"],
        width=args.width or scene.settings.width,
        height=args.height or scene.settings.height,
    )
    camera, native_settings = native._camera(scene.camera), native._settings(settings)
    build, render = [], []
    for _ in range(args.repeat):
        start = time.process_time()
        built = native.build(scene)
        build.append(time.process_time() - start)
        start = time.process_time()
        built.render(camera=camera, settings=native_settings)
        render.append(time.process_time() - start)
    name = args.extension.name if args.extension else "installed"
    print(f"{args.scene} {name}: build {min(build):.3f} s CPU, render {min(render):.3f} s CPU")


if __name__ == "__main__":
    main()
