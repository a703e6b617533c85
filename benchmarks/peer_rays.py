# SPDX-License-Identifier: Apache-2.0
"""The rays a peer renderer traces to stand in for a native render of the same scene: the native
camera's primary rays through the pixel centres, and the points each light sends shadow rays to
(benchmarks/run.py's Embree and Mitsuba peers)."""

from __future__ import annotations

import numpy as np


def primary_rays(scene, settings) -> tuple[np.ndarray, np.ndarray]:
    """(origins, unit directions), float32, one per pixel in row order: the native camera's rays
    through the pixel centres (camera.hpp), perspective only."""
    cam = scene.camera
    w, h = settings.width, settings.height
    forward, up = np.asarray(cam.forward, float), np.asarray(cam.up, float)
    aspect = w / h
    right = np.cross(forward, up) * aspect
    direction = forward * (aspect / (2.0 * np.tan(np.radians(cam.horizontal_fov_deg) / 2.0)))
    j, i = np.mgrid[0:h, 0:w]
    u = ((i + 0.5) / w - 0.5).reshape(-1, 1)
    v = (0.5 - (j + 0.5) / h).reshape(-1, 1)
    d = direction + right * u + up * v
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.broadcast_to(np.asarray(cam.position, float), d.shape).astype(np.float32), d.astype(np.float32)


def shadow_targets(light) -> np.ndarray | None:
    """The points one hit sends shadow rays to for ``light``, (n, 3) float32: a point light's
    position (n = 1); a rectangular area light's full samples × samples grid, edges included (what
    the native tracer traces without ``adaptive``; S3's 9×9 = 81). None for lights a peer does not
    stand in for (directional and spherical area lights: no benchmark scene has them)."""
    from phongscene.scene import PointLight, RectAreaLight

    if isinstance(light, PointLight):
        return np.asarray([light.position], np.float32)
    if isinstance(light, RectAreaLight):
        s = np.linspace(-0.5, 0.5, light.samples)
        a, b = np.meshgrid(s, s, indexing="ij")
        grid = (
            np.asarray(light.center)
            + a.reshape(-1, 1) * np.asarray(light.axis_u)
            + b.reshape(-1, 1) * np.asarray(light.axis_v)
        )
        return grid.astype(np.float32)
    return None
