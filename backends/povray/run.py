# SPDX-License-Identifier: Apache-2.0
"""Run POV-Ray 3.7 on compiled scenes and read the images back (ref §1, §8, §11).

Every render runs in a fresh temporary directory (the working directory of the process) with
``HOME`` pointed at a ``.povray/3.7/povray.conf`` there that forbids shell commands and asks for
file I/O restricted to that directory (which this POV-Ray build does not enforce for ``#fopen``:
docs/security.md); ``POVINI`` is unset so no user ini file adds options; POV-Ray is started
without a shell, with generated file names only. Switches: ``+FE`` (half-float
EXR, linear), ``-D -V -GD -GR -GS +Q9 -J``, and ``-A`` or ``+AM1 +A0.0 +R n`` for anti-aliasing.
"grid" anti-aliasing renders at n× the resolution with ``-A`` and box-averages n×n blocks
(exact, ref §8). POV-Ray's start-up costs ~0.7 s per process, so all render passes, and in
``render_many`` several scenes, are animation frames of ONE process. The passes are added up as
POV-Ray writes them (``PassSums``), and each frame file is removed once added: memory is one
float64 image per scene plus the frame being added, and disk two frames, whatever the light count
(512², 32 lights: 557 -> 80 MiB peak, ``benchmarks/povray_passes.py``). So no bound on lights or
passes is needed for memory; the time is linear in them (each pass is a frame, parsed again).

POV-Ray facts cite ``docs/povray-3.7-semantics.md`` as "ref §n".
"""

from __future__ import annotations

import io
import os
import re
import shutil
import signal
import subprocess
import tempfile
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import TextIO

import numpy as np

from phongscene.errors import BackendError, PhongSceneError, Problem, SceneError
from phongscene.held_signals import held_signals
from phongscene.images import read_image, write_image
from phongscene.scene import POVRAY_SAMPLE_PATTERNS, RenderSettings, Scene

from .compile import PovImage, pass_count, resolve_mapping, texture_files, write_body, write_pov

# The largest value of POV-Ray's half-float EXR output; brighter pixels are written as inf.
HALF_MAX = 65504.0

POVRAY = "povray"
INSTALL_HINT = "POV-Ray 3.7 is not installed ('povray' is not on PATH); install it with: apt-get install povray"
# The user configuration POV-Ray reads from $HOME: file I/O only where the system configuration
# allows it (its own include and /tmp paths, and the working directory), no shell-outs.
POVRAY_CONF = "[File I/O Security]\nrestricted\n[Shellout Security]\nforbidden\n[Permitted Paths]\nread+write = .\n"
OUTPUT_TAIL_LINES = 25  # lines of POV-Ray's output quoted in an error
# Held back while POV-Ray starts (see _run_in): Ctrl-C, and what phongscene's CLI turns into exceptions.
HELD_SIGNALS = {signal.SIGINT, signal.SIGTERM, signal.SIGHUP}
POLL_SECONDS = 0.05  # how often a running render is checked for finished frames and the timeout


@dataclass(frozen=True, slots=True)
class PovJob:
    """One POV-Ray invocation: the SDL, its frames, and the switches to render it.

    The SDL is compiled as it is written (``write_sdl``, ``save_sdl``), never held whole: a scene
    with millions of triangles has gigabytes of it. A compile error (``SceneError``) is therefore
    raised when it is written."""

    write_sdl: Callable[[TextIO], None]  # writes the SDL to a text stream
    frames: int  # animation frames (render passes) in the SDL
    width: int  # POV-Ray image size: the output size times ``supersample``
    height: int
    supersample: int  # "grid" anti-aliasing: average supersample² blocks (1 = none)
    switches: tuple[str, ...]  # everything except input, output and frames
    # The image files the SDL reads, by file name: written beside it (write_textures).
    textures: tuple[tuple[str, PovImage], ...] = ()

    @property
    def sdl(self) -> str:
        """The SDL as one string (small scenes, tests)."""
        out = io.StringIO()
        self.write_sdl(out)
        return out.getvalue()

    def save_sdl(self, path: str | os.PathLike) -> None:
        """Write the SDL to ``path`` (not atomically: write to a temporary file, as ``_run_in``
        and the CLI do)."""
        with open(path, "w", encoding="ascii") as out:
            self.write_sdl(out)

    def write_textures(self, directory: str | os.PathLike) -> list[Path]:
        """Write each image the SDL reads beside it as the half-float EXR it names (atomically),
        one image's pixels at a time."""
        return [write_image(Path(directory) / name, image.pixels(), half=True) for name, image in self.textures]

    def frame_switches(self) -> tuple[str, ...]:
        return ("+KFI0", f"+KFF{self.frames - 1}") if self.frames > 1 else ()

    def command(self, pov: str, output: str) -> list[str]:
        """The ``povray`` command line for ``pov`` writing ``output`` (frames get numbered)."""
        return [POVRAY, f"+I{pov}", f"+O{output}", *self.switches, *self.frame_switches()]

    def ini(self, pov: str, output: str) -> str:
        """An ``.ini`` file with the same options (``povray NAME.ini`` in its directory)."""
        lines = [
            "; phongscene: POV-Ray 3.7 options for this scene (run: povray <this file>)",
            f"Input_File_Name={pov_quoted(pov)}",  # checked: a name cannot add a line
            f"Output_File_Name={pov_quoted(output)}",
            *self.switches,
            *self.frame_switches(),
        ]
        if self.frames > 1:
            lines.insert(1, f"; {self.frames} frames, one per light: add the linear frame images to get the picture")
        if self.supersample > 1:
            lines.insert(
                1, f"; rendered {self.supersample}x larger: average {self.supersample}x{self.supersample} blocks"
            )
        return "\n".join(lines) + "\n"


# POV-Ray 3.7.0.10 reads a file name with these characters only inside double quotes: on the
# command line (``+Ix;y.pov`` fails) or in an .ini (``Input_File_Name=x,y.pov`` fails; ``;`` starts
# a comment there), measured one character at a time. Quoted, every printable ASCII character but
# the quote and the backslash works in both; nothing outside printable ASCII does.
NEEDS_QUOTES = frozenset("#',;= ")
CANNOT_QUOTE = frozenset('"\\')


def pov_quoted(name: str) -> str:
    """A file name as POV-Ray's command line and .ini read it: itself, or in double quotes when
    it has a character POV-Ray reads only quoted (white space, ``# ' , ; =``).

    Raises:
        PhongSceneError: a name POV-Ray cannot read, or that would inject options: a control
            character (a newline would start a new ``.ini`` line, e.g. ``Pre_Scene_Command=``),
            a double quote or backslash, or a character outside printable ASCII.
    """
    bad = next((c for c in name if not " " <= c <= "~" or c in CANNOT_QUOTE), None)
    if bad is not None:
        raise PhongSceneError(
            f"{name!r}: POV-Ray cannot read a file name with {bad!r} (printable ASCII only, no double quote or "
            "backslash): choose another name"
        )
    return f'"{name}"' if any(c in NEEDS_QUOTES for c in name) else name


def aa_threshold(value: float) -> str:
    """POV-Ray's +A value: the shortest decimal that reads back as the same float32 (POV-Ray holds
    it as a float), e.g. 0.03; 0 prints as 0.0."""
    return np.format_float_positional(np.float32(value), trim="0")


def render_switches(settings: RenderSettings, source_file: str = "") -> tuple[int, int, int, tuple[str, ...]]:
    """(width, height, supersample, switches) POV-Ray needs for ``settings`` (a SceneError naming
    ``source_file`` for a pattern POV-Ray does not have)."""
    if settings.sample_pattern not in POVRAY_SAMPLE_PATTERNS:
        raise SceneError(
            Problem(
                f"{settings.sample_pattern!r} is the native tracer's own; POV-Ray renders {', '.join(POVRAY_SAMPLE_PATTERNS)}",
                settings.source,
                "sample_pattern",
                source_file,
                node="RenderSettings",
            )
        )
    n = int(settings.samples)
    k = n if n > 1 and settings.sample_pattern == "grid" else 1
    width, height = settings.width * k, settings.height * k
    # -GD -GR -GS silence the debug, render and statistics streams but keep the fatal and
    # warning streams: they carry "File 'x.pov' line N: Parse Error: ..." for error reports.
    # +V keeps the "Rendered N of M pixels" lines (ref §17) the progress bar is drawn from.
    switches = ["+FE", f"+W{width}", f"+H{height}", "-D", "+V", "-GD", "-GR", "-GS", "+Q9", "-J"]
    if n > 1 and settings.sample_pattern == "povray-am1" or settings.sample_pattern == "povray-am2":
        method = "+AM1" if settings.sample_pattern == "povray-am1" else "+AM2"
        switches += [method, f"+A{aa_threshold(settings.aa_threshold)}", f"+R{n}"]
    else:
        switches.append("-A")
    if settings.threads > 0:
        switches.append(f"+WT{int(settings.threads)}")
    return width, height, k, tuple(switches)


def prepare(scene: Scene, settings: RenderSettings | None = None, mapping: str | None = None) -> PovJob:
    """Compile ``scene`` and work out how POV-Ray must render it (what the CLI prints)."""
    settings = scene.settings if settings is None else settings
    mapping = resolve_mapping(settings, mapping)
    width, height, k, switches = render_switches(settings, scene.source_file)
    textures = tuple(texture_files(scene).items())
    return PovJob(
        partial(write_pov, scene=scene, settings=settings, mapping=mapping),
        pass_count(scene, mapping),
        width,
        height,
        k,
        switches,
        textures,
    )


def render(
    scene: Scene,
    settings: RenderSettings | None = None,
    *,
    mapping: str | None = None,
    progress: Callable[[int, int], None] | None = None,
    timeout: float | None = None,
    keep_dir: str | None = None,
) -> np.ndarray:
    """Render ``scene`` with POV-Ray.

    Args:
        scene: the scene (validated on compilation).
        settings: render settings; default ``scene.settings``.
        mapping: "exact" or "classic"; default from ``settings.specular``.
        progress: called with (passes done, passes) as POV-Ray renders (passes done is
            fractional: the pixels of the current pass, from its "Rendered N of M pixels"
            lines); its ``phase(text)`` method, if it has one, while POV-Ray parses.
        timeout: seconds before POV-Ray is stopped and a ``BackendError`` raised.
        keep_dir: render in this directory and keep the .pov, .ini and EXR files there.

    Returns:
        Linear float32 image (H, W, 3), row 0 at the top.

    Raises:
        BackendError: POV-Ray is missing, fails or times out (the .pov is kept and named).
        SceneError: the scene is invalid.
    """
    return render_many([(scene, settings, mapping)], progress=progress, timeout=timeout, keep_dir=keep_dir)[0]


def render_many(
    items: Sequence[tuple[Scene, RenderSettings | None, str | None]],
    *,
    progress: Callable[[int, int], None] | None = None,
    timeout: float | None = None,
    keep_dir: str | None = None,
) -> list[np.ndarray]:
    """Render several (scene, settings, mapping) triples, as frames of as few POV-Ray processes
    as possible (one per distinct image size and anti-aliasing switches). Arguments as in
    ``render``; ``timeout`` applies to each process. Returns one image per item, in order."""
    if shutil.which(POVRAY) is None:
        raise BackendError(INSTALL_HINT)
    jobs = []
    for scene, settings, mapping in items:
        settings = scene.settings if settings is None else settings
        mapping = resolve_mapping(settings, mapping)
        jobs.append((scene, settings, mapping, render_switches(settings, scene.source_file)))
    groups: dict[tuple, list[int]] = {}
    for i, job in enumerate(jobs):
        groups.setdefault(job[3], []).append(i)
    total = sum(pass_count(job[0], job[2]) for job in jobs)
    done = 0
    if progress:
        progress(0, total)
    images: list[np.ndarray | None] = [None] * len(jobs)
    # A progress callable may have a phase(text) method (phongscene.progress.report_phase).
    phase = getattr(progress, "phase", None) if progress else None
    phase = phase if callable(phase) else None
    for g, ((width, height, k, switches), members) in enumerate(groups.items()):
        if phase is not None:
            phase("compiling the SDL")  # a million triangles take ~1 s
        if len(members) == 1:
            scene, settings, mapping, _ = jobs[members[0]]
            sdl = partial(write_pov, scene=scene, settings=settings, mapping=mapping)
        else:
            sdl = partial(_write_batch, items=[jobs[i][:3] for i in members])
        passes = [pass_count(jobs[i][0], jobs[i][2]) for i in members]
        textures: dict = {}
        for i in members:
            textures.update(texture_files(jobs[i][0]))
        job = PovJob(sdl, sum(passes), width, height, k, switches, tuple(textures.items()))

        def frame_done(frames: float, base: int = done) -> None:
            if progress:
                progress(base + frames, total)

        sums = _run(
            job, f"group{g}-" if len(groups) > 1 else "scene", timeout, keep_dir, frame_done, phase, PassSums(passes)
        )
        done += job.frames
        for i, image in zip(members, sums):
            if k > 1:
                h, w = image.shape[0] // k, image.shape[1] // k
                image = image.reshape(h, k, w, k, 3).mean(axis=(1, 3))
            images[i] = np.ascontiguousarray(image, dtype=np.float32)
    return images  # type: ignore[return-value]


def _write_batch(out: TextIO, items: list[tuple[Scene, RenderSettings, str]]) -> None:
    """Several scenes in one file: scene i owns a range of frames, and its own passes count
    from 0 within it (the identifier ``Pass`` of ``write_body``)."""
    out.write(
        f"// phongscene: {len(items)} scenes as frames of one POV-Ray run\n#version 3.7;\n#switch (frame_number)\n"
    )
    first = 0
    for scene, settings, mapping in items:
        last = first + pass_count(scene, mapping) - 1
        out.write(f"#range ({first}, {last})\n#declare Pass = frame_number - {first};\n")
        write_body(out, scene, settings, mapping)
        out.write("#break\n")
        first = last + 1
    out.write("#end\n")


class PassSums:
    """The images of a POV-Ray run's frames added up as they arrive, one sum per consecutive
    range of frames (a scene's passes; several scenes share one run in ``render_many``): direct
    light is linear in the lights, so the passes add up (in float64: exact for half-float frames).
    Memory is one float64 image per scene and the frame being added, whatever the light count;
    frames are added in order, so the sums are those of adding the whole list at once."""

    def __init__(self, counts: Sequence[int]):
        self.owner = [i for i, n in enumerate(counts) for _ in range(n)]  # frame -> its range
        self.sums: list[np.ndarray | None] = [None] * len(counts)
        self.added = 0  # frames added so far (in order)

    def add(self, image: np.ndarray) -> None:
        i = self.owner[self.added]
        if self.sums[i] is None:
            self.sums[i] = image.astype(np.float64)
        else:
            self.sums[i] += image
        self.added += 1

    def __len__(self) -> int:
        return len(self.owner)


def _run(
    job: PovJob,
    stem: str,
    timeout: float | None,
    keep_dir: str | None,
    frame_done,
    phase=None,
    sums: PassSums | None = None,
) -> list[np.ndarray]:
    """Run one POV-Ray process for ``job``, adding its frames into ``sums`` as they arrive (each
    frame file is removed once added, unless ``keep_dir``); return the sums (float64). The
    temporary directory is removed afterwards, except after a ``BackendError`` (it holds the kept
    .pov). ``frame_done(frames)`` gets the frames done (fractional: pixels of the current one);
    ``phase(text)``, when given, is told while POV-Ray parses. Without ``sums``, each frame is its
    own sum (the frames are returned, as float64)."""
    sums = PassSums([1] * job.frames) if sums is None else sums
    workdir = Path(keep_dir) if keep_dir else None
    try:
        if workdir is None:
            # Made and known to the cleanup below before a signal is acted on (held_signals).
            with held_signals():
                workdir = Path(tempfile.mkdtemp(prefix="phongscene-povray-"))
        images = _run_in(job, workdir, stem, timeout, frame_done, phase, sums, keep=bool(keep_dir))
    except BackendError:
        raise
    except BaseException:  # Ctrl-C, a signal, a full disk, ...: nothing worth keeping
        if not keep_dir and workdir is not None:
            with held_signals():
                shutil.rmtree(workdir, ignore_errors=True)
        raise
    if not keep_dir:
        with held_signals():  # whole: a signal now is acted on once the folder is gone
            shutil.rmtree(workdir, ignore_errors=True)
    return images


def _run_in(
    job: PovJob, workdir: Path, stem: str, timeout: float | None, frame_done, phase, sums: PassSums, keep: bool
) -> list[np.ndarray]:
    workdir.mkdir(parents=True, exist_ok=True)
    pov, output, log = workdir / f"{stem}.pov", workdir / f"{stem}.exr", workdir / f"{stem}.log"
    try:
        try:
            job.save_sdl(pov)
        except BaseException:  # a compile error half way: no half-written .pov kept
            pov.unlink(missing_ok=True)
            raise
        job.write_textures(workdir)
        (workdir / f"{stem}.ini").write_text(job.ini(pov.name, output.name), encoding="ascii")
    except OSError as e:  # a full disk: say where (Python's write error names no file)
        raise BackendError(f"cannot write the POV-Ray scene into {workdir}: {e.strerror or e}") from None
    env = povray_environment(workdir)
    for old in _frame_files(workdir, stem):
        old.unlink()

    def fail(message: str) -> BackendError:
        return BackendError(message, detail=_tail(log), kept=str(pov))

    def add_finished(running: bool) -> None:
        """Add the frames POV-Ray has finished: while it runs, those before the last file it
        has started (frames are rendered in order, each file written whole before the next)."""
        files = _frame_files(workdir, stem)
        if keep:  # the frames added so far are still there
            files = files[sums.added :]
        if running:
            files = files[:-1]
        for f in files[: len(sums) - sums.added]:
            try:
                image = read_image(f)
            except PhongSceneError as e:
                raise fail(f"cannot read POV-Ray's output: {e}") from None
            _check_frame(image, f.name, job, fail)
            sums.add(image)
            if not keep:
                f.unlink()

    with open(log, "wb") as log_file:
        # Signals whose handlers raise (Ctrl-C; SIGTERM, SIGHUP in the CLI) are held back while
        # POV-Ray starts: one handled inside Popen, after the fork but before it returns, would
        # leave POV-Ray running with nothing to kill it (the SIGTERM test hit it, and a blocked
        # signal mask alone did not help: another thread can take the signal).
        held = _hold_signals()
        try:
            proc = subprocess.Popen(
                job.command(pov.name, output.name),
                cwd=workdir,
                env=env,
                stdin=subprocess.DEVNULL,
                stdout=log_file,
                stderr=subprocess.STDOUT,
            )
        except BaseException:
            _release_signals(held)
            raise
        try:
            _release_signals(held)  # a held signal's handler runs here, where POV-Ray gets killed
            deadline = None if timeout is None else time.monotonic() + timeout
            parser = PovLogParser()
            with open(log, encoding="utf-8", errors="replace", newline="") as console:
                while True:
                    try:
                        rc = proc.wait(timeout=POLL_SECONDS)
                        break
                    except subprocess.TimeoutExpired:
                        pass
                    state = parser.feed(console.read())
                    if state.parsing and phase is not None:
                        phase("parsing" + (f" pass {state.frame} of {job.frames}" if job.frames > 1 else ""))
                    elif not state.parsing:
                        frame_done(job.frames * state.fraction(job.frames))
                    if deadline is not None and time.monotonic() > deadline:
                        proc.kill()
                        proc.wait()
                        raise fail(f"POV-Ray timed out after {timeout:g} s")
                    if job.frames > 1:
                        add_finished(running=True)
        finally:
            _stop(proc)
    if rc != 0:
        raise fail(f"POV-Ray failed (exit code {rc})")
    add_finished(running=False)
    if sums.added != job.frames:
        raise fail(f"POV-Ray wrote {sums.added} of {job.frames} frames")
    frame_done(job.frames)
    return sums.sums


def _check_frame(image: np.ndarray, name: str, job: PovJob, fail) -> None:
    """Raise ``fail(...)`` unless a frame has the job's size and finite pixels."""
    if image.shape != (job.height, job.width, 3):
        raise fail(f"{name}: expected {job.width}x{job.height} pixels, got {image.shape[1]}x{image.shape[0]}")
    bad = ~np.isfinite(image).all(axis=2)
    if bad.any():
        y, x = (int(v) for v in np.argwhere(bad)[0])
        raise fail(
            f"{name}: POV-Ray wrote {int(bad.sum())} non-finite pixels, e.g. ({x}, {y}): a light exactly on a "
            f"surface, or a value beyond its half-float EXR's range ({HALF_MAX:g}: lower the light's intensity)"
        )


def povray_environment(workdir: Path) -> dict[str, str]:
    """The environment POV-Ray runs in, in ``workdir`` (a fresh temporary folder): ``HOME`` at a
    folder there whose ``.povray/3.7/povray.conf`` (POVRAY_CONF) forbids shell-outs and asks for
    file I/O only in the working directory, ``POVINI`` unset (no user .ini adds options), the C
    locale. POV-Ray 3.7.0.10 enforces the shell-out ban but NOT the file I/O restriction for
    ``#fopen`` (docs/security.md): the protection is that no scene text reaches the SDL."""
    home = workdir / "home"
    (home / ".povray" / "3.7").mkdir(parents=True, exist_ok=True)
    (home / ".povray" / "3.7" / "povray.conf").write_text(POVRAY_CONF, encoding="ascii")
    env = dict(os.environ, HOME=str(home), LC_ALL="C")
    env.pop("POVINI", None)
    return env


def _hold_signals() -> tuple[dict, list[int]]:
    """Replace the Python handlers of HELD_SIGNALS by ones that only record the signal (main
    thread only: Python runs handlers there alone). Returns (previous handlers, recorded)."""
    recorded: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        return {}, recorded
    previous = {}
    for signum in HELD_SIGNALS:
        handler = signal.getsignal(signum)
        if callable(handler):  # SIG_DFL and SIG_IGN raise nothing: leave them
            previous[signum] = signal.signal(signum, lambda n, frame: recorded.append(n))
    return previous, recorded


def _release_signals(held: tuple[dict, list[int]]) -> None:
    """Put the handlers back, then deliver what was recorded meanwhile (their handlers run now)."""
    previous, recorded = held
    for signum, handler in previous.items():
        signal.signal(signum, handler)
    for signum in dict.fromkeys(recorded):
        signal.raise_signal(signum)


def _stop(proc: subprocess.Popen) -> None:
    """Kill and reap POV-Ray if it still runs (SIGKILL: it also ends a stopped process)."""
    if proc.poll() is None:
        proc.kill()
        proc.wait()


@dataclass(slots=True)
class PovProgress:
    """What POV-Ray's console output (``+V``, ref §17) says so far: the frame being rendered
    (1-based, 0 before the first one) and the pixels of it done."""

    frame: int = 0
    pixels_done: int = 0
    pixels_total: int = 0
    parsing: bool = False  # in "==== [Parsing...]", before the frame's first pixel

    def fraction(self, frames: int) -> float:
        """Share of a job of ``frames`` frames done: finished frames plus this one's pixels."""
        current = self.pixels_done / self.pixels_total if self.pixels_total else 0.0
        return min(1.0, (max(self.frame, 1) - 1 + current) / max(frames, 1))


_PROGRESS_EVENT = re.compile(
    r"Rendering frame (?P<frame>\d+) of \d+|(?P<parsing>==== \[Parsing\.\.\.\])"
    r"|Rendered (?P<done>\d+) of (?P<total>\d+) pixels"
)


class PovLogParser:
    """Reads POV-Ray's console output as it grows (``feed`` each new chunk, split anywhere) and
    keeps a ``PovProgress``. Pure: no I/O. POV-Ray ends each "Rendered N of M pixels" with a
    carriage return and prints them from several threads, so N can step back by a block: the
    largest N of the frame counts."""

    def __init__(self) -> None:
        self.progress = PovProgress()
        self._partial = ""  # the text after the last line end, which the next chunk completes

    def feed(self, chunk: str) -> PovProgress:
        text = self._partial + chunk
        end = max(text.rfind("\n"), text.rfind("\r"))
        self._partial, complete = text[end + 1 :], text[: end + 1]
        p = self.progress
        for m in _PROGRESS_EVENT.finditer(complete):
            if m.group("frame"):
                p.frame, p.pixels_done, p.pixels_total, p.parsing = int(m.group("frame")), 0, 0, False
            elif m.group("parsing"):
                p.parsing = True
            else:
                # A run of one frame prints no "Rendering frame" line (ref §17).
                p.frame = max(p.frame, 1)
                p.pixels_done = max(p.pixels_done, int(m.group("done")))
                p.pixels_total, p.parsing = int(m.group("total")), False
        return p


def _is_progress_line(line: str) -> bool:
    return line.startswith("Rendered ") and " pixels" in line


def _frame_files(workdir: Path, stem: str) -> list[Path]:
    """Output files in frame order: ``stem.exr``, or ``stemN.exr`` (zero-padded N) for animations."""
    pattern = re.compile(re.escape(stem) + r"(\d*)\.exr")
    found = [(m.group(1), p) for p in workdir.iterdir() if (m := pattern.fullmatch(p.name))]
    return [p for _, p in sorted(found, key=lambda item: int(item[0] or 0))]


def _tail(log: Path) -> str:
    try:
        text = log.read_text(encoding="utf-8", errors="replace")
    except OSError:
        return ""
    # The progress lines ("Rendered N of M pixels", ref §17) say nothing about a failure.
    lines = [line for line in text.rstrip().splitlines() if not _is_progress_line(line)]
    return "\n".join(lines[-OUTPUT_TAIL_LINES:])
