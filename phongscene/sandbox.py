# SPDX-License-Identifier: Apache-2.0
"""Read an untrusted USD file in a child process with a memory limit.

USD itself can crash on a corrupt ``.usdc`` / ``.usdz`` (a segfault), or allocate what a corrupt
header claims (6.6 GB for one fuzzed file). Read in a child (``python -m phongscene.sandbox``),
such a file kills or stops only the child, and the caller gets a ``SceneError`` naming the
file; otherwise the child pickles the ``ReadResult`` (scene, warnings, prim → node map) back.
The child's address space is capped (``resource.setrlimit(RLIMIT_AS)``) at
``memory_limit_for(path)``, and it writes no core dump.

It protects against crashes and runaway allocations while reading; not against a file that is
slow to read (that is what ``--timeout`` on the CLI is for), nor against the renderers. Cost:
one interpreter start-up with pxr (~0.5 s on this machine) plus pickling the scene; measured by
``benchmarks/sandbox.py``.

The parent of a sandboxed read never loads USD: nothing here touches pxr."""

from __future__ import annotations

import os
import pickle
import signal
import subprocess
import sys

from .errors import Problem, SceneError

# The limit never exceeds half the machine's memory: a runaway allocation (a corrupt .usdc grew
# to 10 GB resident in 20 s on this 24 GB machine) is stopped before the machine swaps or other
# processes are killed.
MEMORY_CAP_FRACTION = 0.5
# Address space python + numpy + pxr reserve before reading anything (VmPeak 1.4 GB measured),
# with room to spare.
BASE_MEMORY = 2 << 30
# Address space per byte of the file on top of that: a crate file's compressed arrays expand,
# USD keeps them and the model copies them as float64 / int32 (measured by
# benchmarks/sandbox.py: a 1M-triangle .usdc of 17 MiB peaks at ~0.5 GiB resident).
MEMORY_PER_FILE_BYTE = 64
# The child's exit status when an allocation failed under the limit (any other failure is a
# SceneError it pickles back, or a signal).
EXIT_OUT_OF_MEMORY = 86
EXIT_UNEXPECTED = 87


# What the dynamic loader and the OS say when a mapping does not fit the address-space limit.
OUT_OF_MEMORY_SIGNS = ("failed to map segment", "Cannot allocate memory")


def default_memory_limit() -> int:
    """The most address space a sandboxed read may get: half the machine's memory."""
    try:
        physical = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError):
        return BASE_MEMORY * 2
    return max(BASE_MEMORY, int(physical * MEMORY_CAP_FRACTION))


def memory_limit_for(path: str | os.PathLike) -> int:
    """Bytes of address space the child reading ``path`` may use: ``BASE_MEMORY`` plus
    ``MEMORY_PER_FILE_BYTE`` per byte of the file, at most ``default_memory_limit()``."""
    try:
        size = os.path.getsize(path)
    except OSError:
        size = 0
    return min(BASE_MEMORY + MEMORY_PER_FILE_BYTE * size, default_memory_limit())


def read_usd_sandboxed(path: str | os.PathLike, memory_limit: int | None = None, time: float | None = None):
    """``phongscene.usd.read_usd(path, time)`` in a child process (see the module's doc).

    Raises:
        SceneError: the file is invalid, or reading it crashed USD or exceeded ``memory_limit``
            bytes (default ``memory_limit_for(path)``).
    """
    path = os.fspath(path)
    limit = memory_limit_for(path) if memory_limit is None else int(memory_limit)
    proc = subprocess.run(
        [sys.executable, "-m", "phongscene.sandbox", path, str(limit), repr(time)],
        stdin=subprocess.DEVNULL, capture_output=True,
    )
    if proc.returncode == 0:
        kind, payload = pickle.loads(proc.stdout)
        if kind == "error":
            raise SceneError(payload)
        return payload
    if proc.returncode < 0:
        name = signal.Signals(-proc.returncode).name
        # USD aborts when an allocation fails in C++ (std::bad_alloc is not turned into MemoryError).
        memory = f" or ran out of its {limit / 2**30:.1f} GiB memory limit" if name == "SIGABRT" else ""
        raise SceneError(Problem(
            f"USD crashed reading this file ({name}){memory}; it was read in a sandboxed child process, which "
            "alone died: the file is corrupt or triggers a bug in USD", file=path))
    if proc.returncode == EXIT_OUT_OF_MEMORY:
        raise SceneError(Problem(
            f"reading this file needs more than the sandbox's memory limit ({limit / 2**30:.1f} GiB): a corrupt file "
            "(USD allocates what its header claims), or a scene too big to read sandboxed (--no-sandbox reads it in "
            "process)", file=path))
    last = (proc.stderr.decode("utf-8", "replace").strip().splitlines() or ["no message"])[-1]
    raise SceneError(Problem(f"the sandboxed reader failed (exit {proc.returncode}): {last}", file=path))


def _child(path: str, limit: int, time: float | None) -> int:
    import resource

    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    out = sys.stdout.buffer
    try:
        from .usd import read_usd

        payload = ("ok", read_usd(path, time=time))
    except SceneError as e:
        payload = ("error", e.problems)
    except MemoryError:
        return EXIT_OUT_OF_MEMORY
    except (ImportError, OSError) as e:
        # Under the address-space limit the dynamic loader may fail to map USD's own libraries
        # ("failed to map segment from shared object", ENOMEM): the limit, not the file.
        if any(sign in str(e) for sign in OUT_OF_MEMORY_SIGNS):
            return EXIT_OUT_OF_MEMORY
        print(f"{type(e).__name__}: {e}", file=sys.stderr)
        return EXIT_UNEXPECTED
    except Exception as e:  # noqa: BLE001 - reported by the parent as one line naming the file
        print(f"{type(e).__name__}: {e}", file=sys.stderr)
        return EXIT_UNEXPECTED
    try:
        out.write(pickle.dumps(payload, protocol=pickle.HIGHEST_PROTOCOL))
    except MemoryError:
        return EXIT_OUT_OF_MEMORY
    out.flush()
    return 0


if __name__ == "__main__":
    # The time code travels as its repr (None, or a float's shortest exact text).
    raise SystemExit(_child(sys.argv[1], int(sys.argv[2]), None if sys.argv[3] == "None" else float(sys.argv[3])))
