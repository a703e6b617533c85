# SPDX-License-Identifier: Apache-2.0
"""The tutorial's ball under its 10 cm SphereLight (examples/first_scene.usda, the floor left out),
64×48: at the ball's lower terminator some of the light's samples sit just below a shaded point's
horizon, and their shadow rays cross the ball along a chord shorter than POV-Ray's shadow tolerance
(1e-3, ref §6) but longer than the scale-invariant window (1.9e-5 · the scene's half-extent, ~1e-4
here). POV-Ray ignores such a chord; the native tracer in POV-Ray's numerics must too.

This was tests/cross/test_cross_backend.py's strict xfail for first_scene (2 pixels, (29, 32) and
(34, 32)): the native image there had been rendered in the scale-invariant numerics, not POV-Ray's.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from phongscene.backends import native
from phongscene.comparison import HALF_FLOAT, failing_mask
from support import oracle
from support.paths import EXAMPLES

# The pixels (x, y) where the two windows give different images (the cross test's report).
TERMINATOR_PIXELS = ((29, 32), (34, 32))


@pytest.fixture(scope="module")
def ball():
    from phongscene.usd import load_usd

    scene = load_usd(EXAMPLES / "first_scene.usda")
    # The floor cannot shadow the ball's lower half (the light is above): the ball and light alone.
    return dataclasses.replace(scene, meshes=(), settings=dataclasses.replace(scene.settings, width=64, height=48))


def _oracle_at(scene, window: float, monkeypatch) -> np.ndarray:
    with monkeypatch.context() as m:
        m.setattr(oracle, "SHADOW_TOLERANCE", window)
        return oracle.render(scene).astype(np.float32)


def _at(mask: np.ndarray) -> set[tuple[int, int]]:
    return {(int(x), int(y)) for y, x in np.argwhere(mask)}


def test_the_scene_has_chords_between_the_two_windows(ball, monkeypatch):
    # Otherwise the tests below could not fail: POV-Ray's window and the cache's (1e-4) differ here.
    povray = _oracle_at(ball, oracle.SHADOW_TOLERANCE, monkeypatch)
    cached = _oracle_at(ball, oracle.MIN_ISECT_DEPTH, monkeypatch)
    assert set(TERMINATOR_PIXELS) <= _at(failing_mask(povray, cached, HALF_FLOAT))


def test_native_in_povray_numerics_ignores_chords_within_povray_shadow_tolerance(ball, monkeypatch):
    expected = _oracle_at(ball, oracle.SHADOW_TOLERANCE, monkeypatch)
    image = native.render(ball, dataclasses.replace(ball.settings, numerics="povray"))
    assert _at(failing_mask(image, expected, HALF_FLOAT)) == set()


def test_native_in_the_shadow_cache_window_counts_them(ball, monkeypatch):
    expected = _oracle_at(ball, oracle.MIN_ISECT_DEPTH, monkeypatch)
    image = native.render(ball, dataclasses.replace(ball.settings, numerics="povray-shadow-cache"))
    assert _at(failing_mask(image, expected, HALF_FLOAT)) == set()


def test_the_scale_invariant_window_is_a_different_renderer_here(ball, monkeypatch):
    # Why the cross test must render in POV-Ray's numerics: the scale-invariant window (1.9e-5 ·
    # the half-extent: 6.7e-5 for the ball and camera, 1.05e-4 with the floor) counts the chords
    # POV-Ray ignores.
    povray = _oracle_at(ball, oracle.SHADOW_TOLERANCE, monkeypatch)
    image = native.render(ball, dataclasses.replace(ball.settings, numerics="scale-invariant"))
    assert set(TERMINATOR_PIXELS) <= _at(failing_mask(image, povray, HALF_FLOAT))
