# SPDX-License-Identifier: Apache-2.0
"""POV-Ray backend: compile a Scene to POV-Ray 3.7 SDL, run povray, read the image back.

Its mappings (``exact``, ``classic``) are how it renders each specular convention of the model
(``RenderSettings.specular``); they are this backend's own vocabulary, defined in ``compile``.
"""

from .compile import (
    MAPPING_OF_SPECULAR,
    MAPPINGS,
    SPECULAR_OF_MAPPING,
    check_mapping,
    compile_pov,
    pass_count,
    pass_scenes,
    resolve_mapping,
    sanitize_comment,
    specular_of,
)
from .run import INSTALL_HINT, PovJob, prepare, render, render_many, render_switches

__all__ = [
    "INSTALL_HINT",
    "MAPPINGS",
    "MAPPING_OF_SPECULAR",
    "SPECULAR_OF_MAPPING",
    "PovJob",
    "check_mapping",
    "compile_pov",
    "pass_count",
    "pass_scenes",
    "prepare",
    "render",
    "render_many",
    "render_switches",
    "resolve_mapping",
    "sanitize_comment",
    "specular_of",
]
