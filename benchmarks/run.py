# SPDX-License-Identifier: Apache-2.0
"""Time the native tracer and POV-Ray side by side on the benchmark scenes (same machine, same
moment, same thread count) and print the speed ratios.

Both are timed end to end from the loaded Scene to the image in memory: native = flatten +
BVH build + render; POV-Ray = compile SDL + write + parse + render + read the EXR back (through
``phongscene.backends.povray.render``). Each figure is the best of --repeat runs. The images are
compared too (max |native − POV-Ray| relative to the image's max), so a fast wrong answer shows.

``--baseline-extension SO`` also times another build of the ``_native`` extension (say, a copy of
the .so saved before a C++ change) on the same scene at the same moment, in a child process (two
builds of one nanobind module cannot share a process), and checks that its image is
bit-identical to the installed build's. ``--native-only`` skips POV-Ray.

    .venv/bin/python benchmarks/make_scenes.py       # once: writes benchmarks/scenes/*.usd*
    .venv/bin/python benchmarks/run.py [--threads 0] [--repeat 3] [--mapping classic] [S1 S2 S3]
    .venv/bin/python benchmarks/run.py --baseline-extension /tmp/baseline/_native.cpython-311-x86_64-linux-gnu.so

Figures: see benchmarks/README.md.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib.util
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from timing import best_time  # noqa: E402  (benchmarks/ is not a package)
NATIVE_EXTENSION_MODULE = "phongscene.backends.native._native"


def use_extension(path: Path) -> None:
    """Make ``phongscene.backends.native`` use the ``_native`` extension at ``path``."""
    spec = importlib.util.spec_from_file_location(NATIVE_EXTENSION_MODULE, path)
    if spec is None or spec.loader is None:
        raise SystemExit(f"{path}: not a loadable extension module")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    sys.modules[NATIVE_EXTENSION_MODULE] = module


def time_baseline(args: argparse.Namespace, name: str, threads: int) -> tuple[float, np.ndarray]:
    """Best time and image of scene ``name`` rendered by the --baseline-extension build."""
    with tempfile.TemporaryDirectory() as tmp:
        image_path = Path(tmp) / "image.npy"
        out = subprocess.run(
            [sys.executable, __file__, name, "--native-only", "--extension", str(args.baseline_extension),
             "--threads", str(threads), "--repeat", str(args.repeat), "--mapping", args.mapping,
             "--save-image", str(image_path)],
            check=True, capture_output=True, text=True,
        ).stdout
        return json.loads(out.splitlines()[-1])["native"], np.load(image_path)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scenes", nargs="*", metavar="SCENE", help="any of S1, S2, S3 (default: all)")
    parser.add_argument("--threads", type=int, default=0, help="threads for both renderers (0 = all cores)")
    parser.add_argument("--repeat", type=int, default=3, help="runs per renderer; the best counts")
    parser.add_argument("--mapping", choices=("classic", "exact"), default="classic",
                        help="POV-Ray mapping (classic = one idiomatic pass; exact = one pass per light)")
    parser.add_argument("--native-only", action="store_true", help="time the native tracer only")
    parser.add_argument("--baseline-extension", type=Path, metavar="SO",
                        help="also time this build of the _native extension (in a child process)")
    parser.add_argument("--extension", type=Path, metavar="SO", help=argparse.SUPPRESS)  # the child's
    parser.add_argument("--save-image", type=Path, help=argparse.SUPPRESS)  # the child's: one scene, JSON
    args = parser.parse_args()
    if args.extension:
        use_extension(args.extension)

    from make_scenes import FILES, make

    from phongscene.backends import native, povray
    from phongscene.backends.povray import SPECULAR_OF_MAPPING
    from phongscene.usd import load_usd

    args.scenes = args.scenes or list(FILES)
    if unknown := set(args.scenes) - set(FILES):
        parser.error(f"unknown scenes {sorted(unknown)}")
    threads = args.threads or os.cpu_count() or 1

    missing = [name for name in args.scenes if not (HERE / "scenes" / FILES[name]).exists()]
    if missing:
        make(which=tuple(missing))
    if args.save_image:
        (name,) = args.scenes
        scene = load_usd(HERE / "scenes" / FILES[name])
        settings = dataclasses.replace(scene.settings, threads=threads, specular=SPECULAR_OF_MAPPING[args.mapping])
        t_native, image = best_time(lambda: native.render(scene, settings), args.repeat)
        np.save(args.save_image, image)
        print(json.dumps({"native": t_native}))
        return

    print(f"threads {threads}, mapping {args.mapping}, best of {args.repeat}")
    header = f"{'scene':<6}{'pixels':>12}{'triangles':>11}"
    if args.baseline_extension:
        header += f"{'baseline s':>12}{'native s':>10}{'gain':>7}{'identical':>11}"
    else:
        header += f"{'native s':>10}"
    if not args.native_only:
        header += f"{'povray s':>10}{'speed-up':>10}{'max rel diff':>14}"
    print(header)
    for name in args.scenes:
        scene = load_usd(HERE / "scenes" / FILES[name])
        settings = dataclasses.replace(scene.settings, threads=threads, specular=SPECULAR_OF_MAPPING[args.mapping])
        row = f"{name:<6}{settings.width:>6}x{settings.height:<5}{scene.triangle_count:>11}"
        if args.baseline_extension:
            t_baseline, img_baseline = time_baseline(args, name, threads)
        t_native, img_native = best_time(lambda: native.render(scene, settings), args.repeat)
        if args.baseline_extension:
            identical = "yes" if np.array_equal(img_native, img_baseline) else "NO"
            row += f"{t_baseline:>12.3f}{t_native:>10.3f}{t_baseline / t_native:>6.2f}x{identical:>11}"
        else:
            row += f"{t_native:>10.3f}"
        if not args.native_only:
            t_povray, img_povray = best_time(lambda: povray.render(scene, settings, mapping=args.mapping), args.repeat)
            diff = float(np.abs(img_native - img_povray).max() / max(float(np.abs(img_povray).max()), 1e-30))
            row += f"{t_povray:>10.3f}{t_povray / t_native:>9.1f}x{diff:>14.2e}"
        print(row, flush=True)


if __name__ == "__main__":
    main()
