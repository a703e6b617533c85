# SPDX-License-Identifier: Apache-2.0
"""The Dask runtime that frames (``phongscene.animation``) and ``bench`` (``phongscene.bench_tasks``)
run their tasks on: a client of an existing scheduler (``scheduler=`` / the CLI's ``--scheduler``
/ ``DASK_SCHEDULER_ADDRESS``) or of a ``LocalCluster`` of worker processes on this machine, with
each worker's heavy imports made when it joins (a worker plugin), not in its first task;
``run_frames`` (one task per frame, retried once) and ``run_serially`` (the same in this
process, without Dask).

Dask is imported only inside these functions, and only when tasks run on a cluster: a one-frame
render never starts it. A worker keeps the USD stage it opened last between tasks
(``phongscene.usd.stage_reuse``).
"""

from __future__ import annotations

import os
import time as _time
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import dataclass, field

from .errors import BackendError, PhongSceneError

# Dask retries a task that raised this many times before the frame is reported as failed.
TASK_RETRIES = 1
# Imported by every task (the USD reader, OpenImageIO, both backends, the report); a worker
# imports them once when it joins the cluster.
WARM_IMPORTS = (
    "phongscene.usd",
    "phongscene.images",
    "phongscene.rendering",
    "phongscene.backends.native",
    "phongscene.backends.povray",
    "phongscene.crossvalidation",
    "phongscene.report",
    "OpenImageIO",
)


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
    """A Dask client, with the workers warmed (``warm_plugin``), and the name
    of its cluster: the scheduler at ``scheduler`` (or ``DASK_SCHEDULER_ADDRESS``), else a
    LocalCluster of ``local_workers()`` processes, closed on exit. Frames and bench share it."""
    from distributed import Client

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
    except KeyboardInterrupt:
        # Ctrl-C: the scheduler (in this process, for a LocalCluster) and the client log each
        # message they could not deliver, with a traceback, while the cluster closes; the CLI
        # says one line instead.
        _silence_dask_logs()
        raise
    finally:
        if cluster is not None:
            cluster.close()


def _silence_dask_logs() -> None:
    import logging

    # Every logger of theirs: Dask sets levels on its child loggers too (distributed.scheduler, ...).
    names = [n for n in logging.root.manager.loggerDict if n.split(".")[0] in ("distributed", "tornado", "asyncio")]
    for name in ("distributed", "tornado", "asyncio", *names):
        logging.getLogger(name).setLevel(logging.CRITICAL + 1)


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
        futures = {
            client.submit(
                task,
                *arguments(f),
                key=f"{task.__name__}-frame-{f}-{os.getpid()}-{_time.time_ns()}",
                retries=TASK_RETRIES,
                pure=False,
            ): f
            for f in frames
        }
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
    import signal
    import threading

    from distributed import LocalCluster

    # Ctrl-C goes to the terminal's whole process group: each worker would print its own
    # KeyboardInterrupt traceback (~40 lines). The workers start with SIGINT ignored (an ignored
    # signal stays ignored across exec, and Python installs no KeyboardInterrupt handler then),
    # so only this process hears it: it stops, closes the cluster, and says one line.
    quiet = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if quiet else None
    try:
        return LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",
            silence_logs=logging.CRITICAL,
        )
    finally:
        if quiet:
            signal.signal(signal.SIGINT, previous)


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


def warm() -> None:
    """Import what the tasks import (WARM_IMPORTS)."""
    import importlib

    for name in WARM_IMPORTS:
        importlib.import_module(name)


def warm_plugin():
    """A Dask ``WorkerPlugin`` that imports WARM_IMPORTS on every worker of the cluster, those
    there now and those that join later (``Client.register_plugin``)."""
    from distributed import WorkerPlugin

    class WarmImports(WorkerPlugin):
        name = "phongscene-warm-imports"
        idempotent = True

        def setup(self, worker) -> None:
            warm()

    return WarmImports()
