# SPDX-License-Identifier: Apache-2.0
"""One entry point for both backends: ``render(scene_or_path, backend=..., width=, height=, spp=)``
returns the common image (linear float32 (H, W, 3), row 0 at the top, as an ``Image``); with it, what every command does before it
renders: load the scene (``load_scene``) and apply the size, sample, thread and mapping
overrides (``phongscene.overrides.RenderOverrides``). Backends are imported on first use, so that ``import phongscene``
stays light and a missing backend fails only when asked for."""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING, Literal

import numpy as np

from .errors import BackendError, InvalidValueError, Problem, SceneError
from .overrides import RenderOverrides
from .scene import RenderSettings, Scene
from .validate import check

if TYPE_CHECKING:
    from .images import Image

Backend = Literal["native", "povray"]
BACKENDS: tuple[str, ...] = ("native", "povray")


def settings_for(scene: Scene, settings: RenderSettings | None = None, *, mapping: str | None = None) -> RenderSettings:
    """The settings to render with: ``settings`` (default: the scene's), with the specular
    convention that POV-Ray ``mapping`` reproduces when one is given (the CLI's ``--mapping``;
    ValueError for an unknown one)."""
    settings = scene.settings if settings is None else settings
    if mapping is not None:
        from .backends.povray import specular_of  # the mapping is the POV-Ray backend's vocabulary

        # POV-Ray's refracted rays carry kt, without the book's 1/η² (ref §18): like with like.
        settings = replace(settings, specular=specular_of(mapping), transmission="povray")
    return settings


def settings_with(
    scene: Scene,
    mapping: str | None = None,
    *,
    width: int | None = None,
    height: int | None = None,
    samples: int | None = None,
    threads: int | None = None,
    sample_pattern: str | None = None,
    aa_threshold: float | None = None,
) -> RenderSettings:
    """The scene's settings with the overrides that are not None applied, and the specular
    convention that the POV-Ray ``mapping`` reproduces (None: the scene's): ``RenderOverrides(...)
    .settings(scene)``. Giving only one of width/height keeps the aspect ratio."""
    return RenderOverrides(
        mapping=mapping,
        width=width,
        height=height,
        samples=samples,
        threads=threads,
        sample_pattern=sample_pattern,
        aa_threshold=aa_threshold,
    ).settings(scene)


def load_scene(
    scene_or_path: Scene | str | os.PathLike,
    time: float | None = None,
    *,
    sandbox: bool | None = None,
    camera: str | None = None,
    subdivision_level: int | None = None,
) -> tuple[Scene, list[str]]:
    """A Scene as given, or read from a USD file (or a ``phongscene.usd.OpenStage`` of one) at USD
    time code ``time`` (None: the reader's choice, ``phongscene.usd.read_usd``), with the reader's
    warnings (raises SceneError for a bad file). The file is read by ``phongscene.scene_files``:
    in a child process with a memory limit (``phongscene.sandbox``) unless it is safe to read in
    process (``sandbox`` None: decided per file; True / False: always / never the child), so a
    crash inside USD is a SceneError. ``camera``: the path of the Camera prim to render through
    (None: the reader's choice); a Scene given keeps its camera. ``subdivision_level``: every
    subdivision surface's refinement level (None: the scene's, ``phongscene.usd.subdivision``)."""
    if isinstance(scene_or_path, Scene):
        return scene_or_path, []
    from .scene_files import read_scene_file

    result = read_scene_file(scene_or_path, time, sandbox=sandbox, camera=camera, subdivision_level=subdivision_level)
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
    if not isinstance(scene, Scene):  # a path or a stage given where the model is expected
        raise TypeError(
            f"expected a phongscene Scene (phongscene.load_usd(path) reads a USD file), got "
            f"{type(scene).__name__} {scene!r:.80}"
        )
    if settings is None:
        settings = scene.settings  # a wrong type here is one of the scene's problems, below
    elif not isinstance(settings, RenderSettings):
        raise InvalidValueError(
            Problem(f"expected a RenderSettings, got {type(settings).__name__}", attribute="settings")
        )
    try:
        check(replace(scene, settings=settings))
    except SceneError as e:
        raise in_file_terms(e) from None
    return settings


def render(
    scene: Scene | str | os.PathLike,
    backend: Backend = "native",
    settings: RenderSettings | None = None,
    *,
    width: int | None = None,
    height: int | None = None,
    spp: int | None = None,
    threads: int | None = None,
    mapping: str | None = None,
    overrides: RenderOverrides | None = None,
    progress: Callable | None = None,
    timeout: float | None = None,
    explain: bool = True,
) -> Image:
    """Render a scene with one backend.

    ``phongscene.render("scene.usda", width=64)`` and ``render(scene, "povray", settings)``
    both work.

    Args:
        scene: a Scene (``phongscene.load_usd`` or built in Python) or the path of a USD file
            (its reader warnings are issued as ``phongscene.SceneWarning``); validated first.
        backend: "native" (the C++ tracer) or "povray".
        settings: render settings; default ``scene.settings``. ``settings.specular`` chooses
            the convention for either backend (POV-Ray renders "seed" with its exact mapping,
            "povray-classic" with its classic one).
        width, height: image size override; one alone keeps the aspect ratio.
        spp: anti-aliasing override, N x N samples per pixel (``RenderSettings.samples``, the
            CLI's ``--spp``).
        threads: worker threads override (0 = all cores).
        mapping: "exact" or "classic": the specular convention the POV-Ray mapping reproduces
            (the CLI's ``--mapping``); default: the settings'.
        overrides: all the knobs as one ``RenderOverrides`` (instead of width ... mapping; its
            ``time`` reads a USD file at that time code, its shadow fields change the area lights).
        progress: called with the backend's progress reports.
        timeout: POV-Ray only: seconds before the render is abandoned.
        explain: check the image (``phongscene.diagnostics``): a ``phongscene.ImageWarning``
            for one that shows nothing, no light or too little, naming the cause.

    Returns:
        An ``Image``: a numpy array, linear float32 (H, W, 3), row 0 at the top, that Jupyter
        shows as an sRGB PNG. An image that shows nothing, no light or too little of it comes
        with a ``phongscene.ImageWarning`` naming the cause (``phongscene.diagnostics``).

    Raises:
        FileNotFoundError: the USD file does not exist (a ``SceneError`` too).
        SceneError: the scene or the settings are invalid (every problem listed).
        BackendError: the backend is unavailable or failed.
    """
    if backend not in BACKENDS:
        raise ValueError(f"unknown backend {backend!r}; expected one of {', '.join(BACKENDS)}")
    named = {"width": width, "height": height, "samples": spp, "threads": threads, "mapping": mapping}
    if overrides is None:
        overrides = RenderOverrides(**named)
    elif any(v is not None for v in named.values()):
        raise TypeError("render: give overrides= or the separate width, height, spp, threads, mapping, not both")
    import warnings

    from .diagnostics import ImageChecks
    from .errors import ImageWarning, SceneWarning

    reader_warnings: list[str] = []
    if not isinstance(scene, Scene):
        scene, reader_warnings = load_scene(
            scene, overrides.time, camera=overrides.camera, subdivision_level=overrides.subdivision_level
        )
        for text in reader_warnings:
            warnings.warn(f"{scene.source_file}: {text}", SceneWarning, stacklevel=2)
    scene = overrides.scene(scene)
    if overrides.given():
        settings = overrides.settings(scene, settings)
    prepared = prepare_render(scene, backend, settings, progress=progress, timeout=timeout)
    if not explain:
        return prepared()
    checks = ImageChecks.of(scene, settings, reader_warnings)  # validated: the scene's numbers are finite
    image = prepared()
    where = f"{scene.source_file}: " if scene.source_file else ""
    for text in checks.warnings(image):
        warnings.warn(f"{where}{text}", ImageWarning, stacklevel=2)
    return image


def prepare_render(
    scene: Scene,
    backend: Backend = "native",
    settings: RenderSettings | None = None,
    *,
    progress: Callable | None = None,
    timeout: float | None = None,
) -> Callable[[], Image]:
    """``render`` of a loaded scene in two steps: validates ``scene`` with ``settings`` and, for
    the native backend, builds its C++ scene now; calling the result renders (the same image as
    ``render``). The native result holds no reference to ``scene``: a caller that drops it frees
    the model's arrays before the render (the CLI does, for memory).

    Raises:
        SceneError, BackendError: as ``render``, here or when called.
    """
    from .images import Image  # OpenImageIO, only when rendering

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

    def in_file_terms_of_the_backend(run: Callable[[], np.ndarray]) -> Callable[[], Image]:
        def call() -> Image:
            try:
                return run().view(Image)
            except SceneError as e:  # a backend's own check (e.g. a number not finite in the SDL)
                raise in_file_terms(e) from None

        return call

    if backend == "povray":
        return in_file_terms_of_the_backend(lambda: module.render(scene, settings, progress=progress, timeout=timeout))
    try:
        prepared = module.prepare(scene, settings, progress=progress)
    except SceneError as e:
        raise in_file_terms(e) from None
    return in_file_terms_of_the_backend(prepared)


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
