# SPDX-License-Identifier: Apache-2.0
"""phongscene.report: every referenced file exists and decodes; the heat map shows one pixel."""

from __future__ import annotations

import json
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from OpenImageIO import ImageBuf, ImageBufAlgo, TypeFloat

from phongscene.comparison import compare
from phongscene.images import read_image
from phongscene.report import ALLOWED_ERROR_COLOUR, FAILING_COLOUR, display_scale, error_ratio, write_report

# An 8-bit heat-map colour counts as "clearly different" from the zero colour when some
# channel differs by at least a quarter of the range (inferno: near-black at 0, yellow at 1).
CLEARLY_VISIBLE = 0.25
# A linear value read back from an 8-bit sRGB PNG is off by up to one code step at the top of
# the range, where a step is largest: d(linear)/d(code) = 2.4/1.055 / 255 ≈ 0.0089 at code 255.
# (OIIO's conversion does not round to the nearest code: 0.0059 was measured, above half a step.)
PNG_SRGB_8BIT_STEP = 2.4 / 1.055 / 255
# One 8-bit code, for display-referred colours written without conversion (the heat map).
PNG_8BIT_CODE = 1 / 255


class _Links(HTMLParser):
    def __init__(self):
        super().__init__()
        self.links: list[str] = []
        self.text: list[str] = []

    def handle_starttag(self, tag, attrs):
        for name, value in attrs:
            if name in ("src", "href"):
                self.links.append(value)

    def handle_data(self, data):
        self.text.append(data)


def _images(height=24, width=32):
    rng = np.random.default_rng(3)
    a = rng.random((height, width, 3)).astype(np.float32)
    b = a.copy()
    b[5, 9, 0] += 0.002  # one pixel differs, a little
    return a, b


def _write(tmp_path, a, b, **kw):
    return write_report(tmp_path / "rep", a, b, compare(a, b), **kw)


def test_report_every_referenced_file_exists_and_decodes(tmp_path):
    a, b = _images()
    index = _write(
        tmp_path,
        a,
        b,
        labels=("povray", "native"),
        timings={"povray": 0.8, "native": 0.01},
        meta={"scene": "x.usda", "mapping": "exact"},
    )
    parser = _Links()
    parser.feed(index.read_text(encoding="utf-8"))
    assert {"povray.png", "native.png", "povray.exr", "native.exr", "diff_heat.png", "metrics.json"} <= set(
        parser.links
    )
    for link in parser.links:
        assert "://" not in link and not link.startswith("/"), f"external resource {link}"
        path = index.parent / link
        assert path.is_file(), link
        if path.suffix in (".png", ".exr"):
            assert read_image(path).shape[2] == 3
        else:
            json.loads(path.read_text(encoding="utf-8"))
    # The images round-trip: float EXR exactly, PNG as sRGB 8-bit.
    np.testing.assert_array_equal(read_image(index.parent / "native.exr"), b)
    np.testing.assert_allclose(read_image(index.parent / "povray.png"), a, atol=PNG_SRGB_8BIT_STEP, rtol=0)
    metrics = json.loads((index.parent / "metrics.json").read_text(encoding="utf-8"))
    assert metrics["report"]["failing_pixels"] == 1 and metrics["report"]["ok"] is False
    assert metrics["timings_seconds"] == {"povray": 0.8, "native": 0.01}
    assert metrics["mapping"] == "exact" and metrics["report"]["thresholds"]["hard_fail"] is None
    assert not list(index.parent.glob(".*")), "temporary files left behind"


def test_report_heat_map_shows_a_one_pixel_difference(tmp_path):
    a, b = _images()
    index = _write(tmp_path, a, b)
    heat_srgb = ImageBuf(str(index.parent / "diff_heat.png")).get_pixels(TypeFloat)  # display codes / 255
    s = display_scale(a.shape[1])
    assert s > 1  # a 32-pixel-wide image is enlarged
    block = heat_srgb[5 * s : 6 * s, 9 * s : 10 * s]
    zero = heat_srgb[0, 0]
    assert np.all(np.abs(block - zero).max(axis=2) >= CLEARLY_VISIBLE)
    # Neighbours of the block stay at the zero colour.
    np.testing.assert_allclose(heat_srgb[5 * s, 10 * s], zero, atol=1e-6)
    # The failing pixel is drawn in the overlay colour, and the PNG is the map alone: the legend
    # is HTML text (it used to be baked into the PNG at ~8 px).
    np.testing.assert_allclose(block[0, 0], FAILING_COLOUR, atol=PNG_8BIT_CODE)
    assert heat_srgb.shape[:2] == (a.shape[0] * s, a.shape[1] * s)


def test_report_escapes_labels_and_metadata(tmp_path):
    a, b = _images()
    evil = '<script>alert("x")</script>'
    index = _write(tmp_path, a, b, labels=(evil, "b&b"), title=evil, meta={"scene": evil})
    text = index.read_text(encoding="utf-8")
    assert "<script>" not in text
    assert "&lt;script&gt;" in text and "b&amp;b" in text
    # Labels become safe file stems.
    assert (index.parent / "script_alert_x_script.png").is_file()


def test_report_identical_images(tmp_path):
    a, _ = _images()
    index = _write(tmp_path, a, a.copy())
    metrics = json.loads((index.parent / "metrics.json").read_text(encoding="utf-8"))
    assert metrics["report"]["ok"] is True and metrics["heat_map"]["max_ratio"] == 0.0
    assert "PASS" in index.read_text(encoding="utf-8")


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_report_handles_non_finite_errors(tmp_path, bad):
    a, b = _images()
    b[1, 1, 1] = bad
    index = _write(tmp_path, a, b)
    metrics = json.loads((index.parent / "metrics.json").read_text(encoding="utf-8"))  # strict JSON
    assert metrics["report"]["hard_fail"] is True
    assert Path(index.parent / "diff_heat.png").is_file()


@pytest.mark.parametrize("label", ["diff", "diff_heat"])
def test_report_a_label_never_overwrites_the_reports_own_files(tmp_path, label):
    a, b = _images()
    index = _write(tmp_path, a, b, labels=(label, "other"))
    files = json.loads((index.parent / "metrics.json").read_text(encoding="utf-8"))["files"]
    assert len(set(files.values())) == len(files), files
    np.testing.assert_array_equal(read_image(index.parent / files["a_exr"]), a)
    np.testing.assert_array_equal(read_image(index.parent / files["diff_exr"]), np.abs(a - b))


def _page_text(index) -> str:
    """The page's visible text (the style sheet left out)."""
    page = index.read_text(encoding="utf-8")
    page = page[: page.index("<style>")] + page[page.index("</style>") + len("</style>") :]
    parser = _Links()
    parser.feed(page)
    return " ".join(parser.text)


def test_error_ratio_is_above_1_exactly_where_pixels_fail():
    from phongscene.comparison import HALF_FLOAT, failing_mask

    rng = np.random.default_rng(11)
    a = rng.random((40, 50, 3)).astype(np.float32)
    # Errors from 0 to 4x the allowed relative error, and a few pixels near zero (the absolute floor).
    b = (a * (1 + rng.uniform(-4, 4, a.shape) * HALF_FLOAT.fail_relative)).astype(np.float32)
    a[:2] = 1e-9
    b[:2] = 1e-9 + rng.uniform(0, 2, (2, 50, 3)).astype(np.float32) * HALF_FLOAT.fail
    b[3, 3, 1], b[4, 4, 2] = np.inf, np.nan
    ratio = error_ratio(a, b, HALF_FLOAT)
    mask = failing_mask(a, b, HALF_FLOAT)
    assert 0 < mask.sum() < mask.size
    np.testing.assert_array_equal(ratio > 1, mask)


def test_a_pass_heat_map_is_dark_and_a_fail_overlays_every_failing_pixel(tmp_path):
    from phongscene.comparison import HALF_FLOAT

    a, _ = _images()
    b = (a.astype(np.float64) * (1 + 0.99 * HALF_FLOAT.fail_relative)).astype(np.float32)  # just inside
    index = _write(tmp_path / "pass", a, b)
    heat = ImageBuf(str(index.parent / "diff_heat.png")).get_pixels(TypeFloat)
    brightest = ImageBufAlgo.color_map(ImageBuf(np.full((1, 1, 1), ALLOWED_ERROR_COLOUR, np.float32)), 0, "inferno")
    top = np.asarray(brightest.get_pixels(TypeFloat)).reshape(3)
    assert (heat <= top + PNG_8BIT_CODE).all()  # nothing brighter than the allowed error's colour
    b[7, 3] *= 1.01
    b[20, 30] *= 0.99
    index = _write(tmp_path / "fail", a, b)
    heat = ImageBuf(str(index.parent / "diff_heat.png")).get_pixels(TypeFloat)
    s = display_scale(a.shape[1])
    overlaid = (np.abs(heat - np.asarray(FAILING_COLOUR)) <= PNG_8BIT_CODE).all(axis=2)
    assert overlaid.sum() == 2 * s * s
    assert overlaid[7 * s, 3 * s] and overlaid[20 * s, 30 * s]


def test_report_page_shows_values_as_text_and_every_failing_pixel_on_both_sides(tmp_path):
    a, b = _images()
    b[20, 30] = (0.25, 0.5, 0.75)
    index = write_report(
        tmp_path / "rep",
        a,
        b,
        compare(a, b),
        labels=("povray", "native"),
        explained=[(30, 20)],
        cause="POV-Ray's shadow cache",
        meta={"settings": {"width": 32, "background": [0.0, 0.0, 0.0]}},
    )
    text = _page_text(index)
    # No raw Python or JSON values: booleans, infinities and dicts are written for a reader.
    for raw in ("False", "True", " inf", "{", "['", "[0.0"):
        assert raw not in text, raw
    assert "none (no limit)" in text  # hard_fail = inf
    assert "allowed error" in text  # the legend is HTML
    # Both failing pixels are listed with both sides' values and their cause.
    page = index.read_text(encoding="utf-8")
    a_value = "(" + ", ".join(f"{float(v):.6g}" for v in a[20, 30]) + ")"
    assert a_value in page and "(0.25, 0.5, 0.75)" in page
    assert "POV-Ray's shadow cache" in text and "not explained" in text
    metrics = json.loads((index.parent / "metrics.json").read_text(encoding="utf-8"))
    listed = {(p["x"], p["y"]): p["cause"] for p in metrics["failing_pixels_listed"]}
    assert listed == {(30, 20): "POV-Ray's shadow cache", (9, 5): "not explained"}


def test_diff_report_passes_when_every_failing_pixel_is_explained(tmp_path):
    a, b = _images()
    index = write_report(
        tmp_path / "rep", a, b, compare(a, b), explained=[(9, 5)], cause="POV-Ray's shadow cache", ok=True
    )
    text = _page_text(index)
    assert "PASS" in text and "FAIL" not in text
    assert "every failing pixel is explained by POV-Ray's shadow cache" in text
