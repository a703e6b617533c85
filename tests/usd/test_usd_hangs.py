# SPDX-License-Identifier: Apache-2.0
"""Files that used to hang or crash the reader (issue 10, item 5): a FIFO named by a sublayer,
reference, payload or texture blocked USD forever; deep nesting was quadratic (ancestor walks,
path strings) and, at 30 000 levels, overflowed the C stack in USD's transform cache. Each runs
the CLI in a child process with a timeout, so a regression is a failed test, not a stuck or
crashed test run."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

# A FIFO is refused before USD opens anything: the whole command is interpreter start-up plus
# reading a few lines; far below this on a loaded 2-core machine, and far below "forever".
FIFO_TIMEOUT_S = 30
# 30 000 nested Xforms: ~2.5 s end to end on this machine (was > 60 s, then a segfault once the
# ancestor walks were gone). The bound leaves room for a loaded machine and fails a quadratic
# reader (which took 30 s for 10 000 levels).
NESTING_LEVELS = 30_000
NESTING_TIMEOUT_S = 25

pytestmark = pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs POSIX FIFOs")

SCENE_END = 'def Sphere "Ball" {\n}\n'
ARCS = {
    "subLayers": ("#usda 1.0\n(\n    subLayers = [@./pipe.usda@]\n)\n" + SCENE_END, "", "subLayers"),
    "references": ('#usda 1.0\ndef Xform "A" (references = @./pipe.usda@) {\n}\n' + SCENE_END, "/A", "references"),
    "payload_in_variant": (
        '#usda 1.0\ndef Xform "A" (\n    variants = { string v = "x" }\n    prepend variantSets = "v"\n) {\n'
        '    variantSet "v" = {\n        "x" (prepend payload = @./pipe.usda@) {\n        }\n    }\n}\n' + SCENE_END,
        "/A{v=x}",
        "payload",
    ),
    "dome_texture": (
        '#usda 1.0\ndef DomeLight "D" {\n    asset inputs:texture:file = @./pipe.usda@\n}\n' + SCENE_END,
        "/D",
        "inputs:texture:file",
    ),
}


def _cli(*args, timeout: float) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "phongscene", *args], capture_output=True, text=True, timeout=timeout)


@pytest.mark.subprocess
@pytest.mark.parametrize("arc", sorted(ARCS))
def test_a_fifo_named_by_the_scene_is_an_error_not_a_hang(tmp_path, arc):
    text, prim, attribute = ARCS[arc]
    os.mkfifo(tmp_path / "pipe.usda")
    scene = tmp_path / "scene.usda"
    scene.write_text(text)
    result = _cli("validate", str(scene), timeout=FIFO_TIMEOUT_S)
    assert result.returncode == 2, result.stderr
    (line,) = result.stderr.splitlines()
    assert "Traceback" not in result.stderr
    where = f"{prim}.{attribute}" if prim else attribute
    assert line.startswith(f"error: {scene}: {where}: ") and "is a FIFO" in line


@pytest.mark.subprocess
def test_a_fifo_two_layers_down_is_found(tmp_path):
    os.mkfifo(tmp_path / "pipe.usda")
    (tmp_path / "middle.usda").write_text('#usda 1.0\ndef Xform "M" (references = @./pipe.usda@) {\n}\n')
    scene = tmp_path / "scene.usda"
    scene.write_text("#usda 1.0\n(\n    subLayers = [@./middle.usda@]\n)\n" + SCENE_END)
    result = _cli("validate", str(scene), timeout=FIFO_TIMEOUT_S)
    assert result.returncode == 2
    assert f"{tmp_path / 'middle.usda'}: /M.references: " in result.stderr and "is a FIFO" in result.stderr


@pytest.mark.subprocess
def test_deep_nesting_reads_in_linear_time(tmp_path):
    path = tmp_path / "deep.usda"
    path.write_text(
        "#usda 1.0\n"
        + "".join(f'def Xform "x{i}" {{\n' for i in range(NESTING_LEVELS))
        + 'def Sphere "Ball" {\n}\n'
        + "}\n" * NESTING_LEVELS
    )
    result = _cli("validate", "-q", str(path), timeout=NESTING_TIMEOUT_S)
    assert result.returncode == 0, result.stderr[-500:]
    assert result.stdout.strip() == f"ok: {path}"


# A layer that runs at 0 (or a negative number of) time codes per second: usd-core's time-sample
# queries on an attribute animated in a sublayer never returned (usd-wg's
# timeCodesPerSecond_0.usda: `info` ran > 60 s at full CPU). Refused before USD composes, so the
# command is start-up plus parsing two tiny layers.
TIME_RATE_TIMEOUT_S = 30
ANIMATED_SUBLAYER = '#usda 1.0\ndef Cube "Box" {\n    double3 xformOp:translate.timeSamples = { 0: (0, 0, 0), 100: (10, 0, 0) }\n    uniform token[] xformOpOrder = ["xformOp:translate"]\n}\n'


@pytest.mark.subprocess
@pytest.mark.parametrize(
    ("field", "value", "suffix"),
    # USD's text parser refuses framesPerSecond <= 0 itself; a crate file carries it.
    [("timeCodesPerSecond", 0.0, ".usda"), ("timeCodesPerSecond", -1.0, ".usda"), ("framesPerSecond", 0.0, ".usdc")],
)
@pytest.mark.parametrize("command", ["info", "render"])
def test_a_layer_at_no_time_codes_per_second_is_an_error_not_a_hang(tmp_path, field, value, suffix, command):
    from pxr import Sdf

    (tmp_path / "anim.usda").write_text(ANIMATED_SUBLAYER)
    scene = tmp_path / f"scene{suffix}"
    layer = Sdf.Layer.CreateNew(str(scene))
    layer.startTimeCode, layer.endTimeCode = 0.0, 100.0
    layer.subLayerPaths.append("./anim.usda")
    setattr(layer, field, value)
    layer.Save()
    args = ["-o", str(tmp_path / "out.exr"), "--width", "8"] if command == "render" else []
    result = _cli(command, str(scene), *args, timeout=TIME_RATE_TIMEOUT_S)
    assert result.returncode == 2, result.stderr
    (line,) = [l for l in result.stderr.splitlines() if l.startswith("error: ")]
    assert line.startswith(f"error: {scene}: {field}: must be a positive, finite number"), line
    assert not (tmp_path / "out.exr").exists()
