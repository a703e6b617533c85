# SPDX-License-Identifier: Apache-2.0
"""8-bit PNG files for the texture tests, written with OpenImageIO."""

from __future__ import annotations

import numpy as np
import OpenImageIO as oiio


def write_png(path, pixels: np.ndarray) -> str:
    """``pixels`` (H, W, C) uint8 as the PNG ``path`` (row 0 at the top); returns the path."""
    buf = oiio.ImageBuf(oiio.ImageSpec(pixels.shape[1], pixels.shape[0], pixels.shape[2], "uint8"))
    buf.set_pixels(oiio.ROI(), pixels)
    assert buf.write(str(path))
    return str(path)
