# SPDX-License-Identifier: Apache-2.0
"""examples/book_15_8a.usda, figure 15.8(a) of Suffern's book in plain USD (docs/book.md): it
reads as the book's build function says (the mapping of docs/book.md, each value from the
figure's code), without a warning, and renders as the independent oracle does."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from phongscene import render
from phongscene.usd import read_usd
from support import oracle
from support.paths import EXAMPLES

# As tests/native/test_native_render.py: the native tracer against the float64 oracle.
ORACLE_RELATIVE_TOLERANCE = 1e-6
ORACLE_ABSOLUTE_FLOOR = 1e-30


@pytest.fixture(scope="module")
def result():
    return read_usd(EXAMPLES / "book_15_8a.usda")


def test_it_reads_as_the_books_build_function(result):
    scene = result.scene
    assert result.warnings == []
    # Pinhole d = 340, s = 1, 600 x 400: the horizontal field of view 2·atan(300/340).
    assert scene.camera.horizontal_fov_deg == pytest.approx(2 * math.degrees(math.atan(300 / 340)), rel=1e-6)
    assert scene.camera.position == pytest.approx((7.5, 4, 10))
    assert (scene.settings.width, scene.settings.height, scene.settings.samples, scene.settings.sample_pattern) == (
        600,
        400,
        4,
        "grid",
    )
    (sun,) = scene.lights
    assert not sun.linking.shadows and sun.color == pytest.approx((2, 2, 2))
    assert np.asarray(sun.direction) == pytest.approx(-np.array([15, 15, 2.5]) / np.linalg.norm([15, 15, 2.5]))
    assert scene.ambient.color == pytest.approx((0.5, 0.5, 0.5))
    kinds = {i.source.rsplit("/", 1)[1]: i for i in scene.intrinsics}
    assert kinds["Ground"].infinite and kinds["Mauve"].kind == "cylinder" and kinds["LightGreen"].kind == "cube"
    lo, hi = kinds["LightGreen"].world_bounds()
    assert lo == pytest.approx((-3.5, 0, -11)) and hi == pytest.approx((-2.5, 6, 6.5))  # the book's Box
    lo, hi = kinds["Mauve"].world_bounds()
    assert lo == pytest.approx((-2.2, 0, -2.2)) and hi == pytest.approx((2.2, 8.5, 2.2))  # SolidCylinder(0, 8.5, 2.2)


def test_it_renders_as_the_oracle(result):
    scene = result.scene
    small = dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, width=60, height=40, samples=1))
    np.testing.assert_allclose(
        render(small, "native"), oracle.render(small), rtol=ORACLE_RELATIVE_TOLERANCE, atol=ORACLE_ABSOLUTE_FLOOR
    )


def test_figure_15_8b_is_15_8a_lit_by_a_shadowless_point_light():
    """examples/book_15_8b.usda: the book's Figure 15.8(b) build function swaps the directional light
    for a PointLight at (15, 15, 2.5) of radiance 2; everything else is 15.8(a)'s."""
    result = read_usd(EXAMPLES / "book_15_8b.usda")
    scene = result.scene
    assert result.warnings == []
    (point,) = scene.lights
    assert type(point).__name__ == "PointLight"
    assert not point.linking.shadows and point.color == pytest.approx((2, 2, 2))
    assert point.position == pytest.approx((15, 15, 2.5))
    a = read_usd(EXAMPLES / "book_15_8a.usda").scene
    assert scene.intrinsics == a.intrinsics and scene.camera == a.camera and scene.settings == a.settings
    small = dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, width=60, height=40, samples=1))
    np.testing.assert_allclose(
        render(small, "native"), oracle.render(small), rtol=ORACLE_RELATIVE_TOLERANCE, atol=ORACLE_ABSOLUTE_FLOOR
    )


@pytest.mark.parametrize("figure, eta_in", [("a", 1.5), ("b", 0.75)])
def test_figures_28_5_read_as_the_books_build_functions_and_render_as_the_oracle(figure, eta_in):
    """examples/book_28_5a/b.usda (ch. 28, BuildFigure28_05a/b): a Dielectric ball (ka = kd = 0,
    ks 0.2, e 2000, Fresnel, eta_in 1.5 or 0.75) before a red Reflective ball (kr 0.25) on a
    Checker3D rectangle (size 4, 0.75 grey and white), two point lights and a directional one with
    shadows, ambient 0.25, d = 2400 at 600 x 600, depth 5; the book's convention, whose glass
    casts an opaque shadow. (Against the book's own code: docs/book.md's record.)"""
    result = read_usd(EXAMPLES / f"book_28_5{figure}.usda")
    scene = result.scene
    assert result.warnings == []
    assert scene.camera.horizontal_fov_deg == pytest.approx(2 * math.degrees(math.atan(300 / 2400)), rel=1e-6)
    assert scene.settings.max_depth == 5 and scene.settings.transmission == "book"
    glass, red = scene.spheres
    assert glass.material.fresnel and glass.material.ior == pytest.approx(eta_in)
    assert (glass.material.kr, glass.material.kt, glass.material.ka, glass.material.kd) == (1, 1, 0, 0)
    assert red.material.kr == pytest.approx(0.25)
    (floor,) = scene.meshes
    assert floor.material.checker_size == 4 and floor.material.checker_color == (1, 1, 1)
    assert sorted(type(light).__name__ for light in scene.lights) == ["DirectionalLight", "PointLight", "PointLight"]
    small = dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, width=60, height=60, samples=1))
    np.testing.assert_allclose(
        render(small, "native"), oracle.render(small), rtol=ORACLE_RELATIVE_TOLERANCE, atol=ORACLE_ABSOLUTE_FLOOR
    )


@pytest.mark.parametrize("figure, max_depth", [("24_6a", 0), ("24_6b", 1), ("24_7a", 10), ("24_7b", 10)])
def test_figures_24_6_and_24_7_read_as_the_books_build_functions_and_render_as_the_oracle(figure, max_depth):
    """examples/book_24_6a/b.usda, book_24_7a/b.usda (ch. 24, BuildFigure24_06a/b, 24_07a/b):
    Reflective spheres and a solid cylinder (kr 0.75) with Matte ones on a PlaneChecker floor
    (cells 20, white on white, black outlines of width 2), one point light, ambient 0.5, the
    book's pinhole at 600 x 400, depth 0, 1 or 10. (Against the book's own code: docs/book.md.)"""
    result = read_usd(EXAMPLES / f"book_{figure}.usda")
    scene = result.scene
    assert result.warnings == []
    assert scene.settings.max_depth == max_depth and (scene.settings.width, scene.settings.height) == (600, 400)
    distance = 45000 if figure == "24_7b" else 360
    assert scene.camera.horizontal_fov_deg == pytest.approx(2 * math.degrees(math.atan(300 / distance)), rel=1e-6)
    assert sorted(s.material.kr for s in scene.spheres) == pytest.approx([0.0, 0.75, 0.75])
    ground = next(i for i in scene.intrinsics if i.kind == "plane")
    m = ground.material
    assert ground.infinite and m.checker_plane and (m.checker_size, m.checker_outline_width) == (20, 2)
    assert m.checker_outline_color == (0, 0, 0) and m.diffuse_color == m.checker_color == (1, 1, 1)
    small = dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, width=60, height=40, samples=1))
    np.testing.assert_allclose(
        render(small, "native"), oracle.render(small), rtol=ORACLE_RELATIVE_TOLERANCE, atol=ORACLE_ABSOLUTE_FLOOR
    )


# Figure -> (max_depth, the glass's ior, fresnel): from the book's build functions (BuildFigure27_XX;
# examples/book_27.py names each source).
BOOK_27_FIGURES = {
    "12": (5, 1.5, False),
    "13a": (2, 1.0, False),
    "13b": (4, 1.0, False),
    "13c": (5, 1.0, False),
    "14a": (5, 1.1, False),
    "14b": (5, 1.5, False),
    "15b": (5, 0.75, True),
    "15b_transparent": (5, 0.75, False),
    "23a": (3, 1.5, True),
    "23b": (3, 1.5, True),
    "24a": (5, 1.5, False),
    "28": (5, 0.75, False),
}


@pytest.mark.parametrize("figure", sorted(BOOK_27_FIGURES))
def test_figures_27_read_as_the_books_build_functions_and_render_as_the_oracle(figure):
    """examples/book_27_XX.usda (ch. 27, the Transparent material; 27.15(b) and 27.23 the ch. 28
    Dielectric): a glass object (ka = kd = 0) of the figure's ior and depth, in the book's
    convention, read without a warning and rendered as the oracle does. (Against the book's own
    code: docs/book.md's record.)"""
    max_depth, ior, fresnel = BOOK_27_FIGURES[figure]
    result = read_usd(EXAMPLES / f"book_27_{figure}.usda")
    scene = result.scene
    assert result.warnings == []
    assert scene.settings.max_depth == max_depth and scene.settings.transmission == "book"
    assert (scene.settings.width, scene.settings.height) == (600, 600)
    (glass,) = [s for s in scene.spheres if s.material.kt > 0] or [
        o for o in (*scene.meshes, *scene.intrinsics) if o.material.kt > 0
    ]
    m = glass.material
    assert (m.ka, m.kd, m.fresnel) == (0, 0, fresnel) and m.ior == pytest.approx(ior)
    small = dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, width=40, height=40, samples=1))
    np.testing.assert_allclose(
        render(small, "native"), oracle.render(small), rtol=ORACLE_RELATIVE_TOLERANCE, atol=ORACLE_ABSOLUTE_FLOOR
    )
