# SPDX-License-Identifier: Apache-2.0
"""UsdGeom's intrinsic prims as exact surfaces (model ``Intrinsic``): Cube, Cylinder (and its
two-radius form), Cone, Capsule and Plane (finite, or infinite where a scene asks). The native
tracer against the oracle's independent textbook formulas (tests/oracle.py) and against analytic
hits on the hard cases (grazing rays, scales from 1e-6 to 1e6, rays leaving the surface), and
POV-Ray's ``box``/``cylinder``/``cone``/capsule union/``polygon``/``plane`` against the native
tracer."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from phongscene import compile_pov, render
from phongscene.backends import native
from phongscene.comparison import compare
from phongscene.scene import Intrinsic, PointLight, Scene
from phongscene.validate import validate
from support import oracle
from support.calibration import GOLD, _sphere_on_ground

# As tests/test_native_render.py: the native tracer against the float64 oracle.
ORACLE_RELATIVE_TOLERANCE = 1e-6
ORACLE_ABSOLUTE_FLOOR = 1e-30
# An analytic hit distance is found to this relative error: a few ulps of double (the stable
# roots lose no digits to cancellation at any distance or scale).
HIT_RELATIVE_TOLERANCE = 1e-12


def rotation(axis: int, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    m = np.eye(4)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    m[i, i] = m[j, j] = c
    m[i, j], m[j, i] = -s, s
    return m


def placed(translation, scale, turn=None) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = translation
    return m @ (np.eye(4) if turn is None else turn) @ np.diag([*scale, 1.0])


TILTED = placed((0.3, 1.2, -0.2), (0.8, 0.6, 0.9), rotation(0, 0.7) @ rotation(1, 0.4))
KINDS = {
    "cube": dict(kind="cube"),
    "cylinder": dict(kind="cylinder"),
    "cone": dict(kind="cylinder", radius_top=0.0),
    "cylinder_1": dict(kind="cylinder", radius_bottom=0.4, radius_top=1.0),
    "capsule": dict(kind="capsule", radius_bottom=0.5, radius_top=0.5, half_height=0.6),
    "capsule_1": dict(kind="capsule", radius_bottom=0.7, radius_top=0.3, half_height=0.5),  # USD Capsule_1
    "plane": dict(kind="plane"),
}


def intrinsic_scene(name: str) -> Scene:
    """The calibration ground and light with one tilted, non-uniformly scaled intrinsic above it
    (casting its shadow on the ground and, for the concave-free shapes, on itself)."""
    base = _sphere_on_ground(PointLight((3.41, 5.07, 2.93), (2.2, 1.3, 0.7)), material=GOLD)
    return dataclasses.replace(
        base, spheres=(), intrinsics=(Intrinsic(world_from_object=TILTED, material=GOLD, **KINDS[name]),)
    )


def infinite_plane_scene() -> Scene:
    """The calibration sphere resting 0.01 above an infinite ground plane (y = 0: the plane's
    z axis turned onto +y)."""
    base = _sphere_on_ground(PointLight((3.41, 5.07, 2.93), (2.2, 1.3, 0.7)), material=GOLD)
    ground = Intrinsic(
        "plane", placed((0, 0, 0), (1, 1, 1), rotation(0, -math.pi / 2)), base.meshes[0].material, infinite=True
    )
    return dataclasses.replace(base, meshes=(), intrinsics=(ground,))


@pytest.mark.parametrize("name", KINDS)
def test_native_traces_each_intrinsic_as_the_oracle(name):
    scene = intrinsic_scene(name)
    got = render(scene, "native")
    np.testing.assert_allclose(got, oracle.render(scene), rtol=ORACLE_RELATIVE_TOLERANCE, atol=ORACLE_ABSOLUTE_FLOOR)
    empty = render(dataclasses.replace(scene, intrinsics=()), "native")
    assert np.any(got != empty, axis=2).sum() > 150  # the shape is in view


def test_an_infinite_plane_is_traced_as_the_oracle_and_keeps_contact_shadows():
    scene = infinite_plane_scene()
    got = render(scene, "native")
    np.testing.assert_allclose(got, oracle.render(scene), rtol=ORACLE_RELATIVE_TOLERANCE, atol=ORACLE_ABSOLUTE_FLOOR)


def test_an_infinite_plane_does_not_widen_the_ray_tolerances():
    """The scale-aware tolerances come from the finite geometry: with the infinite plane the
    scene measures as the sphere alone, where a 20,000-unit ground square would measure 10,000."""
    scene = infinite_plane_scene()
    built = native.build(scene)
    alone = native.build(dataclasses.replace(scene, intrinsics=()))
    assert built.magnitude == alone.magnitude
    assert scene.bounds()[1][0] == dataclasses.replace(scene, intrinsics=()).bounds()[1][0]


def unit_ray_hits(scene: Scene, origins, dirs, t_min=0.0):
    return native.build(scene).intersect(np.asarray(origins, float), np.asarray(dirs, float), t_min)


def lone(intrinsic: Intrinsic) -> Scene:
    return Scene(intrinsics=(intrinsic,))


@pytest.mark.parametrize("scale", [1e-6, 1.0, 1e6])
@pytest.mark.parametrize("impact", [0.0, 0.5, 0.999999])
@pytest.mark.parametrize("radii", [(1.0, 1.0), (1.5, 0.5), (2.0, 0.0)])
def test_the_side_is_hit_at_the_analytic_distance_at_any_scale(scale, impact, radii):
    """A ray along +x at height z = 0 (radius (r0 + r1)/2 there) and offset impact·r in y, from
    1000 sizes away: it meets the side at x = −r·√(1 − impact²)."""
    r0, r1 = radii
    r = (r0 + r1) / 2
    shape = Intrinsic("cylinder", np.diag([scale, scale, scale, 1.0]), radius_bottom=r0, radius_top=r1)
    start = -1000.0 * scale
    t, _ = unit_ray_hits(lone(shape), [[start, impact * r * scale, 0.0]], [[1.0, 0.0, 0.0]])
    expected = -start - r * scale * math.sqrt(1.0 - impact**2)
    assert abs(t[0] - expected) <= HIT_RELATIVE_TOLERANCE * expected


@pytest.mark.parametrize("scale", [1e-6, 1.0, 1e6])
def test_grazing_rays_hit_inside_and_miss_outside(scale):
    """Offsets of 1e-9 of the radius either side of the silhouette, for the side, a box face and a
    capsule end."""
    cylinder = lone(Intrinsic("cylinder", np.diag([scale, scale, scale, 1.0])))
    cube = lone(Intrinsic("cube", np.diag([scale, scale, scale, 1.0])))
    capsule = lone(Intrinsic("capsule", np.diag([scale, scale, scale, 1.0]), half_height=1.0))
    start, margin = -1000.0 * scale, 1e-9
    for scene, (y, z) in ((cylinder, (1.0, 0.0)), (cube, (1.0, 0.0)), (capsule, (0.0, 1.0 + 1.0))):
        inside = [[start, (y - margin) * scale if y else 0.0, (z - margin) * scale if z else 0.0]]
        outside = [[start, (y + margin) * scale if y else 0.0, (z + margin) * scale if z else 0.0]]
        _, hit_id = unit_ray_hits(scene, inside, [[1.0, 0.0, 0.0]])
        _, miss_id = unit_ray_hits(scene, outside, [[1.0, 0.0, 0.0]])
        assert hit_id[0] >= 0 and miss_id[0] == -1


@pytest.mark.parametrize("scale", [1e-6, 1.0, 1e6])
def test_a_ray_leaving_the_surface_sees_only_the_far_side(scale):
    """From a point on the side, outward: nothing beyond a relative 1e-9 of the size; inward
    along the diameter: the opposite side at 2r."""
    scene = lone(Intrinsic("cylinder", np.diag([scale, scale, scale, 1.0])))
    p = [[scale * math.cos(0.3), scale * math.sin(0.3), 0.2 * scale]]
    out = [[math.cos(0.3), math.sin(0.3), 0.0]]
    t, hit = unit_ray_hits(scene, p, out, t_min=1e-9 * scale)
    assert hit[0] == -1
    t, hit = unit_ray_hits(scene, p, [[-math.cos(0.3), -math.sin(0.3), 0.0]], t_min=1e-9 * scale)
    assert abs(t[0] - 2 * scale) <= HIT_RELATIVE_TOLERANCE * 2 * scale


@pytest.mark.parametrize("scale", [1e-6, 1.0, 1e6])
def test_a_two_radius_capsule_is_the_hull_of_its_end_spheres(scale):
    """Capsule_1 with radii 0.7 and 0.3 at the ends of a side of half-height 0.5: the slope is
    s = 0.4, so the bottom sphere has its centre at −0.5 − 0.28 = −0.78 and radius 0.7·√1.16, the
    the top one at 0.5 − 0.12 = 0.38, radius 0.3·√1.16 (similar triangles, worked by hand).
    Along the axis a ray meets the spheres' poles; across it, at z = 0, the side's radius 0.5."""
    shape = Intrinsic(
        "capsule", np.diag([scale, scale, scale, 1.0]), radius_bottom=0.7, radius_top=0.3, half_height=0.5
    )
    grow = math.sqrt(1.16)
    start = 1000.0 * scale
    t, _ = unit_ray_hits(lone(shape), [[0.0, 0.0, -start]], [[0.0, 0.0, 1.0]])
    assert abs(t[0] - (start - 0.78 * scale - 0.7 * grow * scale)) <= HIT_RELATIVE_TOLERANCE * start
    t, _ = unit_ray_hits(lone(shape), [[0.0, 0.0, start]], [[0.0, 0.0, -1.0]])
    assert abs(t[0] - (start - 0.38 * scale - 0.3 * grow * scale)) <= HIT_RELATIVE_TOLERANCE * start
    t, _ = unit_ray_hits(lone(shape), [[-start, 0.0, 0.0]], [[1.0, 0.0, 0.0]])
    assert abs(t[0] - (start - 0.5 * scale)) <= HIT_RELATIVE_TOLERANCE * start
    # Just outside the side's silhouette at its bottom end (where it touches the sphere): a miss.
    outside = 0.7 * (1 + 1e-9) * scale
    _, hit = unit_ray_hits(lone(shape), [[-start, outside, -0.5 * scale]], [[1.0, 0.0, 0.0]])
    assert hit[0] == -1


def test_caps_close_the_cylinder_and_the_cone_has_no_mirror_image():
    cylinder = lone(Intrinsic("cylinder", np.eye(4)))
    t, _ = unit_ray_hits(cylinder, [[0.2, 0.1, 5.0]], [[0.0, 0.0, -1.0]])
    assert t[0] == pytest.approx(4.0, rel=HIT_RELATIVE_TOLERANCE)  # the top cap at z = 1
    cone = lone(Intrinsic("cylinder", np.eye(4), radius_top=0.0))
    # Above the apex (z = 1) the quadric's other nappe is not part of the cone.
    _, hit = unit_ray_hits(cone, [[-5.0, 0.0, 1.5]], [[1.0, 0.0, 0.0]])
    assert hit[0] == -1
    t, _ = unit_ray_hits(cone, [[0.0, 0.0, -5.0]], [[0.0, 0.0, 1.0]])
    assert t[0] == pytest.approx(4.0, rel=HIT_RELATIVE_TOLERANCE)  # the base disc


@pytest.mark.povray
@pytest.mark.parametrize("name", [*KINDS, "infinite plane"])
def test_povray_draws_each_intrinsic_as_the_native_tracer(name):
    scene = infinite_plane_scene() if name == "infinite plane" else intrinsic_scene(name)
    scene = dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, numerics="povray"))
    result = compare(render(scene, "povray", mapping="exact"), render(scene, "native"))
    assert result.ok, result


def test_the_sdl_uses_povrays_own_shapes():
    expected = {
        "cube": "box {",
        "cylinder": "cylinder {",
        "cone": "cone {",
        "cylinder_1": "cone {",
        "capsule": "union { sphere",
        "capsule_1": "open }",
        "plane": "polygon { 4",
    }
    for name, keyword in expected.items():
        assert keyword in compile_pov(intrinsic_scene(name), mapping="classic")
    assert "plane { z, 0" in compile_pov(infinite_plane_scene(), mapping="classic")


def test_validation_names_bad_intrinsics():
    bad = (
        Intrinsic("cylinder", np.eye(4), radius_bottom=0.0, radius_top=0.0, source="/A"),
        Intrinsic("cube", np.diag([1.0, 0.0, 1.0, 1.0]), source="/B"),
        Intrinsic("capsule", np.eye(4), radius_bottom=-1.0, radius_top=-1.0, source="/C"),
        Intrinsic("cube", np.eye(4), infinite=True, source="/D"),
    )
    problems = {(p.prim, p.attribute) for p in validate(Scene(intrinsics=bad))}
    assert {
        ("/A", "radius_bottom"),
        ("/B", "world_from_object"),
        ("/C", "radius_bottom"),
        ("/D", "infinite"),
    } <= problems
