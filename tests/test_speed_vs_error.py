# SPDX-License-Identifier: Apache-2.0
"""The error metrics and the convergence fit of benchmarks/speed_vs_error.py, on images and error
series whose answers are known in closed form."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "speed_vs_error.py"
HALF_ROUNDING = 2.0**-11
# The fit is exact for an exact power law; what is left is float64 rounding in log/polyfit.
FIT_TOLERANCE = 1e-9
# OIIO computes max and RMS in double from float32 pixels whose differences are exact here.
METRIC_TOLERANCE = 1e-6


@pytest.fixture(scope="module")
def sve():
    spec = importlib.util.spec_from_file_location("speed_vs_error", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_error_against_reference_counts_pixels_beyond_one_half_rounding(sve):
    reference = np.ones((2, 2, 3), dtype=np.float32)
    image = reference.copy()
    # 3·2⁻¹² and 2⁻¹² are exact float32 offsets from 1. Relative to mean(|a|, |b|) ≈ 1 the
    # first is 1.5 half roundings (counted), the second 0.5 (not counted).
    image[0, 0, 0] += 3 * 2.0**-12
    image[1, 1, 1] -= 2.0**-12
    errors = sve.error_against_reference(reference, image)
    assert errors["beyond_half_percent"] == 25.0  # 1 of 4 pixels
    assert errors["max"] == pytest.approx(1.5 * HALF_ROUNDING, rel=METRIC_TOLERANCE)
    # RMS over all 12 channel values.
    expected_rms = math.sqrt(((3 * 2.0**-12) ** 2 + (2.0**-12) ** 2) / 12)
    assert errors["rms"] == pytest.approx(expected_rms, rel=METRIC_TOLERANCE)


def test_error_against_reference_of_an_identical_image_is_zero(sve):
    reference = np.linspace(0.0, 2.0, 4 * 5 * 3, dtype=np.float32).reshape(4, 5, 3)
    assert sve.error_against_reference(reference, reference.copy()) == {
        "rms": 0.0, "max": 0.0, "beyond_half_percent": 0.0}


def test_convergence_recovers_the_order_of_a_power_law_and_extrapolates_it(sve):
    spacings = [1.0, 1 / 2, 1 / 3]
    errors = [0.3 * h**1.5 for h in spacings]
    fit = sve.convergence(spacings, errors, reference_spacing=1 / 9)
    assert fit["order"] == pytest.approx(1.5, rel=FIT_TOLERANCE)
    assert fit["reference_error_estimate"] == pytest.approx(0.3 * (1 / 9) ** 1.5, rel=FIT_TOLERANCE)


def test_grid_spacing_is_per_pixel_for_anti_aliasing_and_per_interval_for_area_lights(sve):
    assert sve.grid_spacing("anti-aliasing", 4) == 1 / 4  # 4 midpoints across a pixel
    assert sve.grid_spacing("area-light shadows", 5) == 1 / 4  # 5 trapezoid points, 4 intervals
