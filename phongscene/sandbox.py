# SPDX-License-Identifier: Apache-2.0
"""Read an untrusted USD file in a child process with a memory limit.

USD itself can crash on a corrupt ``.usdc`` / ``.usdz`` (a segfault), or allocate what a corrupt
header claims (6.6 GB for one fuzzed file). Read in a child (``python -m phongscene.sandbox``),
such a file kills or stops only the child, and the caller gets a ``SceneError`` naming the
file; otherwise the child pickles the ``ReadResult`` (scene, warnings, prim → node map) back, its
large arrays out of band (written as they are, not copied into the pickle).

The child's address space (``resource.setrlimit(RLIMIT_AS)``) follows a model of what the scene
needs (``phongscene.memory_model``): the interpreter's base, measured in the child once python,
numpy and pxr are imported, plus ``READ_HEADROOM`` and a stack per core, then, announced by the
reader before it reads each, ``MEMORY_PER_FILE_BYTE`` per byte of every layer file and each
texture's decoded size from its header. So a scene the in-process reader can read is not refused
(a 4096² texture was, under the old constant 2 GiB), while a corrupt file meets a limit sized by
what it is on disk. The limit never exceeds ``default_memory_limit()`` (half the machine). The
child writes no core dump, and dies with its parent (``PR_SET_PDEATHSIG``): a SIGKILLed
``validate`` leaves no reader behind; on every other exit path the parent kills it.

It protects against crashes and runaway allocations while reading; not against a file that is
slow to read (that is what ``--timeout`` on the CLI is for), nor against the renderers. Cost:
one interpreter start-up with pxr (~0.5 s on this machine) plus pickling the scene; measured by
``benchmarks/sandbox.py``.

The parent of a sandboxed read never loads USD: nothing here touches pxr."""

from __future__ import annotations

import ctypes
import os
import pickle
import signal
import struct
import subprocess
import sys
import tempfile

from .errors import Problem, SceneError
from .memory_model import MEMORY_PER_FILE_BYTE, listen

# The limit never exceeds half the machine's memory: a runaway allocation (a corrupt .usdc grew
# to 10 GB resident in 20 s on this 24 GB machine) is stopped before the machine swaps or other
# processes are killed.
MEMORY_CAP_FRACTION = 0.5
# Address space python + numpy + pxr reserve before reading anything (VmPeak 1.4 GB measured),
# with room to spare: the base where the child cannot measure its own (no /proc/self/status).
BASE_MEMORY = 2 << 30
# Address space a read takes beyond the interpreter's measured base and what the reader announces:
# importing OpenImageIO for a texture (45 MB measured), USD's plugins and schema registry on first
# use, a small stage and its model (~35 MB for an example), with room to spare (measured: the
# examples and textured scenes peak 500-570 MiB below the final limit).
READ_HEADROOM = 512 << 20
# Each worker thread USD (TBB) may start reserves a stack (one per core); glibc's malloc arenas are
# capped at MALLOC_ARENAS in the child (each reserves 64 MiB of address space, and a 64-core
# machine would otherwise reserve 8 per core).
THREAD_STACK_BYTES = 8 << 20
MALLOC_ARENAS = 2
# The child's exit status when an allocation failed under the limit (any other failure is a
# SceneError it pickles back, or a signal).
EXIT_OUT_OF_MEMORY = 86
EXIT_UNEXPECTED = 87
# Linux's prctl option that sends the child a signal when its parent dies (<linux/prctl.h>).
PR_SET_PDEATHSIG = 1
# Arrays smaller than this travel inside the pickle; larger ones as raw buffers after it (each
# costs a length prefix and a read).
OUT_OF_BAND_MIN_BYTES = 1 << 16
_LENGTH = struct.Struct("<Q")


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
    """The model's limit for ``path`` alone, before its dependencies and textures are found, with
    the base estimated (``BASE_MEMORY``): at most ``default_memory_limit()``. (The child measures
    its base and grows its limit as the reader announces layers and textures.)"""
    try:
        size = os.path.getsize(path)
    except OSError:
        size = 0
    return min(BASE_MEMORY + MEMORY_PER_FILE_BYTE * size, default_memory_limit())


def read_usd_sandboxed(
    path: str | os.PathLike,
    memory_limit: int | None = None,
    time: float | None = None,
    camera: str | None = None,
    subdivision_level: int | None = None,
):
    """``phongscene.usd.read_usd(path, time, camera, subdivision_level)`` in a child process (see
    the module's doc).

    Args:
        memory_limit: a fixed address-space limit for the child in bytes; default: the model
            (see the module's doc).

    Raises:
        SceneError: the file is invalid, or reading it crashed USD or exceeded its memory limit.
    """
    path = os.fspath(path)
    mode = "model" if memory_limit is None else str(int(memory_limit))
    env = dict(os.environ, MALLOC_ARENA_MAX=str(MALLOC_ARENAS))
    with tempfile.TemporaryFile() as stderr:
        proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "phongscene.sandbox",
                path,
                mode,
                repr(time),
                str(os.getpid()),
                repr(subdivision_level),
                *([] if camera is None else [camera]),
            ],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=stderr,
            env=env,
        )
        try:
            payload = _receive(proc.stdout)
            returncode = proc.wait()
        finally:  # Ctrl-C, SIGTERM turned into an exception, a failed read: the child goes too
            if proc.poll() is None:
                proc.kill()
                proc.wait()
            proc.stdout.close()
        stderr.seek(0)
        last = (stderr.read().decode("utf-8", "replace").strip().splitlines() or ["no message"])[-1]
    if returncode == 0 and payload is not None:
        kind, value = payload
        if kind == "error":
            raise SceneError(value)
        return value
    if returncode < 0:
        name = signal.Signals(-returncode).name
        # USD aborts when an allocation fails in C++ (std::bad_alloc is not turned into MemoryError).
        memory = " or ran out of its memory limit" if name == "SIGABRT" else ""
        raise SceneError(
            Problem(
                f"USD crashed reading this file ({name}){memory}; it was read in a sandboxed child process, which "
                "alone died: the file is corrupt or triggers a bug in USD",
                file=path,
            )
        )
    if returncode == EXIT_OUT_OF_MEMORY:
        raise SceneError(
            Problem(
                f"reading this file needs more than the sandbox's memory limit ({last}): a corrupt file "
                "(USD allocates what its header claims), or a scene too big to read sandboxed (--no-sandbox reads it in "
                "process)",
                file=path,
            )
        )
    raise SceneError(Problem(f"the sandboxed reader failed (exit {returncode}): {last}", file=path))


def _receive(stream):
    """The child's answer: a pickle and its out-of-band buffers, each after its length; None
    when the child ended before it was complete (its exit status says why)."""
    try:
        (size,) = _LENGTH.unpack(_read_exactly(stream, _LENGTH.size))
        data = _read_exactly(stream, size)
        (count,) = _LENGTH.unpack(_read_exactly(stream, _LENGTH.size))
        buffers = []
        for _ in range(count):
            (size,) = _LENGTH.unpack(_read_exactly(stream, _LENGTH.size))
            # Read-only, as the model's arrays are (in-band arrays are made on immutable bytes).
            buffers.append(memoryview(_read_exactly(stream, size)).toreadonly())
    except EOFError:
        return None
    return pickle.loads(data, buffers=buffers)


def _read_exactly(stream, size: int) -> bytearray:
    out = bytearray(size)
    view, done = memoryview(out), 0
    while done < size:
        n = stream.readinto(view[done:])
        if not n:
            raise EOFError
        done += n
    return out


def _send(out, payload) -> None:
    """Write ``payload`` for ``_receive``: its large arrays are written from where they are."""
    buffers: list[pickle.PickleBuffer] = []

    def in_band(buffer: pickle.PickleBuffer) -> bool:
        if buffer.raw().nbytes < OUT_OF_BAND_MIN_BYTES:
            return True
        buffers.append(buffer)
        return False

    data = pickle.dumps(payload, protocol=5, buffer_callback=in_band)
    out.write(_LENGTH.pack(len(data)))
    out.write(data)
    out.write(_LENGTH.pack(len(buffers)))
    for buffer in buffers:
        raw = buffer.raw()
        out.write(_LENGTH.pack(raw.nbytes))
        out.write(raw)
    out.flush()


def _die_with_parent(parent: int) -> None:
    """Be killed when the parent dies (Linux; elsewhere the parent's kill on its way out is all),
    and exit now if it already has (it died before the prctl, and this process was reparented)."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    except (OSError, AttributeError):
        pass
    if os.getppid() != parent:
        os._exit(EXIT_UNEXPECTED)


def _address_space() -> int | None:
    """This process's address space now (VmSize), or None where /proc cannot say."""
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("VmSize:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


class _Limit:
    """The child's address-space limit (the soft one), grown by what the reader announces, at
    most ``cap`` (the hard one: it cannot be raised again)."""

    def __init__(self, resource, cap: int, start: int):
        self.resource, self.cap, self.soft = resource, cap, start
        self._apply()

    def grow(self, nbytes: int, what: str) -> None:
        self.soft += nbytes
        self._apply()

    def _apply(self) -> None:
        self.resource.setrlimit(self.resource.RLIMIT_AS, (min(self.soft, self.cap), self.cap))

    def describe(self) -> str:
        capped = ", capped at half the machine's memory" if self.soft > self.cap else ""
        return f"{min(self.soft, self.cap) / 2**30:.1f} GiB{capped}"


def _child(
    path: str, mode: str, time: float | None, parent: int, subdivision_level: int | None, camera: str | None = None
) -> int:
    import resource

    _die_with_parent(parent)
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    fixed = None if mode == "model" else int(mode)
    cap = default_memory_limit() if fixed is None else fixed
    resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
    shown = f"{cap / 2**30:.1f} GiB"
    out = sys.stdout.buffer
    try:
        from .usd import read_usd

        if fixed is None:
            base = _address_space()
            threads = THREAD_STACK_BYTES * (os.cpu_count() or 1)
            limit = _Limit(resource, cap, (BASE_MEMORY if base is None else base) + READ_HEADROOM + threads)
            listen(limit.grow)
            shown = limit.describe
        payload = ("ok", read_usd(path, time=time, camera=camera, subdivision_level=subdivision_level))
    except SceneError as e:
        payload = ("error", e.problems)
    except MemoryError:
        return _out_of_memory(shown)
    except (ImportError, OSError) as e:
        # Under the address-space limit the dynamic loader may fail to map USD's own libraries
        # ("failed to map segment from shared object", ENOMEM): the limit, not the file.
        if any(sign in str(e) for sign in OUT_OF_MEMORY_SIGNS):
            return _out_of_memory(shown)
        print(f"{type(e).__name__}: {e}", file=sys.stderr)
        return EXIT_UNEXPECTED
    except Exception as e:
        print(f"{type(e).__name__}: {e}", file=sys.stderr)
        return EXIT_UNEXPECTED
    try:
        _send(out, payload)
    except MemoryError:
        return _out_of_memory(shown)
    return 0


def _out_of_memory(shown) -> int:
    """Say the limit (the parent quotes the last line of stderr) and return the exit status."""
    print(shown() if callable(shown) else shown, file=sys.stderr)
    return EXIT_OUT_OF_MEMORY


if __name__ == "__main__":
    # The time code travels as its repr (None, or a float's shortest exact text).
    raise SystemExit(
        _child(
            sys.argv[1],
            sys.argv[2],
            None if sys.argv[3] == "None" else float(sys.argv[3]),
            int(sys.argv[4]),
            None if sys.argv[5] == "None" else int(sys.argv[5]),
            sys.argv[6] if len(sys.argv) > 6 else None,
        )
    )  # the subdivision level (None: the scene's), the camera if chosen
