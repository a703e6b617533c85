# SPDX-License-Identifier: Apache-2.0
"""Every field of every model node given a hostile value (issue 27.3): building the scene and
validating it (``compile_pov``, the validating entry point without a render) either works or
raises a ``SceneError`` naming the field — never a TypeError, ValueError or AttributeError from
deep inside a check or a backend."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

from phongscene.errors import SceneError
from phongscene.rendering import compile_pov, render
from phongscene.scene import (
    AmbientLight,
    Camera,
    Cone,
    DirectionalLight,
    PhongMaterial,
    PointLight,
    RectAreaLight,
    RenderSettings,
    Scene,
    Sphere,
    SphereAreaLight,
    Texture,
    TriangleMesh,
)

TEXTURE = Texture(np.ones((2, 2, 3)))
MESH = TriangleMesh(
    np.array([[0, 0, -5], [1, 0, -5], [0, 1, -5.0]]),
    [[0, 1, 2]],
    normals=[[0, 0, 1.0]],
    normal_indices=[[0, 0, 0]],
    uvs=[[0, 0.0], [1, 1]],
    uv_indices=[[0, 1, 1]],
    material=PhongMaterial(diffuse_texture=TEXTURE),
)
BALL = Sphere.at((0, 0, -5), 1.0)
LIGHTS = (
    PointLight((0, 0, 0), (1, 1, 1), cone=Cone((0, 0, -1.0), 0.5, 0.9)),
    DirectionalLight((0, 0, -1.0), (1, 1, 1)),
    RectAreaLight((0, 2, 0), (1, 0, 0), (0, 0, 1), (1, 1, 1), samples=3),
    SphereAreaLight((0, 2, 0), 0.5, (1, 1, 1), samples=3),
)
BASE = dict(
    camera=Camera(),
    ambient=AmbientLight((0.1, 0.1, 0.1)),
    lights=LIGHTS,
    spheres=(BALL,),
    meshes=(MESH,),
    settings=RenderSettings(width=4, height=4),
)
HOSTILE = [
    None,
    "x",
    "",
    [1, 2],
    (1, 2, 3, 4),
    np.zeros((2, 2)),
    np.array(["a", "b", "c"]),
    float("nan"),
    float("inf"),
    True,
    object(),
    {},
    -1,
    1e308,
    1 + 2j,
    np.array([1 + 1j, 0, 0]),
    [[1, 2, 3]],
    b"abc",
    (None, None, None),
    ("1", "2", "3"),
    np.float32(0.5),
    2**40,
]


def _scene(**changes) -> Scene:
    return Scene(**{**BASE, **changes})


def _replaced(node, name, value):
    return dataclasses.replace(node, **{name: value})


# (where, the node, how a changed node becomes a scene)
NODES = [
    ("camera", BASE["camera"], lambda n: _scene(camera=n)),
    ("ambient", BASE["ambient"], lambda n: _scene(ambient=n)),
    ("settings", BASE["settings"], lambda n: _scene(settings=n)),
    *[
        (f"lights[{i}]", light, lambda n, i=i: _scene(lights=LIGHTS[:i] + (n,) + LIGHTS[i + 1 :]))
        for i, light in enumerate(LIGHTS)
    ],
    ("cone", LIGHTS[0].cone, lambda n: _scene(lights=(_replaced(LIGHTS[0], "cone", n),))),
    ("sphere", BALL, lambda n: _scene(spheres=(n,))),
    ("sphere.material", BALL.material, lambda n: _scene(spheres=(_replaced(BALL, "material", n),))),
    ("mesh", MESH, lambda n: _scene(meshes=(n,))),
    ("mesh.material", MESH.material, lambda n: _scene(meshes=(_replaced(MESH, "material", n),))),
    ("texture", TEXTURE, lambda n: _scene(meshes=(_replaced(MESH, "material", PhongMaterial(diffuse_texture=n)),))),
]
CASES = [
    pytest.param(make, node, f.name, id=f"{where}.{f.name}")
    for where, node, make in NODES
    for f in dataclasses.fields(node)
] + [pytest.param(lambda n: n, Scene(**BASE), f.name, id=f"scene.{f.name}") for f in dataclasses.fields(Scene)]


@pytest.mark.parametrize(("make", "node", "name"), CASES)
def test_a_hostile_field_is_accepted_or_a_scene_error_naming_it(make, node, name):
    for value in HOSTILE:
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # numpy's ComplexWarning would mean a value was cut silently
            try:
                compile_pov(make(_replaced(node, name, value)))
            except SceneError as e:
                # the field itself, or one that depends on it (one point: the triangles' indices)
                assert e.problems and all(p.attribute for p in e.problems), f"{value!r}: {e}"


@pytest.mark.slow
# The hostile values make odd images (nothing in view, black): the image diagnostics say so, which
# is not what this test is about.
@pytest.mark.filterwarnings("ignore::phongscene.errors.ImageWarning")
def test_the_native_backend_survives_the_same_values():
    # One render per field with the values validation let through (a render is ~ms at 4×4).
    for _where, node, make in NODES:
        for f in dataclasses.fields(node):
            for value in HOSTILE:
                try:
                    scene = make(_replaced(node, f.name, value))
                    compile_pov(scene)
                except SceneError:
                    continue
                render(scene, backend="native")


def test_a_colour_or_point_as_a_numpy_array_or_list_is_the_documented_tuple():
    # Accepted (chosen over refusing: numpy is how colours are computed), stored as the tuple of
    # floats the model documents, so materials stay hashable and compare equal to tuple-built ones.
    m = PhongMaterial(diffuse_color=np.array([0.5, 0.25, 1.0], dtype=np.float32), specular_color=[1, 1, 1])
    assert m.diffuse_color == (0.5, 0.25, 1.0) and type(m.diffuse_color[0]) is float
    assert m == PhongMaterial(diffuse_color=(0.5, 0.25, 1.0)) and hash(m) == hash(
        PhongMaterial(diffuse_color=(0.5, 0.25, 1.0))
    )
    assert PointLight(np.zeros(3), np.ones(3)).position == (0.0, 0.0, 0.0)
    assert RenderSettings(background=np.array([0.0, 0.5, 0.0])).background == (0.0, 0.5, 0.0)


@pytest.mark.parametrize(
    ("build", "field", "message"),
    [
        (lambda: Sphere(np.eye(3)), "world_from_object", "expected a 4x4 matrix, got shape (3, 3)"),
        (lambda: Sphere([["a"] * 4] * 4), "world_from_object", "expected an array of real numbers"),
        (lambda: Sphere(np.eye(4, dtype=complex)), "world_from_object", "got an array of complex128"),
        (lambda: Sphere(np.eye(4, dtype=bool)), "world_from_object", "got an array of bool"),
        (lambda: TriangleMesh(np.zeros((3, 2)), [[0, 1, 2]]), "points", "shape (N, 3), got (3, 2)"),
        (lambda: TriangleMesh(None, [[0, 1, 2]]), "points", "is required"),
        (lambda: TriangleMesh(np.zeros((3, 3)), [[0, 1, 2.5]]), "triangles", "whole-number indices"),
        (lambda: TriangleMesh(np.zeros((3, 3)), np.array([[0, 1, 2**40]])), "triangles", "does not fit"),
        (lambda: TriangleMesh(np.zeros((3, 3)), [[0, 1, 2]], normals=[[0, 0, 1.0]]), "normal_indices", "go together"),
        (lambda: Texture(np.zeros((2, 2))), "image", "shape (H, W, 3)"),
    ],
)
def test_a_wrong_array_is_a_scene_error_naming_the_field(build, field, message):
    with pytest.raises(SceneError) as info:
        build()
    (problem,) = info.value.problems
    assert problem.attribute == field and message in problem.message
    assert isinstance(info.value, (ValueError, TypeError))  # what code written before still catches


def test_int64_and_whole_float_indices_are_accepted():
    mesh = TriangleMesh(np.zeros((3, 3)), np.array([[0, 1, 2]], dtype=np.int64))
    assert mesh.triangles.dtype == np.int32
    assert TriangleMesh(np.zeros((3, 3)), np.array([[0.0, 1.0, 2.0]])).triangles.tolist() == [[0, 1, 2]]


@pytest.mark.parametrize("width", [1e38, 1e19, 0.0, -1.0, 1e-200])
def test_an_absurd_orthographic_window_is_an_error(width):
    with pytest.raises(SceneError, match="ortho_width: the orthographic view window must be"):
        compile_pov(_scene(camera=Camera(projection="orthographic", ortho_width=width)))
