# SPDX-License-Identifier: Apache-2.0
"""Giving the heap memory this process has freed back to the system.

glibc's malloc keeps freed memory resident: it returns only the top of its heap, and only past
M_TRIM_THRESHOLD (which glibc raises as large blocks are freed), so the temporaries of
reading a big USD file stay in the process's resident memory after they are freed (S2: ~60 MiB,
benchmarks/README.md). ``malloc_trim(0)`` hands every free page back. The CLI calls it where a
large amount has just been freed; elsewhere (musl, macOS) there is nothing to call."""

from __future__ import annotations

import ctypes
import functools


@functools.cache
def _malloc_trim():
    """glibc's malloc_trim, or None where the C library has none."""
    return getattr(ctypes.CDLL(None), "malloc_trim", None)


def release_free_heap() -> bool:
    """Return the free pages of the C heap to the system (glibc's ``malloc_trim(0)``): True if
    some were returned, False if none or where the C library cannot."""
    trim = _malloc_trim()
    return bool(trim(0)) if trim is not None else False
