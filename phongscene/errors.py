# SPDX-License-Identifier: Apache-2.0
"""Exceptions. Every scene problem names the file, the USD prim path and the attribute."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class Problem:
    """One thing wrong with a scene."""

    message: str  # what was expected and what was found
    prim: str = ""  # USD prim path ("" for scenes built in Python)
    attribute: str = ""  # attribute name on that prim, or a model field name
    file: str = ""  # the USD file
    # The model node type (e.g. "PhongMaterial") when ``attribute`` is one of its fields: the USD
    # layer translates it into the USD attribute (phongscene.usd.names.in_usd_terms).
    node: str = ""

    def __str__(self) -> str:
        where = self.prim + (f".{self.attribute}" if self.attribute else "") if self.prim else self.attribute
        parts = [p for p in (self.file, where) if p]
        return (": ".join(parts) + ": " if parts else "") + self.message


class PhongSceneError(Exception):
    """Base class of every error phongscene raises on purpose."""


class SceneError(PhongSceneError):
    """A scene could not be read or is invalid; ``problems`` lists every problem found."""

    def __init__(self, problems: list[Problem] | Problem | str):
        if isinstance(problems, (Problem, str)):
            problems = [problems if isinstance(problems, Problem) else Problem(problems)]
        self.problems = list(problems)
        super().__init__("\n".join(str(p) for p in self.problems))


class SceneFileNotFoundError(SceneError, FileNotFoundError):
    """The scene (or mesh) file does not exist: a SceneError (the CLI's exit 2) that is also the
    FileNotFoundError Python code expects."""

    def __init__(self, path: str):
        SceneError.__init__(self, Problem("file not found", file=path))
        self.filename = path
        self.errno = 2  # ENOENT, as os.stat would say

    def __str__(self) -> str:
        return SceneError.__str__(self)


class SceneWarning(UserWarning):
    """Something in a scene file that the model cannot represent (issued by ``render(path)``)."""


class ImageWarning(SceneWarning):
    """A rendered image that shows nothing, no light or too little of it, with the cause found in
    the scene (``phongscene.diagnostics``; issued by ``render``)."""


class BackendError(PhongSceneError):
    """A renderer failed. ``detail`` holds the tail of its output, ``kept`` a path kept for
    inspection (e.g. the .pov file)."""

    def __init__(self, message: str, detail: str = "", kept: str = ""):
        self.detail = detail
        self.kept = kept
        text = message
        if kept:
            text += f"\n  kept: {kept}"
        if detail:
            text += "\n  " + "\n  ".join(detail.rstrip().splitlines())
        super().__init__(text)
