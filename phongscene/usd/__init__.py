# SPDX-License-Identifier: Apache-2.0
"""USD input and output: the only part of phongscene that imports ``pxr``.

Importing this package registers the Phong surface's Sdr definition (any import order works).
"""

from typing import TYPE_CHECKING

from .shader_defs import PHONG_RENDER_CONTEXT, PHONG_SHADER_ID, register_phong_shader

register_phong_shader()

from .materials import preview_to_phong  # noqa: E402
from .reader import OpenStage, ReadResult, load_usd, open_stage, read_usd  # noqa: E402

# The writer's names, imported on first use (PEP 562): reading a scene does not need the writer
# (nor the hashing and file helpers it imports), and a render's start-up is issue 15's.
_WRITER_NAMES = frozenset(
    {
        "bind_material",
        "define_camera",
        "define_light",
        "define_mesh",
        "define_phong_material",
        "define_render_settings",
        "define_sphere",
        "import_mesh",
        "new_stage",
        "save_stage",
        "scene_to_stage",
        "write_usd",
    }
)

if TYPE_CHECKING:
    from .writer import (
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


def __getattr__(name: str):
    if name not in _WRITER_NAMES:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    from . import writer

    value = getattr(writer, name)
    globals()[name] = value  # later lookups skip __getattr__
    return value


__all__ = [
    "PHONG_RENDER_CONTEXT",
    "PHONG_SHADER_ID",
    "OpenStage",
    "ReadResult",
    "load_usd",
    "open_stage",
    "preview_to_phong",
    "read_usd",
    "register_phong_shader",
    *sorted(_WRITER_NAMES),
]
