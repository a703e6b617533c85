# SPDX-License-Identifier: Apache-2.0
"""Timing shared by the benchmark scripts."""

from __future__ import annotations

import time


def best_time(fn, repeat: int):
    """(the shortest wall time of ``repeat`` calls of ``fn``, the last call's result): the
    minimum is the least disturbed run on a shared, noisy machine."""
    best, result = float("inf"), None
    for _ in range(repeat):
        start = time.perf_counter()
        result = fn()
        best = min(best, time.perf_counter() - start)
    return best, result
