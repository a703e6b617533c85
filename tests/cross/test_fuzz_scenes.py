# SPDX-License-Identifier: Apache-2.0
"""Fuzzing (issue 10): random valid scenes render finite on both backends, and the two images
agree as ``phongscene diff`` judges them (half-float precision at every pixel, or failing
pixels all explained by POV-Ray's shadow cache).

What the generator constrains, and why (each keeps a legitimate disagreement out, not a bug):

* Sizes and positions are continuous random numbers, so no silhouette, shadow boundary or
  triangle edge passes exactly through a pixel centre (where the backends' rounding may
  legitimately pick different sides); the camera and the lights stay outside every sphere.
* Pixel values stay far below half float's 65504 (POV-Ray's EXR): colours in [0, 1], light
  strengths up to 3, lights at least ``LIGHT_DISTANCE`` away.
* Point and directional lights, and flat meshes: area lights and smooth normals bring POV-Ray's
  shadow cache and float32 terminator behaviours, which tests/cross/test_cross_backend.py covers
  with the oracle on purpose-built scenes.
* Tiny images (``SIZE``): agreement is per pixel, so many small scenes find more than a few
  big ones; all POV-Ray frames of one example are rendered by one ``render_many`` call.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, seed
from hypothesis import strategies as st

from phongscene.comparison import compare, for_povray_passes
from phongscene.crossvalidation import DiffResult, _explain
from phongscene.rendering import render, settings_for
from phongscene.scene import (
    AmbientLight,
    Camera,
    DirectionalLight,
    PhongMaterial,
    PointLight,
    RenderSettings,
    Scene,
    Sphere,
    TriangleMesh,
)
from support.fuzz import SEED, fuzz_settings

# Random scenes may be empty or dark by construction: the image checks' ImageWarning is not what
# this suite tests (tests/cross/test_image_diagnostics.py is).
pytestmark = [pytest.mark.povray, pytest.mark.filterwarnings("ignore::phongscene.errors.ImageWarning")]

SIZE = (24, 18)
SCENES_PER_EXAMPLE = 8  # one render_many call (one POV-Ray process) per example
EXAMPLES = 3  # x PHONGSCENE_FUZZ_BUDGET
# Geometry lives in the cube |x| <= 2 plus radii <= 1.5 (farthest point 2·√3 + 1.5 ≈ 4.96 from
# the origin): the camera and lights at 6 or more are outside every sphere.
CAMERA_DISTANCE = (6.0, 10.0)
LIGHT_DISTANCE = (6.0, 12.0)

unit = st.floats(0.0, 1.0)
colour = st.tuples(unit, unit, unit)


@st.composite
def direction(draw) -> np.ndarray:
    """A random unit vector (a normalised Gaussian would need draws Hypothesis shrinks badly;
    uniform spherical coordinates are enough here)."""
    z = draw(st.floats(-0.99, 0.99))
    phi = draw(st.floats(0.0, 2 * math.pi))
    r = math.sqrt(1 - z * z)
    return np.array([r * math.cos(phi), z, r * math.sin(phi)])


@st.composite
def material(draw) -> PhongMaterial:
    exponent = draw(st.one_of(st.sampled_from([0.0, 1.0]), st.floats(0.0, 1000.0)))
    return PhongMaterial(draw(unit), draw(unit), draw(unit), exponent, draw(colour), draw(colour))


@st.composite
def sphere(draw) -> Sphere:
    centre = draw(st.tuples(*[st.floats(-2.0, 2.0)] * 3))
    return Sphere.at(centre, draw(st.floats(0.2, 1.5)), draw(material()))


@st.composite
def triangles(draw) -> TriangleMesh:
    """A few flat triangles in the geometry cube (they may intersect each other and spheres)."""
    n = draw(st.integers(1, 4))
    points = np.array(draw(st.lists(st.tuples(*[st.floats(-2.0, 2.0)] * 3), min_size=3 * n, max_size=3 * n)))
    tri = np.arange(3 * n, dtype=np.int32).reshape(n, 3)
    area = np.linalg.norm(
        np.cross(points[tri[:, 1]] - points[tri[:, 0]], points[tri[:, 2]] - points[tri[:, 0]]), axis=1
    )
    keep = area > 1e-3  # a sliver has no area the image can resolve; the model rejects none
    if not keep.any():
        points, tri = np.array([[-2.0, -2.0, -2.0], [2.0, -2.0, -2.0], [0.0, -2.0, 2.0]]), np.array([[0, 1, 2]])
    else:
        tri = tri[keep]
    return TriangleMesh(points, tri, material=draw(material()))


@st.composite
def light(draw):
    strength = draw(st.floats(0.1, 3.0))
    col = tuple(strength * c for c in draw(st.tuples(*[st.floats(0.2, 1.0)] * 3)))
    kind = draw(st.sampled_from(["point", "point-inverse-square", "directional"]))
    d = draw(direction())
    if kind == "directional":
        return DirectionalLight(tuple(-d), col)
    position = tuple(d * draw(st.floats(*LIGHT_DISTANCE)))
    if kind == "point":
        return PointLight(position, col)
    return PointLight(position, tuple(c * 50.0 for c in col), falloff="inverse-square")  # ~1/d² of 7-12


@st.composite
def scene(draw) -> Scene:
    eye = draw(direction()) * draw(st.floats(*CAMERA_DISTANCE))
    camera = Camera.look_at(tuple(eye), (0.0, 0.0, 0.0), draw(st.floats(30.0, 80.0)))
    settings = RenderSettings(
        width=SIZE[0],
        height=SIZE[1],
        background=draw(colour),
        specular=draw(st.sampled_from(["seed", "povray-classic"])),
    )
    return Scene(
        camera=camera,
        ambient=AmbientLight(tuple(0.3 * c for c in draw(colour))),
        lights=tuple(draw(st.lists(light(), min_size=1, max_size=3))),
        spheres=tuple(draw(st.lists(sphere(), min_size=0, max_size=4))),
        meshes=tuple(draw(st.lists(triangles(), min_size=0, max_size=1))),
        settings=settings,
    )


@pytest.mark.slow
@seed(SEED)
@fuzz_settings(EXAMPLES)
@given(st.lists(scene(), min_size=SCENES_PER_EXAMPLE, max_size=SCENES_PER_EXAMPLE))
def test_random_valid_scenes_agree_on_both_backends(scenes):
    from phongscene.backends.povray import MAPPING_OF_SPECULAR, pass_count, render_many

    settings = [replace(settings_for(s), numerics="povray") for s in scenes]  # as `diff` renders
    povray = render_many([(s, st_, None) for s, st_ in zip(scenes, settings)])
    for i, (s, st_, pov) in enumerate(zip(scenes, settings, povray)):
        native = render(s, "native", st_)
        assert np.isfinite(native).all() and (native >= 0).all(), f"scene {i}: native pixel not finite or negative"
        assert np.isfinite(pov).all() and (pov >= 0).all(), f"scene {i}: POV-Ray pixel not finite or negative"
        mapping = MAPPING_OF_SPECULAR[st_.specular]
        thresholds = for_povray_passes(pass_count(s, mapping))  # as `diff` judges them
        report = compare(pov, native, thresholds)
        images = {"povray": pov, "native": native}
        explained, ill_conditioned, unexplained = _explain(s, st_, mapping, images, report, thresholds)
        result = DiffResult(
            report, None, {}, pov, native, st_, mapping, [], explained, unexplained, ill_conditioned=ill_conditioned
        )
        assert result.ok, f"scene {i} ({st_.specular}): {report.summary()}\n{result.explanation()}\n{s}"
