# SPDX-License-Identifier: Apache-2.0
"""POV-Ray backend: compile a Scene to POV-Ray 3.7 SDL, run povray, read the image back."""

from phongscene.rendering import MAPPINGS

from .compile import compile_pov, pass_count, resolve_mapping, sanitize_comment
from .run import INSTALL_HINT, PovJob, prepare, render, render_many, render_switches

__all__ = [
    "INSTALL_HINT",
    "MAPPINGS",
    "PovJob",
    "compile_pov",
    "pass_count",
    "prepare",
    "render",
    "render_many",
    "render_switches",
    "resolve_mapping",
    "sanitize_comment",
]
