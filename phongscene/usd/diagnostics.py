# SPDX-License-Identifier: Apache-2.0
"""USD's own diagnostics as phongscene warnings. USD prints its warnings and unhandled errors
straight to file descriptor 2 ("Warning: in _ReportErrors at line 3326 of .../stage.cpp -- ...",
up to 548 lines for one corrupt file), and its Python bindings offer no hook to take them. So
while a stage is read, descriptor 2 goes to a temporary file; afterwards each diagnostic becomes
one warning ("USD: <message>", without USD's source location), repeated ones counted once, at
most ``MAX_USD_WARNINGS`` listed.

The redirection is process-wide: a thread writing to stderr meanwhile writes into the capture
(the CLI draws no progress while it reads)."""

from __future__ import annotations

import os
import re
import sys
import tempfile
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager

# Enough to see what went wrong; a corrupt file can produce hundreds of near-identical lines.
MAX_USD_WARNINGS = 10
# How USD's default diagnostic output starts each message (TfDiagnosticMgr).
_START = re.compile(r"^(Warning|Error|Coding Error|Runtime Error|Fatal Error|Status)\b.*?:")
_LOCATION = re.compile(r"^[A-Za-z ]+?:? in \S+ at line \d+ of \S+ -- ")
# Composition errors are reported by the reader itself (a warning per arc, naming the prim).
_ALREADY_REPORTED = ("in _ReportErrors at line",)


@contextmanager
def usd_output(texts: list[str]) -> Iterator[None]:
    """Capture what USD writes to descriptor 2 within the block; append the raw text to ``texts``
    (a stage opened once and read many times keeps what USD said while opening it, and each read
    turns that and its own output into warnings together, as one read of the file would)."""
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError):  # no stderr at all: nothing to capture or protect
        yield
        return
    with tempfile.TemporaryFile() as capture:
        os.dup2(capture.fileno(), 2)
        try:
            yield
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            capture.seek(0)
            texts.append(capture.read().decode("utf-8", "replace"))


def as_warnings(text: str) -> list[str]:
    """USD's diagnostic output → one warning per distinct message."""
    messages: list[str] = []
    for line in text.splitlines():
        if not line.strip():
            continue
        if _START.match(line) or not messages:
            messages.append(line.strip())
        else:
            messages[-1] += " " + line.strip()
    kept = [m for m in messages if not any(k in m for k in _ALREADY_REPORTED)]
    counts = Counter(_LOCATION.sub("", m) for m in kept)
    out = [f"USD: {m}" + (f" ({n} times)" if n > 1 else "") for m, n in list(counts.items())[:MAX_USD_WARNINGS]]
    if len(counts) > MAX_USD_WARNINGS:
        out.append(f"USD: {len(counts) - MAX_USD_WARNINGS} more distinct diagnostics not shown")
    return out
