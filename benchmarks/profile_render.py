# SPDX-License-Identifier: Apache-2.0
"""One native render of a benchmark scene on one thread, for an instruction profiler:

    valgrind --tool=callgrind --callgrind-out-file=cg.S1.out \\
        .venv/bin/python benchmarks/profile_render.py S1 --width 320 --height 180 [--extension SO]
    callgrind_annotate --inclusive=yes cg.S1.out | grep 'phong::'

Instruction counts, unlike times, do not depend on what else the machine runs. The installed
extension is stripped; for function names, profile a build with symbols (benchmarks/README.md,
"Profiling") through --extension."""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from run import scene_path, use_extension  # noqa: E402  (benchmarks/ is not a package)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene", help="S1, S2, S3 or S2-10k / S2-100k")
    parser.add_argument("--width", type=int, default=320)
    parser.add_argument("--height", type=int, default=180)
    parser.add_argument("--extension", type=Path, metavar="SO", help="another build of the _native extension")
    args = parser.parse_args()
    if args.extension:
        use_extension(args.extension)
    from phongscene.backends import native
    from phongscene.backends.povray import SPECULAR_OF_MAPPING
    from phongscene.usd import load_usd

    scene = load_usd(scene_path(args.scene))
    settings = dataclasses.replace(scene.settings, threads=1, width=args.width, height=args.height,
                                   specular=SPECULAR_OF_MAPPING["classic"])
    built = native.build(scene)
    built.render(camera=native._camera(scene.camera), settings=native._settings(settings))


if __name__ == "__main__":
    main()
