# SPDX-License-Identifier: Apache-2.0
"""Where the whole-process time of a tiny ``phongscene render`` goes, against POV-Ray's start-up
(issue 15: goal ≤ ½ of POV-Ray's).

Three tables, every child process run interleaved with the others (one of each, then again),
best of --repeat, wall (from the parent) and CPU (user + system of the waited-for child):

1. **Whole processes**: the bare interpreter (``-S``: no site-packages, no ``.pth`` hooks), the
   interpreter with site (``.pth`` hooks), ``import numpy`` (also with OPENBLAS_NUM_THREADS=1),
   the fixed dependencies' floor (numpy, OpenImageIO, pxr's Usd/UsdGeom/UsdShade/UsdLux and
   ``Usd.Stage.Open`` of the scene: what any USD → EXR program in Python pays), ``python -m
   phongscene render`` and the ``phongscene`` console script on S1 at 32×18, and ``povray`` on
   the same scene compiled (``phongscene compile``'s SDL).
2. **Stages** of the same render in one child, in the order the CLI meets them: interpreter,
   each import (the fixed dependencies first, and USD's first stage, so that phongscene's rows
   are its own cost), the stage open, the read (model and validation), the native render, the EXR write, the exit.
   Each row is its best over --repeat (so the rows need not add up to the best total).
3. ``-X importtime`` of the console script's render: the top-level imports by cumulative time
   (one run). ``--profile`` also prints cProfile's top functions of one render.

The children cache compiled bytecode (as an installation does), as benchmarks/run.py's do.

    .venv/bin/python benchmarks/startup.py [--repeat 10] [--profile] [--baseline OTHER/.venv/bin/python]

``--baseline PY`` adds the same tiny render by another installation's console script (say, a
checkout of main with its own venv), interleaved with the rest: a before/after in one run.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from run import TINY_SIZE, cached_bytecode_env, scene_path  # noqa: E402  (benchmarks/ is not a package)

SCENE = "S1"
# The fixed dependencies of a USD -> EXR render in Python, and the opening of the stage.
FLOOR_CODE = "import numpy, OpenImageIO\nfrom pxr import Usd, UsdGeom, UsdShade, UsdLux\nUsd.Stage.Open({scene!r})\n"
# The same, started and ended as the phongscene process is (phongscene/console.py: one BLAS
# thread, no interpreter teardown): the floor under ``phongscene render``.
FLOOR_AS_PHONGSCENE_CODE = FLOOR_CODE + "import os\nos._exit(0)\n"
# A tiny render in stages, the CLI's own calls in its order, started and ended as the phongscene
# process is (phongscene/console.py); marks (label, monotonic, process CPU) go to stdout as JSON. time.monotonic is the clock of the parent's perf_counter on Linux.
STAGES_CODE = """\
import time
marks = [("interpreter start-up", time.monotonic(), time.process_time())]
def mark(label):
    marks.append((label, time.monotonic(), time.process_time()))
import numpy
mark("import numpy")
from pxr import Usd, UsdGeom, UsdShade, UsdLux
mark("import pxr (Usd, UsdGeom, UsdShade, UsdLux)")
Usd.Stage.CreateInMemory()
mark("USD's first stage (schema registry, plugins)")
import OpenImageIO
mark("import OpenImageIO")
from phongscene.cli import build_parser
args = build_parser().parse_args({argv!r})
mark("phongscene.cli: import, parser")
import phongscene.usd
mark("import phongscene.usd (the reader)")
from phongscene.backends import native
from phongscene.images import write_image
from phongscene.rendering import render, settings_with
mark("import rendering, images, native backend")
stage = phongscene.usd.open_stage(args.scene)
mark("stage open (Usd.Stage.Open, checks)")
scene = phongscene.usd.read_usd(stage).scene
settings = settings_with(scene, args.mapping, width=args.width, height=args.height, threads=args.threads)
mark("read (model, validation)")
image = render(scene, "native", settings)
mark("native render")
write_image(args.output, image)
mark("write EXR")
import json, sys
json.dump(marks, sys.stdout)
from phongscene.console import _exit_without_teardown
_exit_without_teardown(0)
"""


def run_child(cmd: list[str], env: dict, cwd: Path | None = None) -> tuple[float, float, str]:
    """(wall s, CPU s, stdout) of one child process, which must succeed."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(cmd, env=env, cwd=cwd, capture_output=True, text=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({done.returncode}): {done.stderr.strip()[-500:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, done.stdout


def stage_rows(start: float, wall_total: float, cpu_total: float, stdout: str) -> dict[str, tuple[float, float]]:
    """label -> (wall s, CPU s) of each stage of one STAGES_CODE child started at ``start``."""
    marks = json.loads(stdout)
    rows, previous = {}, (start, 0.0)
    for label, wall, cpu in marks:
        rows[label] = (wall - previous[0], cpu - previous[1])
        previous = (wall, cpu)
    rows["exit (as phongscene exits)"] = (start + wall_total - previous[0], cpu_total - previous[1])
    return rows


def top_imports(cmd: list[str], env: dict, count: int) -> list[tuple[str, float, float]]:
    """The top-level imports of ``cmd`` under -X importtime: (module, self s, cumulative s),
    the ``count`` largest cumulative ones."""
    done = subprocess.run([cmd[0], "-X", "importtime", *cmd[1:]], env=env, capture_output=True, text=True)
    rows = []
    for line in done.stderr.splitlines():
        match = re.match(r"import time:\s+(\d+) \|\s+(\d+) \| (\S.*)$", line)  # no indent: top level
        if match:
            rows.append((match.group(3), int(match.group(1)) / 1e6, int(match.group(2)) / 1e6))
    return sorted(rows, key=lambda r: -r[2])[:count]


def console_script(python: Path) -> str:
    script = shutil.which("phongscene", path=str(python.parent))
    if script is None:
        raise SystemExit(f"no phongscene console script beside {python}: run make install")
    return script


def povray_job(work: Path) -> list[str]:
    from phongscene.backends.povray import SPECULAR_OF_MAPPING, prepare
    from phongscene.usd import load_usd

    scene = load_usd(scene_path(SCENE))
    settings = dataclasses.replace(
        scene.settings, threads=2, width=TINY_SIZE[0], height=TINY_SIZE[1], specular=SPECULAR_OF_MAPPING["classic"]
    )
    job = prepare(scene, settings, "classic")
    job.save_sdl(work / "scene.pov")
    return job.command("scene.pov", "scene.exr")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=10, help="runs of each child; the best counts")
    parser.add_argument("--profile", action="store_true", help="also print cProfile's top functions of one render")
    parser.add_argument(
        "--baseline", type=Path, metavar="PY", help="another installation's python: its console script too"
    )
    args = parser.parse_args()

    py = sys.executable
    script = console_script(Path(py))
    scene = str(scene_path(SCENE))
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        env = cached_bytecode_env(work / "pycache")
        render_args = [
            "render",
            scene,
            "-o",
            str(work / "native.exr"),
            "--threads",
            "2",
            "--mapping",
            "classic",
            "--width",
            str(TINY_SIZE[0]),
            "--height",
            str(TINY_SIZE[1]),
        ]
        one_blas_thread = {**env, "OPENBLAS_NUM_THREADS": "1"}
        processes = {
            "python -S -c pass (no site, no .pth)": ([py, "-S", "-c", "pass"], env, None),
            "python -c pass (site, .pth hooks)": ([py, "-c", "pass"], env, None),
            "python -c 'import numpy'": ([py, "-c", "import numpy"], env, None),
            "  the same, OPENBLAS_NUM_THREADS=1": ([py, "-c", "import numpy"], one_blas_thread, None),
            "floor: numpy, OpenImageIO, pxr, Stage.Open": ([py, "-c", FLOOR_CODE.format(scene=scene)], env, None),
            "  the same, 1 BLAS thread, no teardown": (
                [py, "-c", FLOOR_AS_PHONGSCENE_CODE.format(scene=scene)],
                one_blas_thread,
                None,
            ),
            "python -m phongscene render (tiny)": ([py, "-m", "phongscene", *render_args], env, None),
            "phongscene render (console script)": ([script, *render_args], env, None),
            "povray (tiny, compiled)": (povray_job(work), os.environ.copy(), work),
        }
        if args.baseline:
            processes["baseline: phongscene render (console script)"] = (
                [console_script(args.baseline), *render_args],
                env,
                None,
            )
        stages_cmd = [py, "-c", STAGES_CODE.format(argv=render_args)]
        best: dict[str, list[float]] = {name: [float("inf"), float("inf")] for name in processes}
        stages: dict[str, list[float]] = {}
        for round_ in range(args.repeat + 1):
            counted = round_ > 0  # the first round fills the bytecode cache
            for name, (cmd, child_env, cwd) in processes.items():
                wall, cpu, _ = run_child(cmd, child_env, cwd)
                if counted:
                    best[name] = [min(best[name][0], wall), min(best[name][1], cpu)]
            start = time.monotonic()
            wall, cpu, out = run_child(stages_cmd, one_blas_thread)
            if counted:
                for label, (w, c) in stage_rows(start, wall, cpu, out).items():
                    old = stages.get(label, [float("inf"), float("inf")])
                    stages[label] = [min(old[0], w), min(old[1], c)]

        load = os.getloadavg()[0]
        print(f"{os.cpu_count()} cores, load average {load:.2f}; best of {args.repeat}, interleaved")
        print(f"\n1. Whole processes (wall s, CPU s)\n{'':<46}{'wall':>8}{'CPU':>8}")
        for name, (wall, cpu) in best.items():
            print(f"{name:<46}{wall:>8.3f}{cpu:>8.3f}")
        pov = best["povray (tiny, compiled)"][0]
        ours = best["phongscene render (console script)"][0]
        floor = best["  the same, 1 BLAS thread, no teardown"][0]
        print(
            f"\nphongscene render / povray {ours / pov:.2f}x (goal <= 0.50x); the fixed dependencies' floor "
            f"(as phongscene starts and ends) / povray {floor / pov:.2f}x; phongscene's own share "
            f"{ours - floor:.3f} s wall"
        )
        if args.baseline:
            before = best["baseline: phongscene render (console script)"]
            print(
                f"baseline ({args.baseline}) / this installation: {before[0] / ours:.2f}x wall, "
                f"{before[1] / best['phongscene render (console script)'][1]:.2f}x CPU"
            )

        print(f"\n2. Stages of one tiny render (each the best of {args.repeat})\n{'':<46}{'wall':>8}{'CPU':>8}")
        for label, (wall, cpu) in stages.items():
            print(f"{label:<46}{wall:>8.3f}{cpu:>8.3f}")

        print("\n3. Top-level imports of the console script's render (-X importtime, one run; self / cumulative s)")
        for module, own, total in top_imports([py, script, *render_args], env, 15):
            print(f"{module:<46}{own:>8.3f}{total:>8.3f}")
        if args.profile:
            print("\ncProfile of one render (cumulative)")
            out = subprocess.run(
                [py, "-m", "cProfile", "-s", "cumulative", script, *render_args],
                env=env,
                capture_output=True,
                text=True,
            ).stdout
            print("\n".join(out.splitlines()[:40]))


if __name__ == "__main__":
    main()
