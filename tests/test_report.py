# SPDX-License-Identifier: Apache-2.0
"""phongscene.report: every referenced file exists and decodes; the heat map shows one pixel."""

from __future__ import annotations

import json
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from OpenImageIO import ImageBuf, TypeFloat

from phongscene.comparison import compare
from phongscene.images import read_image
from phongscene.report import display_scale, write_report

# An 8-bit heat-map colour counts as "clearly different" from the zero colour when some
# channel differs by at least a quarter of the range (inferno: near-black at 0, yellow at 1).
CLEARLY_VISIBLE = 0.25
# A linear value read back from an 8-bit sRGB PNG is off by up to one code step at the top of
# the range, where a step is largest: d(linear)/d(code) = 2.4/1.055 / 255 ≈ 0.0089 at code 255.
# (OIIO's conversion does not round to the nearest code: 0.0059 was measured, above half a step.)
PNG_SRGB_8BIT_STEP = 2.4 / 1.055 / 255


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
        tmp_path, a, b, labels=("povray", "native"), timings={"povray": 0.8, "native": 0.01},
        meta={"scene": "x.usda", "mapping": "exact"},
    )
    parser = _Links()
    parser.feed(index.read_text(encoding="utf-8"))
    assert {"povray.png", "native.png", "povray.exr", "native.exr", "diff_heat.png", "metrics.json"} <= set(parser.links)
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
    assert heat_srgb.shape[0] > a.shape[0] * s  # the legend bar sits below the map


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
    assert metrics["report"]["ok"] is True and metrics["heat_map"]["max"] == 0.0
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
