# SPDX-License-Identifier: Apache-2.0
"""Untrusted files are read in a child process (issue 10, item 6): a corrupt file that makes USD
allocate without bound, or crash, is one error naming the file, and the command that read it
lives on; a valid file reads the same in the sandbox as in process."""

from __future__ import annotations

import subprocess
import sys

import pytest

from support.paths import EXAMPLES, REPO
from phongscene.errors import SceneError
from phongscene.sandbox import read_usd_sandboxed
from phongscene.usd import read_usd

# A .usdc the file fuzzer made from an example (a few bytes changed): USD grows to 10 GB resident
# in 20 s reading it (and on, until the machine runs out). The sandbox stops it at its limit.
RUNAWAY = REPO / "tests" / "scenes" / "corrupt" / "runaway_allocation.usdc"
# The sandbox's limit for that 3.7 kB file is ~2 GiB: reached in a few seconds; generous for a
# loaded 2-core machine.
RUNAWAY_TIMEOUT_S = 120


def test_a_valid_file_reads_the_same_sandboxed():
    path = EXAMPLES / "seed_exponents.usda"
    inside, sandboxed = read_usd(path), read_usd_sandboxed(path)
    assert sandboxed.scene == inside.scene
    assert sandboxed.warnings == inside.warnings and sandboxed.nodes == inside.nodes


def test_an_invalid_file_gives_the_same_problems_sandboxed():
    path = REPO / "tests" / "scenes" / "invalid" / "nan_kd.usda"
    with pytest.raises(SceneError) as inside:
        read_usd(path)
    with pytest.raises(SceneError) as sandboxed:
        read_usd_sandboxed(path)
    assert sandboxed.value.problems == inside.value.problems


def test_a_memory_limit_too_small_for_the_file_is_a_clear_error():
    path = EXAMPLES / "seed_exponents.usda"
    # 64 MiB: less than python and pxr need to start, so the read cannot succeed.
    with pytest.raises(SceneError) as info:
        read_usd_sandboxed(path, memory_limit=64 << 20)
    (problem,) = info.value.problems
    assert problem.file == str(path)
    assert "needs more than the sandbox's memory limit (0.1 GiB)" in problem.message


@pytest.mark.subprocess
def test_a_runaway_allocation_is_stopped_and_named():
    result = subprocess.run([sys.executable, "-m", "phongscene", "validate", str(RUNAWAY)], capture_output=True,
                            text=True, timeout=RUNAWAY_TIMEOUT_S)
    assert result.returncode == 2
    (line,) = result.stderr.splitlines()
    assert line.startswith(f"error: {RUNAWAY}: ") and "sandboxed child process" in line
