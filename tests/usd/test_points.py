# SPDX-License-Identifier: Apache-2.0
"""``UsdGeom.Points`` with ``widths`` read as analytic spheres: one compact ``Points`` node
(world-space centres and radii) under a similarity transform, a ``Sphere`` per point under a
non-uniform one; widths of every interpolation; bad widths are SceneErrors naming the prim and
``widths``; a Points node renders as today's per-point spheres and round-trips through write_usd."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, Vt

from phongscene.backends import native
from phongscene.errors import SceneError
from phongscene.scene import Points, Sphere
from phongscene.usd import read_usd, write_usd
from phongscene.usd.geometry import DEFAULT_POINT_WIDTH, SIMILARITY_TOLERANCE
from phongscene.validate import validate

POSITIONS = [(-1.0, 0.0, 0.0), (0.0, 0.0, 0.0), (1.5, 0.0, 0.0)]


def _points_stage(path, widths=None, interpolation=None, xform=None, positions=POSITIONS) -> str:
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    world = UsdGeom.Xform.Define(stage, "/World")
    if xform is None:
        world.AddTranslateOp().Set(Gf.Vec3d(0, 1, 0))
    else:
        xform(world)
    points = UsdGeom.Points.Define(stage, "/World/Dots")
    points.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*p) for p in positions]))
    if widths is not None:
        points.CreateWidthsAttr(Vt.FloatArray(widths))
        if interpolation:
            points.SetWidthsInterpolation(interpolation)
    stage.GetRootLayer().Save()
    return str(path)


def test_points_are_spheres_of_their_widths(tmp_path):
    result = read_usd(_points_stage(tmp_path / "p.usda", [0.5, 1.0, 0.0], UsdGeom.Tokens.vertex))
    assert result.scene.spheres == ()
    (points,) = result.scene.points
    # A zero width draws nothing; the prim's translate moves the centres.
    assert points.centers.tolist() == [[-1.0, 1.0, 0.0], [0.0, 1.0, 0.0]]
    assert points.radii.tolist() == [0.25, 0.5]
    assert points.source == "/World/Dots"
    assert ("/World/Dots", "Points (2 spheres)") in result.nodes
    assert not any("unsupported geometry" in w for w in result.warnings)


@pytest.mark.parametrize("interpolation", [UsdGeom.Tokens.constant, None])
def test_one_width_is_every_points_width(tmp_path, interpolation):
    """One value: constant (authored so, or by its count as USD renderers read it)."""
    (points,) = read_usd(_points_stage(tmp_path / "c.usda", [0.2], interpolation)).scene.points
    assert points.radii.tolist() == [np.float64(np.float32(0.2)) / 2] * 3


@pytest.mark.parametrize("interpolation", [UsdGeom.Tokens.vertex, UsdGeom.Tokens.varying])
def test_a_width_per_point(tmp_path, interpolation):
    (points,) = read_usd(_points_stage(tmp_path / "v.usda", [0.5, 1.0, 2.0], interpolation)).scene.points
    assert points.radii.tolist() == [0.25, 0.5, 1.0]


def test_missing_widths_warn_and_use_the_default(tmp_path):
    result = read_usd(_points_stage(tmp_path / "none.usda"))
    assert result.scene.points[0].radii.tolist() == [DEFAULT_POINT_WIDTH / 2] * 3
    assert any("Points without widths" in w and "/World/Dots" in w for w in result.warnings)


@pytest.mark.parametrize(
    ("widths", "expected"),
    [
        ([0.1, 0.2], "expected 1 (constant) or 3"),
        ([0.1, -0.2, 0.3], "widths[1] = -0.2"),
        ([0.1, 0.2, math.nan], "widths[2] = nan"),
        ([math.inf], "finite"),
    ],
)
def test_bad_widths_are_scene_errors(tmp_path, widths, expected):
    with pytest.raises(SceneError) as raised:
        read_usd(_points_stage(tmp_path / "bad.usda", widths))
    problem = raised.value.problems[0]
    assert problem.prim == "/World/Dots" and problem.attribute == "widths" and expected in problem.message


def test_a_similarity_transform_keeps_one_points_node(tmp_path):
    """Rotation and uniform scale 2 (and a mirror): spheres stay spheres, radii scaled."""

    def turn_and_scale(world):
        world.AddTranslateOp().Set(Gf.Vec3d(0.5, 0, 0))
        world.AddRotateXYZOp().Set(Gf.Vec3f(30, 45, 10))
        world.AddScaleOp().Set(Gf.Vec3f(2, -2, 2))

    result = read_usd(_points_stage(tmp_path / "s.usda", [0.5], xform=turn_and_scale))
    (points,) = result.scene.points
    stage = Usd.Stage.CreateInMemory()  # the same ops, for the matrix USD composes of them
    world = UsdGeom.Xform.Define(stage, "/World")
    turn_and_scale(world)
    m = np.array(world.ComputeLocalToWorldTransform(Usd.TimeCode.Default())).T
    expected = (m[:3, :3] @ np.array(POSITIONS).T).T + m[:3, 3]
    assert np.allclose(points.centers, expected, rtol=1e-12, atol=1e-12)
    assert np.allclose(points.radii, 0.5, rtol=1e-6)  # 2 · 0.5/2 (float32 rotation angles)


def test_a_non_uniform_scale_makes_ellipsoids(tmp_path):
    """Beyond SIMILARITY_TOLERANCE a sphere's image is an ellipsoid: one Sphere (matrix) each."""

    def stretch(world):
        world.AddScaleOp().Set(Gf.Vec3f(1, 1 + 100 * SIMILARITY_TOLERANCE, 1))

    result = read_usd(_points_stage(tmp_path / "e.usda", [0.5], xform=stretch))
    assert result.scene.points == () and len(result.scene.spheres) == 3
    assert result.scene.spheres[0].world_from_object[1, 1] == pytest.approx(0.25 * (1 + 100 * SIMILARITY_TOLERANCE))


def test_a_points_prim_renders_as_todays_spheres(tmp_path):
    """The node traces as the per-point Spheres the reader made before (world · translate(p) ·
    scale(w/2)): identical under a translation."""
    rng = np.random.default_rng(2)
    positions = [tuple(map(float, p)) for p in rng.random((40, 3)) * 3 - 1.5]
    widths = (rng.random(40) * 0.4 + 0.1).astype(np.float32).tolist()
    result = read_usd(_points_stage(tmp_path / "r.usda", widths, UsdGeom.Tokens.vertex, positions=positions))
    scene = result.scene
    world = np.eye(4)
    world[1, 3] = 1.0
    old = []
    for p, w in zip(np.array(positions, dtype=np.float32).astype(np.float64), np.array(widths, dtype=np.float64)):
        local = np.diag([w / 2, w / 2, w / 2, 1.0])
        local[:3, 3] = p
        old.append(Sphere(world @ local, scene.points[0].material, "/World/Dots"))
    before = native.render(scene.__class__(**{**_fields(scene), "points": (), "spheres": tuple(old)}))
    assert before.max() > 0.05
    assert np.array_equal(native.render(scene), before)


def _fields(scene):
    return {name: getattr(scene, name) for name in scene.__dataclass_fields__}


def test_points_round_trip_through_write_usd(tmp_path):
    scene = read_usd(_points_stage(tmp_path / "a.usda", [0.5, 1.0, 0.25], UsdGeom.Tokens.vertex)).scene
    back = read_usd(write_usd(scene, tmp_path / "b.usda")).scene
    (a,), (b,) = scene.points, back.points
    assert np.array_equal(a.centers, b.centers) and np.array_equal(a.radii, b.radii)


@pytest.mark.parametrize(
    ("centers", "radii", "attribute", "expected"),
    [
        ([[0.0, 0.0, 0.0]] * 2, [1.0], "radii", "has 1 values for 2 centers"),
        ([[0.0, 0.0, 0.0]] * 2, [1.0, 0.0], "radii", "radii[1] = 0"),
        ([[0.0, 0.0, 0.0]] * 2, [1.0, -2.0], "radii", "radii[1] = -2"),
        ([[0.0, 0.0, 0.0]], [1e-120], "radii", "underflows"),
        ([[0.0, math.nan, 0.0]], [1.0], "centers", "finite"),
        ([[0.0, 0.0, 0.0]], [math.nan], "radii", "finite"),
        ([[1e151, 0.0, 0.0]], [1.0], "centers", "within"),
    ],
)
def test_bad_points_nodes_are_problems_naming_the_prim(centers, radii, attribute, expected):
    from phongscene.scene import Scene

    problems = validate(Scene(points=(Points(centers, radii, source="/World/Dots"),)))
    assert [(p.prim, p.attribute) for p in problems] == [("/World/Dots", attribute)]
    assert expected in problems[0].message
