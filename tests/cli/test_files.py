# SPDX-License-Identifier: Apache-2.0
"""phongscene.files: atomic outputs get the ordinary mode (0666 & ~umask), never mkstemp's 0600,
and leave nothing behind when the write fails."""

from __future__ import annotations

import os
import stat

import numpy as np
import pytest

from phongscene.files import atomic_path, write_text_atomic
from phongscene.images import write_image
from phongscene.scene import Scene, Sphere
from phongscene.usd import write_usd

# Two umasks whose results differ from each other and from 0600 in group and other bits.
UMASKS = (0o022, 0o027)


@pytest.fixture(params=UMASKS, ids=lambda m: f"umask{m:03o}")
def umask(request):
    previous = os.umask(request.param)
    yield request.param
    os.umask(previous)


def _mode(path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


def test_text_gets_the_normal_mode(tmp_path, umask):
    path = write_text_atomic(tmp_path / "a.txt", "hello")
    assert path.read_text() == "hello"
    assert _mode(path) == 0o666 & ~umask


def test_files_written_by_name_get_the_normal_mode(tmp_path, umask):
    # OpenImageIO and USD write by file name through atomic_path.
    image = write_image(tmp_path / "a.exr", np.zeros((2, 3, 3), np.float32))
    usd = write_usd(Scene(spheres=(Sphere.at((0.0, 0.0, 0.0), 1.0),)), tmp_path / "s.usda")
    assert _mode(image) == _mode(usd) == 0o666 & ~umask
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.exr", "s.usda"]


def test_a_failed_write_keeps_the_old_file_and_leaves_no_temporary(tmp_path):
    target = write_text_atomic(tmp_path / "a.txt", "old")
    with pytest.raises(RuntimeError), atomic_path(target) as tmp:
        tmp.write_text("half")
        raise RuntimeError("writer failed")
    assert target.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["a.txt"]


def test_the_temporary_keeps_the_suffix_for_format_detection(tmp_path):
    with atomic_path(tmp_path / "scene.usdc") as tmp:
        assert tmp.parent == tmp_path and tmp.suffix == ".usdc" and tmp.exists()
        tmp.write_bytes(b"x")
    assert (tmp_path / "scene.usdc").read_bytes() == b"x"


def test_an_image_that_does_not_read_back_whole_is_not_renamed_into_place(tmp_path):
    # A writer that reports success but leaves a truncated file (OpenImageIO's PNG writer on a
    # full disk): the target keeps its old content and no temporary file is left.
    import numpy as np
    from OpenImageIO import ImageBuf

    from phongscene.errors import PhongSceneError
    from phongscene.images import as_image, write_image, write_imagebuf

    target = tmp_path / "out.png"
    write_image(target, np.full((4, 6, 3), 0.5, np.float32))
    before = target.read_bytes()
    real = ImageBuf(as_image(np.zeros((4, 6, 3), np.float32)))

    class Truncating:
        has_error = False

        def write(self, name, fmt):
            real.write(name, fmt)
            with open(name, "rb") as f:
                data = f.read()
            with open(name, "wb") as f:
                f.write(data[: len(data) // 2])
            return True

        def spec(self):
            return real.spec()

        def geterror(self):
            return ""

    with pytest.raises(PhongSceneError, match="does not read back whole"):
        write_imagebuf(target, Truncating(), "uint8")
    assert target.read_bytes() == before and sorted(p.name for p in tmp_path.iterdir()) == ["out.png"]


def test_a_signal_as_the_temporary_file_is_made_or_removed_leaves_no_file(tmp_path, monkeypatch):
    # Python runs a signal's handler between any two bytecodes: one that came just as the hidden
    # temporary file was created (before the block that removes it began), or while it was being
    # removed, left `.out.<hex>.png` beside the output (a signal sweep: 1 of 300 sends).
    import signal

    from phongscene import files

    create = files._create_temporary

    def create_then_signal(path):
        made = create(path)
        signal.raise_signal(signal.SIGINT)  # arrives with the file made, before anyone knows it
        return made

    monkeypatch.setattr(files, "_create_temporary", create_then_signal)
    with pytest.raises(KeyboardInterrupt):
        with atomic_path(tmp_path / "out.png"):
            pass
    assert list(tmp_path.iterdir()) == []

    monkeypatch.setattr(files, "_create_temporary", create)
    unlink = os.unlink

    def signal_then_unlink(path):
        signal.raise_signal(signal.SIGINT)  # arrives as the cleanup removes the file
        unlink(path)

    monkeypatch.setattr(files.os, "unlink", signal_then_unlink)
    with pytest.raises(KeyboardInterrupt):
        with atomic_path(tmp_path / "out.png"):
            raise OSError("the write failed")
    assert list(tmp_path.iterdir()) == []
