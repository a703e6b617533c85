# SPDX-License-Identifier: Apache-2.0
"""Atomic output files: every file phongscene writes appears whole or not at all.

The data goes to a temporary file in the target's folder (same file system, so the final
``os.replace`` is atomic) and is renamed onto the target once complete; on any error the
temporary file is removed and an existing target is left untouched. The result gets the mode
a plainly created file would get (0666 minus the umask), not the 0600 of ``tempfile.mkstemp``.
"""

from __future__ import annotations

import os
import secrets
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

# Permissions before the umask, as for open(path, "w"): outputs are meant to be shared
# (reports are served as web pages, SDL is handed to povray), not private.
CREATE_MODE = 0o666
# Random bytes in a temporary name; a clash is retried, so this only has to make one unlikely.
TEMP_NAME_BYTES = 6
TEMP_NAME_ATTEMPTS = 100


@contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """A temporary path to write ``path`` through, for libraries that write by file name
    (OpenImageIO, USD's ``Export``). It sits in ``path``'s folder (created if needed) and keeps
    its suffix, so format detection by extension works; the file exists and is empty. When the
    block finishes it is renamed onto ``path``; when it raises, it is deleted.

    Example::

        with atomic_path("out.exr") as tmp:
            buf.write(str(tmp))
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp, mode = _create_temporary(path)
    try:
        yield tmp
        os.chmod(tmp, mode)  # the writer may have replaced the file with one of its own
        os.replace(tmp, path)
    finally:
        if os.path.lexists(tmp):
            os.unlink(tmp)


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
        tmp = path.with_name(f".{path.stem}.{secrets.token_hex(TEMP_NAME_BYTES)}{path.suffix}")
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
