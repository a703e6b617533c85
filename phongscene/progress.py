# SPDX-License-Identifier: Apache-2.0
"""A one-line text progress bar for renders, shared by ``phongscene render`` and ``diff``."""

from __future__ import annotations

import sys
from typing import TextIO

BAR_WIDTH = 30  # characters between the brackets
LABEL_WIDTH = 7  # fits "povray" and "native", so the bars of a diff line up


class ProgressBar:
    """A one-line text progress bar on a stream (stderr). Accepts ``bar(fraction)`` or
    ``bar(done, total)``, whichever a backend reports; redraws only on a terminal, so logs
    get one line per render instead of a stream of carriage returns."""

    def __init__(self, label: str, stream: TextIO | None = None):
        self.label = label
        self.stream = sys.stderr if stream is None else stream
        self.interactive = bool(getattr(self.stream, "isatty", lambda: False)())
        self._shown = -1

    def __call__(self, *args) -> None:
        if len(args) >= 2:
            done, total = args[0], args[1]
            fraction = done / total if total else 1.0
        elif args:
            fraction = float(args[0])
        else:
            return
        if not self.interactive:
            return
        percent = int(100 * min(max(fraction, 0.0), 1.0))
        if percent != self._shown:
            self._shown = percent
            filled = BAR_WIDTH * percent // 100
            self.stream.write(f"\r{self.label:<{LABEL_WIDTH}} [{'#' * filled}{'.' * (BAR_WIDTH - filled)}] {percent:3d}%")
            self.stream.flush()

    def done(self, seconds: float) -> None:
        if self.interactive:
            end = f"\r{self.label:<{LABEL_WIDTH}} [{'#' * BAR_WIDTH}] done in {seconds:.2f} s"
        else:
            end = f"{self.label}: rendered in {seconds:.2f} s"
        self.stream.write(end + "\n")
        self.stream.flush()
