# SPDX-License-Identifier: Apache-2.0
"""POV-Ray backend: compile a Scene to POV-Ray 3.7 SDL, run povray, read the image back.

Its mappings (``exact``, ``classic``) are how it renders each specular convention of the model
(``RenderSettings.specular``); they are this backend's own vocabulary, defined in ``mappings``.
The compiler and the runner are imported on first use (PEP 562): a native render names a
mapping and needs neither (issue 15: start-up).
"""

from typing import TYPE_CHECKING

from .mappings import (
    MAPPING_OF_SPECULAR,
    MAPPINGS,
    SPECULAR_OF_MAPPING,
    check_mapping,
    exact_mapping_obstacle,
    resolve_mapping,
    specular_of,
)

# Exported on first use: name -> submodule.
_LAZY_EXPORTS = {
    "compile_pov": "compile",
    "pass_count": "compile",
    "pass_scenes": "compile",
    "sanitize_comment": "compile",
    "write_pov": "compile",
    "INSTALL_HINT": "run",
    "PovJob": "run",
    "pov_quoted": "run",
    "prepare": "run",
    "render": "run",
    "render_many": "run",
    "render_switches": "run",
}

if TYPE_CHECKING:
    from .compile import compile_pov, pass_count, pass_scenes, sanitize_comment, write_pov
    from .run import INSTALL_HINT, PovJob, pov_quoted, prepare, render, render_many, render_switches


def __getattr__(name: str):
    if name not in _LAZY_EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(f".{_LAZY_EXPORTS[name]}", __name__), name)
    globals()[name] = value  # later lookups skip __getattr__
    return value


__all__ = [
    "INSTALL_HINT",
    "MAPPINGS",
    "MAPPING_OF_SPECULAR",
    "SPECULAR_OF_MAPPING",
    "PovJob",
    "check_mapping",
    "compile_pov",
    "exact_mapping_obstacle",
    "pass_count",
    "pass_scenes",
    "pov_quoted",
    "prepare",
    "render",
    "render_many",
    "render_switches",
    "resolve_mapping",
    "sanitize_comment",
    "specular_of",
    "write_pov",
]
