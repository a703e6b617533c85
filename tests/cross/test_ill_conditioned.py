# SPDX-License-Identifier: Apache-2.0
"""``diff``'s ill-conditioned pixels (phongscene.conditioning): a failing pixel that a turn of the
camera by one float32 rounding moves beyond the tolerance, with the reference's value among those
the turn reaches, is explained; a pixel the turn does not move, or a reference value outside what
it reaches, is not. No POV-Ray: the reference is the native image with chosen pixels changed."""

from __future__ import annotations

import json
import math

import numpy as np

from phongscene.backends import native
from phongscene.comparison import HALF_FLOAT, compare
from phongscene.conditioning import ill_conditioned, tilted_cameras
from phongscene.crossvalidation import ILL_CONDITIONED_CAUSE, SHADOW_CACHE_CAUSE, DiffResult, _explain
from phongscene.report import write_report
from phongscene.scene import Camera, PointLight, RenderSettings, Scene, Sphere

# 41 x 31 pixels: the middle pixel's ray (20, 15) is the camera's forward (0, 0, -1) exactly; diff
# allows 0.2 % of 1,271 pixels, two, to fail when explained.
MIDDLE, INSIDE = (20, 15), (21, 15)


def grazing_scene() -> Scene:
    """A unit sphere at (1, 0, -5) that the middle pixel's ray touches at (0, 0, -5): whether it
    hits is decided by rounding, and a turn of 2⁻²⁴ rad about the camera's up axis makes it a
    clear hit one way and a miss the other. A light on the tangent point's side lights it fully."""
    world = np.eye(4)
    world[:3, 3] = (1.0, 0.0, -5.0)
    return Scene(
        camera=Camera(horizontal_fov_deg=40.0),
        lights=(PointLight(position=(-5.0, 0.0, -5.0), color=(1.0, 1.0, 1.0)),),
        spheres=(Sphere(world),),
        settings=RenderSettings(width=41, height=31, numerics="povray", specular="povray-classic"),
    )


def test_the_tilted_cameras_turn_by_the_angle_and_stay_orthonormal():
    camera = Camera.look_at((1.0, 2.0, 3.0), (0.0, 0.5, -1.0), horizontal_fov_deg=50.0)
    angle = 1e-3  # large enough to measure in double
    turned = tilted_cameras(camera, angle)
    assert len(turned) == 4
    f0, u0 = np.array(camera.forward), np.array(camera.up)
    for i, c in enumerate(turned):
        f, u = np.array(c.forward), np.array(c.up)
        assert c.position == camera.position and c.horizontal_fov_deg == camera.horizontal_fov_deg
        assert math.isclose(np.linalg.norm(f), 1.0, rel_tol=1e-15) and math.isclose(
            np.linalg.norm(u), 1.0, rel_tol=1e-15
        )
        assert abs(f @ u) < 1e-15
        assert math.isclose(math.acos(np.clip(f @ f0, -1, 1)), angle, rel_tol=1e-6)
        if i < 2:  # about up: up stays
            assert np.array_equal(u, u0)
        else:  # about right: up turns as much
            assert math.isclose(math.acos(np.clip(u @ u0, -1, 1)), angle, rel_tol=1e-6)
    # Each way, about each axis: four different cameras.
    assert len({c.forward for c in turned}) == 4


def test_only_a_pixel_the_turn_moves_is_ill_conditioned_and_only_for_values_it_reaches():
    scene = grazing_scene()
    prepared = native.prepare(scene)
    image = prepared()
    tilted = [prepared(c) for c in tilted_cameras(scene.camera)]
    (mx, my), (ix, iy) = MIDDLE, INSIDE
    reached = np.stack([image, *tilted])[:, my, mx, 0]
    # The grazing pixel: lit on one side, background on the other; the pixel beside it does not move.
    assert reached.min() == 0.0 and reached.max() > 0.1
    assert all(
        np.array_equal(t[iy, ix], image[iy, ix]) or abs(t[iy, ix, 0] / image[iy, ix, 0] - 1) < 1e-4 for t in tilted
    )

    reference = image.copy()
    reference[my, mx] = reached.max() / 2  # between: what a turn reaches
    reference[iy, ix] *= 1.01  # a real 1 % error where the image is well-conditioned
    candidates = np.zeros(image.shape[:2], bool)
    candidates[my, mx] = candidates[iy, ix] = True
    found = ill_conditioned(reference, image, tilted, candidates, HALF_FLOAT)
    assert found[my, mx] and not found[iy, ix] and found.sum() == 1

    reference[my, mx] = 2 * reached.max()  # beyond anything the turn reaches: not explained
    assert not ill_conditioned(reference, image, tilted, candidates, HALF_FLOAT).any()


def test_diff_explains_an_ill_conditioned_pixel_and_not_a_real_error():
    scene = grazing_scene()
    settings = scene.settings
    prepared = native.prepare(scene)
    image = prepared()
    reached_max = max(prepared(c)[MIDDLE[1], MIDDLE[0], 0] for c in tilted_cameras(scene.camera))
    reference = image.copy()
    reference[MIDDLE[1], MIDDLE[0]] = max(reached_max, image[MIDDLE[1], MIDDLE[0], 0]) / 2
    reference[INSIDE[1], INSIDE[0]] *= 1.01
    images = {"povray": reference, "native": image}
    report = compare(reference, image, HALF_FLOAT)
    assert report.failing_pixels == 2
    by_cache, ill, unexplained = _explain(scene, settings, "classic", images, report, HALF_FLOAT)
    assert by_cache == () and ill == (MIDDLE,) and unexplained == (INSIDE,)
    result = DiffResult(
        report, None, {}, reference, image, settings, "classic", [], by_cache, unexplained, ill_conditioned=ill
    )
    assert not result.ok  # the real error stays a failure
    assert "1 failing pixels ill-conditioned" in result.explanation()

    # The grazing pixel alone: explained, and diff passes (1 of 1,271 pixels, within 0.2 %).
    reference[INSIDE[1], INSIDE[0]] = image[INSIDE[1], INSIDE[0]]
    report = compare(reference, image, HALF_FLOAT)
    by_cache, ill, unexplained = _explain(
        scene, settings, "classic", images | {"povray": reference}, report, HALF_FLOAT
    )
    result = DiffResult(
        report, None, {}, reference, image, settings, "classic", [], by_cache, unexplained, ill_conditioned=ill
    )
    assert ill == (MIDDLE,) and unexplained == () and result.ok
    assert "PASS (every failing pixel explained)" in result.explanation()


def test_the_report_names_each_failing_pixels_cause(tmp_path):
    a = np.full((8, 8, 3), 0.5, np.float32)
    b = a.copy()
    b[1, 2] = b[3, 4] = b[5, 6] = 0.4
    causes = {(2, 1): SHADOW_CACHE_CAUSE, (4, 3): ILL_CONDITIONED_CAUSE}
    index = write_report(tmp_path / "rep", a, b, compare(a, b), explained=causes)
    listed = {
        (p["x"], p["y"]): p["cause"]
        for p in json.loads((tmp_path / "rep" / "metrics.json").read_text())["failing_pixels_listed"]
    }
    assert listed == {(2, 1): SHADOW_CACHE_CAUSE, (4, 3): ILL_CONDITIONED_CAUSE, (6, 5): "not explained"}
    page = index.read_text()
    for name in (SHADOW_CACHE_CAUSE, ILL_CONDITIONED_CAUSE):
        assert f"explained by {name}" in page.replace("&#x27;", "'")


def test_the_probe_is_skipped_where_it_cannot_change_the_verdict():
    # Three failing pixels of 1,271 are more than diff allows (two) whatever explains them: the
    # four renders are not made, and every pixel is reported unexplained.
    scene = grazing_scene()
    image = native.prepare(scene)()
    reference = image.copy()
    reference[MIDDLE[1], MIDDLE[0]] = image[MIDDLE[1], MIDDLE[0]] / 2
    for x in (21, 22):
        reference[15, x] *= 1.01
    report = compare(reference, image, HALF_FLOAT)
    assert report.failing_pixels == 3
    by_cache, ill, unexplained = _explain(
        scene, scene.settings, "classic", {"povray": reference, "native": image}, report, HALF_FLOAT
    )
    assert ill == () and len(unexplained) == 3 and MIDDLE in unexplained
