# SPDX-License-Identifier: Apache-2.0
"""The one way every command (and ``load_scene``, ``load_usd``) reads a USD file: in process only
where USD cannot crash or allocate without bound, in the sandboxed child otherwise.

USD crashes (SIGSEGV) or allocates what a corrupt header claims in its *binary* readers (crate
``.usdc``, ``.usdz`` archives); its text parser reads a ``.usda`` layer into memory proportional
to the text and reports a syntax error as an error. So a file is read in process ("safe") when:

* it is a text layer (starts with ``#usda``), at most ``MAX_IN_PROCESS_BYTES`` long, and names no
  asset path (no ``@``: no sublayer, reference, payload or texture that could pull a binary layer
  or image into this process) — the examples and most hand-written scenes; or
* it was already read successfully in this process, unchanged since (its size and mtime): a
  ``--frames`` task or a bench repetition reads again what the first read (sandboxed if need be)
  accepted.

Everything else goes through ``phongscene.sandbox.read_usd_sandboxed`` (a crash or a runaway
allocation there is a one-line SceneError, the CLI's exit 2). ``sandbox=True`` forces the child,
``sandbox=False`` (``--no-sandbox``) forces the process. Cost of the child: one interpreter
start-up with pxr, ~0.5 s (``benchmarks/startup.py`` measures both paths)."""

from __future__ import annotations

import os
from pathlib import PurePath

# A text layer longer than this goes to the sandbox anyway: its parse is proportional to its size,
# but a 64 MiB layer already takes seconds and GiBs; the child's memory limit then applies.
MAX_IN_PROCESS_BYTES = 64 << 20
# How much of a text layer is scanned for an asset path (the whole of it, up to the bound above).
_TEXT_MAGIC = b"#usda"

# Files read successfully in this process: path -> (size, mtime_ns) when read.
_read_once: dict[str, tuple[int, int]] = {}


def _state(path: str) -> tuple[int, int] | None:
    try:
        st = os.stat(path)
    except OSError:
        return None
    return st.st_size, st.st_mtime_ns


def safe_in_process(path: str | os.PathLike) -> bool:
    """Whether ``path`` may be read by USD in this process (see the module's doc)."""
    path = os.fspath(path)
    state = _state(path)
    if state is None:
        return True  # not there: the reader's own "file not found", no USD involved
    if _read_once.get(os.path.abspath(path)) == state:
        return True
    if state[0] > MAX_IN_PROCESS_BYTES:
        return False
    try:
        with open(path, "rb") as f:
            data = f.read(MAX_IN_PROCESS_BYTES + 1)
    except OSError:
        return True  # unreadable: the reader names the error
    return data.startswith(_TEXT_MAGIC) and b"@" not in data


def remember_read(path: str | os.PathLike) -> None:
    """Record that ``path`` (as it is now) was read successfully."""
    path = os.fspath(path)
    state = _state(path)
    if state is not None:
        _read_once[os.path.abspath(path)] = state


def read_scene_file(
    path,
    time: float | None = None,
    *,
    sandbox: bool | None = None,
    camera: str | None = None,
    subdivision_level: int | None = None,
):
    """``phongscene.usd.read_usd(path, time)`` (a ``ReadResult``) by the safe path: ``sandbox``
    None decides by ``safe_in_process``; True always reads in the child, False never.

    An ``OpenStage`` or ``Usd.Stage`` (a stage already opened in this process) is read in process."""
    if not isinstance(path, (str, PurePath)):
        from .usd import read_usd

        return read_usd(path, time=time, camera=camera, subdivision_level=subdivision_level)
    if sandbox is None:
        sandbox = not safe_in_process(path)
    if sandbox:
        from .sandbox import read_usd_sandboxed

        result = read_usd_sandboxed(path, time=time, camera=camera, subdivision_level=subdivision_level)
    else:
        from .usd import read_usd  # lazily: the USD reader imports pxr

        result = read_usd(path, time=time, camera=camera, subdivision_level=subdivision_level)
    remember_read(path)
    return result
