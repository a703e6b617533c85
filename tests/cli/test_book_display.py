# SPDX-License-Identifier: Apache-2.0
"""The book's display for 8-bit output (phongscene.display): max_to_one or out-of-gamut red,
gamma 1, truncation; the default PNG stays sRGB-encoded and clipped."""

from __future__ import annotations

import numpy as np
import pytest

from phongscene.display import book_codes
from phongscene.images import write_image

PIXELS = np.array(
    [[[0.5, 0.25, 1.0], [2.0, 1.0, 0.5], [0.999, 0.0039, 0.00392], [1.0000001, 0.2, 0.1]]], dtype=np.float32
)


def test_max_to_one_divides_by_the_largest_channel_and_truncates():
    codes = book_codes(PIXELS)
    # int(c·255) in float32: 0.5 -> 127 (not 128), 0.25 -> 63, 1 -> 255; (2, 1, .5)/2 -> 255, 127, 63;
    # 0.999 -> 254, 0.0039 -> 0 (0.9945), 0.00392 -> 0 (0.9996); just over 1: divided.
    assert codes.tolist() == [[[127, 63, 255], [255, 127, 63], [254, 0, 0], [255, 50, 25]]]


def test_out_of_gamut_pixels_are_red():
    codes = book_codes(PIXELS, out_of_gamut_red=True)
    assert codes[0, 1].tolist() == [255, 0, 0] and codes[0, 3].tolist() == [255, 0, 0]
    assert codes[0, 0].tolist() == [127, 63, 255]


@pytest.mark.parametrize("display", ["book", "book-gamut"])
def test_a_png_written_with_the_books_display_holds_its_codes(tmp_path, display):
    from OpenImageIO import ImageBuf

    path = write_image(tmp_path / "book.png", PIXELS, display=display)
    back = np.asarray(ImageBuf(str(path)).get_pixels()).reshape(PIXELS.shape)
    expected = book_codes(PIXELS, out_of_gamut_red=display == "book-gamut") / 255.0
    np.testing.assert_array_equal(np.round(back * 255), np.round(expected * 255))


def test_the_default_png_is_srgb(tmp_path):
    from OpenImageIO import ImageBuf

    path = write_image(tmp_path / "srgb.png", PIXELS)
    back = np.round(np.asarray(ImageBuf(str(path)).get_pixels()).reshape(PIXELS.shape) * 255)
    assert back[0, 0, 0] == 188  # sRGB(0.5) = 0.7354 -> 188, not the book's 127


def test_an_unknown_display_is_an_error(tmp_path):
    with pytest.raises(ValueError, match="unknown display"):
        write_image(tmp_path / "x.png", PIXELS, display="gamma")


def test_render_writes_the_books_codes_with_display_book(tmp_path):
    from OpenImageIO import ImageBuf

    from phongscene import load_usd, render
    from phongscene.cli import main
    from support.paths import EXAMPLES

    scene = EXAMPLES / "seed_lobe.usda"
    out = tmp_path / "book.png"
    assert main(["render", str(scene), "-o", str(out), "--width", "16", "--display", "book"]) == 0
    back = np.round(np.asarray(ImageBuf(str(out)).get_pixels()).reshape(-1, 16, 3) * 255)
    import dataclasses

    s = load_usd(scene)
    s = dataclasses.replace(s, settings=dataclasses.replace(s.settings, width=16, height=back.shape[0]))
    np.testing.assert_array_equal(back, book_codes(render(s, "native")))


def test_display_needs_a_png(tmp_path):
    from phongscene.cli import main
    from support.paths import EXAMPLES

    assert main(["render", str(EXAMPLES / "seed_lobe.usda"), "-o", str(tmp_path / "x.exr"), "--display", "book"]) == 2
