# SPDX-License-Identifier: Apache-2.0
"""USD input and output: the only part of phongscene that imports ``pxr``.

Importing this package registers the Phong surface's Sdr definition (any import order works).
"""

from .shader_defs import PHONG_RENDER_CONTEXT, PHONG_SHADER_ID, register_phong_shader

register_phong_shader()

from .materials import preview_to_phong  # noqa: E402
from .reader import OpenStage, ReadResult, load_usd, open_stage, read_usd  # noqa: E402
from .writer import (  # noqa: E402
    bind_material,
    define_camera,
    define_light,
    define_mesh,
    define_phong_material,
    define_render_settings,
    define_sphere,
    import_mesh,
    new_stage,
    save_stage,
    scene_to_stage,
    write_usd,
)

__all__ = [
    "PHONG_RENDER_CONTEXT",
    "PHONG_SHADER_ID",
    "OpenStage",
    "ReadResult",
    "bind_material",
    "define_camera",
    "define_light",
    "define_mesh",
    "define_phong_material",
    "define_render_settings",
    "define_sphere",
    "import_mesh",
    "new_stage",
    "open_stage",
    "save_stage",
    "scene_to_stage",
    "write_usd",
    "load_usd",
    "preview_to_phong",
    "read_usd",
    "register_phong_shader",
]
