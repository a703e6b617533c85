# SPDX-License-Identifier: Apache-2.0
"""Hostile input to the POV-Ray compiler: names from USD never become SDL, extreme numbers are
written exactly or rejected by name, NaN/inf never reach SDL, and the compile CLI writes
atomically."""

from __future__ import annotations

import dataclasses
import importlib
import re

import numpy as np
import pytest

from phongscene import cli
from phongscene.backends import povray
from phongscene.backends.povray import compile_pov, sanitize_comment
from phongscene.errors import SceneError
from phongscene.rendering import compile_pov as checked_compile_pov  # validates; names in the file's terms
from phongscene.scene import (
    AmbientLight,
    DirectionalLight,
    PhongMaterial,
    PointLight,
    RenderSettings,
    Scene,
    Sphere,
    TriangleMesh,
)
from support import calibration

HOSTILE_NAMES = [
    '/World/"quoted"}',
    '/World/evil\n#include "/etc/passwd"\n',
    '/World/x\r#fopen F "/tmp/owned" write #write (F, "x") #fclose F',
    "/World/*/ /* }}} #declare Pass = 7; #end",
    "/World/\\x23system",
    "/World/Ünïcödé ☃ 𝄞 \u2028 \x00 \x1b[31m",
]
# The only directives the compiler writes.
OUR_DIRECTIVES = {"#version", "#declare", "#switch", "#case", "#break", "#end", "#range"}


def _hostile_scene() -> Scene:
    base = calibration.SCENES["shadows_two_lights"]()
    names = iter(HOSTILE_NAMES * 4)

    def rename(node):
        return dataclasses.replace(node, source=next(names))

    spheres = tuple(dataclasses.replace(rename(s), material=rename(s.material)) for s in base.spheres)
    meshes = tuple(dataclasses.replace(rename(m), material=rename(m.material)) for m in base.meshes)
    return dataclasses.replace(
        base,
        camera=rename(base.camera),
        ambient=rename(base.ambient),
        lights=tuple(rename(light) for light in base.lights),
        spheres=spheres,
        meshes=meshes,
        source_file='C:\\evil"\n#include "x.inc"',
    )


@pytest.mark.parametrize("mapping", ["exact", "classic"])
def test_names_never_reach_sdl(mapping):
    sdl = compile_pov(_hostile_scene(), mapping=mapping)
    assert sdl.isascii()
    for line in sdl.splitlines():
        stripped = line.strip()
        if stripped.startswith("//"):
            # A comment line carries no quote, no hash, no block-comment end, no control character.
            assert not set(stripped[2:]) & set('"#*\r\x00\x1b'), line
            continue
        for directive in re.findall(r"#\w+", line):
            assert directive in OUR_DIRECTIVES, line
    for bad in ("#include", "#fopen", "#write", "#fclose", "#system", "#declare Pass = 7", "\x00", "\x1b"):
        assert bad not in sdl


def test_sanitize_comment_escapes_everything_outside_a_safe_set():
    assert sanitize_comment("/World/Ball_1") == "/World/Ball_1"
    assert sanitize_comment('a"b') == "a\\x22b"
    assert sanitize_comment("#include") == "\\x23include"
    assert sanitize_comment("*/\n") == "\\x2a/\\x0a"
    assert sanitize_comment("☃𝄞") == "\\u2603\\U0001d11e"
    assert sanitize_comment("\\") == "\\x5c"


@pytest.mark.slow
@pytest.mark.povray
def test_hostile_names_render_like_plain_ones(tmp_path):
    hostile = _hostile_scene()
    plain = calibration.SCENES["shadows_two_lights"]()
    images = povray.render_many(
        [(hostile, None, "exact"), (plain, None, "exact"), (hostile, None, "classic"), (plain, None, "classic")]
    )
    np.testing.assert_array_equal(images[0], images[1])
    np.testing.assert_array_equal(images[2], images[3])


def _simple(**kw) -> Scene:
    base = dict(
        camera=calibration.look_at((0.0, 1.0, 5.0), (0.0, 0.0, 0.0)),
        lights=(PointLight((3.0, 4.0, 5.0), (1.0, 1.0, 1.0), source="/World/Key"),),
        spheres=(Sphere.at((0.0, 0.0, 0.0), 1.0, source="/World/Ball"),),
        settings=RenderSettings(width=16, height=12),
    )
    base.update(kw)
    return Scene(**base)


def test_huge_and_tiny_numbers_are_written_exactly_or_as_the_float32_povray_stores():
    scene = _simple(
        ambient=AmbientLight((1e-300, 5e-324, 1e300)),
        spheres=(Sphere.at((1e300, -1e-300, 0.0), 1e-300, source="/World/Tiny"),),
        lights=(PointLight((1e300, 1e-300, -1e300), (1e300, 1.0, 1e-300)),),
    )
    for mapping in ("exact", "classic"):
        sdl = compile_pov(scene, mapping=mapping)
        # Colours are float32 in POV-Ray (ref §2): 1e-300 and 5e-324 are stored as 0, so they print
        # as 0.0; 1e300 overflows float32 and keeps its exact text. Coordinates are doubles.
        assert "ambient_light rgb <0.0, 0.0, 1e+300>" in sdl
        assert "sphere { <1e+300, -1e-300, 0.0>, 1e-300" in sdl
        assert "light_source { <1e+300, 1e-300, -1e+300> color rgb <1e+300, 1.0, 0.0>" in sdl


def test_mesh_numbers_beyond_float32_are_rejected_by_name():
    big = TriangleMesh([[0, 0, 0], [1e300, 0, 0], [0, 1, 0]], [[0, 1, 2]], source="/World/Huge")
    with pytest.raises(SceneError, match=r"/World/Huge\.points: .*float32"):
        compile_pov(_simple(meshes=(big,)))
    tiny = TriangleMesh([[0, 0, 0], [1e-300, 0, 0], [0, 1, 0]], [[0, 1, 2]], source="/World/Tiny")
    sdl = compile_pov(_simple(meshes=(tiny,)))  # float32 flushes 1e-300 to 0, as POV-Ray would
    assert "<0,0,0>,\n<0,0,0>,\n<0,1,0>" in sdl


NAN = float("nan")


@pytest.mark.parametrize(
    "change,where",
    [
        (
            lambda s: dataclasses.replace(
                s, spheres=(Sphere.at((0, 0, 0), 1.0, PhongMaterial(ks=NAN, source="/World/Mat")),)
            ),
            "/World/Mat.inputs:ks",
        ),
        (
            lambda s: dataclasses.replace(s, lights=(PointLight((NAN, 0, 0), (1, 1, 1), source="/World/Key"),)),
            "/World/Key.xformOp",
        ),
        (
            lambda s: dataclasses.replace(
                s, lights=(DirectionalLight((0, -1, 0), (np.inf, 1, 1), source="/World/Sun"),)
            ),
            "/World/Sun.inputs:color",
        ),
        (
            lambda s: dataclasses.replace(
                s, camera=dataclasses.replace(s.camera, position=(0, NAN, 5), source="/World/Cam")
            ),
            "/World/Cam.xformOp",
        ),
        (
            lambda s: dataclasses.replace(s, spheres=(Sphere(np.diag([1, 1, NAN, 1]), source="/World/Egg"),)),
            "/World/Egg.radius",
        ),
        (
            lambda s: dataclasses.replace(
                s,
                meshes=(
                    TriangleMesh(
                        np.eye(3), [[0, 1, 2]], [[0, 0, 1], [0, NAN, 1], [0, 0, 1]], [[0, 1, 2]], source="/World/M"
                    ),
                ),
            ),
            "/World/M.normals",
        ),
    ],
)
@pytest.mark.parametrize("mapping", ["exact", "classic"])
def test_non_finite_numbers_are_a_clean_error_naming_the_prim(change, where, mapping):
    with pytest.raises(SceneError) as e:
        checked_compile_pov(change(_simple()), mapping=mapping)
    assert where in str(e.value)


def test_derived_overflow_is_caught():
    # A parallel light is placed 2 scene radii behind the scene: with bounds near 1e308 that
    # overflows, which must not reach the SDL as 'inf'.
    scene = _simple(
        spheres=(Sphere.at((0.0, 0.0, 0.0), 1e308),),
        lights=(DirectionalLight((0.0, -1.0, 0.0), (1, 1, 1), source="/World/Sun"),),
    )
    with pytest.raises(SceneError, match="/World/Sun"):
        compile_pov(scene, mapping="classic")


def test_compile_cli_writes_atomically(tmp_path, monkeypatch, capsys):
    from phongscene import files

    rendering = importlib.import_module("phongscene.rendering")
    scene = _simple()
    monkeypatch.setattr(
        rendering,
        "load_scene",
        lambda path, time=None, camera=None, sandbox=None, subdivision_level=None: (scene, ["a warning"]),
    )
    out = tmp_path / "out.pov"
    assert cli.main(["compile", "scene.usda", "-o", str(out), "--mapping", "classic", "--width", "32"]) == 0
    text = capsys.readouterr()
    assert out.read_text() == compile_pov(
        scene, dataclasses.replace(scene.settings, width=32, height=24, specular="povray-classic"), "classic"
    )
    assert "povray +Iout.pov +Oout.exr" in text.out and "+W32 +H24" in text.out
    assert "Input_File_Name=out.pov" in (tmp_path / "out.ini").read_text()
    assert "warning: a warning" in text.err
    # A scene that fails to compile leaves the previous file untouched and no temporary files.
    before = sorted(tmp_path.iterdir())
    bad = _simple(lights=(PointLight((NAN, 0, 0), (1, 1, 1), source="/World/Key"),))
    monkeypatch.setattr(
        rendering, "load_scene", lambda path, time=None, camera=None, sandbox=None, subdivision_level=None: (bad, [])
    )
    assert cli.main(["compile", "scene.usda", "-o", str(out)]) == 2
    assert sorted(tmp_path.iterdir()) == before
    assert "/World/Key.xformOp" in capsys.readouterr().err
    # The SDL is compiled as it is written: a mesh the compiler refuses half way through the
    # file (after the camera and lights: 1e100 passes validation, not float32) leaves nothing
    # behind either.
    huge = TriangleMesh([[0, 0, 0], [1e100, 0, 0], [0, 1, 0]], [[0, 1, 2]], source="/World/Huge")
    monkeypatch.setattr(
        rendering,
        "load_scene",
        lambda path, time=None, camera=None, sandbox=None, subdivision_level=None: (_simple(meshes=(huge,)), []),
    )
    assert cli.main(["compile", "scene.usda", "-o", str(out)]) == 2
    assert sorted(tmp_path.iterdir()) == before
    assert "/World/Huge.points: " in (err := capsys.readouterr().err) and "float32" in err
    # An interrupted write never leaves a half file either.
    monkeypatch.setattr(files.os, "replace", lambda a, b: (_ for _ in ()).throw(OSError("disk full")))
    with pytest.raises(OSError):
        files.write_text_atomic(tmp_path / "new.pov", "x")
    assert sorted(tmp_path.iterdir()) == before


def test_mesh_indices_out_of_range_are_rejected_by_name():
    mesh = TriangleMesh(np.eye(3), [[0, 1, -1]], source="/World/Broken")
    with pytest.raises(SceneError, match=r"/World/Broken\.faceVertexIndices: indices must be in \[0, 3\)"):
        checked_compile_pov(_simple(meshes=(mesh,)))
    mesh = TriangleMesh(np.eye(3), [[0, 1, 2]], [[0, 0, 1]], [[0, 0, 1]], source="/World/Broken")
    with pytest.raises(SceneError, match=r"/World/Broken\.normals: indices"):
        checked_compile_pov(_simple(meshes=(mesh,)))
