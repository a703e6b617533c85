# SPDX-License-Identifier: Apache-2.0
"""release_free_heap (phongscene/memory.py) hands freed heap pages back to the system."""

from __future__ import annotations

import ctypes
import sys

import numpy as np
import pytest

from phongscene.memory import release_free_heap

# Blocks below glibc's mmap threshold (128 KiB at start) come from the heap; 16 KiB ones, freed
# all but the last, leave ~64 MiB of free heap under a live block, which glibc's automatic trim
# (top of the heap only) cannot return.
BLOCK_BYTES = 16 * 1024
BLOCKS = 4096
# At least half of the freed heap must leave the resident set (pages partly used by other
# allocations, and malloc's own bookkeeping, may stay).
RETURNED_FRACTION = 0.5


def resident_bytes() -> int:
    with open("/proc/self/statm", encoding="ascii") as statm:
        return int(statm.read().split()[1]) * 4096


glibc = sys.platform == "linux" and hasattr(ctypes.CDLL(None), "malloc_trim")


@pytest.mark.skipif(not glibc, reason="malloc_trim is glibc's")
def test_freed_heap_memory_leaves_the_resident_set():
    release_free_heap()
    blocks = [np.ones(BLOCK_BYTES, np.uint8) for _ in range(BLOCKS)]  # written: resident
    last = blocks.pop()
    del blocks
    before = resident_bytes()
    assert release_free_heap()
    assert before - resident_bytes() >= RETURNED_FRACTION * BLOCK_BYTES * (BLOCKS - 1)
    assert last.sum() == BLOCK_BYTES  # the live block is untouched
