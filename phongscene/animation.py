# SPDX-License-Identifier: Apache-2.0
"""Animations: one USD file read at many time codes, each frame an independent task.

A frame number is a USD time code (``--frames 1:24`` reads the stage at 1, 2, ..., 24, as
Blender and usdview number frames). Frames run on Dask distributed (``phongscene.dask_runtime``):
by default a ``LocalCluster`` of worker processes on this machine, or an existing cluster
(``scheduler=`` / the CLI's ``--scheduler`` / ``DASK_SCHEDULER_ADDRESS``). What is shipped to a
worker is the scene's path, the time code and a ``RenderOverrides``, never a pickled scene: each
task opens the stage itself (so workers must see the file and the output folder at the same
paths), writes its output atomically and returns only a small dict of metrics. A task that
raises is retried once (Dask's ``retries=1``); a frame that fails twice is reported by number.

The tasks call the same functions as a serial render of one frame (``load_scene`` at the time,
``RenderOverrides.apply``, ``render``, ``write_image``), so a frame is bit-identical to
``phongscene render --time T`` with the same options. A worker keeps the stage it opened last
(``phongscene.usd.stage_reuse``: reopened when the file or a layer of it changes) and reads each
task's frame from it. The report of ``diff --frames`` is ``phongscene.report.write_frames_report``.
"""

from __future__ import annotations

import os
import re
import time as _time
from pathlib import Path

from .overrides import RenderOverrides

# The frame number replaces the run of '#' in an output name, zero-padded to its length.
FRAME_PATTERN = re.compile(r"#+")
# Per-frame report folders of `diff --frames`: frame.0001, frame.0002, ...
FRAME_FOLDER = "frame.####"


def parse_frames(text: str) -> tuple[int, ...]:
    """A frame spec → the frame numbers, in order, each once.

    usdrecord's syntax (UsdAppUtils.framesArgs, UsdUtils.TimeCodeRange): specs separated by
    commas, each a frame ``N``, a range ``START:END`` or a strided range ``START:ENDxSTRIDE``
    (``1:9x4`` is 1, 5, 9); phongscene's own ``START:END:STEP`` is kept. END is included.
    Whole numbers only (a frame is a whole time code); STRIDE >= 1 and START <= END. ValueError
    with a one-line message otherwise."""
    frames: list[int] = []
    for spec in text.split(","):
        for frame in _frame_spec(spec.strip(), text):
            if frame not in frames:
                frames.append(frame)
    return tuple(frames)


def _frame_spec(spec: str, text: str) -> range:
    """One spec of ``parse_frames`` (``text``, the whole of it, for the messages)."""
    expected = f"expected N, START:END, START:ENDxSTRIDE (usdrecord's) or START:END:STEP, got {text!r}"
    parts = spec.split(":")
    if len(parts) == 2 and "x" in parts[1]:
        parts = [parts[0], *parts[1].split("x", 1)]
    if not spec or len(parts) > 3:
        raise ValueError(expected)
    try:
        numbers = [int(p) for p in parts]
    except ValueError:
        raise ValueError(f"frames are whole numbers (USD time codes): {expected}") from None
    start, end, step = (
        (numbers[0], numbers[0], 1) if len(numbers) == 1 else (*numbers[:2], numbers[2] if len(numbers) == 3 else 1)
    )
    if step < 1:
        raise ValueError(f"the step must be >= 1, got {step} in {text!r}")
    if end < start:
        raise ValueError(f"the end frame must not be before the start frame, got {text!r}")
    return range(start, end + 1, step)


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
    return os.path.join(head, f"{tail[: m.start()]}{frame:0{len(m.group())}d}{tail[m.end() :]}")


# ----------------------------------------------------------------------------------------------
# Tasks: module-level functions, so a worker imports them by name. Each gets the scene's path, its
# frame (the time code) and the overrides; each loads the stage itself and returns a small dict.


def _load(scene: str, frame: int, overrides: RenderOverrides):
    from .rendering import load_scene
    from .usd.stage_reuse import open_stage

    if not isinstance(overrides, RenderOverrides):
        raise TypeError(f"overrides: expected a RenderOverrides, got {type(overrides).__name__}")
    start = _time.perf_counter()
    loaded, warnings = load_scene(
        open_stage(scene),
        time=float(frame),
        camera=overrides.camera,
        subdivision_level=overrides.subdivision_level,
    )
    loaded, settings = overrides.apply(loaded)
    return loaded, settings, warnings, _time.perf_counter() - start


def render_frame(scene: str, frame: int, output: str, backend: str, overrides: RenderOverrides) -> dict:
    """Render ``scene`` at time ``frame`` and write ``output`` (atomically)."""
    from .diagnostics import ImageChecks
    from .images import write_image
    from .rendering import prepare_render

    # CPU seconds of this process beside the wall clock: on a shared machine the wall clock of
    # each part says as much about the other jobs as about the part (benchmarks/animation.py).
    cpu = [_time.process_time()]
    loaded, settings, warnings, load_seconds = _load(scene, frame, overrides)
    cpu.append(_time.process_time())
    start = _time.perf_counter()
    checks = ImageChecks.of(loaded, settings, warnings)
    image = prepare_render(loaded, backend, settings)()
    warnings = [*warnings, *checks.warnings(image)]
    render_seconds = _time.perf_counter() - start
    cpu.append(_time.process_time())
    write_image(output, image)
    cpu.append(_time.process_time())
    return {
        "frame": frame,
        "output": output,
        "width": settings.width,
        "height": settings.height,
        "specular": settings.specular,
        "load_seconds": load_seconds,
        "render_seconds": render_seconds,
        "write_seconds": _time.perf_counter() - start - render_seconds,
        "seconds": _time.perf_counter() - start + load_seconds,
        "cpu_seconds": dict(zip(("load", "render", "write"), (b - a for a, b in zip(cpu, cpu[1:])))),
        "warnings": warnings,
        "pid": os.getpid(),
    }


def compile_frame(scene: str, frame: int, output: str, overrides: RenderOverrides) -> dict:
    """Compile ``scene`` at time ``frame`` to ``output`` (.pov) and its .ini (atomically)."""
    from .backends.povray import prepare
    from .files import atomic_files
    from .rendering import check_settings

    loaded, settings, warnings, load_seconds = _load(scene, frame, overrides)
    start = _time.perf_counter()
    out = Path(output)
    job = prepare(loaded, check_settings(loaded, settings), overrides.mapping)
    with atomic_files(out, out.with_suffix(".ini")) as (tmp_pov, tmp_ini):  # both appear, or neither
        job.save_sdl(tmp_pov)
        tmp_ini.write_text(job.ini(out.name, out.with_suffix(".exr").name), encoding="ascii")
    return {
        "frame": frame,
        "output": output,
        "passes": job.frames,
        "load_seconds": load_seconds,
        "seconds": _time.perf_counter() - start + load_seconds,
        "warnings": warnings,
        "pid": os.getpid(),
    }


def diff_frame(scene: str, frame: int, outdir: str, overrides: RenderOverrides, thresholds) -> dict:
    """Diff both backends on ``scene`` at time ``frame``; the frame's report goes to ``outdir``."""
    from dataclasses import replace

    from .crossvalidation import diff
    from .usd.stage_reuse import open_stage

    start = _time.perf_counter()
    result = diff(
        open_stage(scene),
        outdir,
        overrides=replace(overrides, time=float(frame)),  # no mapping: exact, or classic where needed
        thresholds=thresholds,
    )
    r = result.report
    return {
        "frame": frame,
        "outdir": outdir,
        "ok": result.ok,
        "max_error": r.max_error,
        "worst_pixel": [r.worst.x, r.worst.y] if r.worst else None,
        "failing_pixels": r.failing_pixels,
        "failing_percent": r.failing_percent,
        "pixels": r.pixels,
        "explained_pixels": len(result.explained) + len(result.ill_conditioned),
        "timings": result.timings,
        "width": result.settings.width,
        "height": result.settings.height,
        "seconds": _time.perf_counter() - start,
        "warnings": [*result.warnings, *result.image_warnings],
        "pid": os.getpid(),
    }
