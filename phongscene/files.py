# SPDX-License-Identifier: Apache-2.0
"""Atomic output files: every file phongscene writes appears whole or not at all.

The data goes to a temporary file in the target's folder (same file system, so the final
``os.replace`` is atomic) and is renamed onto the target once complete; on any error the
temporary file is removed and an existing target is left untouched. The result gets the mode
a plainly created file would get (0666 minus the umask), not the 0600 of ``tempfile.mkstemp``.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path

from .errors import PhongSceneError
from .held_signals import held_signals

# Permissions before the umask, as for open(path, "w"): outputs are meant to be shared
# (reports are served as web pages, SDL is handed to povray), not private.
CREATE_MODE = 0o666
# Random bytes in a temporary name; a clash is retried, so this only has to make one unlikely.
# (os.urandom, what secrets.token_hex reads: the secrets module imports hmac and hashlib, ~5 ms
# of every render's start-up.)
TEMP_NAME_BYTES = 6
TEMP_NAME_ATTEMPTS = 100


@contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """A temporary path to write ``path`` through, for libraries that write by file name
    (OpenImageIO, USD's ``Export``). It sits in ``path``'s folder (which must exist) and keeps
    its suffix, so format detection by extension works; the file exists and is empty. When the
    block finishes it is renamed onto ``path``; when it raises, it is deleted.

    Example::

        with atomic_path("out.exr") as tmp:
            buf.write(str(tmp))
    """
    path = Path(path)
    check_output(path)
    tmp = None
    try:
        try:
            # Created and known to the cleanup below before a signal is acted on (held_signals).
            with held_signals():
                tmp, mode = _create_temporary(path)
        except OSError as e:
            raise PhongSceneError(f"{path}: cannot write: {e.strerror or e}") from None
        yield tmp
        os.chmod(tmp, mode)  # the writer may have replaced the file with one of its own
        os.replace(tmp, path)
    except OSError as e:
        # Name the user's file, not the hidden temporary one (a full disk, a lost folder).
        if e.filename is not None and os.fspath(e.filename) == os.fspath(tmp):
            raise PhongSceneError(f"{path}: cannot write: {e.strerror or e}") from None
        raise
    except PhongSceneError as e:
        text = str(e)
        if tmp is not None and str(tmp) in text:
            raise PhongSceneError(text.replace(str(tmp), str(path))) from None
        raise
    finally:
        if tmp is not None:
            with held_signals():  # whole: a signal now is acted on once the file is gone
                if os.path.lexists(tmp):
                    os.unlink(tmp)


def check_output(path: str | os.PathLike) -> None:
    """Raise PhongSceneError unless a file can be created at ``path``: its folder exists (it is
    not created: a typo in a folder name should not silently make a new tree), is a folder, and
    is writable; and ``path`` is not a folder. Commands call it before they render, so a bad
    output is found in a second, not after the render."""
    path = Path(path)
    parent = path.parent
    if path.is_dir():
        raise PhongSceneError(f"{path}: is a folder, expected a file name")
    if not parent.exists():
        raise PhongSceneError(f"{path}: the folder {parent} does not exist (create it first)")
    if not parent.is_dir():
        raise PhongSceneError(f"{path}: {parent} is not a folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise PhongSceneError(f"{path}: the folder {parent} is not writable")


def check_output_folder(outdir: str | os.PathLike) -> None:
    """Raise PhongSceneError unless ``outdir`` is a folder files can be written into, or can be
    created as one (its parent exists and is writable)."""
    outdir = Path(outdir)
    if outdir.exists() and not outdir.is_dir():
        raise PhongSceneError(f"{outdir}: exists and is not a folder")
    check_output(outdir / "index.html" if outdir.is_dir() else outdir)


@contextmanager
def atomic_files(*paths: str | os.PathLike) -> Iterator[tuple[Path, ...]]:
    """Temporary paths for several files that must appear together or not at all (an .pov and
    its .ini): all are renamed into place only when the block succeeds."""
    with ExitStack() as stack:
        yield tuple(stack.enter_context(atomic_path(p)) for p in paths)


@contextmanager
def atomic_folder(outdir: str | os.PathLike) -> Iterator[Path]:
    """A temporary folder beside ``outdir`` to write a set of files into (a report); when the
    block succeeds each file is renamed into ``outdir`` (created, with its parents, if missing; files already there
    and not rewritten stay), and when it fails (a full disk) none is, and the temporary folder
    is removed: no half-written report."""
    outdir = Path(outdir)
    # A report folder is created with its parents, as write_report always did (diff --frames
    # writes OUTDIR/frame.####); the CLI checks that OUTDIR's parent exists before rendering.
    if not outdir.parent.exists():
        try:
            outdir.parent.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise PhongSceneError(f"{outdir}: cannot create its folder: {e.strerror or e}") from None
    check_output_folder(outdir)
    tmp = outdir.parent / f".{outdir.name}.{os.urandom(TEMP_NAME_BYTES).hex()}"
    made = False
    try:
        with held_signals():  # made and known to the cleanup before a signal is acted on
            tmp.mkdir()
            made = True
        yield tmp
        outdir.mkdir(exist_ok=True)
        with held_signals():  # the report's files moved in together
            for item in sorted(tmp.iterdir()):
                os.replace(item, outdir / item.name)
    finally:
        if made:
            with held_signals():
                shutil.rmtree(tmp, ignore_errors=True)


def write_text_atomic(path: str | os.PathLike, text: str, encoding: str = "utf-8") -> Path:
    """Write ``text`` to ``path`` atomically; returns ``path`` as a Path."""
    path = Path(path)
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding=encoding)
    return path


def _create_temporary(path: Path) -> tuple[Path, int]:
    """Create an empty, new file beside ``path``: (its path, the mode it was created with).

    ``os.open`` with ``CREATE_MODE`` lets the kernel apply the umask, which avoids reading the
    umask through ``os.umask`` (that changes it process-wide for a moment)."""
    for _ in range(TEMP_NAME_ATTEMPTS):
        tmp = path.with_name(f".{path.stem}.{os.urandom(TEMP_NAME_BYTES).hex()}{path.suffix}")
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, CREATE_MODE)
        except FileExistsError:
            continue
        try:
            mode = os.fstat(fd).st_mode & 0o777
        finally:
            os.close(fd)
        return tmp, mode
    raise FileExistsError(f"{path.parent}: no free temporary file name for {path.name}")
