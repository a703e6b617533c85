# SPDX-License-Identifier: Apache-2.0
"""Animations: one USD file read at many time codes, each frame an independent task.

A frame number is a USD time code (``--frames 1:24`` reads the stage at 1, 2, ..., 24, as
Blender and usdview number frames). Frames run on Dask distributed: by default a ``LocalCluster``
of worker processes on this machine, or an existing cluster (``scheduler=`` / the CLI's
``--scheduler`` / ``DASK_SCHEDULER_ADDRESS``). What is shipped to a worker is the scene's path,
the time code and plain options, never a pickled scene: each task opens the stage itself (so
workers must see the file and the output folder at the same paths), writes its output
atomically and returns only a small dict of metrics. A task that raises is retried once (Dask's
``retries=1``); a frame that fails twice is reported by number.

The tasks call the same functions as a serial render of one frame (``load_scene`` at the time,
``settings_with``, ``render``, ``write_image``), so a frame is bit-identical to
``phongscene render --time T`` with the same options. A worker keeps the stage it opened last
(``phongscene.workers``: reopened when the file or a layer of it changes) and reads each task's
frame from it; its imports are made when it joins the cluster (a worker plugin), not in its first
task.

Dask is imported only here, and only when frames run on a cluster: a one-frame render never
starts it.
"""

from __future__ import annotations

import html
import json
import os
import re
import time as _time
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from .errors import BackendError, PhongSceneError

# The frame number replaces the run of '#' in an output name, zero-padded to its length.
FRAME_PATTERN = re.compile(r"#+")
# Per-frame report folders of `diff --frames`: frame.0001, frame.0002, ...
FRAME_FOLDER = "frame.####"
# Dask retries a task that raised this many times before the frame is reported as failed.
TASK_RETRIES = 1
# Thumbnails in the frames report (CSS pixels wide; the images are the frames' own PNGs).
THUMBNAIL_WIDTH = 160


def parse_frames(text: str) -> tuple[int, ...]:
    """``START:END[:STEP]`` → the frame numbers START, START+STEP, ..., up to END inclusive.

    Whole numbers only (a frame is a whole time code); STEP >= 1 and START <= END. ValueError
    with a one-line message otherwise."""
    parts = text.split(":")
    if len(parts) not in (2, 3):
        raise ValueError(f"expected START:END or START:END:STEP, got {text!r}")
    try:
        start, end, step = int(parts[0]), int(parts[1]), int(parts[2]) if len(parts) == 3 else 1
    except ValueError:
        raise ValueError(f"frames are whole numbers (USD time codes), got {text!r}") from None
    if step < 1:
        raise ValueError(f"the step must be >= 1, got {step} in {text!r}")
    if end < start:
        raise ValueError(f"the end frame must not be before the start frame, got {text!r}")
    return tuple(range(start, end + 1, step))


def has_frame_pattern(name: str | os.PathLike) -> bool:
    return FRAME_PATTERN.search(os.path.basename(os.fspath(name))) is not None


def frame_name(template: str | os.PathLike, frame: int) -> str:
    """``template`` with the (last) run of '#' in its file name replaced by ``frame``, zero-padded
    to the run's length: ``out.####.exr``, 7 → ``out.0007.exr``."""
    head, tail = os.path.split(os.fspath(template))
    matches = list(FRAME_PATTERN.finditer(tail))
    if not matches:
        raise ValueError(f"{template}: the name needs #### where the frame number goes (e.g. out.####.exr)")
    m = matches[-1]
    return os.path.join(head, f"{tail[: m.start()]}{frame:0{len(m.group())}d}{tail[m.end():]}")


# ----------------------------------------------------------------------------------------------
# Tasks: module-level functions, so a worker imports them by name. Each gets the scene's path, its
# frame (the time code) and plain options; each loads the stage itself and returns a small dict.


def _load(scene: str, frame: int, options: dict):
    from .rendering import load_scene, settings_with, with_shadow_adaptive, with_shadow_cells
    from .workers import open_stage

    start = _time.perf_counter()
    loaded, warnings = load_scene(open_stage(scene), time=float(frame))
    loaded = with_shadow_adaptive(loaded, options.get("shadow_adaptive"))
    loaded = with_shadow_cells(loaded, options.get("shadow_cells"))
    settings = settings_with(loaded, options.get("mapping"), width=options.get("width"), height=options.get("height"),
                             samples=options.get("samples"), threads=options.get("threads"),
                             sample_pattern=options.get("sample_pattern"), aa_threshold=options.get("aa_threshold"))
    return loaded, settings, warnings, _time.perf_counter() - start


def render_frame(scene: str, frame: int, output: str, backend: str, options: dict) -> dict:
    """Render ``scene`` at time ``frame`` and write ``output`` (atomically)."""
    from .images import write_image
    from .rendering import render

    # CPU seconds of this process beside the wall clock: on a shared machine the wall clock of
    # each part says as much about the other jobs as about the part (benchmarks/animation.py).
    cpu = [_time.process_time()]
    loaded, settings, warnings, load_seconds = _load(scene, frame, options)
    cpu.append(_time.process_time())
    start = _time.perf_counter()
    image = render(loaded, backend, settings)
    render_seconds = _time.perf_counter() - start
    cpu.append(_time.process_time())
    write_image(output, image)
    cpu.append(_time.process_time())
    return {"frame": frame, "output": output, "width": settings.width, "height": settings.height,
            "specular": settings.specular, "load_seconds": load_seconds, "render_seconds": render_seconds,
            "write_seconds": _time.perf_counter() - start - render_seconds,
            "seconds": _time.perf_counter() - start + load_seconds,
            "cpu_seconds": dict(zip(("load", "render", "write"), (b - a for a, b in zip(cpu, cpu[1:])))),
            "warnings": warnings, "pid": os.getpid()}


def compile_frame(scene: str, frame: int, output: str, options: dict) -> dict:
    """Compile ``scene`` at time ``frame`` to ``output`` (.pov) and its .ini (atomically)."""
    from .backends.povray import prepare
    from .files import write_text_atomic
    from .rendering import check_settings

    loaded, settings, warnings, load_seconds = _load(scene, frame, options)
    start = _time.perf_counter()
    out = Path(output)
    job = prepare(loaded, check_settings(loaded, settings), options.get("mapping"))
    write_text_atomic(out, job.sdl, encoding="ascii")
    write_text_atomic(out.with_suffix(".ini"), job.ini(out.name, out.with_suffix(".exr").name), encoding="ascii")
    return {"frame": frame, "output": output, "passes": job.frames, "load_seconds": load_seconds,
            "seconds": _time.perf_counter() - start + load_seconds, "warnings": warnings, "pid": os.getpid()}


def diff_frame(scene: str, frame: int, outdir: str, options: dict, thresholds) -> dict:
    """Diff both backends on ``scene`` at time ``frame``; the frame's report goes to ``outdir``."""
    from .crossvalidation import diff
    from .workers import open_stage

    start = _time.perf_counter()
    result = diff(open_stage(scene), outdir, mapping=options.get("mapping") or "exact", width=options.get("width"),
                  height=options.get("height"), samples=options.get("samples"), threads=options.get("threads"),
                  thresholds=thresholds, time=float(frame), sample_pattern=options.get("sample_pattern"),
                  aa_threshold=options.get("aa_threshold"), shadow_adaptive=options.get("shadow_adaptive"))
    r = result.report
    return {"frame": frame, "outdir": outdir, "ok": result.ok, "max_error": r.max_error,
            "worst_pixel": [r.worst.x, r.worst.y] if r.worst else None,
            "failing_pixels": r.failing_pixels, "failing_percent": r.failing_percent, "pixels": r.pixels,
            "explained_pixels": len(result.explained), "timings": result.timings,
            "width": result.settings.width, "height": result.settings.height,
            "seconds": _time.perf_counter() - start, "warnings": result.warnings, "pid": os.getpid()}


# ----------------------------------------------------------------------------------------------
# Running frames


@dataclass
class FramesRun:
    """What ``run_frames`` produced: each finished frame's metrics, each failed frame's error."""

    results: dict[int, dict] = field(default_factory=dict)
    failures: dict[int, str] = field(default_factory=dict)
    seconds: float = 0.0  # wall clock, cluster start-up included
    startup_seconds: float = 0.0  # connecting to (or starting) the cluster, and warming its workers
    workers: int = 0  # Dask workers when the frames were submitted
    cluster: str = ""  # "LocalCluster", the scheduler's address, or "" (run in this process)

    @property
    def ok(self) -> bool:
        return not self.failures


def scheduler_address(scheduler: str | None = None) -> str | None:
    """The cluster to use: ``scheduler``, else ``DASK_SCHEDULER_ADDRESS`` (None: a LocalCluster)."""
    return scheduler or os.environ.get("DASK_SCHEDULER_ADDRESS") or None


@contextmanager
def dask_client(scheduler: str | None, local_workers: Callable[[], int]):
    """A Dask client, with the workers warmed (``phongscene.workers.warm_plugin``), and the name
    of its cluster: the scheduler at ``scheduler`` (or ``DASK_SCHEDULER_ADDRESS``), else a
    LocalCluster of ``local_workers()`` processes, closed on exit. Frames and bench share it."""
    from distributed import Client

    from .workers import warm_plugin

    address = scheduler_address(scheduler)
    cluster = local_cluster(local_workers()) if address is None else None
    try:
        try:
            client = Client(cluster if cluster is not None else address)
        except OSError as e:  # a scheduler that is not there (Dask waits distributed.comm.timeouts.connect)
            raise BackendError(f"cannot reach the Dask scheduler {address}: {e}") from None
        with client:
            # Each worker imports what the tasks need now (and any that joins later, when it joins).
            client.register_plugin(warm_plugin())
            yield client, "LocalCluster" if cluster is not None else address
    finally:
        if cluster is not None:
            cluster.close()


def run_frames(
    task: Callable[..., dict],
    frames: tuple[int, ...],
    arguments: Callable[[int], tuple],
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: Callable | None = None,
    on_frame: Callable[[int, dict | None, str | None], None] | None = None,
) -> FramesRun:
    """Run ``task(*arguments(frame))`` for every frame on Dask distributed.

    Args:
        task: one of this module's ``*_frame`` functions (workers import it by name), or any
            function cloudpickle can ship.
        frames: the frame numbers.
        arguments: the task's arguments for a frame (paths, the frame, plain options).
        scheduler: ``tcp://HOST:PORT`` of a running scheduler; None: ``DASK_SCHEDULER_ADDRESS``,
            else a LocalCluster of ``workers`` processes (default: one per core), one thread each.
        progress: called as ``progress(done, total)`` after each frame.
        on_frame: called as ``on_frame(frame, metrics, error)`` as each frame finishes.
    """
    from distributed import as_completed

    run = FramesRun()
    began = _time.perf_counter()
    with dask_client(scheduler, lambda: workers or os.cpu_count() or 1) as (client, run.cluster):
        run.workers = len(client.scheduler_info().get("workers", {}))
        run.startup_seconds = _time.perf_counter() - began
        # pure=False: a frame is an action (it writes a file); never deduplicate or cache it.
        futures = {client.submit(task, *arguments(f), key=f"{task.__name__}-frame-{f}-{os.getpid()}-{_time.time_ns()}",
                                 retries=TASK_RETRIES, pure=False): f for f in frames}
        for done, future in enumerate(as_completed(futures), start=1):
            frame = futures[future]
            if future.status == "error":
                run.failures[frame] = _error_text(future.exception())
                metrics, error = None, run.failures[frame]
            else:
                metrics, error = future.result(), None
                run.results[frame] = metrics
            if on_frame is not None:
                on_frame(frame, metrics, error)
            if progress is not None:
                progress(done, len(frames))
    run.seconds = _time.perf_counter() - began
    return run


def local_cluster(workers: int):
    """A Dask ``LocalCluster`` of ``workers`` processes on this machine, one task at a time each.

    Processes, not threads: the USD reader and the task's Python hold the GIL; each task's
    renderer uses the threads its options give. The scheduler's HTTP server (its /metrics and
    /health routes; no dashboard without bokeh) takes a free port: Dask's default, 8787, is
    taken by any other cluster on the machine, and falling back from it is a warning."""
    import logging

    from distributed import LocalCluster

    return LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0",
                        silence_logs=logging.CRITICAL)


def run_serially(
    task: Callable[..., dict],
    frames: tuple[int, ...],
    arguments: Callable[[int], tuple],
    *,
    progress: Callable | None = None,
    on_frame: Callable[[int, dict | None, str | None], None] | None = None,
) -> FramesRun:
    """``run_frames`` in this process, without Dask (one frame: starting a cluster would cost
    more than the frame). A frame that raises a phongscene or OS error is reported, not retried."""
    run = FramesRun()
    began = _time.perf_counter()
    for done, frame in enumerate(frames, start=1):
        try:
            metrics, error = task(*arguments(frame)), None
            run.results[frame] = metrics
        except (PhongSceneError, OSError) as e:
            metrics, error = None, _error_text(e)
            run.failures[frame] = error
        if on_frame is not None:
            on_frame(frame, metrics, error)
        if progress is not None:
            progress(done, len(frames))
    run.seconds = _time.perf_counter() - began
    return run


def _error_text(error: BaseException | None) -> str:
    text = str(error).strip() if error is not None else ""
    return text or type(error).__name__


# ----------------------------------------------------------------------------------------------
# The report of `diff --frames`


def write_frames_report(outdir: str | os.PathLike, scene: str, run: FramesRun, meta: dict) -> Path:
    """``index.html`` and ``metrics.json`` in ``outdir``: one row per frame (verdict, worst error,
    failing pixels, thumbnails of both renders and the heat map, a link to the frame's report)."""
    from .files import write_text_atomic
    from .report import FILE_NAMES

    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    frames = sorted(set(run.results) | set(run.failures))
    rows, records = [], []
    for frame in frames:
        m = run.results.get(frame)
        if m is None:
            error = run.failures[frame]
            records.append({"frame": frame, "ok": False, "error": error})
            rows.append(f"<tr class='fail'><td>{frame}</td><td>FAILED</td><td colspan='5'>{html.escape(error)}</td></tr>")
            continue
        folder = os.path.relpath(m["outdir"], out)
        records.append({k: v for k, v in m.items() if k != "warnings"} | {"report": folder})
        thumbs = "".join(
            f"<td><a href='{html.escape(folder)}/{FILE_NAMES['html']}'><img src='{html.escape(folder)}/{name}' "
            f"width='{THUMBNAIL_WIDTH}' alt='{label}, frame {frame}'></a></td>"
            for label, name in (("povray", "povray.png"), ("native", "native.png"), ("heat map", FILE_NAMES["heat"]))
        )
        rows.append(
            f"<tr class='{'ok' if m['ok'] else 'fail'}'><td>{frame}</td><td>{'PASS' if m['ok'] else 'FAIL'}</td>"
            f"<td>{m['max_error']:.6g}{' at ({}, {})'.format(*m['worst_pixel']) if m.get('worst_pixel') else ''}</td>"
            f"<td>{m['failing_pixels']} ({m['failing_percent']:.4g}%)</td>{thumbs}</tr>"
        )
    failed = [r["frame"] for r in records if not r["ok"]]
    summary = f"{len(frames)} frames, {len(frames) - len(failed)} pass" + (f", fail: {', '.join(map(str, failed))}" if failed else "")
    page = (
        "<!doctype html><html><head><meta charset='utf-8'>"
        f"<title>phongscene diff --frames: {html.escape(Path(scene).name)}</title>"
        "<style>body{font-family:sans-serif}td,th{padding:4px 8px;border-bottom:1px solid #ccc}"
        "tr.fail td:nth-child(2){color:#b00;font-weight:bold}img{image-rendering:pixelated}</style></head><body>"
        f"<h1>phongscene diff --frames: {html.escape(Path(scene).name)}</h1><p>{html.escape(summary)}</p>"
        "<table><tr><th>frame</th><th>verdict</th><th>max error</th><th>failing pixels</th>"
        "<th>POV-Ray</th><th>native</th><th>heat map</th></tr>" + "".join(rows) + "</table></body></html>\n"
    )
    write_text_atomic(out / "metrics.json", json.dumps({"scene": scene, **meta, "summary": summary, "frames": records},
                                                       indent=2, default=str) + "\n")
    return write_text_atomic(out / FILE_NAMES["html"], page)
