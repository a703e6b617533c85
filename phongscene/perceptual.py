# SPDX-License-Identifier: Apache-2.0
"""Comparing with another renderer: NVIDIA's FLIP (``compare --metric flip``) and a report that
ranks failing *regions*, not single pixels.

A render from another renderer (Cycles, a reference path tracer) never agrees with ours to half
precision: its noise and its light transport differ everywhere, so a pixel-by-pixel verdict fails
most pixels, and a list of the worst pixels by relative error starts with near-black ones. FLIP
(Andersson et al. 2020, the PyPI package ``flip-evaluator``, an optional dependency) models what
a viewer sees when flipping between the two images: its error map is high where an object is
wrong and low where noise differs. ``failing_regions`` then ranks square tiles of the image by
their total error, so a report points at the wrong object, not at a pixel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# A pixel fails where its FLIP error reaches this (FLIP: 0 identical, 1 the largest perceivable
# difference). Measured on tests/cross/test_compare_foreign.py's images: relative render noise of
# 2 % peaks at FLIP 0.09 and 5 % (an unconverged reference) at 0.19, while an object of the wrong
# colour is at 0.96-0.97; a quarter sits between with a margin on both sides.
FLIP_FAIL = 0.25
# The images pass when at most this % of the pixels fail (a converged image against another
# renderer's: a few edge pixels where their anti-aliasing differs).
FLIP_FAIL_PERCENT = 1.0
# Regions are square tiles of this many pixels a side: objects in a test render are tens of pixels
# across, so a tile is part of one object, and 16 keeps a 1280-pixel image to 80 tiles a row.
REGION_SIZE = 16
# Regions listed in a report (the worst first).
REGIONS_LISTED = 10


@dataclass(frozen=True, slots=True)
class Region:
    """A square tile of the image and its errors."""

    x: int  # left column
    y: int  # top row
    width: int
    height: int
    failing_pixels: int
    total_error: float  # the sum of its pixels' errors (what regions are ranked by)
    max_error: float

    def __str__(self) -> str:
        return (
            f"({self.x}, {self.y})-({self.x + self.width - 1}, {self.y + self.height - 1}): "
            f"{self.failing_pixels} failing pixels, total error {self.total_error:.4g}, max {self.max_error:.4g}"
        )


def failing_regions(error: np.ndarray, failing: np.ndarray, size: int = REGION_SIZE) -> list[Region]:
    """The tiles of ``size`` pixels that hold a failing pixel (``failing``, (H, W) bool), ranked
    by the sum of ``error`` ((H, W)) over their failing pixels, the worst first."""
    height, width = error.shape
    rows, cols = math.ceil(height / size), math.ceil(width / size)
    pad = ((0, rows * size - height), (0, cols * size - width))
    counted = np.pad(np.where(failing, error, 0.0), pad).reshape(rows, size, cols, size)
    counts = np.pad(failing, pad).reshape(rows, size, cols, size).sum(axis=(1, 3))
    totals, peaks = counted.sum(axis=(1, 3)), counted.max(axis=(1, 3))
    order = np.lexsort((-peaks.ravel(), -totals.ravel()))
    regions = []
    for index in order:
        r, c = divmod(int(index), cols)
        if counts[r, c] == 0:
            break
        regions.append(
            Region(
                c * size,
                r * size,
                min(size, width - c * size),
                min(size, height - r * size),
                int(counts[r, c]),
                float(totals[r, c]),
                float(peaks[r, c]),
            )
        )
    return regions


@dataclass(frozen=True)
class FlipReport:
    """The outcome of ``flip_compare``."""

    width: int
    height: int
    mean_error: float  # FLIP's mean over the image
    error_map: np.ndarray  # (H, W) FLIP error per pixel, in [0, 1]
    failing_pixels: int  # pixels whose FLIP error reaches FLIP_FAIL
    regions: tuple[Region, ...]  # failing regions, the worst first
    dynamic_range: str  # "HDR" (linear floats) or "LDR" (8-bit sRGB)
    fail_percent: float = FLIP_FAIL_PERCENT

    @property
    def failing_percent(self) -> float:
        return 100.0 * self.failing_pixels / (self.width * self.height)

    @property
    def ok(self) -> bool:
        return self.failing_percent <= self.fail_percent

    def summary(self) -> str:
        lines = [
            f"  size        {self.width} x {self.height}  (FLIP, {self.dynamic_range})",
            f"  mean FLIP   {self.mean_error:.4g}",
            f"  {self.failing_pixels} pixels ({self.failing_percent:.4g}%) fail (FLIP >= {FLIP_FAIL:g}; allowed "
            f"{self.fail_percent:g}%)",
        ]
        if self.regions:
            lines.append(f"  worst regions ({REGION_SIZE} x {REGION_SIZE} tiles, by total FLIP error):")
            lines += [f"    {region}" for region in self.regions[:REGIONS_LISTED]]
        lines.append("  PASS" if self.ok else "  FAILURE")
        return "\n".join(lines)


def flip_available() -> bool:
    try:
        import flip_evaluator  # noqa: F401
    except ImportError:
        return False
    return True


def flip_compare(a, b, *, ldr: bool = False, fail_percent: float = FLIP_FAIL_PERCENT) -> FlipReport:
    """FLIP between reference ``a`` and test ``b``: linear float images (H, W, 3) as
    ``read_image`` gives them. ``ldr``: both came from 8-bit sRGB files; they are compared as
    FLIP's LDR images (sRGB-encoded, clipped to [0, 1]), else as HDR (linear, FLIP's exposure
    range).

    Raises:
        ImportError: flip-evaluator is not installed (``pip install 'phongscene[flip]'``).
        ImageMismatchError: the images differ in size.
    """
    from .comparison import ImageMismatchError

    try:
        import flip_evaluator
    except ImportError:
        raise ImportError(
            "compare --metric flip needs NVIDIA's FLIP: pip install flip-evaluator (or phongscene[flip])"
        ) from None
    a, b = (np.ascontiguousarray(x, dtype=np.float32) for x in (a, b))
    if a.shape != b.shape:
        raise ImageMismatchError(
            f"the images differ in size: {a.shape[1]} x {a.shape[0]} vs {b.shape[1]} x {b.shape[0]}"
        )
    if ldr:
        a, b = (_srgb(np.clip(x, 0.0, 1.0)) for x in (a, b))
    else:
        a, b = (np.nan_to_num(np.maximum(x, 0.0), nan=0.0, posinf=np.finfo(np.float32).max) for x in (a, b))
    error, mean, _ = flip_evaluator.evaluate(a, b, "LDR" if ldr else "HDR", applyMagma=False)
    error = np.asarray(error, dtype=np.float64).reshape(a.shape[:2])
    failing = error >= FLIP_FAIL
    return FlipReport(
        a.shape[1],
        a.shape[0],
        float(mean),
        error,
        int(failing.sum()),
        tuple(failing_regions(error, failing)),
        "LDR" if ldr else "HDR",
        fail_percent,
    )


def _srgb(linear: np.ndarray) -> np.ndarray:
    return np.where(linear <= 0.0031308, 12.92 * linear, 1.055 * np.power(linear, 1 / 2.4) - 0.055).astype(np.float32)
