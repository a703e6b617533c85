# SPDX-License-Identifier: Apache-2.0
"""A ``Points`` set in POV-Ray: one ``union`` of ``sphere { <c>, r }`` with one texture, which
renders as the native tracer's balls (``compare``'s half-float thresholds), and the same SDL
numbers as the spheres one by one."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from phongscene import compile_pov, render
from phongscene.comparison import compare
from phongscene.scene import PointLight, Points, Sphere
from support.calibration import GOLD, _sphere_on_ground


def points_scene():
    """The calibration ground and light with a small cloud of overlapping balls above it (each
    shadowing others and the ground)."""
    base = _sphere_on_ground(PointLight((3.41, 5.07, 2.93), (2.2, 1.3, 0.7)), material=GOLD)
    rng = np.random.default_rng(7)
    centers = rng.random((30, 3)) * (2.4, 1.6, 2.4) + (-1.2, 0.35, -1.3)
    radii = rng.random(30) * 0.2 + 0.12
    return dataclasses.replace(base, spheres=(), points=(Points(centers, radii, GOLD, "/World/Cloud"),))


@pytest.mark.povray
def test_povray_draws_points_as_the_native_tracer():
    scene = points_scene()
    scene = dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, numerics="povray"))
    result = compare(render(scene, "povray", mapping="exact"), render(scene, "native"))
    assert result.ok, result


def test_the_sdl_is_one_union_with_one_texture():
    scene = points_scene()
    sdl = compile_pov(scene, mapping="classic")
    (points,) = scene.points
    union = sdl[sdl.index("union {") :]
    assert union.count("sphere {") == len(points) and union.count("texture {") == 1
    # The numbers of each sphere are those compile writes for Sphere.at(c, r).
    one = compile_pov(
        dataclasses.replace(scene, points=(), spheres=(Sphere.at(points.centers[3], points.radii[3], GOLD),))
    )
    line = next(text for text in one.splitlines() if text.startswith("sphere {"))
    numbers = line[len("sphere { ") : line.index(" texture")]
    assert f" sphere {{ {numbers} }}" in union
