# SPDX-License-Identifier: Apache-2.0
"""phongscene: author Phong scenes in USD, compile them to POV-Ray 3.7, render them natively,
and diff the two backends."""

import importlib as _importlib

from .errors import BackendError, PhongSceneError, Problem, SceneError
from .scene import (
    AmbientLight,
    Camera,
    Cone,
    DirectionalLight,
    PhongMaterial,
    PointLight,
    RectAreaLight,
    RenderSettings,
    Scene,
    Sphere,
    SphereAreaLight,
    TriangleMesh,
)

__version__ = "0.1.0"

# Exported on first use, name -> (module, attribute) (PEP 562 module __getattr__): these modules
# bring in OpenImageIO, pxr or a backend, which ``import phongscene`` does not need.
_LAZY_EXPORTS = {
    "compare": (".comparison", "compare"),
    "compile_pov": (".backends.povray", "compile_pov"),
    "diff": (".crossvalidation", "diff"),
    "load_usd": (".usd", "load_usd"),
    "read_usd": (".usd", "read_usd"),
    "render": (".rendering", "render"),
    "write_usd": (".usd", "write_usd"),
}


def __getattr__(name: str):
    if name not in _LAZY_EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    module, attribute = _LAZY_EXPORTS[name]
    value = getattr(_importlib.import_module(module, __name__), attribute)
    globals()[name] = value  # later lookups skip __getattr__
    return value


__all__ = [
    "AmbientLight",
    "BackendError",
    "Camera",
    "Cone",
    "DirectionalLight",
    "PhongMaterial",
    "PhongSceneError",
    "PointLight",
    "Problem",
    "RectAreaLight",
    "RenderSettings",
    "Scene",
    "SceneError",
    "Sphere",
    "SphereAreaLight",
    "TriangleMesh",
    "compare",
    "compile_pov",
    "diff",
    "load_usd",
    "read_usd",
    "render",
    "write_usd",
]
