# SPDX-License-Identifier: Apache-2.0
"""The report page as a browser draws it: headless Chromium screenshots of index.html. A FAIL
shows its failing pixel in the overlay colour at the right place on the heat map; a PASS whose
every pixel is just inside the allowed error is dark everywhere and shows no overlay."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest
from OpenImageIO import ImageBuf, ImageBufAlgo, TypeFloat

from phongscene.comparison import HALF_FLOAT, compare
from phongscene.report import ALLOWED_ERROR_COLOUR, EXPLAINED_COLOUR, FAILING_COLOUR, HEAT_MAP, write_report
from support.paths import chromium

pytestmark = pytest.mark.chromium

WINDOW = (1400, 1100)  # CSS pixels at device scale 1: the three figures side by side, legend included
CHROMIUM_SECONDS = 120  # a cold start on a loaded 2-core machine; a hang fails instead of blocking
# A screen colour matches a drawn one within 3 of 255 codes: PNG decoding and the browser's
# colour handling of an untagged 8-bit PNG (measured: exact) leave a margin for other builds.
COLOUR_MATCH = 3 / 255
# Near black: inferno at 0 is (0, 0, 4)/255; the page's darkest text is #222 (0.13).
NEAR_BLACK = 0.06
# "Dark": linear luminance at most 0.1. The brightest colour a PASS can have is inferno at
# ALLOWED_ERROR_COLOUR (linear luminance ~0.09); the old scale drew a PASS's worst pixel at
# inferno(1), a light yellow (~0.9).
DARK_LUMINANCE = 0.1
# How far (screen pixels) the overlay's centre may sit from where the failing pixel belongs: the
# browser scales the enlarged map to the figure, rounding edges to whole pixels.
PLACE_TOLERANCE = 1.5
SIZE = (48, 64)  # height, width of the test images
# Screen rows that hold the failing pixel's block (6 screen pixels: 64 pixels enlarged to 384),
# well short of the gap down to the legend's swatch of the same colour.
CLUSTER_PIXELS = 20


def _screenshot(index: Path, out: Path) -> np.ndarray:
    width, height = WINDOW
    subprocess.run(
        [
            chromium(),
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--hide-scrollbars",
            "--force-device-scale-factor=1",
            f"--window-size={width},{height}",
            f"--screenshot={out}",
            index.as_uri(),
        ],
        check=True,
        capture_output=True,
        timeout=CHROMIUM_SECONDS,
    )
    return np.asarray(ImageBuf(str(out)).get_pixels(TypeFloat))[..., :3]  # sRGB codes / 255


def _matches(shot: np.ndarray, colour) -> np.ndarray:
    return (np.abs(shot - np.asarray(colour, np.float32)) <= COLOUR_MATCH).all(axis=2)


def _run(mask_row: np.ndarray, start: int, step: int) -> int:
    """The last index of the run of True in ``mask_row`` going from ``start`` by ``step``."""
    i = start
    while 0 <= i + step < len(mask_row) and mask_row[i + step]:
        i += step
    return i


def _bright_images():
    rng = np.random.default_rng(7)
    a = (0.5 + 0.4 * rng.random((*SIZE, 3))).astype(np.float32)  # light: nothing near black on screen but the map
    return a


@pytest.mark.slow
def test_a_failing_pixel_is_overlaid_at_its_place_on_the_heat_map(tmp_path):
    a = _bright_images()
    b = a.copy()
    x0, y0 = 20, 10
    b[y0, x0] *= 1.05  # fails; every other pixel is identical (error 0: inferno's black)
    index = write_report(tmp_path / "rep", a, b, compare(a, b), labels=("povray", "native"))
    shot = _screenshot(index, tmp_path / "shot.png")

    cyan = _matches(shot, FAILING_COLOUR)
    assert cyan.any(), "the failing pixel's overlay is not visible in the browser"
    # The legend's swatch, below the map, has the colour too: keep the topmost cluster.
    ys, xs = np.nonzero(cyan)
    cyan &= np.arange(cyan.shape[0])[:, None] < ys.min() + CLUSTER_PIXELS
    ys, xs = np.nonzero(cyan)
    cy, cx = ys.mean(), xs.mean()
    # The heat map around it: the run of near-black screen pixels (error 0) through the overlay.
    black_or_cyan = (shot.max(axis=2) <= NEAR_BLACK) | cyan
    row, col = black_or_cyan[int(round(cy))], black_or_cyan[:, int(round(cx))]
    left, right = _run(row, int(round(cx)), -1), _run(row, int(round(cx)), +1)
    top, bottom = _run(col, int(round(cy)), -1), _run(col, int(round(cy)), +1)
    shown_w, shown_h = right - left + 1, bottom - top + 1
    assert shown_w / shown_h == pytest.approx(SIZE[1] / SIZE[0], rel=0.03)  # the map, not some other dark patch
    assert cx == pytest.approx(left + (x0 + 0.5) * shown_w / SIZE[1], abs=PLACE_TOLERANCE)
    assert cy == pytest.approx(top + (y0 + 0.5) * shown_h / SIZE[0], abs=PLACE_TOLERANCE)
    # Only the one pixel is overlaid: its block is about one image pixel on screen.
    assert len(ys) <= 2 * (shown_w / SIZE[1]) ** 2


@pytest.mark.slow
def test_a_pass_is_dark_everywhere_and_shows_no_overlay(tmp_path):
    a = _bright_images()
    # Every channel 0.95 x the allowed error away: the worst a PASS can be, everywhere.
    b = (a.astype(np.float64) * (1 + 0.95 * HALF_FLOAT.fail_relative)).astype(np.float32)
    report = compare(a, b)
    assert report.ok and report.max_relative_error > 0.9 * HALF_FLOAT.fail_relative
    index = write_report(
        tmp_path / "rep", a, b, report, labels=("povray", "native"), explained=[], cause="POV-Ray's shadow cache"
    )
    shot = _screenshot(index, tmp_path / "shot.png")

    # The map's colour (ratio ~0.95 everywhere) covers the map's area on screen, and it is dark.
    level = np.full((1, 1, 1), 0.95 * ALLOWED_ERROR_COLOUR, np.float32)
    expected = np.asarray(ImageBufAlgo.color_map(ImageBuf(level), 0, HEAT_MAP).get_pixels(TypeFloat)).reshape(3)
    near = (np.abs(shot - expected) <= 6 * COLOUR_MATCH).all(axis=2)  # ratios 0.93 .. 0.95: a few codes apart
    shown = int(near.sum())
    scale_w = 384  # MIN_DISPLAY_WIDTH: the map is shown at its enlarged size in this window
    assert shown >= 0.9 * scale_w * scale_w * SIZE[0] / SIZE[1], shown
    ys, xs = np.nonzero(near)
    on_map = shot[ys.min() : ys.max() + 1, xs.min() : xs.max() + 1]
    assert not _matches(on_map, FAILING_COLOUR).any() and not _matches(on_map, EXPLAINED_COLOUR).any()
    linear = np.where(expected <= 0.04045, expected / 12.92, ((expected + 0.055) / 1.055) ** 2.4)
    assert float(linear @ [0.2126, 0.7152, 0.0722]) <= DARK_LUMINANCE
    # The legend is text on the page (the old one was baked into the PNG).
    page = index.read_text(encoding="utf-8")
    assert "allowed error" in page and 'id="legend"' in page
