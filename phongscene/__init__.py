# SPDX-License-Identifier: Apache-2.0
"""phongscene: author Phong scenes in USD, compile them to POV-Ray 3.7, render them natively,
and diff the two backends."""

import importlib as _importlib
import sys as _sys
import types as _types

from .errors import BackendError, PhongSceneError, Problem, SceneError
from .scene import (
    AmbientLight,
    Camera,
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

# compare / diff / render load on first use (OpenImageIO, the backends). Each name is both a
# submodule and its main function; the import system binds a submodule to the package attribute
# when it is first loaded, so the package's class swaps in the function at that moment.
_FUNCTION_MODULES = ("compare", "diff", "render")


class _Package(_types.ModuleType):
    def __setattr__(self, name, value):
        if name in _FUNCTION_MODULES and isinstance(value, _types.ModuleType):
            value = getattr(value, name)
        super().__setattr__(name, value)


_sys.modules[__name__].__class__ = _Package


def __getattr__(name: str):
    if name in ("load_usd", "read_usd", "write_usd"):  # USD I/O imports pxr: load it on first use
        return getattr(_importlib.import_module(".usd", __name__), name)
    if name == "compile_pov":  # the POV-Ray compiler (pure Python, numpy)
        return _importlib.import_module(".backends.povray", __name__).compile_pov
    if name in _FUNCTION_MODULES:
        _importlib.import_module(f".{name}", __name__)  # binds the function (see _Package)
        return globals()[name]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "AmbientLight",
    "BackendError",
    "Camera",
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
