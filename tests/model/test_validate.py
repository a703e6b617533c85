# SPDX-License-Identifier: Apache-2.0
"""validate(): every rule has a failing case (named attribute) and the base scene passes."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from phongscene.errors import SceneError
from phongscene.rendering import in_file_terms
from phongscene.scene import (
    AmbientLight,
    Camera,
    DirectionalLight,
    PhongMaterial,
    PointLight,
    RectAreaLight,
    RenderSettings,
    Scene,
    Sphere,
    SphereAreaLight,
    TriangleMesh,
)
from phongscene.validate import check, validate

NAN, INF = float("nan"), float("inf")
MAT = PhongMaterial(0.25, 0.6, 0.2, 20.0, (0.8, 0.2, 0.1), (1.0, 1.0, 1.0))
TRI = TriangleMesh([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [(0, 1, 2)], [(0, 0, 1)], [(0, 0, 0)], MAT)


def base() -> Scene:
    return Scene(
        camera=Camera((0, 0, 5), (0, 0, -1), (0, 1, 0)),
        ambient=AmbientLight((0.1, 0.1, 0.1)),
        lights=(
            PointLight((1, 2, 3), (math.pi,) * 3),
            DirectionalLight((0, -1, 0), (1, 1, 1)),
            RectAreaLight((0, 5, 0), (1, 0, 0), (0, 0, 1), (1, 1, 1), 5),
            SphereAreaLight((3, 3, 3), 0.5, (1, 1, 1), 9),
        ),
        spheres=(Sphere.at((0, 0, 0), 1.0, MAT),),
        meshes=(TRI,),
    )


def with_material(**kw) -> Scene:
    return replace(base(), spheres=(Sphere.at((0, 0, 0), 1.0, replace(MAT, **kw)),))


def with_light(i: int, **kw) -> Scene:
    s = base()
    lights = list(s.lights)
    lights[i] = replace(lights[i], **kw)
    return replace(s, lights=tuple(lights))


def with_mesh(**kw) -> Scene:
    fields = dict(
        points=TRI.points, triangles=TRI.triangles, normals=TRI.normals, normal_indices=TRI.normal_indices, material=MAT
    )
    fields.update(kw)
    return replace(base(), meshes=(TriangleMesh(**fields),))


def sphere_matrix(m) -> Scene:
    return replace(base(), spheres=(Sphere(np.asarray(m, float), MAT),))


BAD = {
    "ka above 1": (lambda: with_material(ka=1.5), "ka"),
    "kd below 0": (lambda: with_material(kd=-0.1), "kd"),
    "ks below 0": (lambda: with_material(ks=-0.5), "ks"),
    "ks NaN": (lambda: with_material(ks=NAN), "ks"),
    "exponent below 0": (lambda: with_material(exponent=-1.0), "exponent"),
    "exponent infinite": (lambda: with_material(exponent=INF), "exponent"),
    "negative diffuse colour": (lambda: with_material(diffuse_color=(0.5, -0.1, 0.5)), "diffuse_color"),
    "NaN specular colour": (lambda: with_material(specular_color=(1.0, NAN, 1.0)), "specular_color"),
    "zero forward": (lambda: replace(base(), camera=Camera(forward=(0, 0, 0))), "forward"),
    "non-unit up": (lambda: replace(base(), camera=Camera(up=(0, 2, 0))), "up"),
    "up parallel to forward": (lambda: replace(base(), camera=Camera(forward=(0, 1, 0), up=(0, 1, 0))), "up"),
    "NaN camera position": (lambda: replace(base(), camera=Camera(position=(NAN, 0, 0))), "position"),
    "fov 0": (lambda: replace(base(), camera=Camera(horizontal_fov_deg=0.0)), "horizontal_fov_deg"),
    "fov 180": (lambda: replace(base(), camera=Camera(horizontal_fov_deg=180.0)), "horizontal_fov_deg"),
    "ortho width 0": (
        lambda: replace(base(), camera=Camera(projection="orthographic", ortho_width=0.0)),
        "ortho_width",
    ),
    "unknown projection": (lambda: replace(base(), camera=Camera(projection="fisheye")), "projection"),
    "width 0": (lambda: replace(base(), settings=RenderSettings(width=0)), "width"),
    "height 0": (lambda: replace(base(), settings=RenderSettings(height=0)), "height"),
    "samples 0": (lambda: replace(base(), settings=RenderSettings(samples=0)), "samples"),
    "samples 10": (lambda: replace(base(), settings=RenderSettings(samples=10)), "samples"),
    "unknown pattern": (lambda: replace(base(), settings=RenderSettings(sample_pattern="random")), "sample_pattern"),
    "unknown convention": (lambda: replace(base(), settings=RenderSettings(specular="blinn")), "specular"),
    "negative background": (lambda: replace(base(), settings=RenderSettings(background=(-1, 0, 0))), "background"),
    "negative ambient": (lambda: replace(base(), ambient=AmbientLight((-0.1, 0, 0))), "color"),
    "negative light colour": (lambda: with_light(0, color=(1, -1, 1)), "color"),
    "fade power without distance": (lambda: with_light(0, fade_power=2.0, fade_distance=0.0), "fade_distance"),
    "negative fade power": (lambda: with_light(0, fade_power=-1.0), "fade_power"),
    "zero direction": (lambda: with_light(1, direction=(0, 0, 0)), "direction"),
    "non-unit direction": (lambda: with_light(1, direction=(0, -2, 0)), "direction"),
    "rect samples 4": (lambda: with_light(2, samples=4), "samples"),
    "rect samples 1": (lambda: with_light(2, samples=1), "samples"),
    "parallel rect axes": (lambda: with_light(2, axis_v=(2, 0, 0)), "axis_v"),
    "zero rect axis": (lambda: with_light(2, axis_u=(0, 0, 0)), "axis_u"),
    "sphere light radius 0": (lambda: with_light(3, radius=0.0), "radius"),
    "sphere light samples 6": (lambda: with_light(3, samples=6), "samples"),
    "sphere radius 0": (lambda: sphere_matrix(np.diag([0, 0, 0, 1])), "world_from_object"),
    "flattened sphere": (lambda: sphere_matrix(np.diag([1, 1, 0, 1])), "world_from_object"),
    "sphere with NaN": (
        lambda: sphere_matrix([[1, 0, 0, NAN], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]),
        "world_from_object",
    ),
    "projective sphere matrix": (
        lambda: sphere_matrix([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 1, 1]]),
        "world_from_object",
    ),
    "triangle index out of range": (lambda: with_mesh(triangles=[(0, 1, 3)]), "triangles"),
    "negative triangle index": (lambda: with_mesh(triangles=[(0, -1, 2)]), "triangles"),
    "NaN point": (lambda: with_mesh(points=[(0, 0, NAN), (1, 0, 0), (0, 1, 0)]), "points"),
    "normal index out of range": (lambda: with_mesh(normal_indices=[(0, 0, 1)]), "normal_indices"),
    "normal rows mismatch": (lambda: with_mesh(normal_indices=[(0, 0, 0), (0, 0, 0)]), "normal_indices"),
    "zero-length normal": (lambda: with_mesh(normals=[(0, 0, 0)]), "normals"),
    "non-unit normal": (lambda: with_mesh(normals=[(0, 0, 2)]), "normals"),
}


def test_valid_scene_has_no_problems():
    assert validate(base()) == []
    assert check(base()) == base()


@pytest.mark.parametrize("name", BAD)
def test_each_rule_reports_its_attribute(name):
    build, attribute = BAD[name]
    problems = validate(build())
    assert [p.attribute for p in problems] == [attribute], problems


def test_every_problem_is_reported_at_once_with_usd_names_and_file():
    material = replace(MAT, ks=-0.5, exponent=-1.0, source="/World/Looks/M/Phong")
    scene = replace(
        base(),
        spheres=(Sphere.at((0, 0, 0), 1.0, material, source="/World/Ball"),),
        settings=RenderSettings(samples=12, source="/Render/Settings"),
        source_file="scene.usda",
    )
    with pytest.raises(SceneError) as info:
        check(scene)
    # The model names its own fields (and the node type); the USD layer translates them into
    # the file's attributes for nodes read from USD, which is what the CLI and render() print.
    model_terms = {(p.prim, p.attribute, p.node) for p in info.value.problems}
    assert model_terms == {
        ("/World/Looks/M/Phong", "ks", "PhongMaterial"),
        ("/World/Looks/M/Phong", "exponent", "PhongMaterial"),
        ("/Render/Settings", "samples", "RenderSettings"),
    }
    error = in_file_terms(info.value)
    found = {(p.prim, p.attribute, p.file) for p in error.problems}
    assert found == {
        ("/World/Looks/M/Phong", "inputs:ks", "scene.usda"),
        ("/World/Looks/M/Phong", "inputs:exponent", "scene.usda"),
        ("/Render/Settings", "phong:samples", "scene.usda"),
    }
    assert "scene.usda: /World/Looks/M/Phong.inputs:ks: must be in [0, 1], got -0.5" in str(error)


def test_boundary_values_are_valid():
    scene = replace(
        with_material(ka=0.0, kd=1.0, ks=1.0, exponent=0.0, diffuse_color=(0, 0, 0)),
        settings=RenderSettings(samples=9, width=1, height=1),
        lights=(
            RectAreaLight((0, 5, 0), (1, 0, 0), (0, 0, 1), (0, 0, 0), 3),
            SphereAreaLight((0, 0, 0), 1e-9, (1, 1, 1), 17),
        ),
    )
    assert validate(scene) == []


def test_a_shared_material_is_reported_once_in_order_of_first_use():
    bad_ks = replace(MAT, ks=-0.5)
    bad_ka = replace(MAT, ka=2.0)
    unhashable = replace(MAT, diffuse_color=[0.5, -1.0, 0.5])  # a list colour, as built by hand
    materials = [
        bad_ks,
        bad_ka,
        replace(MAT, ks=-0.5),
        unhashable,
        bad_ka,
        replace(MAT, diffuse_color=[0.5, -1.0, 0.5]),
    ]
    scene = replace(base(), spheres=tuple(Sphere.at((i, 0, 0), 0.4, m) for i, m in enumerate(materials)))
    assert [p.attribute for p in validate(scene)] == ["ks", "ka", "diffuse_color"]


def test_positions_the_tracer_cannot_represent_are_problems():
    # ±1e308 is finite, but the extent between two such spheres is not (it crashed the BVH build).
    far = replace(
        base(), spheres=(Sphere.at((1e308, 0, 0), 1.0, source="/A"), Sphere.at((-1e308, 0, 0), 1.0, source="/B"))
    )
    found = {(p.prim, p.attribute) for p in validate(far)}
    assert found == {("/A", "world_from_object"), ("/B", "world_from_object")}
    mesh = TriangleMesh([[1.5e308, 0, 0], [-1.5e308, 0, 0], [0, 1, 0]], [[0, 1, 2]], source="/T")
    (problem,) = validate(replace(base(), meshes=(mesh,)))
    assert (problem.prim, problem.attribute) == ("/T", "points") and "within ±1e+150" in problem.message
    assert not validate(replace(base(), spheres=(Sphere.at((1e149, 0, 0), 1.0),)))  # inside the limit


def test_native_tracer_survives_infinite_extents():
    # What validation rejects must still not crash the C++ (bins clamp whatever slips through).
    from phongscene.backends import native

    far = replace(
        base(),
        spheres=(Sphere.at((1e308, 0, 0), 1.0), Sphere.at((-1e308, 0, 0), 1.0)),
        settings=RenderSettings(width=8, height=6),
    )
    image = native.render(far)
    assert image.shape == (6, 8, 3)


def test_sizes_threads_and_grids_beyond_what_a_render_can_hold_are_problems():
    from phongscene.validate import MAX_IMAGE_SIDE, MAX_SHADOW_SAMPLES, MAX_THREADS

    def settings_problems(**kw):
        return {p.attribute for p in validate(replace(base(), settings=RenderSettings(**kw)))}

    assert settings_problems(width=MAX_IMAGE_SIDE + 1) == {"width"}
    assert settings_problems(width=MAX_IMAGE_SIDE, height=MAX_IMAGE_SIDE) == set()  # 2^28 px: the limit
    assert settings_problems(threads=MAX_THREADS + 1) == {"threads"}
    assert settings_problems(threads=2**32 + 1) == {"threads"}
    rect = RectAreaLight((0, 5, 0), (1, 0, 0), (0, 0, 1), (1, 1, 1), samples=2**32 + 1)
    assert {p.attribute for p in validate(replace(base(), lights=(rect,)))} == {"samples"}
    assert not validate(replace(base(), lights=(replace(rect, samples=MAX_SHADOW_SAMPLES),)))


def test_cli_rejects_sizes_and_threads_out_of_range(capsys):
    from phongscene.cli import main

    for argv in (
        ["render", "x.usda", "-o", "x.png", "--width", "1000000"],
        ["render", "x.usda", "-o", "x.png", "--threads", "3000000000"],
    ):
        with pytest.raises(SystemExit) as e:
            main(argv)
        assert e.value.code == 2
    assert "expected a number in" in capsys.readouterr().err
