# SPDX-License-Identifier: Apache-2.0
"""Render one benchmark scene natively, once, on one thread, at a small size: the process to run
under ``valgrind --tool=callgrind`` (instruction counts do not depend on the machine's load).

    .venv/bin/python benchmarks/profile_render.py S1 --width 320 --height 180 [--extension SO]

The C++ scene is built first, so the render worker thread's inclusive count (callgrind_annotate
--inclusive=yes, the ``render_image`` lambda run by ``std::thread``) is the render alone. The
installed extension is stripped; a build with symbols for callgrind (same flags, -O3 wins over
RelWithDebInfo's -O2, plus -g) is made as benchmarks/README.md ("What paid", branch `shading`) says.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from run import scene_path, use_extension  # noqa: E402  (benchmarks/ is not a package)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene", help="S1, S2, S3 (benchmarks/make_scenes.py names)")
    parser.add_argument("--width", type=int, default=320)
    parser.add_argument("--height", type=int, default=180)
    parser.add_argument("--mapping", default="classic", choices=("classic", "exact"))
    parser.add_argument("--extension", type=Path, help="another build of the _native extension")
    args = parser.parse_args()
    if args.extension:
        use_extension(args.extension)
    from phongscene.backends import native
    from phongscene.backends.povray import SPECULAR_OF_MAPPING
    from phongscene.usd import load_usd

    scene = load_usd(scene_path(args.scene))
    settings = dataclasses.replace(scene.settings, width=args.width, height=args.height, threads=1,
                                   specular=SPECULAR_OF_MAPPING[args.mapping])
    built = native.build(scene)
    built.render(camera=native._camera(scene.camera), settings=native._settings(settings))


if __name__ == "__main__":
    main()
