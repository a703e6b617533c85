# SPDX-License-Identifier: Apache-2.0
"""phongscene.comparison: thresholds at half-float precision, locations, NaN/inf, sizes."""

from __future__ import annotations

import math

import numpy as np
import pytest
from OpenImageIO import ImageBuf, ImageBufAlgo

from phongscene.comparison import (
    HALF_FLOAT,
    HALF_ROUNDING_RELATIVE,
    ImageMismatchError,
    Thresholds,
    compare,
    failing_mask,
)
from phongscene.images import write_image


def _image(seed: int = 0, height: int = 12, width: int = 16, scale: float = 1.0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return (rng.random((height, width, 3)) * scale).astype(np.float32)


def test_compare_identical_images_pass():
    a = _image()
    r = compare(a, a.copy())
    assert r.ok and not r.hard_fail
    assert (r.max_error, r.mean_error, r.rms_error, r.failing_pixels) == (0.0, 0.0, 0.0, 0)
    assert r.worst is None and r.worst_pixels == ()


def test_compare_one_pixel_beyond_threshold_fails_with_location_and_values():
    a = _image()
    b = a.copy()
    b[7, 3, 2] += 0.01  # row 7, column 3, blue
    r = compare(a, b)
    assert not r.ok
    assert r.failing_pixels == 1
    assert r.failing_percent == pytest.approx(100 / (12 * 16))
    assert r.max_error == pytest.approx(0.01, rel=1e-5)
    w = r.worst
    assert (w.x, w.y, w.channel) == (3, 7, 2)
    assert w.a == tuple(map(float, a[7, 3])) and w.b == tuple(map(float, b[7, 3]))
    assert "@ (3, 7, B)" in r.summary() and "FAILURE" in r.summary()


def test_compare_half_float_rounding_passes_over_the_whole_range():
    # Values from the subnormal half range (< 2^-14) to large HDR values, rounded to half as
    # POV-Ray's EXR output is: every such difference is within the thresholds.
    rng = np.random.default_rng(1)
    exponents = rng.uniform(-26, 15, size=(24, 32, 3))
    a = (2.0**exponents).astype(np.float32)
    h = a.astype(np.float16).astype(np.float32)
    assert not np.array_equal(a, h)
    r = compare(a, h)
    assert r.ok, r.summary()
    assert r.max_relative_error <= HALF_ROUNDING_RELATIVE * (1 + 1e-6)


def test_compare_error_just_above_the_relative_threshold_fails():
    # The threshold is tight: 2 half-float roundings fail at 2.2·2^-11 relative error.
    a = np.full((4, 4, 3), 0.75, np.float32)
    b = a.copy()
    b[1, 2, 0] = 0.75 * (1 + 2.2 * HALF_ROUNDING_RELATIVE)
    b[2, 2, 0] = 0.75 * (1 + 1.8 * HALF_ROUNDING_RELATIVE)
    r = compare(a, b)
    assert r.failing_pixels == 1 and (r.worst.x, r.worst.y) == (2, 1)


def test_compare_relative_rule_is_oiio_mean_of_magnitudes():
    # The module docstring's claim about OIIO: relative error = |a-b| / mean(|a|, |b|), and a
    # value fails only when it is above both the absolute and the relative threshold.
    a, b = np.ones((1, 1, 3), np.float32), np.full((1, 1, 3), 1.5, np.float32)  # rel to mean 0.4
    assert ImageBufAlgo.compare(ImageBuf(a), ImageBuf(b), 1e-6, 1e-6, 0.39, 0.39).nfail == 1
    assert ImageBufAlgo.compare(ImageBuf(a), ImageBuf(b), 1e-6, 1e-6, 0.41, 0.41).nfail == 0  # max would be 0.33
    assert ImageBufAlgo.compare(ImageBuf(a), ImageBuf(b), 0.6, 0.6, 0.0, 0.0).nfail == 0


def test_compare_absolute_floor_covers_tiny_values():
    a = np.zeros((2, 2, 3), np.float32)
    b = a.copy()
    b[0, 0, 0] = HALF_FLOAT.fail  # one subnormal half step: agrees
    assert compare(a, b).ok
    b[0, 0, 0] = 3 * HALF_FLOAT.fail
    assert not compare(a, b).ok


def test_compare_size_mismatch_is_an_error():
    with pytest.raises(ImageMismatchError, match=r"16x12 \(array\) vs 16x11"):
        compare(_image(), _image(height=11))


def test_compare_nan_never_agrees_and_is_a_hard_fail():
    a = _image()
    b = a.copy()
    b[2, 5, 1] = np.nan
    r = compare(a, b, Thresholds(fail_percent=100.0))
    assert not r.ok and r.hard_fail
    assert r.failing_pixels == 1 and r.nonfinite_pixels_b == 1 and r.nonfinite_pixels_a == 0
    assert (r.worst.x, r.worst.y, r.worst.channel) == (5, 2, 1) and math.isnan(r.max_error)
    assert not compare(b, b.copy()).ok  # NaN != NaN, even in "identical" images
    assert r.to_dict()["max_error"] == "nan"  # strict JSON: no bare NaN


def test_compare_infinity_agrees_only_with_the_same_infinity():
    a = _image()
    a[0, 0, 0] = np.inf  # POV-Ray writes inf for values above the half range (65504)
    b = a.copy()
    assert compare(a, b).ok
    b[0, 0, 0] = 65504.0
    r = compare(a, b)
    assert not r.ok and r.hard_fail and r.max_error == math.inf and r.failing_pixels == 1


def test_compare_fail_percent_and_hard_fail():
    a = _image()
    b = a.copy()
    b[0, 0, 0] += 0.05  # 1 of 192 pixels = 0.52 %
    assert compare(a, b, Thresholds(fail_percent=1.0)).ok
    assert not compare(a, b, Thresholds(fail_percent=0.5)).ok
    r = compare(a, b, Thresholds(fail_percent=1.0, hard_fail=0.04))
    assert not r.ok and r.hard_fail


def test_compare_reads_image_paths(tmp_path):
    a = _image(scale=3.0)  # HDR values survive float EXR exactly
    pa = write_image(tmp_path / "a.exr", a)
    pb = write_image(tmp_path / "b.exr", a, half=True)
    r = compare(pa, str(pb))
    assert r.ok and r.max_error > 0


@pytest.mark.parametrize("bad", [-1.0, math.nan, "0.1"])
def test_thresholds_reject_bad_values(bad):
    with pytest.raises(ValueError, match="Thresholds.fail "):
        Thresholds(fail=bad)


def test_failing_mask_counts_what_compare_counts():
    # Errors spread around the relative threshold, plus non-finite values: the numpy mask and
    # OIIO's count must agree pixel for pixel count.
    rng = np.random.default_rng(5)
    a = (rng.random((40, 50, 3)) * 4).astype(np.float32)
    rel = rng.uniform(0, 4 * HALF_ROUNDING_RELATIVE, size=a.shape)
    b = (a * (1 + rel)).astype(np.float32)
    b[3, 4, 0], a[5, 6, 2] = np.nan, np.inf
    a[7, 8] = b[7, 8] = (1.0, np.inf, 2.0)  # the same infinity agrees
    mask = failing_mask(a, b)
    r = compare(a, b)
    assert 0 < mask.sum() < mask.size
    assert mask.sum() == r.failing_pixels
    assert mask[3, 4] and mask[5, 6] and not mask[7, 8]


# ----------------------------------------------------------------------------------------------
# Thresholds follow the files' formats (issue 11)

from phongscene.cli import main  # noqa: E402
from phongscene.comparison import integer_thresholds, thresholds_for_files  # noqa: E402
from phongscene.images import read_image  # noqa: E402


def _write_codes(path, codes: np.ndarray) -> None:
    """An 8-bit sRGB PNG holding exactly ``codes`` (OpenImageIO writes uint8 as given)."""
    buf = ImageBuf(np.ascontiguousarray(codes, dtype=np.uint8))
    buf.specmod().attribute("oiio:ColorSpace", "sRGB")
    assert buf.write(str(path), "uint8")


def _codes(seed: int) -> np.ndarray:
    return np.random.default_rng(seed).integers(1, 254, (12, 16, 3), dtype=np.int64)


def test_png_codes_one_step_apart_agree_and_two_steps_fail(tmp_path, capsys):
    codes = _codes(3)
    neighbour = codes.copy()
    neighbour[::2, ::3, 0] += 1  # what two renders agreeing at half precision can give after rounding
    _write_codes(tmp_path / "a.png", codes)
    _write_codes(tmp_path / "b.png", neighbour)
    # At half-float thresholds on linear values, a one-code step fails (the 344 pixels)...
    assert not compare(read_image(tmp_path / "a.png"), read_image(tmp_path / "b.png"), HALF_FLOAT).ok
    # ... at the files' own precision it agrees, from the API and the CLI.
    report = compare(tmp_path / "a.png", tmp_path / "b.png")
    assert report.ok and report.thresholds == integer_thresholds(8)
    assert main(["compare", str(tmp_path / "a.png"), str(tmp_path / "b.png")]) == 0
    out = capsys.readouterr().out
    assert "8-bit sRGB input" in out and "PASS" in out
    two = codes.copy()
    two[5, 6, 1] += 2
    _write_codes(tmp_path / "c.png", two)
    report = compare(tmp_path / "a.png", tmp_path / "c.png")
    assert not report.ok and report.failing_pixels == 1 and (report.worst.x, report.worst.y) == (6, 5)
    assert main(["compare", str(tmp_path / "a.png"), str(tmp_path / "c.png")]) == 1
    # An option still overrides one field of the format's thresholds.
    assert main(["compare", str(tmp_path / "a.png"), str(tmp_path / "c.png"), "--fail-percent", "1"]) == 0


def test_float_files_keep_half_float_thresholds_and_a_png_makes_a_pair_8_bit(tmp_path):
    image = _image(4)
    write_image(tmp_path / "a.exr", image)
    write_image(tmp_path / "h.exr", image, half=True)
    write_image(tmp_path / "a.png", image)
    assert thresholds_for_files(tmp_path / "a.exr", tmp_path / "h.exr")[0] == HALF_FLOAT
    assert compare(tmp_path / "a.exr", tmp_path / "h.exr").ok  # half rounding is within half precision
    mixed, why = thresholds_for_files(tmp_path / "a.exr", tmp_path / "a.png")
    assert mixed == integer_thresholds(8) and "a.png" in why
    assert compare(tmp_path / "a.exr", tmp_path / "a.png").ok  # the PNG is the EXR to 8-bit rounding


# OpenImageIO's built-in sRGB curve is an approximation of the formula: measured 2.5e-4 relative at
# worst (2.4e-5 absolute). The requantisation this guards against was off by up to half a code
# step of the linear value, over 10 % for dark codes.
SRGB_CURVE_TOLERANCE = 3e-4


def test_png_decodes_to_linear_at_float_precision(tmp_path):
    # Every 8-bit code, decoded by the sRGB curve (IEC 61966-2-1) without requantising to 8 bits
    # (read_image stored the linear values in 8 bits before: codes 51 and 52 both read 8/255).
    codes = np.arange(256, dtype=np.int64).reshape(16, 16, 1).repeat(3, axis=2)
    _write_codes(tmp_path / "ramp.png", codes)
    c = codes / 255.0
    expected = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    np.testing.assert_allclose(read_image(tmp_path / "ramp.png"), expected, rtol=SRGB_CURVE_TOLERANCE, atol=0)


def test_thresholds_for_summed_povray_passes_allow_each_frames_subnormal_rounding():
    from phongscene.comparison import HALF_FLOAT, HALF_SUBNORMAL_STEP, for_povray_passes

    # Three frames, each rounded to the nearest half subnormal (within half a step): their sum
    # can be 1.5 steps off, which the one-step floor fails and the three-pass floor passes.
    exact = np.full((1, 1, 3), 3 * 0.49 * HALF_SUBNORMAL_STEP, np.float32)
    summed = np.zeros((1, 1, 3), np.float32)
    assert not compare(summed, exact, HALF_FLOAT).ok
    assert compare(summed, exact, for_povray_passes(3)).ok
    assert for_povray_passes(1) == HALF_FLOAT and for_povray_passes(2) == HALF_FLOAT
