# SPDX-License-Identifier: Apache-2.0
"""The book's Checker3D (PhongMaterial.checker_size, checker_color): the cells and their parity
as Suffern's Checker3D::get_color computes them, the hard cases (a plane on a cell boundary,
cells beyond 32-bit counts, tiny and huge cells), validation, and the USD round trip. Agreement
with the oracle and POV-Ray on the calibration scene ``checker`` is in the calibration suites
(tests/native/test_native_render.py, tests/cross/test_cross_backend.py)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from phongscene.backends import native
from phongscene.errors import SceneError
from phongscene.scene import CHECKER_SHIFT, PhongMaterial
from phongscene.usd import load_usd, write_usd
from phongscene.validate import check, validate
from support import calibration, oracle

R = dataclasses.replace
# The native image is float32: values agree with the oracle's to float rounding of values near 1.
IMAGE_TOLERANCE = 1e-6


def _book_colour(material: PhongMaterial, p) -> tuple[float, ...]:
    """Suffern's Checker3D::get_color, transcribed: (int)floor(x / size) per axis, summed, % 2."""
    x, y, z = (c + CHECKER_SHIFT for c in p)
    s = material.checker_size
    total = int(math.floor(x / s)) + int(math.floor(y / s)) + int(math.floor(z / s))
    return material.diffuse_color if total % 2 == 0 else material.checker_color


def _ground_colour_at(scene, points: np.ndarray) -> np.ndarray:
    """The ground quad's cd at world points on it, as the native tracer shades them: rays straight
    down onto the points, through the oracle's hit routine's checker (the same rule)."""
    geo = oracle._prepare(scene)
    o = points + np.array([0.0, 1.0, 0.0])
    d = np.tile([0.0, -1.0, 0.0], (len(points), 1))
    t, material, *_rest = oracle._closest_hit(geo, o, d)
    colour = np.zeros((len(points), 3))
    oracle._checker_colours(geo, o, d, t, material, colour)
    return colour


def test_cells_are_the_books_on_a_plane_at_a_cell_boundary():
    # The ground is at y = 0, a whole multiple of the cell size: the book's ε puts it in the row
    # below (floor(ε / s) = -1), so a point at (x, 0, z) takes the parity of floor(x') + floor(z') - 1.
    scene = R(calibration.checker(), spheres=())  # the ground alone under the rays
    floor = scene.meshes[0].material
    rng = np.random.default_rng(7)
    points = np.column_stack([rng.uniform(-3, 3, 400), np.zeros(400), rng.uniform(-4, 1, 400)])
    want = np.array([_book_colour(floor, p) for p in points])
    assert np.array_equal(_ground_colour_at(scene, points), want)
    assert {tuple(c) for c in want} == {floor.diffuse_color, floor.checker_color}  # both colours seen


def test_native_image_equals_the_oracle_and_shows_both_colours_of_each_checker():
    scene = calibration.checker()
    image = native.render(scene)
    assert np.abs(image - oracle.render(scene)).max() <= IMAGE_TOLERANCE
    plain = native.render(R(scene, meshes=(calibration.ground_quad(0.0, calibration.GROUND),)))
    changed = (np.abs(image - plain) > 0.01).any(axis=2)
    assert 0.2 < changed.mean() < 0.8  # roughly half the ground's cells take the second colour


@pytest.mark.parametrize("size", [1e-6, 1e5])
def test_tiny_and_huge_cells_agree_with_the_oracle(size):
    scene = calibration.checker()
    floor = R(scene.meshes[0].material, checker_size=size)
    scene = R(scene, meshes=(calibration.ground_quad(0.0, floor),))
    assert np.abs(native.render(scene) - oracle.render(scene)).max() <= IMAGE_TOLERANCE


def test_cells_beyond_32_bit_counts_are_even_as_povray_counts_them():
    # 1e-12-unit cells: every visible point is > 2^31 cells from the origin, where POV-Ray's int
    # cast of the summed cells gives INT_MIN (even): the first colour everywhere, in both.
    scene = calibration.checker()
    floor = R(scene.meshes[0].material, checker_size=1e-12)
    tiny = R(scene, meshes=(calibration.ground_quad(0.0, floor),))
    uniform = R(scene, meshes=(calibration.ground_quad(0.0, R(floor, checker_size=0.0)),))
    image = native.render(tiny)
    assert np.abs(image - native.render(uniform)).max() <= IMAGE_TOLERANCE
    assert np.abs(image - oracle.render(tiny)).max() <= IMAGE_TOLERANCE


def test_a_scene_without_a_checker_is_unchanged_by_the_fields():
    scene = calibration.point_light()
    grey = R(scene.spheres[0].material, checker_color=(0.3, 0.3, 0.3))  # size 0: no checker
    same = R(scene, spheres=(R(scene.spheres[0], material=grey),))
    assert np.array_equal(native.render(scene), native.render(same))


@pytest.mark.parametrize(
    "change, message",
    [
        ({"checker_size": -0.5}, "must be >= 0"),
        ({"checker_size": float("nan")}, "must be finite"),
        ({"checker_color": (0.2, -1.0, 0.2)}, "checker_color"),
    ],
)
def test_bad_checker_values_are_scene_errors_naming_the_field(change, message):
    scene = calibration.checker()
    bad = R(scene.spheres[0].material, **change)
    problems = validate(R(scene, spheres=(R(scene.spheres[0], material=bad),)))
    assert any(message in str(p) for p in problems), problems
    assert {p.attribute for p in problems} & {"checker_size", "checker_color"}


def test_a_checker_with_a_diffuse_texture_is_an_error():
    scene = calibration.SCENES["texture_repeat"]()
    mesh = next(m for m in scene.meshes if m.material.diffuse_texture is not None)
    both = R(mesh.material, checker_size=0.5)
    with pytest.raises(SceneError, match="a checker and a diffuse texture"):
        check(R(scene, meshes=tuple(R(m, material=both) if m is mesh else m for m in scene.meshes)))


def test_checker_inputs_round_trip_through_usd(tmp_path):
    scene = calibration.checker()
    path = write_usd(scene, tmp_path / "checker.usda")
    text = path.read_text()
    assert "inputs:checkerSize = 0.43" in text and "inputs:checkerColor" in text
    back = load_usd(path)
    # USD's float inputs hold float32 (as every other Phong input does).
    materials = {float(np.float32(m.material.checker_size)): m.material for m in (*back.meshes, *back.spheres)}
    assert set(materials) == {float(np.float32(0.43)), float(np.float32(0.2371))}
    assert materials[float(np.float32(0.43))].checker_color == pytest.approx((0.12, 0.16, 0.3))
    assert np.abs(native.render(back) - native.render(scene)).max() <= 1e-5  # float32 colours in USD


# --- The book's PlaneChecker (ch. 24's floors) --------------------------------------------------

PLANE = PhongMaterial(
    ka=0.3,
    kd=0.9,
    ks=0.0,
    exponent=1.0,
    diffuse_color=(0.9, 0.8, 0.1),
    checker_size=2.5,
    checker_color=(0.1, 0.3, 0.9),
    checker_plane=True,
    checker_outline_width=0.4,
    checker_outline_color=(0.0, 0.6, 0.0),
)


def _book_plane_colour(m: PhongMaterial, p) -> tuple[float, ...]:
    """Suffern's PlaneChecker::get_color as its code computes it (float x, z, x/s, fx, fz, width;
    ``1.0 - width`` in double), transcribed with numpy's float32."""
    f = np.float32
    x, z, s = f(p[0]), f(p[2]), f(m.checker_size)
    ix, iz = int(np.floor(x / s)), int(np.floor(z / s))
    fx, fz = f(x / s - f(ix)), f(z / s - f(iz))
    width = f(0.5 * float(f(m.checker_outline_width)) / float(s))
    if fx < width or fx > 1.0 - float(width) or fz < width or fz > 1.0 - float(width):
        return m.checker_outline_color
    return m.diffuse_color if (ix + iz) % 2 == 0 else m.checker_color


def _plane_scene(material: PhongMaterial = PLANE, numerics: str = "scale-invariant"):
    """The checker calibration scene with its ground wearing ``material``, seen from above."""
    scene = R(calibration.checker(), spheres=())
    ground = R(scene.meshes[0], material=material)
    settings = R(scene.settings, width=48, height=36, numerics=numerics)
    return R(scene, meshes=(ground,), settings=settings)


def test_plane_cells_and_outlines_are_the_books():
    scene = _plane_scene()
    rng = np.random.default_rng(11)
    points = np.column_stack([rng.uniform(-3, 3, 600), np.zeros(600), rng.uniform(-4, 1, 600)])
    want = np.array([_book_plane_colour(PLANE, p) for p in points])
    assert np.array_equal(_ground_colour_at(scene, points), want)
    assert len({tuple(c) for c in want}) == 3  # both cell colours and the outline seen


def test_plane_checker_native_image_equals_the_oracle():
    scene = _plane_scene()
    image = native.render(scene)
    np.testing.assert_allclose(image, oracle.render(scene), rtol=IMAGE_TOLERANCE, atol=1e-30)


@pytest.mark.povray
def test_plane_checker_povray_function_pigment_agrees_with_native():
    from phongscene import render
    from phongscene.comparison import compare

    for mapping in ("exact", "classic"):
        scene = _plane_scene(numerics="povray")
        settings = R(scene.settings, specular="seed" if mapping == "exact" else "povray-classic")
        pov = render(scene, "povray", settings, mapping=mapping, explain=False)
        assert compare(pov, native.render(scene, settings)).ok


@pytest.mark.parametrize(
    "change, field",
    [({"checker_outline_width": -1.0}, "checker_outline_width"), ({"checker_plane": "yes"}, "checker_plane")],
)
def test_bad_plane_checker_values_are_scene_errors_naming_the_field(change, field):
    scene = _plane_scene(R(PLANE, **change))
    assert field in {p.attribute for p in validate(scene)}


def test_plane_checker_inputs_round_trip_through_usd(tmp_path):
    scene = _plane_scene()
    read = load_usd(write_usd(scene, tmp_path / "plane.usda"))
    m = read.meshes[0].material
    assert (m.checker_plane, m.checker_size, m.checker_outline_width) == (True, 2.5, pytest.approx(0.4))
    assert m.checker_outline_color == pytest.approx(PLANE.checker_outline_color)
    assert m.checker_color == pytest.approx(PLANE.checker_color)
