# SPDX-License-Identifier: Apache-2.0
"""UsdGeom.BasisCurves as tubes (phongscene/usd/curves.py): each segment the hull of its end
spheres as a capsule Intrinsic, checked in closed form (the capsule's end spheres are the given
ones; rays onto a straight tube hit at the height √(r² − d²)), cubic bases through their end
points, widths by interpolation, bad input named by prim and attribute, and POV-Ray against the
native tracer."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, UsdLux, Vt

from phongscene import render
from phongscene.backends import native
from phongscene.comparison import compare
from phongscene.errors import SceneError
from phongscene.rendering import settings_for
from phongscene.usd import read_usd
from phongscene.usd.curves import SAMPLES_PER_SEGMENT, swept_segment

# Closed forms in double precision over unit-sized values: a few roundings.
EXACT = 1e-12
# Rays against the traced tube: the stable quadratic and the frame's rotation, ~1e-15 relative;
# the curve's points are float32 in the stage (exact small binary fractions here).
HIT_TOLERANCE = 1e-9


def world_ends(shape):
    """The capsule's end spheres in world space: (centre (3,), radius)."""
    m = shape.world_from_object
    scale = np.linalg.norm(m[:3, 2])
    return [(m[:3, :3] @ np.array([0.0, 0.0, z]) + m[:3, 3], r * scale) for z, r in shape.capsule_ends()]


@pytest.mark.parametrize(
    "c0, r0, c1, r1",
    [
        ((0, 0, 0), 0.5, (2, 0, 0), 0.5),
        ((1, 2, 3), 0.9, (-1, 0.5, 2), 0.1),
        ((0, 0, 0), 0.0, (0, 0, 1), 0.3),  # a cone from a point
        ((0, 0, 0), 0.3, (0, 1e-3, 0), 0.2995),  # nearly containing: σ → 0.5
        ((0, 0, 0), 1e-6, (1e-5, 0, 0), 2e-6),  # tiny
        ((1e5, 0, 0), 2e3, (1e5, 3e4, 0), 1e3),  # huge
    ],
)
def test_a_segment_is_the_hull_of_its_end_spheres(c0, r0, c1, r1):
    shape = swept_segment(c0, r0, c1, r1, np.eye(4), _material(), "/C")
    got = world_ends(shape)
    wanted = [(np.asarray(c, float), r) for c, r in ((c0, r0), (c1, r1)) if r > 0]
    assert len(got) == len(wanted)
    size = max(np.abs(np.r_[c0, c1]).max(), r0, r1)
    for (gc, gr), (wc, wr) in zip(got, wanted):
        np.testing.assert_allclose(gc, wc, atol=EXACT * size)
        assert gr == pytest.approx(wr, rel=EXACT, abs=EXACT * size)


def test_a_sphere_inside_the_other_leaves_the_larger():
    shape = swept_segment((0, 0, 0), 1.0, (0.5, 0, 0), 0.2, np.eye(4), _material(), "/C")
    for centre, radius in world_ends(shape):  # a capsule of height 0: both ends the one sphere
        np.testing.assert_array_equal(centre, [0, 0, 0])
        assert radius == 1.0


def _material():
    from phongscene.scene import DEFAULT_MATERIAL

    return DEFAULT_MATERIAL


def write_curves(path, points, counts, *, kind="linear", basis=None, wrap=None, widths=None, interpolation=None):
    stage = Usd.Stage.CreateNew(str(path))
    curves = UsdGeom.BasisCurves.Define(stage, "/C")
    curves.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*p) for p in points]))
    curves.CreateCurveVertexCountsAttr(counts)
    curves.CreateTypeAttr(kind)
    if basis is not None:
        curves.CreateBasisAttr(basis)
    if wrap is not None:
        curves.CreateWrapAttr(wrap)
    if widths is not None:
        curves.CreateWidthsAttr(widths)
        if interpolation is not None:
            curves.SetWidthsInterpolation(interpolation)
    stage.GetRootLayer().Save()
    return stage


def test_a_straight_tube_is_hit_at_its_closed_form_height(tmp_path):
    path = tmp_path / "tube.usda"
    write_curves(path, [(-1, 0, 0), (0, 0, 0), (1, 0, 0)], [3], widths=[0.5])
    scene = read_usd(str(path)).scene
    assert len(scene.intrinsics) == 2
    x, y = np.meshgrid(np.linspace(-1.6, 1.6, 33), np.linspace(-0.4, 0.4, 17))
    origins = np.stack([x.ravel(), y.ravel(), np.full(x.size, 5.0)], axis=1)
    dirs = np.tile([0.0, 0.0, -1.0], (len(origins), 1))
    t, _ = native.build(scene).intersect(origins, dirs)
    # distance from (x, y) to the segment's axis [-1, 1] × {0}: the stadium of radius 0.25
    d = np.hypot(np.maximum(np.abs(origins[:, 0]) - 1.0, 0.0), origins[:, 1])
    inside = d < 0.25 - 1e-9
    outside = d > 0.25 + 1e-9
    assert inside.sum() > 100 and outside.sum() > 100
    np.testing.assert_allclose(t[inside], 5.0 - np.sqrt(0.25**2 - d[inside] ** 2), atol=HIT_TOLERANCE)
    assert np.isinf(t[outside]).all()


@pytest.mark.parametrize("basis", ["bezier", "bspline", "catmullRom"])
def test_cubic_curves_sample_their_basis(tmp_path, basis):
    points = [(0, 0, 0), (1, 1, 0), (2, -1, 0), (3, 0, 0)]
    path = tmp_path / "cubic.usda"
    write_curves(path, points, [4], kind="cubic", basis=basis, widths=[0.1])
    tubes = read_usd(str(path)).scene.intrinsics
    assert len(tubes) == SAMPLES_PER_SEGMENT
    starts = np.array([world_ends(s)[0][0] for s in tubes])
    p = np.asarray(points, float)
    if basis == "bezier":  # through its end points, B(1/2) = (P0 + 3P1 + 3P2 + P3)/8
        np.testing.assert_allclose(starts[0], p[0], atol=EXACT)
        np.testing.assert_allclose(starts[SAMPLES_PER_SEGMENT // 2], (p[0] + 3 * p[1] + 3 * p[2] + p[3]) / 8, atol=1e-7)
    elif basis == "catmullRom":  # the middle segment, from P1 to P2
        np.testing.assert_allclose(starts[0], p[1], atol=EXACT)
        np.testing.assert_allclose(world_ends(tubes[-1])[-1][0], p[2], atol=1e-7)
    else:  # B-spline: from (P0 + 4P1 + P2)/6
        np.testing.assert_allclose(starts[0], (p[0] + 4 * p[1] + p[2]) / 6, atol=1e-7)


def test_pinned_and_periodic_wraps(tmp_path):
    square = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
    path = tmp_path / "wrap.usda"
    write_curves(path, square, [4], kind="cubic", basis="bspline", wrap="pinned", widths=[0.1])
    tubes = read_usd(str(path)).scene.intrinsics
    assert len(tubes) == 3 * SAMPLES_PER_SEGMENT
    np.testing.assert_allclose(world_ends(tubes[0])[0][0], square[0], atol=1e-7)  # pinned to its ends
    np.testing.assert_allclose(world_ends(tubes[-1])[-1][0], square[-1], atol=1e-7)
    write_curves(path, square, [4], wrap="periodic", widths=[0.1])
    loop = read_usd(str(path)).scene.intrinsics
    assert len(loop) == 4  # closed: the fourth segment back to the start
    np.testing.assert_allclose(world_ends(loop[-1])[-1][0], square[0], atol=EXACT)


def test_widths_by_interpolation(tmp_path):
    path = tmp_path / "widths.usda"
    pts = [(0, 0, 0), (1, 0, 0), (2, 0, 0), (5, 0, 0), (6, 0, 0)]
    write_curves(path, pts, [3, 2], widths=[0.2, 0.4, 0.6, 0.8, 1.0], interpolation="vertex")
    radii = [r for s in read_usd(str(path)).scene.intrinsics for _, r in world_ends(s)]
    assert radii == pytest.approx([0.1, 0.2, 0.2, 0.3, 0.4, 0.5], rel=1e-6)  # widths are float
    write_curves(path, pts, [3, 2], widths=[0.2, 1.0], interpolation="uniform")
    radii = [r for s in read_usd(str(path)).scene.intrinsics for _, r in world_ends(s)]
    assert radii == pytest.approx([0.1, 0.1, 0.1, 0.1, 0.5, 0.5], rel=1e-6)


@pytest.mark.parametrize(
    "kwargs, attribute, message",
    [
        ({"widths": [0.1, 0.2], "interpolation": "vertex"}, "widths", "expected 3"),
        ({"widths": [-0.1]}, "widths", "finite and >= 0"),
        ({"kind": "cubic", "basis": "bezier"}, "curveVertexCounts", "too few"),
        ({"kind": "cubic", "basis": "hermite"}, "basis", "must be one of"),
    ],
)
def test_bad_curves_name_the_prim_and_attribute(tmp_path, kwargs, attribute, message):
    path = tmp_path / "bad.usda"
    write_curves(path, [(0, 0, 0), (1, 0, 0), (2, 0, 0)], [3], **kwargs)
    with pytest.raises(SceneError) as caught:
        read_usd(str(path))
    assert f"/C.{attribute}" in str(caught.value) and message in str(caught.value)


@pytest.mark.povray
def test_povray_renders_the_tubes_as_the_native_tracer(tmp_path):
    path = tmp_path / "curl.usda"
    stage = write_curves(
        path,
        [(-1.5, -0.5, 0), (-0.5, 1, 0.3), (0.5, -1, -0.3), (1.5, 0.5, 0)],
        [4],
        kind="cubic",
        basis="catmullRom",
        wrap="pinned",
        widths=[0.3, 0.5, 0.2, 0.4],
        interpolation="vertex",
    )
    light = UsdLux.SphereLight.Define(stage, "/Light")
    light.AddTranslateOp().Set((2, 3, 4))
    light.CreateIntensityAttr(30.0)
    light.CreateTreatAsPointAttr(True)
    stage.GetRootLayer().Save()
    scene = read_usd(str(path)).scene
    scene = dataclasses.replace(
        scene, settings=dataclasses.replace(scene.settings, width=64, height=48, numerics="povray")
    )
    native_image = render(scene, "native", settings=settings_for(scene, mapping="exact"))
    assert native_image.max() > 0.05
    result = compare(render(scene, "povray", mapping="exact"), native_image)
    assert result.ok, result
