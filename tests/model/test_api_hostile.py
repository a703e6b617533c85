# SPDX-License-Identifier: Apache-2.0
"""Bad Python API calls (issue 10, item 8): an index that does not fit the model's int32 is an
error, not a silent wrap (2^32 + 2 used to become 2); fractional indices are not truncated; a
wrong type is one problem naming the field, or a TypeError naming what was expected, not an
AttributeError deep inside a check or a backend."""

from __future__ import annotations

import numpy as np
import pytest

from phongscene.errors import SceneError
from phongscene.rendering import compile_pov, render  # the validating entry points
from phongscene.scene import PhongMaterial, PointLight, Scene, Sphere, TriangleMesh

POINTS = np.zeros((3, 3))


@pytest.mark.parametrize("index", [2**32 + 2, 2**31, -(2**31) - 1])
def test_an_index_beyond_int32_is_an_error_not_a_wrap(index):
    with pytest.raises(ValueError, match=f"index {index} does not fit the model's int32 indices"):
        TriangleMesh(POINTS, np.array([[0, 1, index]], dtype=np.int64))


def test_normal_indices_are_checked_the_same_way():
    with pytest.raises(ValueError, match="does not fit"):
        TriangleMesh(POINTS, [[0, 1, 2]], normals=[[0.0, 0.0, 1.0]], normal_indices=np.array([[0, 0, 2**32]]))


def test_fractional_or_text_indices_are_errors():
    with pytest.raises(ValueError, match="whole-number indices"):
        TriangleMesh(POINTS, [[0, 1.5, 2]])
    with pytest.raises(TypeError, match="integer indices"):
        TriangleMesh(POINTS, [["0", "1", "2"]])
    assert TriangleMesh(POINTS, [[0.0, 1.0, 2.0]]).triangles.tolist() == [[0, 1, 2]]  # whole floats are fine


BALL = Sphere.at((0.0, 0.0, -5.0), 1.0)


@pytest.mark.parametrize(
    ("scene", "attribute", "message"),
    [
        (Scene(lights=(1,)), "lights[0]", "must be a PointLight or a DirectionalLight"),
        (Scene(spheres=("ball",)), "spheres[0]", "must be a Sphere, got str"),
        (Scene(meshes=BALL), "meshes", "must be a tuple, got Sphere"),
        (Scene(ambient=None), "ambient", "must be an AmbientLight, got NoneType"),
        (Scene(spheres=(Sphere.at((0.0, 0.0, -5.0), 1.0, material=3),)), "material", "must be a PhongMaterial"),
        (Scene(spheres=(Sphere.at((0.0, 0.0, -5.0), 1.0, PhongMaterial(kd="a")),)), "kd", "must be a number"),
        (Scene(lights=(PointLight((0.0, 0.0, 0.0), "white"),), spheres=(BALL,)), "color", "must be 3 numbers"),
    ],
)
def test_a_wrong_type_is_one_problem_naming_the_field(scene, attribute, message):
    for call in (render, compile_pov):
        with pytest.raises(SceneError) as info:
            call(scene)
        (problem,) = info.value.problems
        assert problem.attribute == attribute and message in problem.message


def test_a_path_where_a_scene_is_expected_is_a_type_error():
    # render reads a path itself; compile_pov takes the model only.
    with pytest.raises(TypeError, match="expected a phongscene Scene .*load_usd.*got str 'scene.usda'"):
        compile_pov("scene.usda")
    with pytest.raises(TypeError):
        render(42)
