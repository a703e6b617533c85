# SPDX-License-Identifier: Apache-2.0
"""The writer: round trip, Sdr compliance of what it writes, registration order, mesh import."""

from __future__ import annotations

import math
import subprocess
import sys
from dataclasses import fields, replace

import numpy as np
import pytest
import trimesh
from pxr import Sdf, Usd, UsdValidation

from phongscene.cli import main
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
    TriangleMesh,
)
from phongscene.usd import PHONG_SHADER_ID, load_usd, read_usd, write_usd

# USD stores colours, material inputs, points, normals and apertures as float32: a value comes
# back within float32 rounding (2^-24 relative ≈ 6e-8) plus double arithmetic on top (FOV via
# tan/atan). 1e-6 relative bounds both with margin.
FLOAT32_ROUNDING = 1e-6


def scene() -> Scene:
    red = PhongMaterial(0.25, 0.6, 0.2, 20.0, (0.9, 0.2, 0.1), (1.0, 0.9, 0.8))
    normals = np.array([[0, 0, 1], [0, 0.6, 0.8], [0.1, 0.2, 0.3]], float)
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    return Scene(
        camera=Camera((0.1, 1.0, 5.0), (0.0, 0.0, -1.0), (0.0, 1.0, 0.0), horizontal_fov_deg=50.0),
        ambient=AmbientLight((0.1, 0.2, 0.3)),
        lights=(
            PointLight((1, 2, 3), (math.pi,) * 3, 2.0, 1.0),
            PointLight(
                (0, 4, 1), (5.0, 6.0, 7.0), falloff="inverse-square", cone=Cone((0.6, -0.8, 0.0), 0.8, 0.9, 4.0)
            ),
            DirectionalLight((0.0, -0.6, -0.8), (1.0, 0.5, 0.2), diffuse=0.5, specular=2.0),
            RectAreaLight((0, 5, 0), (1, 0, 0), (0, 0.5, 2), (2, 2, 2), 5),
            SphereAreaLight((3, 3, 3), 0.3, (1, 1, 1), 17),
        ),
        spheres=(
            Sphere.at((0, 1, 0), 1.3, red),
            Sphere(np.array([[2, 0, 0, 1], [0, 1, 0.5, 0], [0, 0, 0.5, 0], [0, 0, 0, 1.0]]), PhongMaterial()),
        ),
        meshes=(
            TriangleMesh(
                [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.3]],
                [[0, 1, 2], [1, 3, 2]],
                normals,
                [[0, 1, 2], [2, 1, 0]],
                red,
            ),
            TriangleMesh(
                [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], [[0, 0, 1]] * 3, [[0, 1, 2]], PhongMaterial(ks=0.0)
            ),
            TriangleMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 2, 1]]),
        ),
        settings=RenderSettings(96, 72, 3, "povray-am1", background=(0.1, 0.2, 0.3), specular="povray-classic"),
    )


def assert_close(a, b, path="scene"):
    """Structural comparison ignoring `source`, floats within float32 rounding."""
    if isinstance(a, (tuple, list)) and not isinstance(a, str):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            assert_close(x, y, f"{path}[{i}]")
    elif hasattr(a, "__dataclass_fields__"):
        assert type(a) is type(b), path
        for f in fields(a):
            if f.name not in ("source", "source_file"):
                assert_close(getattr(a, f.name), getattr(b, f.name), f"{path}.{f.name}")
    elif isinstance(a, np.ndarray) or isinstance(a, float):
        np.testing.assert_allclose(a, b, rtol=FLOAT32_ROUNDING, atol=FLOAT32_ROUNDING, err_msg=path)
    else:
        assert a == b, path


def test_round_trip(tmp_path):
    s = scene()
    s1 = load_usd(write_usd(s, tmp_path / "s1.usda"))
    s2 = load_usd(write_usd(s1, tmp_path / "s2.usda"))
    assert replace(s2, source_file="") == replace(s1, source_file="")  # exact: a re-read is idempotent
    assert_close(s, s1)  # the first pass rounds through float32


def test_round_trip_orthographic_and_usdc(tmp_path):
    s = replace(scene(), camera=Camera((0, 0, 3), (0, 0, -1), (0, 1, 0), "orthographic", ortho_width=4.5))
    s1 = load_usd(write_usd(s, tmp_path / "s.usdc"))
    assert s1.camera.projection == "orthographic"
    assert_close(s, s1)


def test_write_is_atomic_and_rejects_unknown_formats(tmp_path):
    target = tmp_path / "out.usda"
    write_usd(scene(), target)
    assert [p.name for p in tmp_path.iterdir()] == ["out.usda"]  # no temporary left behind
    with pytest.raises(Exception, match="can only write"):
        write_usd(scene(), tmp_path / "out.obj")


def sdr_errors(stage):
    validator = UsdValidation.ValidationRegistry().GetOrLoadValidatorByName("usdShadeValidators:ShaderSdrCompliance")
    return [e.GetMessage() for prim in stage.Traverse() for e in validator.Validate(prim)]


def test_written_scene_passes_sdr_validation_and_a_wrong_type_is_reported(tmp_path):
    path = write_usd(scene(), tmp_path / "s.usda")
    stage = Usd.Stage.Open(str(path))
    assert sdr_errors(stage) == []
    shader = next(p for p in stage.Traverse() if p.GetAttribute("info:id").Get() == PHONG_SHADER_ID)
    shader.RemoveProperty("inputs:ks")
    shader.CreateAttribute("inputs:ks", Sdf.ValueTypeNames.Double).Set(0.5)
    (message,) = sdr_errors(stage)
    assert "inputs:ks" in message and "Expected 'float'; got 'double'" in message


@pytest.mark.subprocess
def test_sdr_registration_after_stages_were_opened(tmp_path):
    path = write_usd(scene(), tmp_path / "s.usda")
    probe = (
        "import sys\n"
        "from pxr import Usd, UsdGeom, UsdValidation\n"
        "stage = Usd.Stage.Open(sys.argv[1]); UsdGeom.Xform.Define(Usd.Stage.CreateInMemory(), '/X')\n"
        "import phongscene.usd\n"
        "v = UsdValidation.ValidationRegistry().GetOrLoadValidatorByName('usdShadeValidators:ShaderSdrCompliance')\n"
        "errors = [e.GetMessage() for p in stage.Traverse() for e in v.Validate(p)]\n"
        "assert errors == [], errors\n"
        "assert phongscene.usd.load_usd(stage).spheres[0].material.ks > 0.19\n"
    )
    subprocess.run([sys.executable, "-c", probe, str(path)], check=True)


def test_import_mesh_command(tmp_path, capsys):
    source = tmp_path / "ico.ply"
    ico = trimesh.creation.icosphere(subdivisions=2)
    ico.export(source)
    out = tmp_path / "ico.usda"
    assert main(["import", str(source), "-o", str(out)]) == 0
    result = read_usd(out)
    (mesh,) = result.scene.meshes
    assert len(mesh.triangles) == len(ico.faces)
    assert np.allclose(mesh.points, ico.vertices, atol=FLOAT32_ROUNDING)
    # vertex normals of a unit icosphere point away from the centre
    assert np.allclose(mesh.normals, mesh.points / np.linalg.norm(mesh.points, axis=1)[:, None], atol=1e-2)
    assert mesh.material.source.endswith("/Phong")
    stage = Usd.Stage.Open(str(out))
    assert stage.GetPrimAtPath("/World/ico").GetAttribute("subdivisionScheme").Get() == "none"
    assert main(["import", str(tmp_path / "missing.ply"), "-o", str(out)]) == 2


def test_import_mesh_gives_every_vertex_a_unit_normal(tmp_path):
    # A two-sided sheet (each triangle twice, opposite windings: the vertex normals cancel) and a
    # degenerate triangle whose third vertex belongs to no other face.
    points = [(0, 0, 0), (1, 0, 0), (0, 0, 1), (2, 0, 0)]
    faces = [(0, 1, 2), (0, 2, 1), (0, 1, 3)]
    source = tmp_path / "sheet.obj"
    source.write_text(
        "".join(f"v {x} {y} {z}\n" for x, y, z in points) + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in faces)
    )
    out = tmp_path / "sheet.usda"
    assert main(["import", str(source), "-o", str(out)]) == 0
    (mesh,) = read_usd(out).scene.meshes  # raised SceneError (zero-length normals) before
    assert np.allclose(np.linalg.norm(mesh.normals, axis=1), 1.0)
    # Where the sheet's faces meet, the normal is the sheet's (±Y), not an arbitrary axis.
    sheet = np.unique(mesh.triangles[:2])
    assert np.allclose(np.abs(mesh.normals[sheet, 1]), 1.0)


def test_write_usd_refuses_an_invalid_scene_and_writes_nothing(tmp_path):
    from phongscene.errors import SceneError
    from phongscene.scene import PhongMaterial, Scene, Sphere
    from phongscene.usd import write_usd

    scene = Scene(spheres=(Sphere.at((0, 0, 0), 1.0, PhongMaterial(kd=float("nan"))),))
    with pytest.raises(SceneError, match="kd: must be finite"):
        write_usd(scene, tmp_path / "bad.usda")
    assert not list(tmp_path.iterdir())


# Import normals (issue 11): STL/PLY carry none, so they are split at creases, not averaged.


def _corner_normals(mesh) -> np.ndarray:
    return np.asarray(mesh.normals)[np.asarray(mesh.normal_indices)]  # (F, 3, 3)


def _face_normals(mesh) -> np.ndarray:
    p = np.asarray(mesh.points)[np.asarray(mesh.triangles)]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    return n / np.linalg.norm(n, axis=1)[:, None]


@pytest.mark.parametrize("suffix", [".stl", ".ply"])
def test_import_splits_normals_at_a_box_s_creases(tmp_path, suffix):
    source = tmp_path / f"box{suffix}"
    trimesh.creation.box().export(source)
    assert main(["import", str(source), "-o", str(tmp_path / "box.usda")]) == 0
    (mesh,) = read_usd(tmp_path / "box.usda").scene.meshes
    # Every corner's normal is its face's: flat faces, as the box is (averaged, a corner's
    # normal was the diagonal (±1, ±1, ±1)/√3).
    corners, faces = _corner_normals(mesh), _face_normals(mesh)
    assert np.allclose(np.abs(np.einsum("fcj,fj->fc", corners, faces)), 1.0, atol=1e-6)


def test_import_smooths_below_the_crease_angle_and_the_angle_is_an_option(tmp_path):
    source = tmp_path / "cylinder.stl"
    trimesh.creation.cylinder(radius=1.0, height=2.0, sections=24).export(source)  # sides meet at 15°
    out = tmp_path / "cylinder.usda"
    assert main(["import", str(source), "-o", str(out)]) == 0
    (mesh,) = read_usd(out).scene.meshes
    corners, faces = _corner_normals(mesh), _face_normals(mesh)
    side = np.abs(faces[:, 2]) < 0.5
    # Side corners: radial normals (smooth round the cylinder); cap corners: the cap's normal.
    radial = np.asarray(mesh.points)[np.asarray(mesh.triangles)][side] * [1.0, 1.0, 0.0]
    radial /= np.linalg.norm(radial, axis=2)[..., None]
    assert np.allclose(corners[side], radial, atol=1e-6)
    assert np.allclose(np.abs(corners[~side][..., 2]), 1.0, atol=1e-6)
    # Below 15°, the sides are flat too.
    assert main(["import", str(source), "-o", str(out), "--crease-angle", "10"]) == 0
    (mesh,) = read_usd(out).scene.meshes
    assert np.allclose(np.abs(np.einsum("fcj,fj->fc", _corner_normals(mesh), _face_normals(mesh))), 1.0, atol=1e-6)
    with pytest.raises(SystemExit) as usage:
        main(["import", str(source), "-o", str(out), "--crease-angle", "200"])
    assert usage.value.code == 2


def test_import_keeps_a_file_s_own_normals(tmp_path):
    source = tmp_path / "tilted.obj"
    source.write_text(
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n" + "vn 0 0.6 0.8\n" * 4 + "f 1//1 2//2 3//3\nf 1//1 3//3 4//4\n"
    )
    assert main(["import", str(source), "-o", str(tmp_path / "tilted.usda")]) == 0
    (mesh,) = read_usd(tmp_path / "tilted.usda").scene.meshes
    assert np.allclose(_corner_normals(mesh), [0.0, 0.6, 0.8], atol=1e-6)  # not the face's +Z
