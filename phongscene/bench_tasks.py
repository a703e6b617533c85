# SPDX-License-Identifier: Apache-2.0
"""``phongscene bench`` on Dask: each family's reference and each (estimator, backend) setting
is an independent task, run on the same engine as animation frames (a ``LocalCluster`` here by
default, or ``--scheduler`` / ``DASK_SCHEDULER_ADDRESS``). Which settings exist is
``phongscene.bench``'s business; this module only says where and how many at once they run.

Timings stay honest: a timing task never shares its cores with another task. Each task renders
with the settings' threads (0: all cores), so at most ``cores // threads`` tasks run at once on
a host (one with threads = 0), each worker runs one task at a time, and the result says how many
ran at once (``concurrency``). A task ships the scene's path, the settings and the estimator,
never a pickled scene; the worker opens the stage itself (``phongscene.usd.stage_reuse``) and returns
only the row's metrics. A reference image is computed by a task and sent once to every worker
(``Client.scatter``), where the setting tasks compare against it.
"""

from __future__ import annotations

import os
from collections import deque
from collections.abc import Callable, Sequence

from . import bench
from .errors import BackendError
from .scene import RenderSettings


def reference_task(scene: str, settings: RenderSettings, family: str) -> dict:
    """``bench.reference`` of ``family`` for the USD file ``scene`` (read at its default time)."""
    from .rendering import load_scene
    from .usd.stage_reuse import open_stage

    loaded, _ = load_scene(open_stage(scene))
    return bench.reference(family, loaded, settings, bench.render_native)


def setting_task(
    scene: str, settings: RenderSettings, estimator: bench.Estimator, backend: str, ref: dict, repeat: int
) -> dict:
    """``bench.measure``: one row (times, errors against ``ref``); the stage is read before the clock starts."""
    from .rendering import load_scene
    from .usd.stage_reuse import open_stage

    loaded, _ = load_scene(open_stage(scene))
    return bench.measure(loaded, settings, estimator, backend, ref, repeat) | {"pid": os.getpid()}


def slots_per_host(cores: int, threads: int) -> int:
    """How many tasks rendering with ``threads`` (0: all cores) fit on ``cores`` without sharing one."""
    return 1 if threads <= 0 else max(1, cores // threads)


def run(
    scene_path: str,
    scene,
    settings: RenderSettings,
    *,
    repeat: int = 3,
    quick: bool = False,
    backends: Sequence[str] = bench.BACKEND_NAMES,
    families: Sequence[str] | None = None,
    scheduler: str | None = None,
    workers: int | None = None,
    log: Callable[[str], None] = print,
) -> dict:
    """``bench.run`` of the USD file ``scene_path`` (whose model ``scene`` the caller read, to
    choose the estimators) with its settings as Dask tasks. The result is ``bench.run``'s, rows in
    its order, plus ``concurrency`` (tasks at once), ``workers`` and ``cluster``."""
    from distributed import as_completed

    from .dask_runtime import dask_client

    chosen = bench.estimators(scene, quick)
    wanted = bench.families_of(chosen, families)
    jobs = [
        (est, backend)
        for family in wanted
        for est in chosen
        if est.family == family
        for backend in backends
        if backend in est.backends
    ]
    cores = os.cpu_count() or 1
    with dask_client(scheduler, lambda: min(workers or cores, slots_per_host(cores, settings.threads))) as (
        client,
        cluster,
    ):
        used = _workers_to_use(client, settings.threads, workers)
        log(
            f"{len(used)} setting{'s' if len(used) > 1 else ''} at once: {len(used)} Dask worker"
            f"{'s' if len(used) > 1 else ''} ({cluster}), one task "
            f"each, each rendering with {settings.threads or 'all'} thread{'' if settings.threads == 1 else 's'}"
        )
        references: dict = {}
        refs = {}

        def reference_done(family: str, ref: dict) -> None:
            references[family] = {k: v for k, v in ref.items() if k != "image"}
            log(bench.reference_line(family, ref))
            # Sent once to every worker (in a list: a dict would be scattered value by value).
            refs[family] = client.scatter([ref], broadcast=True)[0]

        _one_per_worker(
            client,
            used,
            [(reference_task, (scene_path, settings, f), f) for f in wanted],
            lambda family, future: reference_done(family, future.result()),
            as_completed,
        )
        rows: dict[int, dict] = {}

        def row_done(index: int, future) -> None:
            rows[index] = future.result()
            log(bench.row_line(rows[index]))

        _one_per_worker(
            client,
            used,
            [
                (setting_task, (scene_path, settings, est, backend, refs[est.family], repeat), i)
                for i, (est, backend) in enumerate(jobs)
            ],
            row_done,
            as_completed,
        )
    result = bench.result_of(settings, repeat, references, [rows[i] for i in range(len(jobs))], backends, wanted)
    return result | {"concurrency": len(used), "cluster": cluster}


def _workers_to_use(client, threads: int, most: int | None) -> list[str]:
    """The workers that may run a timing task at once: per host, as many as its cores hold tasks
    of ``threads`` (``slots_per_host``), at most ``most`` in all."""
    info = client.scheduler_info()["workers"]
    cores = client.run(os.cpu_count)  # each worker's host's cores
    by_host: dict[str, list[str]] = {}
    for address in sorted(info):
        by_host.setdefault(info[address]["host"], []).append(address)
    used = []
    for _host, addresses in sorted(by_host.items()):
        used += addresses[: slots_per_host(cores.get(addresses[0]) or 1, threads)]
    if not used:
        raise BackendError("the Dask cluster has no workers")
    return used[:most] if most else used


def _one_per_worker(client, workers: list[str], jobs: list[tuple], done: Callable, as_completed) -> None:
    """Run ``jobs`` ((function, arguments, tag)) with at most one in flight per worker of
    ``workers`` (each submitted to a free one); ``done(tag, future)`` as each finishes. A task
    that raises is one error naming what it measured."""
    pending = deque(jobs)
    running = as_completed()
    where: dict = {}

    def submit(worker: str) -> None:
        function, arguments, tag = pending.popleft()
        # pure=False: a timing is an action, never deduplicated; allow_other_workers: should this
        # worker leave, the task runs on another rather than waiting for it forever.
        future = client.submit(function, *arguments, workers=[worker], allow_other_workers=True, pure=False)
        where[future] = (worker, tag)
        running.add(future)

    for worker in workers:
        if pending:
            submit(worker)
    for future in running:
        worker, tag = where.pop(future)
        if future.status == "error":
            raise BackendError(
                f"bench: {tag if isinstance(tag, str) else _job_name(jobs, tag)}: {future.exception()}"
            ) from None
        done(tag, future)
        if pending:
            submit(worker)


def _job_name(jobs: list[tuple], tag) -> str:
    arguments = next(a for _, a, t in jobs if t == tag)
    return f"{arguments[2].label} on {arguments[3]}"
