# SPDX-License-Identifier: Apache-2.0
"""A one-line text progress bar for renders, shared by ``phongscene render`` and ``diff``.

A progress callable takes ``(done, total)`` (``done`` may be fractional: POV-Ray reports pixels
within a pass) or a fraction. It may also have a ``phase(text)`` method, which the backends
call as they enter a step that reports no fraction (POV-Ray parsing the SDL, the native tracer
building its BVH): ``report_phase`` calls it when it is there, so a plain function still works.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

BAR_WIDTH = 30  # characters between the brackets
LABEL_WIDTH = 7  # fits "povray" and "native", so the bars of a diff line up
# A terminal line is redrawn at most this often when only the clock changed (elapsed, ETA), so a
# phase that reports no fraction still shows it is alive, without flooding a slow terminal.
REDRAW_SECONDS = 0.5
# An ETA from less than this fraction of the work is mostly start-up noise: show none yet.
ETA_MIN_FRACTION = 0.02


def report_phase(progress, text: str) -> None:
    """Tell ``progress`` (a progress callable, or None) that a phase without a fraction began."""
    phase = getattr(progress, "phase", None)
    if callable(phase):
        phase(text)


def format_seconds(seconds: float) -> str:
    """``42 s``, ``3 min 05 s``, ``1 h 02 min``: short, and stable in width within a unit."""
    s = max(0, int(round(seconds)))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {s % 3600 // 60:02d} min"


class ProgressBar:
    """A one-line text progress bar on a stream (stderr). Accepts ``bar(fraction)`` or
    ``bar(done, total)``, whichever a backend reports, and ``bar.phase(text)`` for steps without
    a fraction; shows the elapsed time and, once the fraction moves, an ETA. Redraws only on a
    terminal, so logs get one line per render instead of a stream of carriage returns."""

    def __init__(self, label: str, stream: TextIO | None = None, clock=time.monotonic):
        self.label = label
        self.stream = sys.stderr if stream is None else stream
        self.interactive = bool(getattr(self.stream, "isatty", lambda: False)())
        self._clock = clock
        self._start = clock()
        self._phase = ""
        self._fraction = 0.0
        self._rate_origin: tuple[float, float] | None = None  # (time, fraction) the ETA is measured from
        self._shown = ("", -1)
        self._shown_at = -float("inf")
        self._width = 0

    def __call__(self, *args) -> None:
        if len(args) >= 2:
            done, total = args[0], args[1]
            fraction = done / total if total else 1.0
        elif args:
            fraction = float(args[0])
        else:
            return
        fraction = min(max(fraction, 0.0), 1.0)
        now = self._clock()
        if self._rate_origin is None or fraction < self._fraction:
            self._rate_origin = (now, fraction)
        self._phase = ""  # a fraction again: the phase without one is over
        self._fraction = fraction
        self._draw(now)

    def phase(self, text: str) -> None:
        """A step that reports no fraction began (shown instead of the percentage); called
        again with the same text, it only lets the clock tick."""
        if text == self._phase:
            self._draw(self._clock())
            return
        self._phase = text
        # Time spent in it says nothing about the rate of the fraction: measure the ETA afresh.
        self._rate_origin = None
        self._draw(self._clock(), force=True)

    def line(self, now: float) -> str:
        """The text of the bar at time ``now`` (what a terminal shows)."""
        percent = int(100 * self._fraction)
        filled = BAR_WIDTH * percent // 100
        text = f"{self.label:<{LABEL_WIDTH}} [{'#' * filled}{'.' * (BAR_WIDTH - filled)}] "
        elapsed = format_seconds(now - self._start)
        if self._phase:
            return text + f"{self._phase}, {elapsed}"
        text += f"{percent:3d}%, {elapsed}"
        if self._rate_origin is not None:
            t0, f0 = self._rate_origin
            moved = self._fraction - f0
            if moved >= ETA_MIN_FRACTION and self._fraction < 1.0:
                text += f", ETA {format_seconds((now - t0) * (1.0 - self._fraction) / moved)}"
        return text

    def _draw(self, now: float, force: bool = False) -> None:
        if not self.interactive:
            return
        key = (self._phase, int(100 * self._fraction))
        if not force and key == self._shown and now - self._shown_at < REDRAW_SECONDS:
            return
        self._shown, self._shown_at = key, now
        self._write(self.line(now))

    def _write(self, text: str) -> None:
        # Pad to the previous line's width: a shorter line would leave its tail on screen.
        padded = text.ljust(self._width)
        self._width = len(text)
        self.stream.write("\r" + padded)
        self.stream.flush()

    def done(self, seconds: float, what: str = "rendered") -> None:
        if self.interactive:
            self._write(f"{self.label:<{LABEL_WIDTH}} [{'#' * BAR_WIDTH}] done in {seconds:.2f} s")
            self.stream.write("\n")
        else:
            self.stream.write(f"{self.label}: {what} in {seconds:.2f} s\n")
        self.stream.flush()
