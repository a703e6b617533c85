# SPDX-License-Identifier: Apache-2.0
"""Where a whole process's peak memory comes from: ``phongscene render``'s stages run one after
another in this process as the CLI runs them (imports, ``load_usd``, the native scene with its
BVH, the render, the EXR write, and between them the model and the C++ scene dropped and
``malloc_trim``), printing after each the process's peak (VmHWM) and current (VmRSS) resident memory
from /proc/self/status (Linux) and the stage's wall time.

    .venv/bin/python benchmarks/memory_stages.py [S2] [--sdl] [--numerics povray]

SCENE is a make_scenes.FILES name (default S2) or a USD file's path; --numerics povray builds the
native scene in POV-Ray's numerics, as ``diff`` does.

The peak is monotone: the stage where it jumps is the one to look at. Figures: benchmarks/README.md.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))


def resident_mib() -> tuple[float, float]:
    """(peak, current) resident memory of this process, MiB."""
    fields = {}
    with open("/proc/self/status", encoding="ascii") as status:
        for line in status:
            key, _, value = line.partition(":")
            fields[key] = value
    return int(fields["VmHWM"].split()[0]) / 1024, int(fields["VmRSS"].split()[0]) / 1024


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene", nargs="?", default="S2", help="a make_scenes.FILES name (default S2) or a USD file")
    parser.add_argument(
        "--sdl",
        action="store_true",
        help="also compile the POV-Ray SDL to a file after the load (what render/diff's POV-Ray side adds)",
    )
    parser.add_argument(
        "--numerics",
        default="scale-invariant",
        choices=["scale-invariant", "povray"],
        help="the native render's numerics (povray: as diff renders it)",
    )
    args = parser.parse_args()
    print(f"{'stage':<28}{'peak MiB':>10}{'now MiB':>10}{'s':>8}")
    start = time.perf_counter()

    def stage(name: str) -> None:
        nonlocal start
        peak, now = resident_mib()
        print(f"{name:<28}{peak:>10.0f}{now:>10.0f}{time.perf_counter() - start:>8.3f}", flush=True)
        start = time.perf_counter()

    stage("interpreter")
    from make_scenes import FILES, make

    import phongscene.usd
    from phongscene.backends import native  # noqa: F401  (imported here, as its own stage)
    from phongscene.memory import release_free_heap
    from phongscene.rendering import prepare_render

    stage("imports (numpy, pxr, ...)")
    if args.scene in FILES:
        path = HERE / "scenes" / FILES[args.scene]
        if not path.exists():
            make(which=(args.scene,))
    else:
        path = Path(args.scene)
    start = time.perf_counter()
    scene = phongscene.usd.load_usd(path)
    scene = replace(scene, settings=replace(scene.settings, numerics=args.numerics))
    stage("load_usd")
    release_free_heap()
    stage("malloc_trim")
    if args.sdl:
        from phongscene.backends.povray import prepare

        with tempfile.TemporaryDirectory() as tmp:
            prepare(scene).save_sdl(Path(tmp) / "scene.pov")  # written as it is compiled
        stage("POV-Ray SDL written")
    render = prepare_render(scene, "native")
    stage("native scene + BVH")
    del scene
    release_free_heap()
    stage("model freed, malloc_trim")
    image = render()
    stage("render")
    del render
    release_free_heap()
    stage("C++ scene freed, malloc_trim")
    from phongscene.images import write_image

    with tempfile.TemporaryDirectory() as tmp:
        write_image(Path(tmp) / "image.exr", image)
    stage("EXR write (OpenImageIO)")


if __name__ == "__main__":
    main()
