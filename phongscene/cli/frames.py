# SPDX-License-Identifier: Apache-2.0
"""``--frames`` and the output names of an animation, for render, compile and diff: the
overrides a frame task renders with, running the tasks (one frame in this process, more on
Dask) with their summary, and the checks of #### in an output name."""

from __future__ import annotations

import os
import sys
from dataclasses import replace

from ..overrides import RenderOverrides
from .options import UsageError, overrides_from_args, print_warnings


def frame_overrides(args) -> RenderOverrides:
    """The overrides a frame task renders with. Each LocalCluster worker renders one frame at a
    time; unless --threads says otherwise it gets its share of the cores (so workers x threads
    = cores); on an existing cluster the scene's setting applies unless --threads is given."""
    from ..dask_runtime import scheduler_address

    threads = getattr(args, "threads", None)
    if threads is None and "threads" in args and scheduler_address(args.scheduler) is None:
        cores = os.cpu_count() or 1
        threads = max(1, cores // min(args.workers or cores, len(args.frames)))
    return replace(overrides_from_args(args), threads=threads)


def frames_to_run(args, output_of) -> tuple[int, ...]:
    """``args.frames``, less those whose output (``output_of(frame)``) exists when
    --skip-existing is given (outputs are written atomically: one that exists is whole), with how
    many were skipped said."""
    if not getattr(args, "skip_existing", False):
        return args.frames
    todo = tuple(f for f in args.frames if not os.path.exists(output_of(f)))
    if len(todo) < len(args.frames):
        print(
            f"{args.scene}: {len(args.frames) - len(todo)} of {len(args.frames)} frames skipped, their outputs "
            f"exist (--skip-existing){'' if todo else ': nothing to do'}"
        )
    return todo


def run_frames(args, task, arguments, label: str, frames: tuple[int, ...] | None = None):
    """Run ``task`` for every frame of ``frames`` (default ``args.frames``): one frame in this
    process, more on Dask. The stage is read once here first (at the first frame), so a bad file
    is one error before any cluster starts, and its warnings are printed once."""
    from ..dask_runtime import TASK_RETRIES, run_frames, run_serially
    from ..progress import ProgressBar
    from ..rendering import load_scene

    frames = args.frames if frames is None else frames
    # The tasks then reopen the file in process: it was read once, here (sandboxed if need be).
    _, warnings = load_scene(
        args.scene,
        time=float(frames[0]),
        sandbox=getattr(args, "sandbox", None),
        camera=getattr(args, "camera", None),
        subdivision_level=getattr(args, "subdivision_level", None),
    )
    printed = print_warnings(warnings)
    bar = ProgressBar("frames")

    def on_frame(frame, metrics, error):
        if error is not None:
            print(f"error: frame {frame}: {error}", file=sys.stderr)

    # One frame, no cluster asked for: this process (a cluster's start-up would cost more).
    if len(frames) == 1 and not (args.scheduler or args.workers):
        run = run_serially(task, frames, arguments, progress=bar, on_frame=on_frame)
    else:
        run = run_frames(
            task, frames, arguments, scheduler=args.scheduler, workers=args.workers, progress=bar, on_frame=on_frame
        )
    bar.done(run.seconds)
    # Warnings the first frame did not have (a light that clips only later, ...), once each.
    later: dict[str, list[int]] = {}
    for frame in sorted(run.results):
        for warning in run.results[frame].get("warnings", ()):
            if warning not in warnings:
                later.setdefault(warning, []).append(frame)
    # Within the same cap as the first frame's (a command prints at most MAX_WARNING_LINES).
    print_warnings(
        (f"frames {', '.join(map(str, frames))}: {warning}" for warning, frames in later.items()), leave=printed
    )
    where = (
        f"on {run.workers} Dask worker{'' if run.workers == 1 else 's'} ({run.cluster})"
        if run.cluster
        else "in this process"
    )
    print(f"{args.scene}: {len(run.results)} of {len(frames)} {label} {where} in {run.seconds:.2f} s")
    if run.failures:
        print(
            f"error: frames failed (each tried {1 + TASK_RETRIES} times): {', '.join(map(str, sorted(run.failures)))}",
            file=sys.stderr,
        )
    return run


def check_cluster_needs_frames(args) -> None:
    """--scheduler/--workers without --frames: a UsageError, since nothing would use them."""
    if (args.scheduler or args.workers) and not args.frames:
        raise UsageError("--scheduler and --workers run frames: give --frames START:END")


def check_frame_pattern(output: str, example: str) -> None:
    """An output name for --frames must have #### for the frame number (else a UsageError)."""
    from ..animation import has_frame_pattern

    if not has_frame_pattern(output):
        raise UsageError(f"{output}: with --frames the name needs #### for the frame number (e.g. {example})")


def output_at_time(args, output: str) -> str:
    """A single frame's output name: #### replaced by --time when it is a whole number (a
    UsageError when the name has #### and there is no frame number for it)."""
    from ..animation import frame_name, has_frame_pattern

    if not has_frame_pattern(output):
        return output
    if args.time is None or args.time != int(args.time):
        raise UsageError(f"{output}: #### in the name needs --frames, or a whole --time")
    return frame_name(output, int(args.time))
