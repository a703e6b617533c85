# SPDX-License-Identifier: Apache-2.0
"""One entry point for both backends: ``render(scene, backend=...)`` returns the common image
(linear float32 (H, W, 3), row 0 at the top); with it, what every command does before it
renders: load the scene (``load_scene``) and apply the size, sample, thread and mapping
overrides (``settings_with``). Backends are imported on first use, so that ``import phongscene``
stays light and a missing backend fails only when asked for."""

from __future__ import annotations

import os
from dataclasses import replace
from typing import Callable, Literal

import numpy as np

from .errors import BackendError, SceneError
from .scene import RenderSettings, Scene
from .validate import check

Backend = Literal["native", "povray"]
BACKENDS: tuple[str, ...] = ("native", "povray")


def settings_for(scene: Scene, settings: RenderSettings | None = None, *, mapping: str | None = None) -> RenderSettings:
    """The settings to render with: ``settings`` (default: the scene's), with the specular
    convention that POV-Ray ``mapping`` reproduces when one is given (the CLI's ``--mapping``;
    ValueError for an unknown one)."""
    settings = scene.settings if settings is None else settings
    if mapping is not None:
        from .backends.povray import specular_of  # the mapping is the POV-Ray backend's vocabulary

        settings = replace(settings, specular=specular_of(mapping))
    return settings


def settings_with(
    scene: Scene,
    mapping: str | None = None,
    *,
    width: int | None = None,
    height: int | None = None,
    samples: int | None = None,
    threads: int | None = None,
) -> RenderSettings:
    """The scene's settings with the overrides that are not None applied, and the specular
    convention that the POV-Ray ``mapping`` reproduces (None: the scene's). Giving only one of
    width/height keeps the aspect ratio."""
    s = settings_for(scene, mapping=mapping)
    if width is not None and height is None:
        height = max(1, round(width * s.height / s.width))
    elif height is not None and width is None:
        width = max(1, round(height * s.width / s.height))
    changes = {"width": width, "height": height, "samples": samples, "threads": threads}
    return replace(s, **{k: v for k, v in changes.items() if v is not None})


def load_scene(scene_or_path: Scene | str | os.PathLike, time: float | None = None) -> tuple[Scene, list[str]]:
    """A Scene as given, or read from a USD file at USD time code ``time`` (None: the reader's
    choice, ``phongscene.usd.read_usd``), with the reader's warnings (raises SceneError for a bad
    file)."""
    if isinstance(scene_or_path, Scene):
        return scene_or_path, []
    from .usd import read_usd  # lazily: the USD reader imports pxr

    result = read_usd(os.fspath(scene_or_path), time=time)
    return result.scene, list(result.warnings)


def in_file_terms(error: SceneError) -> SceneError:
    """``error`` naming USD attributes instead of model fields for nodes read from USD (their
    prims are USD paths), so a user reads the names in their file."""
    if not any(p.node and p.prim.startswith("/") for p in error.problems):
        return error
    from .usd.names import error_in_usd_terms

    return error_in_usd_terms(error)


def check_settings(scene: Scene, settings: RenderSettings | None = None) -> RenderSettings:
    """Validate ``scene`` rendered with ``settings`` (default: its own) and return the settings.

    The backends assume a valid scene (C++ only asserts): a scene built in Python or settings
    changed after loading are checked here. ~20 ms for a million triangles.

    Raises:
        SceneError: every problem, in the terms of the file the scene came from.
    """
    settings = scene.settings if settings is None else settings
    try:
        check(replace(scene, settings=settings))
    except SceneError as e:
        raise in_file_terms(e) from None
    return settings


def render(
    scene: Scene,
    backend: Backend = "native",
    settings: RenderSettings | None = None,
    *,
    progress: Callable | None = None,
    timeout: float | None = None,
) -> np.ndarray:
    """Render ``scene`` with one backend.

    Args:
        scene: a scene (``phongscene.load_usd`` or built in Python); it is validated first.
        backend: "native" (the C++ tracer) or "povray".
        settings: render settings; default ``scene.settings``. ``settings.specular`` chooses
            the convention for either backend (POV-Ray renders "seed" with its exact mapping,
            "povray-classic" with its classic one).
        progress: called with the backend's progress reports.
        timeout: POV-Ray only: seconds before the render is abandoned.

    Returns:
        Linear float32 image (H, W, 3), row 0 at the top.

    Raises:
        SceneError: the scene or the settings are invalid (every problem listed).
        BackendError: the backend is unavailable or failed.
    """
    if backend not in BACKENDS:
        raise ValueError(f"unknown backend {backend!r}; expected one of {', '.join(BACKENDS)}")
    settings = check_settings(scene, settings)
    try:
        if backend == "native":
            from .backends import native as module
        else:
            from .backends import povray as module
    except ImportError as e:
        raise BackendError(f"the {backend} backend is not available: {e}") from e
    try:
        if backend == "native":
            return module.render(scene, settings, progress=progress)
        return module.render(scene, settings, progress=progress, timeout=timeout)
    except SceneError as e:  # a backend's own check (e.g. a number not finite in the SDL)
        raise in_file_terms(e) from None


def compile_pov(scene: Scene, settings: RenderSettings | None = None, mapping: str | None = None) -> str:
    """Validate ``scene`` and compile it to POV-Ray 3.7 SDL.

    Args:
        scene: the scene.
        settings: render settings (default: the scene's).
        mapping: "exact" or "classic"; default: the one that renders ``settings.specular``.

    Returns:
        The SDL text (``phongscene.backends.povray.compile_pov`` documents its passes).

    Raises:
        SceneError: the scene is invalid (every problem listed, in the file's terms).
        ValueError: ``mapping`` is unknown.
    """
    from .backends import povray

    settings = check_settings(scene, settings)
    try:
        return povray.compile_pov(scene, settings, mapping)
    except SceneError as e:
        raise in_file_terms(e) from None
