# SPDX-License-Identifier: Apache-2.0
"""What a process that runs many tasks (a Dask worker) keeps between them: the USD file it
opened last (``open_stage``), so that each frame of an animation reads the model at its time
from a stage opened once.

A task still receives only the scene's path and its time: the cache is an optimisation inside
the worker, and a frame read from it is the same model ``phongscene render --time T`` reads
(tests/test_animation.py). A stage nothing of which varies in time is read once, and its
model reused while its files (layers, textures) are unchanged (``phongscene.usd.read_cache``);
where only lights' and gprims' own inputs vary, only those are read again at each time
(``phongscene.usd.read_parts``); otherwise each read reads the whole stage at its time."""

from __future__ import annotations

import os

# (path as given, the files it was composed from with their states, the open stage): one entry,
# a worker renders the frames of one file at a time.
_last: tuple[str, tuple[str, ...], tuple, object] | None = None


def open_stage(path: str):
    """``phongscene.usd.open_stage(path)``, reusing the stage this process opened last for the
    same path while neither its file nor any layer the stage was composed from has changed
    (modification time, size and inode: an edited, replaced or removed file is opened anew)."""
    global _last
    if _last is not None and _last[0] == path and _states(_last[1]) == _last[2]:
        return _last[3]
    from . import open_stage as open_usd

    if _last is not None and _last[0] == path:
        # USD keeps a layer that is still referenced (by the old stage, or a caller holding it) in
        # its registry and would hand it out again as it was: reread the old stage's layers.
        from pxr import Sdf, Tf

        from .diagnostics import usd_output

        try:
            # USD's "Unable to re-read" warning is held back: the open below says what is wrong.
            with usd_output([]):
                Sdf.Layer.ReloadLayers(set(_last[3].stage.GetUsedLayers()), force=True)
        except Tf.ErrorException:
            pass  # a layer that no longer parses: opening it anew below reports it (a SceneError naming it)
    _last = None  # release the old stage first
    opened = open_usd(path)
    files = _layer_files(path, opened.stage)
    _last = (path, files, _states(files), opened)
    return opened


def used_files(path: str) -> tuple[str, ...]:
    """The files the stage kept for ``path`` was composed from (its root and every layer it
    used), or only the root when no stage of it is kept (none opened yet, or the last open
    failed): what a live preview watches (``phongscene.preview``)."""
    if _last is not None and _last[0] == path:
        return _last[1]
    return (os.path.abspath(path),)


def _layer_files(path: str, stage) -> tuple[str, ...]:
    """The files on disk the stage was composed from: the root and every layer it used (a
    package's inner layer counts as the package)."""
    from pxr import Ar

    files = {os.path.abspath(path)}
    for layer in stage.GetUsedLayers():
        real = layer.realPath
        if real:
            files.add(Ar.SplitPackageRelativePathOuter(real)[0] if Ar.IsPackageRelativePath(real) else real)
    return tuple(sorted(files))


def _states(files: tuple[str, ...]) -> tuple:
    from .read_cache import file_state

    return tuple(file_state(file) for file in files)


def forget() -> None:
    """Drop the kept stage (tests; a long-lived process that is done with a file)."""
    global _last
    _last = None
