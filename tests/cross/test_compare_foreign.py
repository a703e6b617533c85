# SPDX-License-Identifier: Apache-2.0
"""Comparing with another renderer (issue 26.4): a noisy image with one wrong object fails nearly
every pixel test, but the failing regions, ranked by total error, point at the wrong object, and
``compare --metric flip`` (NVIDIA's FLIP) fails only there."""

from __future__ import annotations

import numpy as np
import pytest

from phongscene.cli import main
from phongscene.images import write_image
from phongscene.perceptual import FLIP_FAIL, Region, failing_regions, flip_compare

SIZE = 96
# The wrong object: a disc of this radius at this centre (pixels).
DISC_CENTRE, DISC_RADIUS = (64, 40), 12
# FLIP's spatial filters (at its default 67 pixels per degree) spread an edge's error this far (pixels).
FLIP_SPREAD = 5
# Another renderer's noise: relative, as a path tracer's is (2 %), over a near-black floor.
NOISE = 0.02


def scene_image(disc_colour, seed: int, noise: float = NOISE) -> np.ndarray:
    y, x = np.mgrid[0:SIZE, 0:SIZE]
    image = np.full((SIZE, SIZE, 3), 0.002, np.float32)  # near-black background
    image[20:76, 10:40] = 0.5  # a grey box
    disc = (x - DISC_CENTRE[0]) ** 2 + (y - DISC_CENTRE[1]) ** 2 <= DISC_RADIUS**2
    image[disc] = disc_colour
    return image * np.random.default_rng(seed).normal(1.0, noise, image.shape).astype(np.float32)


def on_the_disc(region) -> bool:
    cx, cy = DISC_CENTRE
    return (
        region.x - DISC_RADIUS <= cx <= region.x + region.width + DISC_RADIUS
        and region.y - DISC_RADIUS <= cy <= region.y + region.height + DISC_RADIUS
    )


@pytest.fixture
def pair(tmp_path):
    reference, test = tmp_path / "cycles.exr", tmp_path / "native.exr"
    write_image(reference, scene_image((0.8, 0.1, 0.1), seed=1))
    write_image(test, scene_image((0.1, 0.8, 0.1), seed=2))  # the wrong colour, other noise
    return str(reference), str(test)


def test_the_pixel_metric_ranks_the_wrong_object_first_not_near_black_pixels(pair, capsys):
    assert main(["compare", *pair]) == 1
    out = capsys.readouterr().out
    fail_percent = float(out.split(" pixels (")[1].split("%")[0])
    assert fail_percent > 90  # noise: nearly every pixel fails a half-float test
    import re

    tiles = re.findall(
        r"^    \((\d+), (\d+)\)-\((\d+), (\d+)\): (\d+) failing pixels", out.split("worst regions")[1], re.M
    )
    x, y, x2, y2, _ = map(int, tiles[0])  # the worst tile
    assert on_the_disc(Region(x, y, x2 - x + 1, y2 - y + 1, 0, 0.0, 0.0))


@pytest.mark.slow
def test_flip_fails_only_where_the_object_is_wrong(pair, capsys):
    assert main(["compare", *pair, "--metric", "flip"]) == 1
    out = capsys.readouterr().out
    assert "mean FLIP" in out and "(FLIP, HDR)" in out
    from phongscene.images import read_image

    report = flip_compare(read_image(pair[0]), read_image(pair[1]))
    failing = report.error_map >= FLIP_FAIL
    y, x = np.mgrid[0:SIZE, 0:SIZE]
    near_disc = (x - DISC_CENTRE[0]) ** 2 + (y - DISC_CENTRE[1]) ** 2 <= (DISC_RADIUS + FLIP_SPREAD) ** 2
    assert failing[near_disc].mean() > 0.5 and not failing[~near_disc].any()
    assert all(on_the_disc(r) for r in report.regions)
    # The same noise without the wrong object passes, even at 5 % (an unconverged reference).
    assert flip_compare(scene_image((0.8, 0.1, 0.1), 1), scene_image((0.8, 0.1, 0.1), 2)).failing_pixels == 0
    noisy = scene_image((0.8, 0.1, 0.1), 3, noise=0.05), scene_image((0.8, 0.1, 0.1), 4, noise=0.05)
    assert flip_compare(*noisy).failing_pixels == 0


def test_regions_rank_by_total_error():
    error = np.zeros((40, 40))
    failing = np.zeros((40, 40), bool)
    error[0, 0], failing[0, 0] = 1.0, True  # one large error
    error[20:30, 20:30], failing[20:30, 20:30] = 0.1, True  # a region of small ones: 10 in total
    first, second = failing_regions(error, failing, size=16)[:2]
    assert (first.x, first.y) == (16, 16) and first.failing_pixels == 100 and first.total_error == pytest.approx(10)
    assert (second.x, second.y, second.max_error) == (0, 0, 1.0)
