# SPDX-License-Identifier: Apache-2.0
"""Frames on Dask (issue 13): the speed-up of 2 LocalCluster workers over 1, and the per-task
overhead (scheduling + stage load + write) against the frame itself.

1. ``diff --frames 1:24`` of tests/scenes/animated.usda at 320×240 (POV-Ray and the native
   tracer per frame, as ``phongscene diff --frames`` runs it), each worker one process with 1
   render thread, with 1 worker and with 2, interleaved (1, 2, 1, 2, ...) because the machine
   is shared; the ratio is taken per pair. Wall clock includes the cluster's start-up.
2. S1 (benchmarks/scenes/s1_spheres.usda) at 640×360, native, 1 thread, ``--overhead-frames``
   frames on 1 worker: per task, wall time and the worker's CPU time after the first frame,
   against the render and the EXR write inside the task; what is left is the stage load (from
   the worker's kept stage: S1 has no time samples, so its first read is reused), scheduling
   and returning the metrics. The same for S1 with one sphere moving and one light's intensity
   animated (``animated_s1``, written to a temporary folder): each of its frames reads the stage.
3. For both scenes, the stage load inside a frame task, the worker's kept stage against the file
   opened anew, interleaved in this process; and (with ``--pairs``) one diff frame in this process: wall and
   CPU seconds of the task and of POV-Ray in it (its own CPU is small: it mostly waits).

4. The EXR write of a 640×360 frame, step by step; with ``--profiler-pairs N``, the S1
   overhead with Dask's worker profiler on and off, interleaved.

    .venv/bin/python benchmarks/animation.py [--pairs 2] [--overhead-frames 12] [--profiler-pairs 0]

Figures: benchmarks/README.md ("Frames on Dask").
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
ANIMATED = REPO / "tests" / "scenes" / "animated.usda"
S1 = HERE / "scenes" / "s1_spheres.usda"


def diff_frames(workers: int, frames: tuple[int, ...], width: int, height: int) -> float:
    from phongscene.animation import FRAME_FOLDER, diff_frame, frame_name
    from phongscene.comparison import HALF_FLOAT
    from phongscene.dask_runtime import run_frames
    from phongscene.overrides import RenderOverrides

    options = RenderOverrides(mapping="exact", width=width, height=height, threads=1)
    with tempfile.TemporaryDirectory() as tmp:
        run = run_frames(
            diff_frame,
            frames,
            lambda f: (str(ANIMATED), f, os.path.join(tmp, frame_name(FRAME_FOLDER, f)), options, HALF_FLOAT),
            workers=workers,
        )
    if run.failures or run.workers != workers:
        raise SystemExit(f"frames failed or wrong worker count: {run.failures}, {run.workers} workers")
    return run.seconds, run.startup_seconds


def diff_anatomy(frames: int) -> dict:
    """One diff frame in this process (after a first one that imports): median wall and CPU
    seconds (this process and its waited-for children, POV-Ray) of the whole task and of POV-Ray."""
    import resource

    from phongscene.animation import diff_frame
    from phongscene.comparison import HALF_FLOAT
    from phongscene.overrides import RenderOverrides

    options = RenderOverrides(mapping="exact", width=320, height=240, threads=1)
    children = lambda: (lambda r: r.ru_utime + r.ru_stime)(resource.getrusage(resource.RUSAGE_CHILDREN))  # noqa: E731
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for frame in range(1, frames + 2):
            wall, cpu, pov = time.perf_counter(), time.process_time(), children()
            m = diff_frame(str(ANIMATED), frame, os.path.join(tmp, f"frame.{frame}"), options, HALF_FLOAT)
            pov = children() - pov
            rows.append((time.perf_counter() - wall, time.process_time() - cpu + pov, m["timings"]["povray"], pov))
    return dict(
        zip(("wall", "cpu", "povray_wall", "povray_cpu"), (statistics.median(r[i] for r in rows[1:]) for i in range(4)))
    )


def animated_s1(folder: str, frames: int) -> Path:
    """S1 with two of its parts animated from frame 1 to ``frames`` (two time samples each, USD
    interpolating): /World/Sphere0 moves 2 units along x, /World/Lights/PointLight_0's intensity
    halves; written to ``folder``. A frame of it reads the stage at its time, where a frame of S1
    (no time samples) reuses its first read."""
    from pxr import Gf, Sdf, Usd

    path = Path(folder) / "s1_animated.usda"
    layer = Sdf.Layer.CreateNew(str(path))
    layer.TransferContent(Sdf.Layer.FindOrOpen(str(S1)))
    stage = Usd.Stage.Open(layer)
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(frames)
    move = stage.GetAttributeAtPath("/World/Sphere0.xformOp:translate")
    start = move.Get()
    move.Set(start, 1)
    move.Set(start + Gf.Vec3d(2, 0, 0), frames)
    intensity = stage.GetAttributeAtPath("/World/Lights/PointLight_0.inputs:intensity")
    intensity.Set(1.0, 1)
    intensity.Set(0.5, frames)
    layer.Save()
    return path


def _process_cpu(pid: int) -> float:
    """User + system CPU seconds of process ``pid`` so far, all its threads (/proc, clock ticks)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def overhead(frames: int, scene: Path) -> dict:
    """Per task in the steady state, from the second frame on (the first finds the worker
    without the stage opened): the interval between frames finishing on one worker (wall), and
    the worker process's CPU seconds per task (all its threads: the task, Dask's event loop),
    against what the task reports for its render and its EXR write. What is left is the
    overhead: the stage load (reported by the task) plus scheduling and the metrics' way back.
    The CPU seconds of this process (the client and, on a LocalCluster, the scheduler) per task
    are reported too."""
    from phongscene.animation import render_frame
    from phongscene.dask_runtime import run_frames
    from phongscene.overrides import RenderOverrides

    options = RenderOverrides(width=640, height=360, threads=1)
    finished = []

    def on_frame(frame, metrics, error):
        finished.append((time.perf_counter(), _process_cpu(metrics["pid"]), time.process_time()))

    with tempfile.TemporaryDirectory() as tmp:
        run = run_frames(
            render_frame,
            tuple(range(1, frames + 1)),
            lambda f: (str(scene), f, os.path.join(tmp, f"s1.{f:04d}.exr"), "native", options),
            workers=1,
            on_frame=on_frame,
        )
    steady = [run.results[f] for f in range(2, frames + 1)]  # the frames the intervals cover
    per = lambda i: (finished[-1][i] - finished[0][i]) / (frames - 1)  # noqa: E731
    mean = lambda key, part=None: statistics.fmean(r[key] if part is None else r[key][part] for r in steady)  # noqa: E731
    render_s, write_s, load_s = mean("render_seconds"), mean("write_seconds"), mean("load_seconds")
    render_c, write_c, load_c = (mean("cpu_seconds", part) for part in ("render", "write", "load"))
    return {
        "per_task": per(0),
        "render": render_s,
        "write": write_s,
        "load": load_s,
        "startup": run.startup_seconds,
        "scheduling": per(0) - render_s - write_s - load_s,
        "overhead": per(0) - render_s - write_s,
        "cpu_per_task": per(1),
        "render_cpu": render_c,
        "write_cpu": write_c,
        "load_cpu": load_c,
        "overhead_cpu": per(1) - render_c - write_c,
        "client_cpu": per(2),
    }


def stage_load(frames: int, scene: Path) -> dict:
    """The stage load inside a frame task, the worker's kept stage against the file opened anew,
    interleaved frame by frame in this process (each after a render and a write, as in a
    worker): median CPU and wall seconds of each."""
    from phongscene.animation import render_frame
    from phongscene.overrides import RenderOverrides
    from phongscene.usd import stage_reuse as workers

    options = RenderOverrides(width=640, height=360, threads=1)
    loads: dict[str, list[tuple[float, float]]] = {"kept": [], "anew": []}
    with tempfile.TemporaryDirectory() as tmp:
        for frame in range(frames + 1):
            for how in ("kept", "anew"):
                if how == "anew":
                    workers.forget()
                m = render_frame(str(scene), frame + 1, os.path.join(tmp, "s1.exr"), "native", options)
                if frame:  # the first pair warms both
                    loads[how].append((m["cpu_seconds"]["load"], m["load_seconds"]))
    workers.forget()
    return {how: tuple(statistics.median(x[i] for x in v) for i in (0, 1)) for how, v in loads.items()}


def exr_write(repeat: int) -> dict:
    """Where the EXR write of a 640×360 frame goes (``phongscene.images.write_image``: OpenImageIO,
    float, uncompressed, atomic, read back whole before the rename): median CPU milliseconds of
    the whole write and of its steps, against OpenImageIO's ``ImageOutput`` writing the array."""
    import numpy as np
    import OpenImageIO as oiio

    from phongscene.images import EXR_COMPRESSION, write_image

    image = np.random.default_rng(1).random((360, 640, 3), dtype=np.float32)

    def median_ms(step) -> float:
        times = []
        for _ in range(repeat):
            start = time.process_time()
            step()
            times.append(time.process_time() - start)
        return statistics.median(times) * 1e3

    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "frame.exr")

        def buf_write():
            buf = oiio.ImageBuf(image)
            buf.specmod().attribute("compression", EXR_COMPRESSION)
            buf.write(out, "float")

        def read_back():
            buf = oiio.ImageBuf(out)
            buf.read(force=True)
            buf.clear()

        def image_output():
            output = oiio.ImageOutput.create(out)
            spec = oiio.ImageSpec(640, 360, 3, "float")
            spec.attribute("compression", EXR_COMPRESSION)
            output.open(out, spec)
            output.write_image(image)
            output.close()

        return {
            "write_image": median_ms(lambda: write_image(out, image)),
            "imagebuf": median_ms(lambda: oiio.ImageBuf(image)),
            "buf_write": median_ms(buf_write),
            "read_back": median_ms(read_back),
            "image_output": median_ms(image_output),
        }


def profiler_pairs(pairs: int, frames: int) -> list[tuple[float, float]]:
    """The per-task overhead (wall) of S1 frames with Dask's statistical profiler of the worker
    (``distributed.worker.profile``, sampling every 10 ms) on and off, interleaved."""
    import dask

    out = []
    for _ in range(pairs):
        on = overhead(frames, S1)["overhead"]
        with dask.config.set({"distributed.worker.profile.enabled": False}):
            off = overhead(frames, S1)["overhead"]
        out.append((on, off))
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--pairs", type=int, default=2, help="(1 worker, 2 workers) runs, interleaved (0: none)")
    parser.add_argument("--overhead-frames", type=int, default=12)
    parser.add_argument(
        "--profiler-pairs",
        type=int,
        default=0,
        help="(profiler on, off) runs of the S1 overhead, interleaved (0: none)",
    )
    args = parser.parse_args()
    if not S1.exists():
        import subprocess

        subprocess.run([sys.executable, str(HERE / "make_scenes.py")], check=True)
    print(f"{os.cpu_count()} cores; load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    frames = tuple(range(1, 25))
    ratios = []
    if args.pairs:
        d = diff_anatomy(4)
        print(
            f"one diff frame at 320x240 in process, median of 4: {d['wall']:.3f} s wall, {d['cpu']:.3f} s CPU; "
            f"of it POV-Ray {d['povray_wall']:.3f} s wall, {d['povray_cpu']:.3f} s CPU"
        )
    for pair in range(args.pairs):
        one, one_startup = diff_frames(1, frames, 320, 240)
        two, two_startup = diff_frames(2, frames, 320, 240)
        ratios.append(one / two)
        print(
            f"pair {pair + 1}: 24-frame diff at 320x240: 1 worker {one:.2f} s, 2 workers {two:.2f} s, "
            f"speed-up {one / two:.2f}x (cluster start-up {one_startup:.2f} s, {two_startup:.2f} s; "
            f"load average {os.getloadavg()[0]:.2f})"
        )
    if ratios:
        print(f"speed-up of 2 workers over 1: median {statistics.median(ratios):.2f}x (min {min(ratios):.2f}x)")
    with tempfile.TemporaryDirectory() as tmp:
        for name, scene in (
            ("S1", S1),
            ("S1 animated (one sphere moving, one light's intensity)", animated_s1(tmp, args.overhead_frames)),
        ):
            o = overhead(args.overhead_frames, scene)
            print(
                f"{name} 640x360 native, 1 thread, {args.overhead_frames} frames on 1 worker, per task from the second frame on:"
            )
            print(
                f"  wall: {o['per_task']:.4f} s = render {o['render']:.4f} + EXR write {o['write']:.4f} + overhead "
                f"{o['overhead']:.4f} (stage load {o['load']:.4f} + scheduling and the rest {o['scheduling']:.4f}) = "
                f"{100 * o['overhead'] / o['render']:.1f} % of the render, "
                f"{100 * o['overhead'] / (o['render'] + o['write']):.1f} % of render + write"
            )
            print(
                f"  worker CPU: {o['cpu_per_task']:.4f} s = render {o['render_cpu']:.4f} + EXR write {o['write_cpu']:.4f} + "
                f"overhead {o['overhead_cpu']:.4f} (stage load {o['load_cpu']:.4f} + Dask in the worker "
                f"{o['overhead_cpu'] - o['load_cpu']:.4f}) = {100 * o['overhead_cpu'] / o['render_cpu']:.1f} % of the render, "
                f"{100 * o['overhead_cpu'] / (o['render_cpu'] + o['write_cpu']):.1f} % of render + write; "
                f"client and scheduler CPU {o['client_cpu']:.4f} s per task"
            )
            print(f"  cluster start-up (workers importing phongscene included) {o['startup']:.2f} s once")
            loads = stage_load(args.overhead_frames, scene)
            print(
                f"  stage load per frame, interleaved, median of {args.overhead_frames}: kept stage "
                f"{loads['kept'][0] * 1e3:.2f} ms CPU ({loads['kept'][1] * 1e3:.2f} ms wall), opened anew "
                f"{loads['anew'][0] * 1e3:.2f} ms CPU ({loads['anew'][1] * 1e3:.2f} ms wall): "
                f"{loads['anew'][0] / loads['kept'][0]:.2f}x"
            )
    w = exr_write(30)
    print(
        f"EXR write of a 640x360 frame, median CPU of 30: write_image {w['write_image']:.2f} ms = ImageBuf from the "
        f"array {w['imagebuf']:.2f} + its write {w['buf_write'] - w['imagebuf']:.2f} + read back {w['read_back']:.2f} "
        f"(+ rename); ImageOutput.write_image of the array {w['image_output']:.2f} ms"
    )
    for on, off in profiler_pairs(args.profiler_pairs, args.overhead_frames):
        print(
            f"S1 per-task overhead, Dask's worker profiler on {on * 1e3:.2f} ms, off {off * 1e3:.2f} ms "
            f"(load average {os.getloadavg()[0]:.2f})"
        )
    print(f"load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
