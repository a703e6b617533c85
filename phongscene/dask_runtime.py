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
import shutil
import time as _time
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import dataclass, field

from .errors import BackendError, PhongSceneError
from .held_signals import held_signals

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
    LocalCluster of ``local_workers()`` processes, closed on exit. Frames and bench share it.

    A LocalCluster's files (Dask's scratch space, each worker's folder) go in a temporary folder
    of ours, removed once the cluster is closed: Dask's own default, ``$TMPDIR/dask-scratch-space``,
    outlives the run, and a worker ended early leaves its folder in it."""
    import tempfile

    import dask
    from distributed import Client

    address = scheduler_address(scheduler)
    scratch = tempfile.mkdtemp(prefix="phongscene-dask-") if address is None else None
    cluster = None
    try:
        with dask.config.set({"temporary-directory": scratch} if scratch else {}):
            if address is None:
                # Assigned before a held signal is acted on, so that the cluster is closed below.
                with _terminal_signals_held():
                    cluster = local_cluster(local_workers(), scratch)
            try:
                client = Client(cluster if cluster is not None else address)
            except OSError as e:  # a scheduler that is not there (Dask waits distributed.comm.timeouts.connect)
                raise BackendError(f"cannot reach the Dask scheduler {address}: {e}") from None
            with client:
                # Each worker imports what the tasks need now (and any that joins later, when it joins).
                client.register_plugin(warm_plugin())
                yield client, "LocalCluster" if cluster is not None else address
    except BaseException:
        # Ctrl-C, SIGTERM, SIGHUP (cli.process.Terminated) or an error: the scheduler (in this
        # process, for a LocalCluster) and the client log each message they could not deliver,
        # with a traceback, while the cluster closes; the CLI says one line instead.
        _silence_dask_logs()
        raise
    finally:
        # Whole: a signal during the cleanup is acted on after it (the workers gone, the folder
        # removed), not in the middle of it.
        with _terminal_signals_held():
            if cluster is not None:
                _close_local_cluster(cluster)
            if scratch is not None:
                shutil.rmtree(scratch, ignore_errors=True)


# How long the workers of a closed LocalCluster may take to exit before they are killed.
WORKER_EXIT_SECONDS = 5.0


def _close_local_cluster(cluster) -> None:
    """Close ``cluster`` and make sure its worker processes are gone: a worker that did not exit
    when its nanny asked (one busy in a frame, or whose nanny was interrupted) is killed, so
    that nothing of the run outlives it."""
    processes = []
    for nanny in getattr(cluster, "workers", {}).values():
        process = getattr(getattr(nanny, "process", None), "process", None)
        if process is not None and process.pid is not None:
            processes.append(process.pid)
    try:
        cluster.close(timeout=WORKER_EXIT_SECONDS)
    except Exception:
        pass
    deadline = _time.monotonic() + WORKER_EXIT_SECONDS
    for pid in processes:
        while _alive(pid) and _time.monotonic() < deadline:
            _time.sleep(0.05)
        if _alive(pid):
            try:
                os.kill(pid, 9)  # SIGKILL: it holds the terminating signals back (local_cluster)
                os.waitpid(pid, 0)
            except (ProcessLookupError, ChildProcessError):
                pass


def _alive(pid: int) -> bool:
    """``pid`` exists and is not a zombie (reaps it if it is our exited child)."""
    try:
        done, _ = os.waitpid(pid, os.WNOHANG)
        if done:
            return False
    except ChildProcessError:
        pass  # not our child (or reaped already): ask the kernel
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


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


def local_cluster(workers: int, directory: str | None = None):
    """A Dask ``LocalCluster`` of ``workers`` processes on this machine, one task at a time each,
    its files in ``directory``.

    Processes, not threads: the USD reader and the task's Python hold the GIL; each task's
    renderer uses the threads its options give. The scheduler's HTTP server (its /metrics and
    /health routes; no dashboard without bokeh) takes a free port: Dask's default, 8787, is
    taken by any other cluster on the machine, and falling back from it is a warning."""
    import logging

    from distributed import LocalCluster

    return LocalCluster(
        n_workers=workers,
        threads_per_worker=1,
        processes=True,
        dashboard_address=":0",
        silence_logs=logging.CRITICAL,
        local_directory=directory,
    )


@contextmanager
def _terminal_signals_held():
    """``held_signals`` while a LocalCluster starts or closes, blocked in this thread too.

    A terminal's Ctrl-C or hang-up, and a SIGTERM to the process group, reach every process of
    the group: each worker would die mid-message or print its own KeyboardInterrupt traceback
    (~40 lines), and a resource tracker killed by SIGHUP is restarted without its records
    (KeyError tracebacks). Dask's event-loop thread, the resource tracker and the workers,
    created inside the block, keep the blocked mask, so only this process hears those signals
    (it closes the cluster and asks its workers to exit); one that comes meanwhile is acted on
    as the block ends, not lost."""
    import multiprocessing.resource_tracker
    import signal

    with held_signals(block_thread=True):
        # The resource tracker that multiprocessing's spawn gives the workers, started now with
        # SIGHUP blocked (it ignores SIGINT and SIGTERM itself); starting it unblocks SIGINT and
        # SIGTERM in this thread (multiprocessing.resource_tracker.ensure_running), so block
        # them again before Dask creates its threads and workers.
        multiprocessing.resource_tracker.ensure_running()
        signal.pthread_sigmask(signal.SIG_BLOCK, (signal.SIGINT, signal.SIGTERM, signal.SIGHUP))
        yield


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
