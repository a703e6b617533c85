# SPDX-License-Identifier: Apache-2.0
"""Progress: POV-Ray's console output parsed as a pure function, the bar's phases, elapsed time
and ETA, and end to end on a pseudo-terminal (the bar is drawn only on a terminal)."""

from __future__ import annotations

import io
import os
import pty
import random
import re
import subprocess
import sys
from pathlib import Path

import pytest

from phongscene.backends.povray.run import PovLogParser, _tail
from phongscene.progress import ProgressBar, format_seconds
from support.paths import REPO

EXAMPLES = REPO / "examples"
PHONGSCENE = Path(sys.executable).with_name("phongscene")

# What POV-Ray 3.7.0.10 printed for a two-frame run (+V -GR), abridged (docs ref §17): the
# first frame's line twice, a "Rendered" count stepping back by a block, a banner out of order.
TWO_FRAMES = (
    "Persistence of Vision(tm) Ray Tracer Version 3.7.0.10.unofficial\n"
    "Rendering frame 1 of 2\n\nRendering frame 1 of 2\n\n"
    "Parser Options\n  Input file: scene.pov\n"
    "==== [Parsing...] ==========================================================\n"
    "Rendered 1024 of 4096 pixels (25%)\rRendered 3072 of 4096 pixels (75%)\r"
    "==== [Rendering...] ========================================================\n"
    "Rendered 2048 of 4096 pixels (50%)\rRendered 4096 of 4096 pixels (100%)\r\n"
    "Rendering frame 2 of 2\n\n"
    "==== [Parsing...] ==========================================================\n"
    "Rendered 1024 of 4096 pixels (25%)\r"
)


class _FakeTerminal(io.StringIO):
    def isatty(self) -> bool:
        return True


class _Clock:
    def __init__(self):
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def _states(text: str, chunk_sizes) -> list[tuple]:
    parser = PovLogParser()
    out, i = [], 0
    for n in chunk_sizes:
        p = parser.feed(text[i : i + n])
        out.append((p.frame, p.pixels_done, p.pixels_total, p.parsing))
        i += n
    return out


def test_povray_log_parser_follows_frames_pixels_and_parsing():
    parser = PovLogParser()
    head, tail = TWO_FRAMES.split("==== [Rendering")
    p = parser.feed(head.split("Rendered")[0])
    assert (p.frame, p.parsing, p.fraction(2)) == (1, True, 0.0)
    p = parser.feed(head[len(head.split("Rendered")[0]) :])
    assert (p.frame, p.pixels_done, p.pixels_total, p.parsing) == (1, 3072, 4096, False)
    p = parser.feed("==== [Rendering" + tail)
    # Frame 2 has begun: frame 1 is done, and 1024 of frame 2's 4096 pixels.
    assert (p.frame, p.pixels_done, p.pixels_total) == (2, 1024, 4096)
    assert p.fraction(2) == pytest.approx((1 + 0.25) / 2)


def test_povray_log_parser_keeps_the_largest_count_when_threads_print_out_of_order():
    p = PovLogParser().feed("Rendered 3072 of 4096 pixels (75%)\rRendered 2048 of 4096 pixels (50%)\r")
    assert p.pixels_done == 3072
    # A single-frame run prints no "Rendering frame" line: its pixels are frame 1's.
    assert p.frame == 1 and p.fraction(1) == 0.75


def test_povray_log_parser_gives_the_same_answer_however_the_output_is_chunked():
    whole = _states(TWO_FRAMES, [len(TWO_FRAMES)])[-1]
    rng = random.Random(5)
    for _ in range(50):
        sizes, left = [], len(TWO_FRAMES)
        while left:
            sizes.append(min(left, rng.randint(1, 40)))
            left -= sizes[-1]
        assert _states(TWO_FRAMES, sizes)[-1] == whole
    # A line cut in the middle is not read until it ends: "Rendered 1" must not count as 1 pixel.
    assert _states("Rendered 1", [10]) == [(0, 0, 0, False)]


def test_error_tail_leaves_out_the_progress_lines(tmp_path):
    log = tmp_path / "scene.log"
    log.write_text(TWO_FRAMES + "File 'scene.pov' line 2: Parse Error: oops\nRender failed\n", encoding="utf-8")
    tail = _tail(log)
    assert "Parse Error" in tail and "Rendered" not in tail


def test_bar_shows_phases_elapsed_time_and_an_eta():
    clock, tty = _Clock(), _FakeTerminal()
    bar = ProgressBar("povray", tty, clock=clock)
    clock.now = 3.0
    bar.phase("parsing")
    assert tty.getvalue().endswith("parsing, 3 s")
    clock.now = 5.0
    bar(0.0)  # the fraction moves from here: the ETA is measured from t = 5 s
    clock.now = 15.0
    bar(1, 4)  # 25 % in 10 s: 30 s to go
    assert bar.line(clock.now).endswith(" 25%, 15 s, ETA 30 s")
    assert tty.getvalue().endswith(" 25%, 15 s, ETA 30 s")
    # Too little done for an honest ETA: none is shown.
    bar2 = ProgressBar("native", _FakeTerminal(), clock=clock)
    bar2(0.0)
    clock.now = 16.0
    bar2(0.01)
    assert "ETA" not in bar2.line(clock.now)


def test_bar_pads_a_shorter_line_over_a_longer_one():
    tty = _FakeTerminal()
    bar = ProgressBar("native", tty)
    bar.phase("building the BVH (1000000 triangles)")
    bar(1, 2)
    last = tty.getvalue().split("\r")[-1]
    first = tty.getvalue().split("\r")[1]
    assert len(last) >= len(first)  # no tail of the phase text left on screen


def test_bar_writes_nothing_but_the_result_line_to_a_log():
    log = io.StringIO()
    bar = ProgressBar("povray", log)
    bar.phase("parsing")
    bar(1, 2)
    bar.done(1.25)
    assert log.getvalue() == "povray: rendered in 1.25 s\n"


def test_format_seconds():
    assert [format_seconds(s) for s in (0.4, 42, 185, 3720)] == ["0 s", "42 s", "3 min 05 s", "1 h 02 min"]


def _on_a_terminal(args: list[str]) -> tuple[int, str]:
    """Run the phongscene command with stderr (and stdout) on a pseudo-terminal; its output."""
    master, slave = pty.openpty()
    proc = subprocess.Popen([str(PHONGSCENE), *args], stdin=subprocess.DEVNULL, stdout=slave, stderr=slave)
    os.close(slave)
    chunks = []
    while True:
        try:
            data = os.read(master, 65536)
        except OSError:  # EIO: the child closed the terminal
            break
        if not data:
            break
        chunks.append(data)
    os.close(master)
    return proc.wait(), b"".join(chunks).decode("utf-8", "replace")


@pytest.mark.subprocess
@pytest.mark.povray
def test_povray_progress_on_a_terminal_moves_between_0_and_100(tmp_path):
    # 1600 x 1200 renders for ~1 s after ~0.5 s of start-up; POV-Ray prints its count every
    # ~0.2 s (measured, ref §17), so at least one redraw lies strictly between 0 and 100 %.
    rc, text = _on_a_terminal(
        [
            "render",
            str(EXAMPLES / "seed_exponents.usda"),
            "-o",
            str(tmp_path / "x.exr"),
            "--backend",
            "povray",
            "--width",
            "1600",
        ]
    )
    assert rc == 0, text
    frames = text.split("\r")
    assert any("reading seed_exponents.usda" in f for f in frames)
    # (POV-Ray's "parsing" is unit-tested above: a small scene parses within one burst of output.)
    assert any("compiling the SDL" in f for f in frames)
    percents = {int(m.group(1)) for f in frames if (m := re.search(r"\]\s+(\d+)%", f))}
    assert any(0 < p < 100 for p in percents), percents
    assert "done in" in text


@pytest.mark.subprocess
def test_native_progress_on_a_terminal_names_its_phases(tmp_path):
    rc, text = _on_a_terminal(
        ["render", str(EXAMPLES / "seed_lobe.usda"), "-o", str(tmp_path / "x.png"), "--width", "64"]
    )
    assert rc == 0, text
    frames = text.split("\r")
    assert any("reading seed_lobe.usda" in f for f in frames)
    assert any("building the BVH" in f for f in frames)
    assert "done in" in text
