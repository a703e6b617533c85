# SPDX-License-Identifier: Apache-2.0
"""How a linear image becomes 8-bit codes for eyes: ``srgb`` (the default: clip each channel to
[0, 1], sRGB-encode, round; OpenImageIO does it in ``images.write_image``) or the display of
Suffern's book (*Ray Tracing from the Ground Up*, World::display_pixel and
World::map_to_pixel_color in its code), so that a figure's PNG has the codes the book's own
renderer writes:

* ``book``: ``max_to_one``: a colour with a channel above 1 is divided by its largest channel
  (hue kept, brightness lost), then gamma 1 (no encoding) and truncation, ``int(c · 255)``;
* ``book-gamut``: the book's ``show_out_of_gamut``: a colour with a channel above 1 becomes
  pure red (1, 0, 0), else as ``book``.

The book computes colours in float32 (its RGBColor), and so does this. Its colours are never
negative; a negative channel (a scene with negative light) is clipped to 0 here rather than
wrapped by the cast."""

from __future__ import annotations

from typing import Literal

import numpy as np

Display = Literal["srgb", "book", "book-gamut"]
DISPLAYS: tuple[str, ...] = ("srgb", "book", "book-gamut")
# The book's 8-bit conversion: int(c * 255), truncating.
BOOK_CODE_SCALE = np.float32(255.0)


def book_codes(pixels, *, out_of_gamut_red: bool = False) -> np.ndarray:
    """The book's 8-bit codes (H, W, 3) uint8 of a linear float image (H, W, 3)."""
    c = np.asarray(pixels, dtype=np.float32)
    peak = c.max(axis=2, keepdims=True)
    over = peak > np.float32(1.0)
    if out_of_gamut_red:
        mapped = np.where(over, np.array([1.0, 0.0, 0.0], dtype=np.float32), c)
    else:
        with np.errstate(divide="ignore", invalid="ignore"):
            mapped = np.where(over, c / np.where(over, peak, np.float32(1.0)), c)
    mapped = np.clip(mapped, np.float32(0.0), np.float32(1.0))
    return (mapped * BOOK_CODE_SCALE).astype(np.uint8)  # astype truncates toward zero, like the cast


def check_display(display: str) -> str:
    if display not in DISPLAYS:
        raise ValueError(f"unknown display {display!r}; use one of {', '.join(DISPLAYS)}")
    return display
