# SPDX-License-Identifier: Apache-2.0
"""phongscene: author Phong scenes in USD, compile them to POV-Ray 3.7, render them natively,
and diff the two backends."""

import importlib as _importlib
from typing import TYPE_CHECKING

from .errors import (
    BackendError,
    ImageWarning,
    PhongSceneError,
    Problem,
    SceneError,
    SceneFileNotFoundError,
    SceneWarning,
)

__version__ = "0.1.0"

# Exported on first use, name -> (module, attribute) (PEP 562 module __getattr__): these modules
# bring in OpenImageIO, pxr or a backend, which ``import phongscene`` does not need.
_LAZY_EXPORTS = {
    # The scene model (numpy): lazy too, so that the CLI's entry point imports nothing heavy
    # before main() installs its Ctrl-C handling.
    "AmbientLight": (".scene", "AmbientLight"),
    "Camera": (".scene", "Camera"),
    "Cone": (".scene", "Cone"),
    "DirectionalLight": (".scene", "DirectionalLight"),
    "PhongMaterial": (".scene", "PhongMaterial"),
    "PointLight": (".scene", "PointLight"),
    "Points": (".scene", "Points"),
    "RectAreaLight": (".scene", "RectAreaLight"),
    "RenderSettings": (".scene", "RenderSettings"),
    # The render knobs over a scene's own (render(overrides=...), diff(overrides=...)).
    "RenderOverrides": (".overrides", "RenderOverrides"),
    "Scene": (".scene", "Scene"),
    "Sphere": (".scene", "Sphere"),
    "SphereAreaLight": (".scene", "SphereAreaLight"),
    "TriangleMesh": (".scene", "TriangleMesh"),
    # Instancing: a prototype read once, placed by many transforms.
    "Prototype": (".scene", "Prototype"),
    "Instances": (".scene", "Instances"),
    # A perspective camera at an eye point looking at a target.
    "look_at": (".scene", "Camera.look_at"),
    "Image": (".images", "Image"),
    "Thresholds": (".comparison", "Thresholds"),
    "compare": (".comparison", "compare"),
    "compile_pov": (".rendering", "compile_pov"),
    "diff": (".crossvalidation", "diff"),
    # The warnings for a rendered image: nothing in view, no light, too dark, with their causes.
    "explain_image": (".diagnostics", "explain_image"),
    "load_usd": (".usd", "load_usd"),
    "open_stage": (".usd", "open_stage"),
    "read_usd": (".usd", "read_usd"),
    "render": (".rendering", "render"),
    "read_image": (".images", "read_image"),
    "write_image": (".images", "write_image"),
    "write_usd": (".usd", "write_usd"),
}

if TYPE_CHECKING:  # the lazy names, for type checkers and IDEs
    from .scene import (
        AmbientLight,
        Camera,
        Cone,
        DirectionalLight,
        Instances,
        PhongMaterial,
        PointLight,
        Points,
        Prototype,
        RectAreaLight,
        RenderSettings,
        Scene,
        Sphere,
        SphereAreaLight,
        TriangleMesh,
    )

    look_at = Camera.look_at
    from .comparison import Thresholds, compare
    from .crossvalidation import diff
    from .diagnostics import explain_image
    from .images import Image, read_image, write_image
    from .overrides import RenderOverrides
    from .rendering import compile_pov, render
    from .usd import load_usd, open_stage, read_usd, write_usd


def __getattr__(name: str):
    if name not in _LAZY_EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    module, attribute = _LAZY_EXPORTS[name]
    value = _importlib.import_module(module, __name__)
    for part in attribute.split("."):
        value = getattr(value, part)
    globals()[name] = value  # later lookups skip __getattr__
    return value


__all__ = [
    "AmbientLight",
    "BackendError",
    "Camera",
    "Cone",
    "DirectionalLight",
    "Image",
    "ImageWarning",
    "Instances",
    "PhongMaterial",
    "PhongSceneError",
    "PointLight",
    "Points",
    "Problem",
    "Prototype",
    "RectAreaLight",
    "RenderOverrides",
    "RenderSettings",
    "Scene",
    "SceneError",
    "SceneFileNotFoundError",
    "SceneWarning",
    "Sphere",
    "SphereAreaLight",
    "Thresholds",
    "TriangleMesh",
    "compare",
    "compile_pov",
    "diff",
    "explain_image",
    "load_usd",
    "open_stage",
    "look_at",
    "read_image",
    "read_usd",
    "render",
    "write_image",
    "write_usd",
]
