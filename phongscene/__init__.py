# SPDX-License-Identifier: Apache-2.0
"""phongscene: author Phong scenes in USD, compile them to POV-Ray 3.7, render them natively,
and diff the two backends."""

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
]
