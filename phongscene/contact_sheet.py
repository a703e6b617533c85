# SPDX-License-Identifier: Apache-2.0
"""A contact sheet of a frame range: the frames' images side by side in a grid, each shrunk to a
thumbnail and labelled with its frame number (``render --frames ... --contact-sheet SHEET``).
OpenImageIO does the work (``ImageBufAlgo.resize``, ``paste``, ``render_text``); the sheet is
written atomically, as every output (``phongscene.images.write_imagebuf``)."""

from __future__ import annotations

import math
import os
from pathlib import Path

# Thumbnails are this wide (pixels; frames narrower stay at their size): 8 across fit a 1280-pixel screen.
THUMBNAIL_WIDTH = 160
# Pixels between thumbnails and around the grid (the sheet's background, black).
GAP = 4
# The label's height in pixels (OpenImageIO's built-in font), drawn in the thumbnail's top-left corner.
LABEL_SIZE = 14


def write_contact_sheet(path: str | os.PathLike, frames: list[tuple[int, str]], columns: int | None = None) -> Path:
    """Write ``path`` (.png: sRGB 8-bit; .exr: linear float): the images of ``frames``
    ((frame number, image file) pairs, in that order) in a grid of ``columns`` (default: about
    square), each THUMBNAIL_WIDTH wide at most, labelled with its frame number."""
    import OpenImageIO as oiio
    from OpenImageIO import ROI, ImageBuf, ImageBufAlgo, ImageSpec

    from .errors import PhongSceneError
    from .images import write_image

    if not frames:
        raise ValueError("a contact sheet needs at least one frame")
    thumbs = []
    for frame, file in frames:
        buf = ImageBuf(str(file))
        if buf.has_error or not buf.read(0, 0, True, oiio.TypeFloat):
            raise PhongSceneError(f"{file}: cannot read frame {frame}: {buf.geterror()}")
        spec = buf.spec()
        if "srgb" in spec.get_string_attribute("oiio:ColorSpace").lower():
            buf = ImageBufAlgo.colorconvert(buf, "sRGB", "linear")  # the sheet is assembled in linear light
        width = min(THUMBNAIL_WIDTH, spec.width)
        height = max(1, round(spec.height * width / spec.width))
        small = (
            ImageBufAlgo.resize(buf, roi=ROI(0, width, 0, height, 0, 1, 0, 3))
            if width != spec.width
            else ImageBufAlgo.channels(buf, (0, 1, 2))
        )
        thumbs.append((frame, small))
    cell_w = max(t.spec().width for _, t in thumbs)
    cell_h = max(t.spec().height for _, t in thumbs)
    columns = columns or math.ceil(math.sqrt(len(thumbs)))
    rows = math.ceil(len(thumbs) / columns)
    sheet = ImageBuf(ImageSpec(GAP + columns * (cell_w + GAP), GAP + rows * (cell_h + GAP), 3, oiio.FLOAT))
    for i, (frame, thumb) in enumerate(thumbs):
        x, y = GAP + (i % columns) * (cell_w + GAP), GAP + (i // columns) * (cell_h + GAP)
        ImageBufAlgo.paste(sheet, x, y, 0, 0, thumb)
        ImageBufAlgo.render_text(sheet, x + 3, y + LABEL_SIZE, str(frame), LABEL_SIZE, "", (1.0, 1.0, 1.0))
    import numpy as np

    pixels = np.asarray(sheet.get_pixels(oiio.TypeFloat), dtype=np.float32).reshape(
        sheet.spec().height, sheet.spec().width, 3
    )
    return write_image(path, pixels)
