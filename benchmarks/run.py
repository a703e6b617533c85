# SPDX-License-Identifier: Apache-2.0
"""Time the native tracer, POV-Ray and the peers found installed side by side on the benchmark
scenes (same machine, same moment, same thread counts) and print the speed ratios.

Five tables, in one run:

1. **In process**, from the loaded Scene to the image in memory, at each ``--threads`` count:
   native = build (flatten + C++ scene + BVH) and render; POV-Ray = compile SDL + write + parse +
   render + read the EXR back (``phongscene.backends.povray.render``); Mitsuba 3 (``mitsuba``'s
   LLVM variant, when installed and a child process finds that it starts and traces a ray: with
   Debian's LLVM 14/15 it aborts; benchmarks/mitsuba_peer.py) = build, and the same primary rays
   plus the native tracer's shadow rays (one per hit and point light, S3's 9×9 per hit for its
   area light), at each thread count, checked against the native tracer's hits on the same rays.
   The max |native − POV-Ray| relative to the image's max is printed too, so a fast wrong answer
   shows.
2. **Compiled peers** on the same rays (benchmarks/compiled_peers.py, built at run time into a
   cache folder): Embree through its C API (Debian's ``libembree-dev``), single rays and 8/16-ray
   packets, its build timed by ``rtcCommitScene``, ``threads=N`` as labelled; the naive scalar C
   loop (brute force, small scenes), for the x86-64 baseline and ``-march=native``. Each peer's
   hits are checked against the native BVH's before its time is printed; ratios are peer / native.
3. **Whole process**: ``phongscene render SCENE -o x.exr`` against ``povray`` on the compiled
   scene (``phongscene compile``'s job, written before timing), wall time and peak RSS of the
   child, and POV-Ray's own reported trace time; the "tiny" row is S1 at 32×18, i.e. the
   start-up costs. The children cache compiled bytecode as an installation does (the best of
   --repeat runs is a cached one).
4. **Threads**: the native render's speed-up from 1 thread to the most asked for.
5. **Triangles**: S2's native render (without build) at 10k, 100k and 1M triangles.

Each figure is the best of --repeat runs (the least disturbed on a shared machine). A peer not
installed is skipped with the reason printed.

``--baseline-extension SO`` instead times another build of the ``_native`` extension (say, a
copy of the .so saved before a C++ change) on the same scenes at the same moment, in a child
process (two builds of one nanobind module cannot share a process), and checks that its image is
bit-identical to the installed build's. ``--baseline-wrapper PY`` gives that build's own
``backends/native/__init__.py`` when the extension's arguments changed since.

    .venv/bin/python benchmarks/make_scenes.py       # once: writes benchmarks/scenes/*.usd*
    .venv/bin/python benchmarks/run.py [--threads 1 2] [--repeat 3] [--mapping classic] [S1 S2 S3]
    .venv/bin/python benchmarks/run.py --baseline-extension /tmp/baseline/_native.cpython-311-x86_64-linux-gnu.so \
        [--baseline-wrapper old_native.py]

Figures: see benchmarks/README.md.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib.util
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import compiled_peers  # noqa: E402  (benchmarks/ is not a package)
import mitsuba_peer  # noqa: E402
from timing import best_time  # noqa: E402

NATIVE_EXTENSION_MODULE = "phongscene.backends.native._native"
# S2 at these triangle counts for the scaling table (make_scenes.FILES names).
SCALING_SCENES = ("S2-10k", "S2-100k", "S2")
# The "tiny" whole-process row: S1 at this size (start-up costs only).
TINY_SIZE = (32, 18)
GNU_TIME = "/usr/bin/time"  # Debian package "time"


def use_extension(path: Path, wrapper: Path | None = None) -> None:
    """Make ``phongscene.backends.native`` use the ``_native`` extension at ``path``, and the
    wrapper module at ``wrapper`` (that build's ``backends/native/__init__.py``) when given: for
    a baseline whose extension takes other arguments than today's wrapper passes."""
    spec = importlib.util.spec_from_file_location(NATIVE_EXTENSION_MODULE, path)
    if spec is None or spec.loader is None:
        raise SystemExit(f"{path}: not a loadable extension module")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    sys.modules[NATIVE_EXTENSION_MODULE] = module
    if wrapper is not None:
        import phongscene.backends  # noqa: F401  (the parent package of the wrapper)

        name = NATIVE_EXTENSION_MODULE.rsplit(".", 1)[0]
        spec = importlib.util.spec_from_file_location(name, wrapper, submodule_search_locations=[])
        if spec is None or spec.loader is None:
            raise SystemExit(f"{wrapper}: not a loadable module")
        package = importlib.util.module_from_spec(spec)
        sys.modules[name] = package
        spec.loader.exec_module(package)


def scene_path(name: str) -> Path:
    from make_scenes import FILES, make

    path = HERE / "scenes" / FILES[name]
    if not path.exists():
        make(which=(name,))
    return path


def time_baseline(args: argparse.Namespace, name: str, threads: int) -> tuple[float, np.ndarray]:
    """Best time and image of scene ``name`` rendered by the --baseline-extension build."""
    with tempfile.TemporaryDirectory() as tmp:
        image_path = Path(tmp) / "image.npy"
        out = subprocess.run(
            [
                sys.executable,
                __file__,
                name,
                "--extension",
                str(args.baseline_extension),
                *(["--wrapper", str(args.baseline_wrapper)] if args.baseline_wrapper else []),
                "--threads",
                str(threads),
                "--repeat",
                str(args.repeat),
                "--mapping",
                args.mapping,
                "--save-image",
                str(image_path),
            ],
            check=True,
            capture_output=True,
            text=True,
        ).stdout
        return json.loads(out.splitlines()[-1])["native"], np.load(image_path)


def run_process(cmd: list[str], cwd: Path | None = None, env: dict | None = None) -> tuple[float, float, str]:
    """(wall seconds, peak RSS in MiB, its standard error) of one child process, which must succeed. The peak comes
    from GNU time, whose own child is measured: a child forked from this (large) process would
    report this process's size, which ru_maxrss keeps across exec."""
    with tempfile.NamedTemporaryFile("r", suffix=".time") as report:
        start = time.perf_counter()
        done = subprocess.run(
            [GNU_TIME, "-f", "%M", "-o", report.name, *cmd],
            cwd=cwd,
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        wall = time.perf_counter() - start
        if done.returncode != 0:
            raise SystemExit(f"{cmd[0]} failed ({done.returncode}): {done.stderr.strip()[-500:]}")
        return wall, int(report.read().split()[-1]) / 1024.0, done.stderr  # KiB


def best_process(cmd: list[str], repeat: int, cwd: Path | None = None, env: dict | None = None) -> tuple[float, float]:
    runs = [run_process(cmd, cwd, env) for _ in range(repeat)]
    return min(r[0] for r in runs), max(r[1] for r in runs)


# POV-Ray's own statistics (on standard error): "Trace Time:  0 hours  0 minutes  1 seconds (1.027 seconds)"
POVRAY_TRACE_TIME = re.compile(r"Trace Time:.*\(\s*([0-9.]+) seconds\)")


def best_povray_process(cmd: list[str], repeat: int, cwd: Path) -> tuple[float, float, float]:
    """(best wall s, peak RSS MiB, best of POV-Ray's own reported trace times, summed over its
    passes) of ``povray`` runs."""
    runs = [run_process(cmd, cwd) for _ in range(repeat)]
    traces = []
    for _, _, stderr in runs:
        found = [float(x) for x in POVRAY_TRACE_TIME.findall(stderr)]
        if not found:
            raise SystemExit(f"povray printed no trace time: {stderr.strip()[-300:]}")
        traces.append(sum(found))
    return min(r[0] for r in runs), max(r[1] for r in runs), min(traces)


def cached_bytecode_env(cache: Path) -> dict:
    """The environment for a ``phongscene`` child that caches compiled bytecode (in ``cache``, not
    beside the sources), as a user's installation does: with PYTHONDONTWRITEBYTECODE set (some
    harnesses set it) every run would compile the package's modules again (~0.07 s CPU of the
    tiny render, measured)."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPYCACHEPREFIX"] = str(cache)
    return env


def mitsuba_cell(scene, settings, built, repeat: int, threads: int) -> str:
    if reason := mitsuba_peer.why_not(scene):
        return f"- ({reason})"
    peer = mitsuba_peer.times(scene, settings, built, repeat, threads)
    return (
        f"{peer['build']:.3f} / {peer['render']:.3f} ({peer['rays'] / 1e6:.1f}M rays, {100 * peer['agreement']:.3f} %)"
    )


def peers_line() -> str:
    peers = ["POV-Ray"]
    embree = compiled_peers.embree_binary()
    peers.append(f"no Embree ({embree})" if isinstance(embree, str) else "Embree (C API, compiled peer)")
    naive = compiled_peers.naive_binary(False)
    peers.append(f"no naive C loop ({naive})" if isinstance(naive, str) else "naive C loop (compiled peer)")
    reason = mitsuba_peer.unavailable()
    peers.append(f"no Mitsuba 3 ({reason})" if reason else f"Mitsuba 3 ({mitsuba_peer.VARIANT})")
    return ", ".join(peers)


# -- the tables ------------------------------------------------------------------------------------


def in_process_table(args, names, thread_counts) -> dict:
    from phongscene.backends import native, povray
    from phongscene.backends.povray import SPECULAR_OF_MAPPING
    from phongscene.usd import load_usd

    with_mitsuba = mitsuba_peer.unavailable() is None and not args.native_only
    print(f"\n1. In process (loaded Scene -> image), mapping {args.mapping}, best of {args.repeat}")
    header = f"{'scene':<8}{'threads':>8}{'triangles':>10}{'build s':>9}{'render s':>9}{'native s':>9}"
    if not args.native_only:
        header += f"{'povray s':>9}{'ratio':>7}{'max rel diff':>13}"
    if with_mitsuba:
        header += f"  {'mitsuba build/render s (rays, agreeing with native)'}"
    print(header)
    render_times: dict = {}
    for name in names:
        scene = load_usd(scene_path(name))
        for threads in thread_counts:
            settings = dataclasses.replace(scene.settings, threads=threads, specular=SPECULAR_OF_MAPPING[args.mapping])
            camera, native_settings = native._camera(scene.camera), native._settings(settings)
            t_build, built = best_time(lambda: native.build(scene, threads), args.repeat)
            t_render, image = best_time(lambda: built.render(camera=camera, settings=native_settings), args.repeat)
            t_native, image = best_time(lambda: native.render(scene, settings), args.repeat)
            render_times[name, threads] = t_render
            row = f"{name:<8}{threads:>8}{scene.triangle_count:>10}{t_build:>9.3f}{t_render:>9.3f}{t_native:>9.3f}"
            if not args.native_only:
                t_pov, img_pov = best_time(lambda: povray.render(scene, settings, mapping=args.mapping), args.repeat)
                diff = float(np.abs(image - img_pov).max() / max(float(np.abs(img_pov).max()), 1e-30))
                row += f"{t_pov:>9.3f}{t_pov / t_native:>6.1f}x{diff:>13.2e}"
            if with_mitsuba:
                row += "  " + mitsuba_cell(scene, settings, built, args.repeat, threads)
            print(row, flush=True)
    return render_times


def compiled_peers_table(args, names, thread_counts) -> None:
    """The compiled peers (compiled_peers.py) on the same rays, each scene and thread count with
    native's build and render timed again just before its peers (side by side on a shared machine;
    native's render shades every pixel, the peers trace the rays only)."""
    from phongscene.backends import native
    from phongscene.backends.povray import SPECULAR_OF_MAPPING
    from phongscene.usd import load_usd

    print(
        f"\n2. Compiled peers on the same rays (primary + a shadow ray per hit and target), best of {args.repeat};"
        "\n   ratio = peer / native, timed side by side (below 1: the peer is faster); native render shades too"
    )
    print(
        f"{'scene':<8}{'threads':>8}  {'peer':<22}{'rays':>8}{'build s':>9}{'ratio':>7}{'render s':>10}{'ratio':>7}"
        f"{'agreeing':>10}"
    )
    for name in names:
        scene = load_usd(scene_path(name))
        for threads in thread_counts:
            settings = dataclasses.replace(scene.settings, threads=threads, specular=SPECULAR_OF_MAPPING[args.mapping])
            camera, native_settings = native._camera(scene.camera), native._settings(settings)
            t_build, built = best_time(lambda: native.build(scene, threads), args.repeat)
            t_render, _ = best_time(lambda: built.render(camera=camera, settings=native_settings), args.repeat)
            print(
                f"{name:<8}{threads:>8}  {'native (' + str(built.walk_width) + '-wide walk)':<22}{'':>8}{t_build:>9.3f}"
                f"{'':>7}{t_render:>10.3f}",
                flush=True,
            )
            if threads == 1 and compiled_peers.why_not(scene) is None:
                # The same rays as the peers, traced only (Scene.intersect / Scene.occluded run on
                # one thread): the ratio is the share of native's render spent tracing them.
                figures = compiled_peers.native_trace(scene, settings, built, args.repeat)
                print(
                    f"{name:<8}{threads:>8}  {'native, tracing only':<22}{figures['rays'] / 1e6:>7.1f}M{'-':>9}{'':>7}"
                    f"{figures['render']:>10.3f}{figures['render'] / t_render:>6.2f}x",
                    flush=True,
                )
            for peer, figures in compiled_peers.run_peers(scene, settings, built, threads, args.repeat).items():
                if isinstance(figures, str):
                    print(f"{name:<8}{threads:>8}  {peer:<22}- ({figures})")
                    continue
                build = (
                    f"{figures['build']:>9.3f}{figures['build'] / max(t_build, 1e-9):>6.2f}x"
                    if "build" in figures
                    else f"{'-':>9}{'':>7}"
                )
                print(
                    f"{name:<8}{threads:>8}  {peer:<22}{figures['rays'] / 1e6:>7.1f}M{build}{figures['render']:>10.3f}"
                    f"{figures['render'] / t_render:>6.2f}x{100 * figures['agreement']:>9.3f}%",
                    flush=True,
                )


def whole_process_table(args, names, threads: int) -> None:
    from phongscene.backends.povray import SPECULAR_OF_MAPPING, prepare
    from phongscene.usd import load_usd

    print(f"\n3. Whole process ({threads} threads, wall s and peak RSS MiB of the child, best of {args.repeat})")
    header = f"{'scene':<8}{'phongscene render':>20}"
    if not args.native_only:
        header += f"{'povray':>18}{'ratio':>8}{'povray trace s':>16}"
    print(header)
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for name in ["tiny", *names]:
            path = scene_path("S1" if name == "tiny" else name)
            size = ["--width", str(TINY_SIZE[0]), "--height", str(TINY_SIZE[1])] if name == "tiny" else []
            cmd = [
                sys.executable,
                "-m",
                "phongscene",
                "render",
                str(path),
                "-o",
                str(work / "native.exr"),
                "--threads",
                str(threads),
                "--mapping",
                args.mapping,
                *size,
            ]
            t_native, rss_native = best_process(cmd, args.repeat, env=cached_bytecode_env(work / "pycache"))
            row = f"{name:<8}{t_native:>11.3f} s {rss_native:>4.0f} M"
            if not args.native_only:
                scene = load_usd(path)
                settings = dataclasses.replace(
                    scene.settings, threads=threads, specular=SPECULAR_OF_MAPPING[args.mapping]
                )
                if name == "tiny":
                    settings = dataclasses.replace(settings, width=TINY_SIZE[0], height=TINY_SIZE[1])
                job = prepare(scene, settings, args.mapping)
                job.save_sdl(work / "scene.pov")
                # +GS: the statistics stream on (the compiler's -GS silences it), for the trace time
                cmd_pov = ["+GS" if s == "-GS" else s for s in job.command("scene.pov", "scene.exr")]
                t_pov, rss_pov, t_trace = best_povray_process(cmd_pov, args.repeat, work)
                row += f"{t_pov:>9.3f} s {rss_pov:>4.0f} M{t_pov / t_native:>7.2f}x{t_trace:>16.3f}"
            print(row, flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scenes", nargs="*", metavar="SCENE", help="any of S1, S2, S3 (default: all)")
    parser.add_argument("--threads", type=int, nargs="+", help="thread counts (0 = all cores; default: 1 and all)")
    parser.add_argument("--repeat", type=int, default=3, help="runs per renderer; the best counts")
    parser.add_argument(
        "--mapping",
        choices=("classic", "exact"),
        default="classic",
        help="POV-Ray mapping (classic = one idiomatic pass; exact = one pass per light)",
    )
    parser.add_argument("--native-only", action="store_true", help="time the native tracer only")
    parser.add_argument("--peers-only", action="store_true", help="only table 2 (native against the compiled peers)")
    parser.add_argument("--processes-only", action="store_true", help="only table 3 (whole processes)")
    parser.add_argument("--no-scaling", action="store_true", help="skip the S2 triangle-count table")
    parser.add_argument(
        "--baseline-extension",
        type=Path,
        metavar="SO",
        help="only compare the installed extension with this build (in a child process)",
    )
    parser.add_argument(
        "--baseline-wrapper",
        type=Path,
        metavar="PY",
        help="the baseline's backends/native/__init__.py, when its extension's arguments differ "
        "from today's (git show COMMIT:backends/native/__init__.py > old_native.py)",
    )
    parser.add_argument("--extension", type=Path, metavar="SO", help=argparse.SUPPRESS)  # the child's
    parser.add_argument("--wrapper", type=Path, metavar="PY", help=argparse.SUPPRESS)  # the child's
    parser.add_argument("--save-image", type=Path, help=argparse.SUPPRESS)  # the child's: one scene, JSON
    args = parser.parse_args()
    if args.extension:
        use_extension(args.extension, args.wrapper)

    from make_scenes import FILES

    from phongscene.backends import native
    from phongscene.backends.povray import SPECULAR_OF_MAPPING
    from phongscene.usd import load_usd

    names = args.scenes or ["S1", "S2", "S3"]
    if unknown := set(names) - set(FILES):
        parser.error(f"unknown scenes {sorted(unknown)}")
    cores = os.cpu_count() or 1
    thread_counts = sorted({t or cores for t in (args.threads or [1, cores])})

    if args.save_image:
        (name,) = names
        scene = load_usd(scene_path(name))
        settings = dataclasses.replace(
            scene.settings, threads=thread_counts[-1], specular=SPECULAR_OF_MAPPING[args.mapping]
        )
        t_native, image = best_time(lambda: native.render(scene, settings), args.repeat)
        np.save(args.save_image, image)
        print(json.dumps({"native": t_native}))
        return

    if args.baseline_extension:
        print(
            f"threads {thread_counts[-1]}, mapping {args.mapping}, best of {args.repeat}; native = flatten + build + render"
        )
        print(f"{'scene':<8}{'triangles':>10}{'baseline s':>12}{'native s':>10}{'gain':>7}{'identical':>11}")
        for name in names:
            scene = load_usd(scene_path(name))
            settings = dataclasses.replace(
                scene.settings, threads=thread_counts[-1], specular=SPECULAR_OF_MAPPING[args.mapping]
            )
            t_baseline, img_baseline = time_baseline(args, name, thread_counts[-1])
            t_native, img_native = best_time(lambda: native.render(scene, settings), args.repeat)
            identical = "yes" if np.array_equal(img_native, img_baseline) else "NO"
            print(
                f"{name:<8}{scene.triangle_count:>10}{t_baseline:>12.3f}{t_native:>10.3f}"
                f"{t_baseline / t_native:>6.2f}x{identical:>11}",
                flush=True,
            )
        return

    print(f"{cores} cores; peers: {peers_line()}")
    if args.peers_only:
        compiled_peers_table(args, names, thread_counts)
        return
    if args.processes_only:
        whole_process_table(args, names, thread_counts[-1])
        return
    render_times = in_process_table(args, names, thread_counts)
    if not args.native_only:
        compiled_peers_table(args, names, thread_counts)
    whole_process_table(args, names, thread_counts[-1])
    if len(thread_counts) > 1:
        lo, hi = thread_counts[0], thread_counts[-1]
        print(f"\n4. Native render speed-up, {lo} -> {hi} threads")
        for name in names:
            print(f"{name:<8}{render_times[name, lo] / render_times[name, hi]:>6.2f}x")
    if not args.no_scaling:
        threads = thread_counts[-1]
        print(f"\n5. S2's native render (no build) by triangle count, {threads} threads, best of {args.repeat}")
        previous = None
        for name in SCALING_SCENES:
            scene = load_usd(scene_path(name))
            settings = dataclasses.replace(scene.settings, threads=threads, specular=SPECULAR_OF_MAPPING[args.mapping])
            built = native.build(scene)
            camera, native_settings = native._camera(scene.camera), native._settings(settings)
            t, _ = best_time(lambda: built.render(camera=camera, settings=native_settings), args.repeat)
            growth = f"{t / previous:>6.2f}x per 10x" if previous else ""
            print(f"{name:<8}{scene.triangle_count:>10}{t:>9.3f} s {growth}", flush=True)
            previous = t


if __name__ == "__main__":
    main()
