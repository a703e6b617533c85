# SPDX-License-Identifier: Apache-2.0
"""One read path for every command (issue 27.1): a file USD might crash on or allocate without
bound reading (binary, or naming other files) is read in the sandboxed child by ``render``,
``info``, ``compile``, ``bench`` and ``load_usd`` as by ``validate``; a self-contained text layer,
or a file already read once in this process, is read in process."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from phongscene import scene_files
from phongscene.errors import SceneError
from phongscene.usd import load_usd
from support.paths import EXAMPLES, REPO

RUNAWAY = REPO / "tests" / "scenes" / "corrupt" / "runaway_allocation.usdc"
RUNAWAY_TIMEOUT_S = 120  # as tests/cli/test_sandbox.py: the child reaches its limit in seconds
TEXT = '#usda 1.0\n(\n    upAxis = "Y"\n)\n\ndef Sphere "s"\n{\n}\n'


def test_a_self_contained_text_layer_is_read_in_process(tmp_path):
    path = tmp_path / "a.usda"
    path.write_text(TEXT)
    assert scene_files.safe_in_process(path)


@pytest.mark.parametrize(
    ("name", "content"),
    [
        ("a.usdc", b"PXR-USDC" + bytes(64)),  # a crate file
        ("a.usdz", b"PK\x03\x04" + bytes(64)),  # an archive
        ("a.usda", TEXT.replace("def Sphere", 'def Xform "r" ( references = @other.usdc@ ) { }\ndef Sphere').encode()),
        ("a.usd", b"PXR-USDC" + bytes(64)),  # .usd may be either: the bytes decide
    ],
)
def test_a_binary_file_or_one_naming_another_goes_to_the_sandbox(tmp_path, name, content):
    path = tmp_path / name
    path.write_bytes(content)
    assert not scene_files.safe_in_process(path)


def test_a_file_read_once_is_read_in_process_until_it_changes(tmp_path):
    path = tmp_path / "a.usdc"
    path.write_bytes(b"PXR-USDC" + bytes(64))
    scene_files.remember_read(path)
    assert scene_files.safe_in_process(path)
    path.write_bytes(b"PXR-USDC" + bytes(65))  # another size: read again in the sandbox
    assert not scene_files.safe_in_process(path)


def test_a_valid_binary_file_reads_the_same_by_either_path(tmp_path):
    from pxr import Usd

    path = tmp_path / "seed.usdc"
    Usd.Stage.Open(str(EXAMPLES / "seed_exponents.usda")).Export(str(path))
    assert load_usd(path) == load_usd(path, sandbox=False)


@pytest.mark.slow
@pytest.mark.subprocess
def test_load_usd_of_a_runaway_file_is_a_scene_error():
    with pytest.raises(SceneError, match="sandboxed child process"):
        load_usd(RUNAWAY)


@pytest.mark.slow
@pytest.mark.subprocess
@pytest.mark.parametrize(
    "command",
    [
        ["render", "-o", "{tmp}/x.png", "--width", "8"],
        ["info"],
        ["compile", "-o", "{tmp}/x.pov"],
        ["bench", "-o", "{tmp}/bench", "--repeat", "1", "--native-only"],
    ],
)
def test_every_command_stops_a_runaway_file_with_one_line(tmp_path, command):
    argv = [a.format(tmp=tmp_path) for a in command]
    result = subprocess.run(
        [sys.executable, "-m", "phongscene", argv[0], str(RUNAWAY), *argv[1:]],
        capture_output=True,
        text=True,
        timeout=RUNAWAY_TIMEOUT_S,
        env={**os.environ, "PYTHONWARNINGS": "ignore"},
    )
    assert result.returncode == 2, result.stderr
    (line,) = result.stderr.splitlines()
    assert line.startswith(f"error: {RUNAWAY}: ") and "sandboxed child process" in line
    assert not list(tmp_path.iterdir())  # no partial output


LONG_MESSAGE = REPO / "tests" / "scenes" / "corrupt" / "long_usd_message.usdz"  # found by the campaign, seed 2


def test_a_corrupt_file_with_a_long_usd_message_is_one_short_line():
    from phongscene.usd.reader import MAX_USD_MESSAGE_CHARS

    with pytest.raises(SceneError) as info:
        load_usd(LONG_MESSAGE)
    (problem,) = info.value.problems
    assert "cannot read USD: Corrupt asset" in problem.message and "more characters)" in problem.message
    assert len(problem.message) <= MAX_USD_MESSAGE_CHARS + 100
