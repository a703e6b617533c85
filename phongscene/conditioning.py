# SPDX-License-Identifier: Apache-2.0
"""Ill-conditioned pixels: pixels whose value the scene does not fix to the precision ``diff``
compares at, so that two correct tracers may disagree there.

POV-Ray intersects its mesh2 data in float32 (vertices, normals and each triangle's plane
distance; docs/povray-3.7-semantics.md §7). The native tracer in POV-Ray's numerics holds the same floats but
not every float operation of POV-Ray's intersection code, so the two tracers' hit points on a
mesh may differ by a few float32 roundings of their coordinates. Where such a shift moves a
pixel beyond the compared tolerance, their difference there measures the pixel, not a tracer: a
pixel that sees, through glass and one internal reflection, a highlight of exponent 116 on a
triangle a few µm wide (OpenChessSet's pixel (77, 57) moves 0.2 % when its camera ray turns by
2⁻³⁰ rad, 13 % at 2⁻²⁴; the backends are 0.16 % apart there).

The probe: the native image rendered again from the camera turned by ``ILL_CONDITIONED_TILT``
about its up and its right axis, each way (four images, one C++ scene). A failing pixel is
ill-conditioned when

1. one of the four fails against the native image there (the same thresholds): a turn of one
   float32 rounding changes the pixel beyond the tolerance, and
2. the reference's value lies, channel by channel, between the smallest and the largest of the
   native image and the four (or agrees with one of them): what it shows is one of the values
   the turn reaches.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from .comparison import Thresholds, failing_mask
from .scene import Camera

# Radians a camera ray turns in the probe: float32's unit roundoff 2⁻²⁴. Turning a ray by u
# moves its hit point at distance t by t·u, what rounding the coordinates of points that far from
# the origin to float32 moves them by (POV-Ray's mesh data; scenes are framed from distances
# like their size). Measured on OpenChessSet at 160 x 120: 9 of 19,200 pixels move beyond
# half-float precision at 2⁻²⁴ rad, 1 at 2⁻³⁰.
ILL_CONDITIONED_TILT = 2.0**-24


def tilted_cameras(camera: Camera, angle: float = ILL_CONDITIONED_TILT) -> tuple[Camera, ...]:
    """``camera`` turned by ``angle`` radians about its up axis (either way) and its right axis
    (either way), in that order: the same eye point and projection."""
    f, u, r = (np.asarray(v, dtype=np.float64) for v in (camera.forward, camera.up, camera.right))
    c, s = np.cos(angle), np.sin(angle)
    out = []
    for sign in (1.0, -1.0):  # about up: forward turns towards ±right, up stays
        out.append(_with_axes(camera, c * f + sign * s * r, u))
    for sign in (1.0, -1.0):  # about right: forward turns towards ±up, up turns with it
        out.append(_with_axes(camera, c * f + sign * s * u, c * u - sign * s * f))
    return tuple(out)


def _with_axes(camera: Camera, forward: np.ndarray, up: np.ndarray) -> Camera:
    return replace(camera, forward=tuple(map(float, forward)), up=tuple(map(float, up)))


def ill_conditioned(
    reference: np.ndarray,
    native: np.ndarray,
    tilted: Sequence[np.ndarray],
    candidates: np.ndarray,
    thresholds: Thresholds,
) -> np.ndarray:
    """(H, W) bool: the ``candidates`` pixels (failing ones) that are ill-conditioned (the module's
    rule): some ``tilted`` image fails against ``native`` there, and ``reference`` lies between the
    smallest and largest of ``native`` and ``tilted`` in every channel, or agrees with one of them."""
    moves = np.zeros_like(candidates)
    agrees = np.zeros_like(candidates)
    for image in tilted:
        moves |= failing_mask(native, image, thresholds)
        agrees |= ~failing_mask(reference, image, thresholds)
    stack = np.stack([native, *tilted]).astype(np.float64)
    ref = np.asarray(reference, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        between = ((ref >= stack.min(axis=0)) & (ref <= stack.max(axis=0))).all(axis=2)
    return candidates & moves & (between | agrees)
