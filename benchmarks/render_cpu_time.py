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

Instructions of the render call alone (no interpreter, USD reading or build): start valgrind
with --instr-atstart=no and pass --callgrind-render, which switches instrumentation on
(callgrind_control -i on) just before Scene.render and off after it, in the last run only:

    valgrind --tool=callgrind --instr-atstart=no --callgrind-out-file=cg.S1.out \\
        .venv/bin/python benchmarks/render_cpu_time.py S1 --width 320 --height 180 --repeat 1 --callgrind-render

The installed extension is stripped; for function names, profile a build with symbols
(benchmarks/README.md, "Profiling") through --extension.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import subprocess
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
    parser.add_argument("--samples", type=int, help="samples per pixel (per axis; default: the scene's)")
    parser.add_argument(
        "--sample-pattern",
        choices=["grid", "povray-am1", "povray-am2", "stratified", "adaptive"],
        help="the pixel estimator (default: the scene's)",
    )
    parser.add_argument("--aa-threshold", type=float, help="its threshold (default: the scene's)")
    parser.add_argument(
        "--ortho-width",
        type=float,
        metavar="W",
        help="through an orthographic camera W units wide (the scene camera's position and view)",
    )
    parser.add_argument("--extension", type=Path, metavar="SO", help="another build of the _native extension")
    parser.add_argument(
        "--wrapper",
        type=Path,
        metavar="PY",
        help="that build's backends/native/__init__.py (when its arguments differ)",
    )
    parser.add_argument(
        "--numerics",
        default="scale-invariant",
        choices=["scale-invariant", "povray"],
        help="the native numerics (povray: the scene built and rendered as diff does)",
    )
    parser.add_argument(
        "--callgrind-render",
        action="store_true",
        help="under valgrind --instr-atstart=no: count the last render call's instructions only",
    )
    args = parser.parse_args()
    if args.extension:
        use_extension(args.extension, args.wrapper)
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
        numerics=args.numerics,
        samples=args.samples or scene.settings.samples,
        sample_pattern=args.sample_pattern or scene.settings.sample_pattern,
        aa_threshold=scene.settings.aa_threshold if args.aa_threshold is None else args.aa_threshold,
    )
    if args.ortho_width:
        scene = dataclasses.replace(
            scene, camera=dataclasses.replace(scene.camera, projection="orthographic", ortho_width=args.ortho_width)
        )
    posed = dataclasses.replace(scene, settings=settings)
    camera, native_settings = native._camera(scene.camera), native._settings(settings)
    build, render = [], []
    for run in range(args.repeat):
        start = time.process_time()
        built = native.build(scene) if args.numerics == "scale-invariant" else native.prepare(posed)._native
        build.append(time.process_time() - start)
        counted = args.callgrind_render and run == args.repeat - 1
        if counted:
            _callgrind_instrumentation("on")
        start = time.process_time()
        built.render(camera=camera, settings=native_settings)
        render.append(time.process_time() - start)
        if counted:
            _callgrind_instrumentation("off")
    name = args.extension.name if args.extension else "installed"
    print(f"{args.scene} {name}: build {min(build):.3f} s CPU, render {min(render):.3f} s CPU")


def _callgrind_instrumentation(state: str) -> None:
    """Switches callgrind's instrumentation of this process on or off (callgrind_control waits
    until valgrind has done it); a clear error when the process does not run under callgrind."""
    result = subprocess.run(["callgrind_control", "-i", state, str(os.getpid())], capture_output=True, text=True)
    if result.returncode != 0 or "Error" in result.stdout + result.stderr:
        sys.exit(
            f"--callgrind-render: callgrind_control -i {state} failed (run under valgrind --tool=callgrind): "
            f"{(result.stdout + result.stderr).strip()}"
        )


if __name__ == "__main__":
    main()
