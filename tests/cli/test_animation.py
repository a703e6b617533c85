# SPDX-License-Identifier: Apache-2.0
"""Issue 13: a stage read at a USD time code, and frames rendered as Dask tasks (a real
LocalCluster of processes, and a scheduler and a worker started as separate processes)."""

from __future__ import annotations

import json
import math
import os
import pickle
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from phongscene import animation, dask_runtime
from phongscene.cli import main
from phongscene.errors import SceneError
from phongscene.images import read_image
from phongscene.rendering import load_scene, render
from phongscene.usd import open_stage, read_usd
from support.paths import SCENES

ANIMATED = SCENES / "animated.usda"  # frames 1..24; see the comment at its top
BLENDER = SCENES / "blender_keyframes.usda"
PYTHON = sys.executable

# The ball's image is found by hue (red at frame 1 turning blue; the rest is grey). The centroid of
# a sphere's perspective image lies off the projection of its centre by a fraction of its radius
# (≈ 5 px here), and its pixels are whole: within 1.5 px of the projected centre at 64 × 48.
BALL_CENTROID_TOLERANCE_PX = 1.5
# How long a scheduler and a worker started as processes get to come up on a loaded 2-core machine.
CLUSTER_START_TIMEOUT_S = 60.0


# -- reading at a time ---------------------------------------------------------------------------


def _ball(scene):
    return next(s for s in scene.spheres if s.source == "/World/Ball")


def test_every_kind_of_value_is_read_at_the_time():
    at_24 = read_usd(ANIMATED, time=24)
    s = at_24.scene
    assert _ball(s).world_from_object[:3, 3].tolist() == [3.0, 1.0, 0.0]  # transform
    assert s.camera.position == (0.0, 1.0, 12.0)  # camera
    assert s.lights[0].color == (6.0, 6.0, 6.0)  # light intensity
    assert _ball(s).material.diffuse_color == (0.0, 0.0, 1.0)  # material
    assert [sp.source for sp in s.spheres] == ["/World/Ball"]  # visibility: the blinker is gone
    assert at_24.warnings == []  # a time was asked for: nothing to say
    at_11 = read_usd(ANIMATED, time=11).scene
    assert {sp.source for sp in at_11.spheres} == {"/World/Ball", "/World/Blinker"}


def test_values_between_samples_are_usd_interpolation():
    s = load_scene(ANIMATED, time=12.5)[0]
    # Linear interpolation at (12.5 - 1) / 23 = 1/2 of the way from frame 1 to frame 24.
    assert _ball(s).world_from_object[:3, 3].tolist() == pytest.approx([0.0, 1.0, 0.0], abs=1e-12)
    assert s.camera.position == pytest.approx((0.0, 1.0, 11.0))
    assert s.lights[0].color == pytest.approx((4.0, 4.0, 4.0))
    assert _ball(s).material.diffuse_color == pytest.approx((0.5, 0.0, 0.5))
    # A token is held, not interpolated: invisible from its sample at 12 on.
    assert [sp.source for sp in s.spheres] == ["/World/Ball"]


def test_without_a_time_an_animated_stage_is_read_at_its_start_with_a_warning():
    result = read_usd(ANIMATED)
    assert _ball(result.scene).world_from_object[0, 3] == -3.0
    assert any(
        "animated (time codes 1 to 24): rendering its start time 1" in w and "--time" in w for w in result.warnings
    )


def test_a_time_outside_the_range_holds_the_last_sample_and_says_so():
    result = read_usd(ANIMATED, time=30)
    assert _ball(result.scene).world_from_object[0, 3] == 3.0
    assert any("time 30 is outside the stage's time codes 1 to 24" in w for w in result.warnings)


def test_time_samples_without_a_range_read_the_earliest_sample_not_the_origin(tmp_path):
    # No startTimeCode/endTimeCode and no default value: the default time has no transform at all.
    path = tmp_path / "norange.usda"
    path.write_text(
        '#usda 1.0\ndef Sphere "Ball" {\n    double3 xformOp:translate.timeSamples = {5: (2, 0, 0), 9: (6, 0, 0)}\n'
        '    uniform token[] xformOpOrder = ["xformOp:translate"]\n}\n'
    )
    result = read_usd(path)
    assert result.scene.spheres[0].world_from_object[0, 3] == 2.0
    assert any(
        "time samples but no startTimeCode/endTimeCode: rendering its earliest sample, time 5" in w
        for w in result.warnings
    )
    assert read_usd(path, time=7).scene.spheres[0].world_from_object[0, 3] == 4.0


def test_a_static_stage_reads_the_same_at_any_time():
    path = SCENES / "instancing.usda"
    plain, at_time = read_usd(path), read_usd(path, time=100)
    assert at_time.warnings == plain.warnings
    assert [s.world_from_object.tolist() for s in at_time.scene.spheres] == [
        s.world_from_object.tolist() for s in plain.scene.spheres
    ]


@pytest.mark.parametrize("bad", [math.nan, math.inf, "24"])
def test_a_time_that_is_not_a_finite_number_is_one_error_naming_the_file(bad):
    with pytest.raises(SceneError, match=r"animated\.usda: the time must be a finite number"):
        read_usd(ANIMATED, time=bad)


def test_a_blender_style_export_with_keyframes_reads_its_frames():
    # Z-up, translate/rotateXYZ/scale time samples, constants as single samples (no defaults).
    first, last = (read_usd(BLENDER, time=t).scene for t in (1, 24))
    cube = lambda s: next(m for m in s.meshes if m.source.endswith("BallMesh"))  # noqa: E731
    # Blender's (x, y, z) is the model's (x, z, -y); the cube's centre is at Blender z = 1.
    assert cube(first).points.mean(axis=0) == pytest.approx([-3.0, 1.0, 0.0], abs=1e-6)
    assert cube(last).points.mean(axis=0) == pytest.approx([3.0, 1.0, 0.0], abs=1e-6)
    # A quarter turn about Blender's Z: the cube's corner (1, 1) turns to (-1, 1).
    corner = cube(last).points[0] - cube(last).points.mean(axis=0)
    assert corner == pytest.approx([-1.0, 1.0, -1.0], abs=1e-5)
    assert first.camera.position == pytest.approx((0.0, 2.0, 10.0)) and last.camera.position == pytest.approx(
        (0.0, 2.0, 12.0)
    )
    # The light's power was keyframed 500 -> 1500 W: its intensity samples 159.15494 -> 477.46484.
    assert last.lights[0].color[0] / first.lights[0].color[0] == pytest.approx(477.46484 / 159.15494)


def test_a_blender_style_export_renders_its_frames(tmp_path):
    for frame in (1, 24):
        assert (
            main(["render", str(BLENDER), "-o", str(tmp_path / "b.####.exr"), "--time", str(frame), "--width", "64"])
            == 0
        )
    # The red cube (Blender's base colour (0.8, 0.1, 0.1)) crosses the frame from the left to the right.
    first, last = (read_image(tmp_path / f"b.{f:04d}.exr") for f in (1, 24))
    red_x = lambda image: float(np.nonzero(image[..., 0] > 2 * image[..., 1] + 1e-3)[1].mean())  # noqa: E731
    assert red_x(first) < 64 / 3 and red_x(last) > 2 * 64 / 3


# -- a worker's kept stage ------------------------------------------------------------------


def _same_read(a, b) -> bool:
    """The same model (every field, arrays byte for byte), the same warnings and prim mapping."""
    return pickle.dumps(a.scene) == pickle.dumps(b.scene) and a.warnings == b.warnings and a.nodes == b.nodes


@pytest.mark.parametrize(
    "path", [ANIMATED, BLENDER, SCENES / "warned" / "missing_reference.usda"], ids=lambda p: p.name
)
def test_a_stage_opened_once_reads_at_every_time_what_the_file_reads(path):
    # The time-independent checks (composition errors, typos) run at the first read and are
    # replayed by the others; each read's own warnings (the time, clipping lights) are its own.
    opened = open_stage(path)
    for time_code in (1, 24, 12.5, None, 30, 1):
        assert _same_read(read_usd(opened, time=time_code), read_usd(path, time=time_code)), time_code
    assert read_usd(opened, time=None).warnings  # these files do warn: the comparison saw some


# One static scene in which one thing at a time is animated, each in a way a read of a stage
# opened once must see: its own transform, only an ancestor's, a material input reached through a
# connection, a light, the camera, visibility, an instancer moved by velocities from one positions
# sample. {name} marks where a variant puts its value or samples.
_PARTS = """#usda 1.0
(
    startTimeCode = 1
    endTimeCode = 24
)
def Xform "World"
{
    def Camera "Camera"
    {
        float focalLength = 50
        float horizontalAperture = 36
        double3 xformOp:translate{camera}
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def SphereLight "Key"
    {
        float inputs:intensity{light}
        float inputs:radius = 0
        custom token phong:lightModel = "seed"
        bool treatAsPoint = 1
        double3 xformOp:translate = (-4, 8, 6)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def Xform "Rig"
    {
        double3 xformOp:translate{ancestor}
        uniform token[] xformOpOrder = ["xformOp:translate"]
        def Sphere "Ball" (prepend apiSchemas = ["MaterialBindingAPI"])
        {
            rel material:binding = </World/Looks/Paint>
            token visibility{visibility}
            double3 xformOp:translate{transform}
            uniform token[] xformOpOrder = ["xformOp:translate"]
        }
    }
    def PointInstancer "Crowd"
    {
        rel prototypes = </World/Crowd/Proto>
        int[] protoIndices = [0, 0]
        point3f[] positions{instancer}
        vector3f[] velocities{velocities}
        def Sphere "Proto" {
            double radius = 0.25
        }
    }
    def Scope "Looks"
    {
        def Material "Paint"
        {
            color3f inputs:tint{material}
            token outputs:phong:surface.connect = </World/Looks/Paint/Phong.outputs:surface>
            def Shader "Phong"
            {
                uniform token info:id = "phongscene_PhongSurface"
                color3f inputs:diffuseColor.connect = </World/Looks/Paint.inputs:tint>
                token outputs:surface
            }
        }
    }
}
"""
_STATIC = {
    "camera": " = (0, 1, 10)",
    "light": " = 2",
    "ancestor": " = (0, 0, 0)",
    "visibility": ' = "inherited"',
    "transform": " = (0, 1, 0)",
    "instancer": " = [(-2, 0, 0), (2, 0, 0)]",
    "velocities": "",
    "material": " = (1, 0, 0)",
}
_ANIMATED = {
    "camera": {"camera": ".timeSamples = {1: (0, 1, 10), 24: (0, 1, 12)}"},
    "light": {"light": ".timeSamples = {1: 2, 24: 6}"},
    "ancestor": {"ancestor": ".timeSamples = {1: (-3, 0, 0), 24: (3, 0, 0)}"},
    "visibility": {"visibility": '.timeSamples = {1: "inherited", 12: "invisible"}'},
    "transform": {"transform": ".timeSamples = {1: (-3, 1, 0), 24: (3, 1, 0)}"},
    "instancer": {"instancer": ".timeSamples = {1: [(-2, 0, 0), (2, 0, 0)], 24: [(-2, 3, 0), (2, 3, 0)]}"},
    # One positions sample, which does not vary in time: USD moves the instances from it by their
    # velocities (units per second) to the time read.
    "velocities": {
        "instancer": ".timeSamples = {1: [(-2, 0, 0), (2, 0, 0)]}",
        "velocities": ".timeSamples = {1: [(24, 0, 0), (0, 24, 0)]}",
    },
    "material": {"material": ".timeSamples = {1: (1, 0, 0), 24: (0, 0, 1)}"},
}


@pytest.mark.parametrize("part", [None, *_ANIMATED], ids=lambda p: p or "nothing")
def test_a_stage_opened_once_sees_every_way_a_part_of_it_varies_in_time(tmp_path, part):
    path = tmp_path / f"{part}.usda"
    text = _PARTS
    for name, value in (_STATIC | _ANIMATED.get(part, {})).items():
        text = text.replace(f"{{{name}}}", value)
    path.write_text(text)
    opened = open_stage(path)
    reads = {t: read_usd(opened, time=t) for t in (1, 24, 12.5, None, 30, 1)}
    for time_code, read in reads.items():
        assert _same_read(read, read_usd(path, time=time_code)), time_code
    # The scene moves, or not, as the part says (so the comparison above compared frames that differ).
    assert (pickle.dumps(reads[1].scene) != pickle.dumps(reads[24].scene)) == (part is not None)
    # A stage nothing of which varies is read once: every read gives the first read's model.
    assert (reads[24].scene is reads[1].scene) == (part is None)
    # A light or gprim whose inputs do not vary is read once (the first read's object comes back)
    # unless a material, visibility or purpose varies (the whole stage is read again).
    ball = lambda read: next(s for s in read.scene.spheres if s.source == "/World/Rig/Ball")  # noqa: E731
    whole = part in ("visibility", "material")
    assert (reads[None].scene.lights[0] is reads[1].scene.lights[0]) == (part != "light" and not whole)
    assert (ball(reads[None]) is ball(reads[1])) == (part not in ("transform", "ancestor") and not whole)


def test_a_single_time_sample_beside_a_default_is_held_at_every_time(tmp_path):
    # One sample does not vary in time, but it is not the default value: every numeric time reads
    # the sample, the default time the default (the stage has a range, so no read is at default).
    path = tmp_path / "held.usda"
    path.write_text(
        "#usda 1.0\n(\n    startTimeCode = 1\n    endTimeCode = 4\n)\n"
        'def Sphere "Ball" {\n    double radius = 1\n    double radius.timeSamples = {2: 3}\n}\n'
    )
    opened = open_stage(path)
    for time_code in (1, 4, None, 100):
        read = read_usd(opened, time=time_code)
        assert _same_read(read, read_usd(path, time=time_code)), time_code
        assert read.scene.spheres[0].world_from_object[0, 0] == 3.0


@pytest.mark.parametrize("indices", ["{1: [], 24: [0]}", "{1: [0], 24: []}"], ids=["from_24", "until_24"])
def test_a_material_first_used_by_another_part_at_another_time_reads_the_stage_anew(tmp_path, indices):
    # The mesh's GeomSubset binds "Bare" from (or until) frame 24 (no faces at the other end): at
    # one time the mesh, read anew, uses it first, at the other the sphere after it (kept). The
    # material's warning must come once, as a read of the file gives it.
    path = tmp_path / "subset.usda"
    path.write_text(
        """#usda 1.0
(
    startTimeCode = 1
    endTimeCode = 24
)
def Mesh "Quad"
{
    int[] faceVertexCounts = [3, 3]
    int[] faceVertexIndices = [0, 1, 2, 0, 2, 3]
    point3f[] points = [(-1, 0, -1), (1, 0, -1), (1, 0, 1), (-1, 0, 1)]
    uniform token subsetFamily:materialBind:familyType = "nonOverlapping"
    def GeomSubset "Part" (prepend apiSchemas = ["MaterialBindingAPI"])
    {
        uniform token elementType = "face"
        uniform token familyName = "materialBind"
        int[] indices.timeSamples = INDICES
        rel material:binding = </Looks/Bare>
    }
}
def Sphere "Later" (prepend apiSchemas = ["MaterialBindingAPI"])
{
    rel material:binding = </Looks/Bare>
}
def Scope "Looks"
{
    def Material "Bare"
    {
    }
}
""".replace("INDICES", indices)
    )
    opened = open_stage(path)
    read_usd(opened, time=1)
    assert opened.reads.by_parts  # the subset is its mesh's input: the sphere is kept
    for time_code in (24, 1, 12, 24):
        assert _same_read(read_usd(opened, time=time_code), read_usd(path, time=time_code)), time_code
    assert any(
        "materials without a surface shader (rendered grey) (1): /Looks/Bare" in w
        for w in read_usd(opened, time=24).warnings
    )


def test_a_stage_read_once_reads_a_changed_texture_again(tmp_path):
    # The model of a stage that does not vary is kept, its textures decoded in it: a texture file
    # that changes (or goes) between two reads is read again, as a read of the file would.
    import shutil

    from phongscene.images import write_image

    folder = tmp_path / "textured"
    shutil.copytree(SCENES / "blender_textured", folder)
    path = folder / "textured_glossy.usdc"
    texture = folder / "textures" / "textured_glossy_grid.png"  # both materials read it
    opened = open_stage(path)
    first = read_usd(opened, time=1)
    assert _same_read(first, read_usd(path, time=1)) and read_usd(opened, time=2).scene is first.scene
    write_image(texture, np.full((4, 4, 3), 0.25, dtype=np.float32))
    os.utime(texture, ns=(time.time_ns(), time.time_ns() + 10**9))  # whatever the clock's resolution
    changed = read_usd(opened, time=1)
    assert _same_read(changed, read_usd(path, time=1))
    assert pickle.dumps(changed.scene) != pickle.dumps(first.scene)  # the new texels are in the model
    texture.unlink()
    assert _same_read(read_usd(opened, time=1), read_usd(path, time=1))


def test_a_kept_stage_is_reused_until_its_file_or_a_layer_changes(tmp_path):
    from phongscene.usd import stage_reuse as workers

    layer, root = tmp_path / "ball.usda", tmp_path / "shot.usda"
    layer.write_text('#usda 1.0\ndef Sphere "Ball" {\n    double radius = 1\n}\n')
    root.write_text(f"#usda 1.0\n(\n    subLayers = [@{layer.name}@]\n)\n")
    radius = lambda: load_scene(workers.open_stage(str(root)), time=1.0)[0].spheres[0].world_from_object[0, 0]  # noqa: E731
    try:
        first = workers.open_stage(str(root))
        assert radius() == 1.0 and workers.open_stage(str(root)) is first  # unchanged: kept
        layer.write_text('#usda 1.0\ndef Sphere "Ball" {\n    double radius = 2.5\n}\n')
        os.utime(layer, ns=(time.time_ns(), time.time_ns() + 10**9))  # whatever the clock's resolution
        assert radius() == 2.5 and workers.open_stage(str(root)) is not first  # the sublayer changed
        again = workers.open_stage(str(root))
        root.write_text(root.read_text() + 'def Sphere "Other" {\n}\n')
        os.utime(root, ns=(time.time_ns(), time.time_ns() + 2 * 10**9))
        assert workers.open_stage(str(root)) is not again
        assert len(load_scene(workers.open_stage(str(root)), time=1.0)[0].spheres) == 2
    finally:
        workers.forget()


def test_a_kept_stage_whose_layer_no_longer_parses_is_a_scene_error_then_recovers(tmp_path, capfd):
    """A layer broken by an edit (the live preview, a worker): the reopen names the file; USD's
    own re-read warning is held back; the fixed file opens again."""
    from phongscene.errors import SceneError
    from phongscene.usd import stage_reuse as workers

    root = tmp_path / "shot.usda"
    good = '#usda 1.0\ndef Sphere "Ball" {\n    double radius = 1\n}\n'
    root.write_text(good)
    try:
        workers.open_stage(str(root))
        root.write_text(good + "def Xform {{{\n")
        with pytest.raises(SceneError, match="shot.usda"):
            workers.open_stage(str(root))
        assert "Unable to re-read" not in capfd.readouterr().err
        root.write_text(good.replace("radius = 1", "radius = 3"))
        assert load_scene(workers.open_stage(str(root)))[0].spheres[0].world_from_object[0, 0] == 3.0
    finally:
        workers.forget()


def test_frames_read_from_the_kept_stage_are_bit_identical_to_render_time(tmp_path):
    from phongscene.overrides import RenderOverrides
    from phongscene.usd import stage_reuse as workers

    options = RenderOverrides(width=48, samples=2, threads=1)
    try:
        for frame in (1, 9, 17, 24):
            metrics = animation.render_frame(
                str(ANIMATED), frame, str(tmp_path / f"task.{frame}.exr"), "native", options
            )
            assert (
                main(
                    [
                        "render",
                        str(ANIMATED),
                        "-o",
                        str(tmp_path / f"cli.{frame}.exr"),
                        "--time",
                        str(frame),
                        "--width",
                        "48",
                        "--spp",
                        "2",
                    ]
                )
                == 0
            )
            task, serial = (read_image(tmp_path / f"{kind}.{frame}.exr") for kind in ("task", "cli"))
            assert np.array_equal(task, serial), frame
            assert metrics["warnings"] == read_usd(ANIMATED, time=frame).warnings
        assert workers._last is not None and workers._last[0] == str(ANIMATED)  # the frames shared one stage
    finally:
        workers.forget()


@pytest.mark.dask
def test_a_worker_has_made_its_imports_when_it_joins():
    from distributed import Client

    from phongscene.dask_runtime import WARM_IMPORTS, warm_plugin

    with dask_runtime.local_cluster(1) as cluster, Client(cluster) as client:
        before = client.run(lambda: [m for m in WARM_IMPORTS if m in sys.modules])
        client.register_plugin(warm_plugin())
        after = client.run(lambda: [m for m in WARM_IMPORTS if m in sys.modules])
    assert [set(v) for v in before.values()] != [set(WARM_IMPORTS)]  # a fresh worker had not
    assert list(after.values()) == [list(WARM_IMPORTS)]


# -- frames: names and ranges ----------------------------------------------------------------


def test_frame_ranges_and_names():
    assert animation.parse_frames("1:24:8") == (1, 9, 17)
    assert animation.parse_frames("3:3") == (3,)
    assert animation.parse_frames("7") == (7,)


def test_usdrecords_frame_specs_read_as_usd_reads_them():
    # usdrecord's --frames (UsdAppUtils.framesArgs): comma-separated specs, a stride after 'x';
    # UsdUtils.TimeCodeRange is the oracle for each spec.
    from pxr import UsdUtils

    for spec in ("1:9x4", "1:10x4", "-3:3x2", "5", "2:6"):
        expected = tuple(int(t.GetValue()) for t in UsdUtils.TimeCodeRange.CreateFromFrameSpec(spec))
        assert animation.parse_frames(spec) == expected, spec
    assert animation.parse_frames("1:9x4,2,5") == (1, 5, 9, 2)  # in order, each frame once
    for bad, message in (
        ("5:1", "before the start"),
        ("1:5:0", "step must be >= 1"),
        ("1:2.5", "whole numbers"),
        ("1:9x0", "step must be >= 1"),
        ("1::2:3", "START:END"),
        ("", "START:END"),
        ("1,", "START:END"),
    ):
        with pytest.raises(ValueError, match=message):
            animation.parse_frames(bad)
    assert animation.frame_name("out/a.####.exr", 7) == os.path.join("out", "a.0007.exr")
    assert animation.frame_name("dir.##/f.#.png", 12) == os.path.join("dir.##", "f.12.png")  # the file name's run
    with pytest.raises(ValueError, match="needs ####"):
        animation.frame_name("out.exr", 1)


def test_the_cluster_is_the_option_else_the_environment_else_a_local_one(monkeypatch):
    monkeypatch.delenv("DASK_SCHEDULER_ADDRESS", raising=False)
    assert dask_runtime.scheduler_address(None) is None  # a LocalCluster
    monkeypatch.setenv("DASK_SCHEDULER_ADDRESS", "tcp://10.0.0.1:8786")
    assert dask_runtime.scheduler_address(None) == "tcp://10.0.0.1:8786"
    assert dask_runtime.scheduler_address("tcp://127.0.0.1:9999") == "tcp://127.0.0.1:9999"


@pytest.mark.dask
def test_a_scheduler_that_is_not_there_is_one_error_naming_it(tmp_path, capsys):
    import dask
    import distributed  # noqa: F401  (its config defaults first: leaving set() restores the config as it was)

    with dask.config.set({"distributed.comm.timeouts.connect": "1s"}):
        rc = main(
            [
                "render",
                str(ANIMATED),
                "-o",
                str(tmp_path / "f.####.exr"),
                "--frames",
                "1:2",
                "--scheduler",
                "tcp://127.0.0.1:9",
            ]
        )  # the discard port: nothing listens
    assert rc == 3
    assert "error: cannot reach the Dask scheduler tcp://127.0.0.1:9: " in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


def _ball_x(image: np.ndarray) -> float:
    hue = np.abs(image[..., 0] - image[..., 1]) + np.abs(image[..., 2] - image[..., 1])
    return float(np.nonzero(hue > 0.1)[1].mean()) + 0.5  # pixel centres


def _projected_x(frame: int, width: int = 64) -> float:
    """Where the ball's centre projects at ``frame``: x = -3 + 6 (frame - 1) / 23 at depth
    10 + 2 (frame - 1) / 23 from the camera, focal length 50 over a 36-wide aperture."""
    u = (frame - 1) / 23
    ndc = (-3 + 6 * u) / (10 + 2 * u) / (18 / 50)
    return (1 + ndc) / 2 * width


def test_render_time_24_puts_the_object_where_frame_24_has_it(tmp_path, capsys):
    assert main(["render", str(ANIMATED), "-o", str(tmp_path / "ball.####.exr"), "--time", "24"]) == 0
    image = read_image(tmp_path / "ball.0024.exr")
    assert abs(_ball_x(image) - _projected_x(24)) <= BALL_CENTROID_TOLERANCE_PX
    assert "animated" not in capsys.readouterr().err  # asked for a time: no warning
    assert main(["render", str(ANIMATED), "-o", str(tmp_path / "start.exr")]) == 0
    assert abs(_ball_x(read_image(tmp_path / "start.exr")) - _projected_x(1)) <= BALL_CENTROID_TOLERANCE_PX
    assert "rendering its start time 1" in capsys.readouterr().err


def test_frame_options_are_checked_before_anything_runs(tmp_path, capsys):
    assert main(["render", str(ANIMATED), "-o", str(tmp_path / "out.exr"), "--frames", "1:3"]) == 2
    assert "needs #### for the frame number" in capsys.readouterr().err
    assert main(["render", str(ANIMATED), "-o", str(tmp_path / "out.####.exr"), "--time", "2.5"]) == 2
    assert "needs --frames, or a whole --time" in capsys.readouterr().err
    assert main(["render", str(ANIMATED), "-o", str(tmp_path / "out.exr"), "--workers", "2"]) == 2
    assert "--scheduler and --workers run frames: give --frames" in capsys.readouterr().err
    for bad in (["--frames", "9:1"], ["--time", "nan"], ["--time", "1", "--frames", "1:2"]):
        with pytest.raises(SystemExit) as exit_:
            main(["render", str(ANIMATED), "-o", str(tmp_path / "o.####.exr"), *bad])
        assert exit_.value.code == 2
    assert not list(tmp_path.iterdir())


@pytest.mark.subprocess
def test_one_frame_does_not_start_dask(tmp_path):
    code = (
        "import sys; from phongscene.cli import main; "
        f"rc = main(['render', {str(ANIMATED)!r}, '-o', {str(tmp_path / 'f.####.exr')!r}, '--frames', '24:24']); "
        "print(rc, 'distributed' in sys.modules, 'dask' in sys.modules)"
    )
    out = subprocess.run([PYTHON, "-c", code], capture_output=True, text=True, check=True).stdout.splitlines()
    assert out[-1] == "0 False False"
    assert (tmp_path / "f.0024.exr").is_file()


def test_compile_frames_write_one_pov_and_ini_per_frame(tmp_path):
    # One frame runs in this process; the SDL differs between frames where the scene moves.
    for frame in (1, 24):
        assert main(["compile", str(ANIMATED), "-o", str(tmp_path / "s.####.pov"), "--frames", f"{frame}:{frame}"]) == 0
    first, last = (tmp_path / "s.0001.pov").read_text(), (tmp_path / "s.0024.pov").read_text()
    assert (tmp_path / "s.0024.ini").is_file() and first != last
    assert main(["compile", str(ANIMATED), "-o", str(tmp_path / "t.pov"), "--time", "24"]) == 0
    assert (tmp_path / "t.pov").read_text() == last  # the same compiler either way


# -- frames on Dask --------------------------------------------------------------------------


@pytest.mark.dask
def test_frames_on_a_local_cluster_of_processes_are_bit_identical_to_serial_renders(tmp_path, capsys):
    out = tmp_path / "f.####.exr"
    assert (
        main(["render", str(ANIMATED), "-o", str(out), "--frames", "1:24:8", "--workers", "2", "--threads", "1"]) == 0
    )
    printed = capsys.readouterr()
    assert "3 of 3 frames rendered on 2 Dask workers (LocalCluster)" in printed.out
    assert "frames: rendered in" in printed.err  # the progress bar counts frames (not a terminal: one line)
    for frame in (1, 9, 17):
        scene, _ = load_scene(ANIMATED, time=float(frame))
        serial = render(scene, "native")  # the scene's settings (all cores): threads do not change pixels
        assert np.array_equal(read_image(animation.frame_name(out, frame)), serial), frame
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.0001.exr", "f.0009.exr", "f.0017.exr"]


@pytest.mark.dask
def test_a_failing_task_is_retried_once_and_a_frame_failing_twice_is_reported_by_number(tmp_path):
    attempts = tmp_path / "attempts"
    attempts.mkdir()

    def flaky(frame: int, folder: str) -> dict:
        # Defined here, so cloudpickle ships it by value; the attempts are files, seen by every worker.
        tries = len(list(Path(folder).glob(f"{frame}.*"))) + 1
        Path(folder, f"{frame}.{tries}").touch()
        if frame == 2 or (frame == 3 and tries == 1):
            raise RuntimeError(f"frame {frame} broke on try {tries}")
        return {"frame": frame, "pid": os.getpid()}

    run = dask_runtime.run_frames(flaky, (1, 2, 3), lambda f: (f, str(attempts)), workers=1)
    assert sorted(run.results) == [1, 3] and set(run.failures) == {2}
    assert run.failures[2] == "frame 2 broke on try 2"  # tried once more, then reported
    assert sorted(p.name for p in attempts.iterdir()) == ["1.1", "2.1", "2.2", "3.1", "3.2"]
    assert run.workers == 1 and run.results[1]["pid"] != os.getpid()  # a worker process, not this one


@pytest.mark.dask
def test_a_frame_that_is_invalid_is_reported_by_number_and_the_others_are_written(tmp_path, capsys):
    path = tmp_path / "bad12.usda"
    path.write_text(
        "#usda 1.0\n(\n    startTimeCode = 11\n    endTimeCode = 13\n)\n"
        'def Sphere "Ball" {\n    double radius.timeSamples = {11: 1, 12: -1, 13: 1}\n}\n'
        'def SphereLight "Key" {\n    float inputs:intensity.timeSamples = {11: 1, 13: 100}\n'
        '    custom token phong:lightModel = "seed"\n    bool treatAsPoint = 1\n}\n'
    )
    assert main(["render", str(path), "-o", str(tmp_path / "b.####.png"), "--frames", "11:13", "--workers", "1"]) == 3
    err = capsys.readouterr().err
    # Every frame has no camera (said once, at the first frame); only frame 13's light clips.
    assert err.count("no camera: using a default framing camera") == 1
    assert err.count("clips to white") == 1 and "warning: frames 13: /Key: lights a white surface" in err
    assert "error: frame 12: " in err and "/Ball.radius" in err and "frames failed (each tried 2 times): 12" in err
    assert sorted(p.name for p in tmp_path.glob("b.*")) == ["b.0011.png", "b.0013.png"]


@pytest.mark.dask
@pytest.mark.subprocess
@pytest.mark.povray
def test_diff_frames_through_a_scheduler_and_a_worker_started_as_processes(tmp_path, capsys):
    """`dask scheduler` and `dask worker` as separate processes on loopback, as on a cluster."""
    dask = Path(PYTHON).with_name("dask")
    info = tmp_path / "scheduler.json"
    env = {**os.environ, "DASK_DISTRIBUTED__LOGGING__DISTRIBUTED": "error"}
    started = []
    try:
        started.append(
            subprocess.Popen(
                [
                    str(dask),
                    "scheduler",
                    "--host",
                    "127.0.0.1",
                    "--port",
                    "0",
                    "--no-dashboard",
                    "--scheduler-file",
                    str(info),
                ],
                env=env,
                stderr=subprocess.DEVNULL,
            )
        )
        deadline = time.monotonic() + CLUSTER_START_TIMEOUT_S
        while not info.exists() and time.monotonic() < deadline:
            time.sleep(0.2)
        address = json.loads(info.read_text())["address"]
        started.append(
            subprocess.Popen(
                [str(dask), "worker", address, "--nworkers", "1", "--nthreads", "1", "--no-dashboard"],
                env=env,
                stderr=subprocess.DEVNULL,
            )
        )
        from distributed import Client

        with Client(address, timeout=CLUSTER_START_TIMEOUT_S) as client:
            client.wait_for_workers(1, timeout=CLUSTER_START_TIMEOUT_S)
        outdir = tmp_path / "report"
        assert main(["diff", str(ANIMATED), "-o", str(outdir), "--frames", "1:24:23", "--scheduler", address]) == 0
        assert f"2 of 2 frames diffed on 1 Dask worker ({address})" in capsys.readouterr().out
        metrics = json.loads((outdir / "metrics.json").read_text())
        assert [(r["frame"], r["ok"]) for r in metrics["frames"]] == [(1, True), (24, True)]
        assert all(r["pid"] not in (os.getpid(), started[1].pid) for r in metrics["frames"])  # the worker's child
        page = (outdir / "index.html").read_text()
        for frame in ("frame.0001", "frame.0024"):
            assert f"src='{frame}/native.png'" in page and (outdir / frame / "index.html").is_file()
    finally:
        for process in reversed(started):
            process.send_signal(signal.SIGTERM)
        for process in reversed(started):
            try:
                process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()


@pytest.mark.povray
def test_diff_frames_exits_1_when_a_frame_fails_and_says_which(tmp_path, capsys):
    # Zero thresholds: the backends' half-float-level differences fail every pixel that differs.
    outdir = tmp_path / "report"
    rc = main(["diff", str(ANIMATED), "-o", str(outdir), "--frames", "24:24", "--fail", "0", "--fail-relative", "0"])
    assert rc == 1
    assert "frame 24: FAIL" in capsys.readouterr().out
    metrics = json.loads((outdir / "metrics.json").read_text())
    row = metrics["frames"][0]
    assert row["ok"] is False and row["failing_pixels"] > 0
    x, y = row["worst_pixel"]  # the worst pixel of the frame's own report
    frame_report = json.loads((outdir / "frame.0024" / "metrics.json").read_text())
    assert f"{row['max_error']:.6g} at ({x}, {y})" in (outdir / "index.html").read_text()
    assert frame_report["report"]["max_error"] == row["max_error"]
    assert [frame_report["report"]["worst"][k] for k in ("x", "y")] == [x, y]
    assert "fail: 24" in metrics["summary"] and "FAIL" in (outdir / "index.html").read_text()


def test_frames_carry_the_estimator_options(tmp_path):
    """--frames renders each frame with the same anti-aliasing options as a single --time render."""
    options = ["--width", "48", "--spp", "3", "--sample-pattern", "povray-am2", "--aa-threshold", "0.1"]
    assert main(["render", str(ANIMATED), "-o", str(tmp_path / "f.####.exr"), "--frames", "24:24", *options]) == 0
    assert main(["render", str(ANIMATED), "-o", str(tmp_path / "t.exr"), "--time", "24", *options]) == 0
    assert main(["render", str(ANIMATED), "-o", str(tmp_path / "plain.exr"), "--time", "24", "--width", "48"]) == 0
    framed, timed = read_image(tmp_path / "f.0024.exr"), read_image(tmp_path / "t.exr")
    np.testing.assert_array_equal(framed, timed)
    assert not np.array_equal(framed, read_image(tmp_path / "plain.exr"))  # the options did something


# A run's processes are found by a marker in their environment (POV-Ray, Dask's workers and the
# resource tracker inherit it); one still alive this long after the command ended is an orphan.
ORPHAN_GRACE_S = 5.0
# How long a frames run may take to start its cluster and write a first frame here (loaded
# 2-core machine), and to end after the signal.
FRAMES_WAIT_S = 120


def _marked(marker: str) -> list[int]:
    found = []
    for environ in Path("/proc").glob("[0-9]*/environ"):
        try:
            if marker.encode() in environ.read_bytes():
                found.append(int(environ.parent.name))
        except OSError:
            continue
    return found


@pytest.mark.dask
@pytest.mark.subprocess
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
def test_a_signal_to_the_group_during_frames_leaves_nothing_behind(tmp_path, signum):
    # As a terminal's Ctrl-C or hang-up does: every process of the group gets it, the workers too.
    tmp, out = tmp_path / "tmp", tmp_path / "out"
    tmp.mkdir()
    out.mkdir()
    marker = f"phongscene-test-{os.getpid()}-{signum}"
    proc = subprocess.Popen(
        [sys.executable, "-m", "phongscene", "render", str(ANIMATED), "-o", str(out / "f.####.png")]
        + ["--frames", "1:24", "--workers", "2", "--threads", "1", "--width", "64"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env=dict(os.environ, TMPDIR=str(tmp), PHONGSCENE_TEST_RUN=marker),
        start_new_session=True,
    )
    deadline = time.monotonic() + FRAMES_WAIT_S
    while not list(out.glob("f.*.png")) and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    assert proc.poll() is None, proc.communicate()[1]  # mid-run: frames written, the rest to come
    os.killpg(proc.pid, signum)
    _, err = proc.communicate(timeout=FRAMES_WAIT_S)
    line = "interrupted" if signum == signal.SIGINT else f"terminated by {signal.Signals(signum).name}"
    said = [l for l in err.splitlines() if not l.startswith("frames:")]  # the progress line
    assert (proc.returncode, said) == (128 + signum, [line]), err
    deadline = time.monotonic() + ORPHAN_GRACE_S
    while _marked(marker) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert _marked(marker) == []  # no worker, nanny or resource tracker outlives the command
    assert list(tmp.iterdir()) == []  # Dask's scratch space went with the cluster
    for frame in out.iterdir():  # the frames done are whole (written atomically), nothing else
        assert frame.name.startswith("f.") and read_image(frame).shape == (48, 64, 3), frame.name
