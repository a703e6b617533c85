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

from .errors import BackendError
from .scene import RenderSettings, Scene
from .validate import check

Backend = Literal["native", "povray"]
BACKENDS: tuple[str, ...] = ("native", "povray")
Mapping = Literal["exact", "classic"]
# POV-Ray mapping ↔ the native specular convention it reproduces (DESIGN §4).
SPECULAR_OF_MAPPING: dict[str, str] = {"exact": "seed", "classic": "povray-classic"}
MAPPING_OF_SPECULAR: dict[str, str] = {v: k for k, v in SPECULAR_OF_MAPPING.items()}
MAPPINGS: tuple[str, ...] = tuple(SPECULAR_OF_MAPPING)


def check_mapping(mapping: str) -> str:
    """``mapping`` if it is a POV-Ray mapping; otherwise ValueError naming the known ones."""
    if mapping not in SPECULAR_OF_MAPPING:
        raise ValueError(f"unknown POV-Ray mapping {mapping!r}; expected one of {', '.join(MAPPINGS)}")
    return mapping


def settings_for(scene: Scene, settings: RenderSettings | None = None, *, mapping: str | None = None) -> RenderSettings:
    """The settings to render with: ``settings`` (default: the scene's), with the specular
    convention set by ``mapping`` when one is given."""
    settings = scene.settings if settings is None else settings
    if mapping is not None:
        settings = replace(settings, specular=SPECULAR_OF_MAPPING[check_mapping(mapping)])
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


def load_scene(scene_or_path: Scene | str | os.PathLike) -> tuple[Scene, list[str]]:
    """A Scene as given, or read from a USD file, with the reader's warnings (raises
    SceneError for a bad file)."""
    if isinstance(scene_or_path, Scene):
        return scene_or_path, []
    from .usd import read_usd  # lazily: the USD reader imports pxr

    result = read_usd(os.fspath(scene_or_path))
    return result.scene, list(result.warnings)


def render(
    scene: Scene,
    backend: Backend = "native",
    settings: RenderSettings | None = None,
    *,
    mapping: Mapping | None = None,
    progress: Callable | None = None,
    timeout: float | None = None,
) -> np.ndarray:
    """Render ``scene`` with one backend.

    Args:
        scene: a validated scene (``phongscene.load_usd`` or built in Python).
        backend: "native" (the C++ tracer) or "povray".
        settings: render settings; default ``scene.settings``.
        mapping: POV-Ray mapping, "exact" (native convention "seed") or "classic" (native
            "povray-classic"); it sets ``settings.specular`` for either backend. Default: the
            one that matches ``settings.specular``.
        progress: called with the backend's progress reports.
        timeout: POV-Ray only: seconds before the render is abandoned.

    Returns:
        Linear float32 image (H, W, 3), row 0 at the top.

    Raises:
        SceneError: the scene or the settings are invalid (every problem listed).
        BackendError: the backend is unavailable or failed.
    """
    settings = settings_for(scene, settings, mapping=mapping)
    # The backends assume a valid scene (C++ only asserts): a scene built in Python or settings
    # changed after loading are checked here. ~20 ms for a million triangles.
    check(replace(scene, settings=settings))
    if backend == "native":
        try:
            from .backends import native
        except ImportError as e:
            raise BackendError(f"the native backend is not available: {e}") from e
        return native.render(scene, settings, progress=progress)
    if backend == "povray":
        try:
            from .backends import povray
        except ImportError as e:
            raise BackendError(f"the POV-Ray backend is not available: {e}") from e
        return povray.render(
            scene, settings, mapping=MAPPING_OF_SPECULAR[settings.specular], progress=progress, timeout=timeout
        )
    raise ValueError(f"unknown backend {backend!r}; expected one of {', '.join(BACKENDS)}")
