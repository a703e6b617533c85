# SPDX-License-Identifier: Apache-2.0
"""A live preview: one process keeps a scene's stage and the native tracer loaded, renders the
scene, serves the latest image on a local web page (127.0.0.1 only) and renders again when the
file, any layer the stage was composed from or any texture it reads changes.

Why in-process: a CLI render of an edit pays Python's, USD's and the extension's start-up
(~1.2 s, issue 26); a warm process pays only the read and the render. The stage is the one
``phongscene.usd.stage_reuse.open_stage`` keeps (reopened when one of its layers changes), and
the files watched are that stage's layers (``stage_reuse.used_files``) and the textures the
model read: each polled for its state (modification time, size, inode, ``read_cache.file_state``)
every ``POLL_SECONDS``, with no new dependency.

Each change is rendered twice: a coarse pass (``COARSE_DIVISOR`` times smaller, one sample per
pixel) that appears at once, then the full image; a change seen before the full pass starts
skips it. A scene that does not read (a typo, a broken edit) keeps the last image and shows the
errors on the page; the next good edit recovers.

The page polls ``/state.json`` (a generation counter that grows with each new image, the pass,
the errors and warnings) and reloads ``/image.png`` when the counter moves. Its button posts
``/diff``: the loop runs ``phongscene diff`` on the scene (POV-Ray against the native tracer) and
the report is served under ``/diff/``."""

from __future__ import annotations

import html
import json
import os
import tempfile
import threading
import time
from dataclasses import dataclass, field, replace
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

from .errors import BackendError, PhongSceneError, SceneError
from .overrides import RenderOverrides

# How often the watched files are checked: well under the 0.5 s an edit may take to show
# (issue 26), and a stat of a few files costs microseconds.
POLL_SECONDS = 0.05
# The coarse pass is this many times smaller on each side (16x fewer pixels) and 1 sample per
# pixel: a first image in a fraction of the full render's time.
COARSE_DIVISOR = 4
# The local address only: the preview serves files of the user's disk and has no authentication.
HOST = "127.0.0.1"


@dataclass
class PreviewState:
    """What the page shows: the latest image (PNG bytes) and what became of the last read."""

    generation: int = 0  # grows by one with every new image (or new error text)
    png: bytes = b""
    width: int = 0  # of the scene's full image (the coarse one is shown at this size)
    height: int = 0
    stage: str = "starting"  # "coarse", "full", "error"
    errors: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    seconds: float = 0.0  # from the change seen to this image
    # The POV-Ray diff the page's button asks for: "", "running", "done" or "error", and its verdict.
    diff: str = ""
    diff_summary: str = ""

    def as_json(self) -> dict:
        return {
            "generation": self.generation,
            "width": self.width,
            "height": self.height,
            "pass": self.stage,
            "errors": self.errors,
            "warnings": self.warnings,
            "seconds": round(self.seconds, 4),
            "diff": self.diff,
            "diff_summary": self.diff_summary,
        }


class Preview:
    """Render ``scene`` (a USD file) with ``overrides`` whenever one of its files changes; the
    state is read by the web server's threads under ``lock``."""

    def __init__(self, scene: str | os.PathLike, overrides: RenderOverrides | None = None):
        self.scene = os.path.abspath(os.fspath(scene))
        self.overrides = overrides or RenderOverrides()
        self.state = PreviewState()
        self.lock = threading.Lock()
        self.stop = threading.Event()
        self.diff_requested = threading.Event()  # the page's button (run by the loop, between renders)
        self._watched: tuple[str, ...] = (self.scene,)
        self._states: tuple = ()
        self._tmp: tempfile.TemporaryDirectory | None = None  # made by the first image
        self._tmp_lock = threading.Lock()

    # -- the watch-and-render loop (the main thread of ``phongscene preview``) --

    def run(self) -> None:
        """Render now and after each change until ``stop`` is set."""
        while not self.stop.is_set():
            states = self._file_states()
            if states != self._states:
                self.render_once()
            elif self.diff_requested.is_set():
                self.diff_requested.clear()
                self.run_diff()
            else:
                self.stop.wait(POLL_SECONDS)

    def close(self) -> None:
        if self._tmp is not None:
            self._tmp.cleanup()

    def _file_states(self) -> tuple:
        from .usd.read_cache import file_state

        return tuple(file_state(f) for f in self._watched)

    def render_once(self) -> None:
        """Read the scene, render the coarse pass, then (no change seen meanwhile) the full one."""
        from .diagnostics import explain_image
        from .rendering import check_settings, load_scene, render
        from .usd.stage_reuse import open_stage, used_files

        start = time.perf_counter()
        # The states before the read: an edit made during it is seen by the next poll.
        self._states = self._file_states()
        try:
            scene, warnings = load_scene(open_stage(self.scene), time=self.overrides.time)
            scene, settings = self.overrides.apply(scene)
            check_settings(scene, settings)
        except SceneError as e:
            from .rendering import in_file_terms

            self._watch(used_files(self.scene))
            self._publish(stage="error", errors=[str(p) for p in in_file_terms(e).problems], warnings=[], start=start)
            return
        except Exception as e:
            self._watch(used_files(self.scene))
            said = str(e) if isinstance(e, (PhongSceneError, OSError)) else f"{type(e).__name__}: {e}"
            self._publish(stage="error", errors=[said], warnings=[], start=start)
            return
        gprims = (
            *scene.spheres,
            *scene.meshes,
            *scene.points,
            *(m for i in scene.instances for m in i.prototype.meshes),
        )
        textures = {t.file for g in gprims for t in g.material.textures if t.file}
        self._watch(used_files(self.scene) + tuple(sorted(textures)))
        coarse = replace(
            settings,
            width=max(1, settings.width // COARSE_DIVISOR),
            height=max(1, settings.height // COARSE_DIVISOR),
            samples=1,
        )
        passes = [("coarse", coarse), ("full", settings)]
        if (coarse.width, coarse.height, coarse.samples) == (settings.width, settings.height, settings.samples):
            passes = passes[1:]  # a tiny image: the coarse pass would be the full one
        for stage, pass_settings in passes:
            if stage == "full" and self._file_states() != self._states:
                return  # edited again: the next loop renders the new version, coarse first
            try:
                # The image's own warnings go on the page (below), not through Python's warnings.
                image = render(scene, "native", pass_settings, explain=False)
            except BackendError as e:  # the tracer refused (out of memory, say): shown, the next edit retries
                self._publish(stage="error", errors=[str(e)], warnings=list(warnings), start=start)
                return
            explained = explain_image(scene, image, pass_settings, warnings) if stage == "full" else []
            self._publish(
                stage=stage,
                png=self._png(image),
                size=(settings.width, settings.height),
                warnings=[*warnings, *explained],
                start=start,
            )

    @property
    def diff_folder(self) -> Path:
        """Where the last POV-Ray diff's report is (served under /diff/)."""
        return Path(self._tmp_folder()) / "diff"

    def run_diff(self) -> None:
        """``phongscene diff`` of the scene as it is now, with the preview's overrides (without
        --mapping, diff's choice: exact, or classic where needed); its report replaces the last one. In the
        loop's thread: USD's stage is not shared between threads, and edits wait for it."""
        from .crossvalidation import diff
        from .usd.stage_reuse import open_stage

        with self.lock:
            self.state.diff, self.state.diff_summary = "running", ""
            self.state.generation += 1
        try:
            result = diff(open_stage(self.scene), self.diff_folder, overrides=self.overrides)
            r = result.report
            verdict, summary = (
                "done",
                (
                    f"{'agree' if result.ok else 'DIFFER'}: max error {r.max_error:.3g}, "
                    f"{r.failing_pixels} of {r.pixels} pixels ({r.failing_percent:.3g} %) fail"
                ),
            )
        except SceneError as e:
            from .rendering import in_file_terms

            verdict, summary = "error", "; ".join(str(p) for p in in_file_terms(e).problems)
        except Exception as e:
            verdict, summary = "error", f"{type(e).__name__}: {e}" if not isinstance(e, PhongSceneError) else str(e)
        with self.lock:
            self.state.diff, self.state.diff_summary = verdict, summary
            self.state.generation += 1

    def _tmp_folder(self) -> str:
        with self._tmp_lock:  # the loop and the server's threads both ask
            if self._tmp is None:
                self._tmp = tempfile.TemporaryDirectory(prefix="phongscene-preview-")
            return self._tmp.name

    def _watch(self, files: tuple[str, ...]) -> None:
        """Watch ``files`` (and the scene) from now on: each with its state before the read when
        it was watched then (an edit made during the read shows at the next poll), else as it
        is now (it was read just now)."""
        from .usd.read_cache import file_state

        before = dict(zip(self._watched, self._states))
        self._watched = tuple(dict.fromkeys((self.scene, *files)))
        self._states = tuple(before[f] if f in before else file_state(f) for f in self._watched)

    def _png(self, image) -> bytes:
        from .images import write_image

        return write_image(Path(self._tmp_folder()) / "preview.png", image).read_bytes()

    def _publish(self, *, stage: str, start: float, png: bytes | None = None, size=None, errors=(), warnings=()):
        with self.lock:
            s = self.state
            s.generation += 1
            s.stage, s.errors, s.warnings = stage, list(errors), list(warnings)
            s.seconds = time.perf_counter() - start
            if png is not None:
                s.png = png
                s.width, s.height = size

    def snapshot(self) -> tuple[dict, bytes]:
        with self.lock:
            return self.state.as_json(), self.state.png


# ----------------------------------------------------------------------------------------------
# The web page


PAGE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>phongscene preview: {name}</title>
<style>
body {{ font-family: sans-serif; margin: 1em; background: #222; color: #ddd; }}
#image {{ image-rendering: pixelated; background: #000; display: block; }}
#errors {{ color: #f77; white-space: pre-wrap; }}
#warnings {{ color: #fc6; white-space: pre-wrap; }}
#status {{ color: #999; }}
</style></head>
<body>
<h1>{name}</h1>
<p id="status">waiting for the first image</p>
<img id="image" alt="the latest render of {name}">
<p><button id="diff" onclick="fetch('diff', {{method: 'POST'}})">POV-Ray diff</button>
<span id="diffstatus"></span></p>
<pre id="errors"></pre>
<pre id="warnings"></pre>
<script>
let seen = -1;
async function poll() {{
  try {{
    const state = await (await fetch("state.json", {{cache: "no-store"}})).json();
    if (state.generation !== seen) {{
      seen = state.generation;
      const img = document.getElementById("image");
      if (state.width) {{
        img.width = state.width; img.height = state.height;
        img.src = "image.png?g=" + state.generation;
      }}
      document.getElementById("errors").textContent = state.errors.map(e => "error: " + e).join("\\n");
      document.getElementById("warnings").textContent = state.warnings.map(w => "warning: " + w).join("\\n");
      const diff = document.getElementById("diffstatus");
      diff.textContent = state.diff === "running" ? "rendering with POV-Ray ..." : state.diff_summary;
      document.getElementById("diff").disabled = state.diff === "running";
      if (state.diff === "done") {{
        const link = document.createElement("a");
        link.href = "diff/index.html?g=" + state.generation; link.textContent = " the report";
        diff.appendChild(link);
      }}
      document.getElementById("status").textContent =
        "image " + state.generation + ", " + state.pass + " pass, " + state.seconds.toFixed(3) + " s";
    }}
  }} catch (e) {{
    document.getElementById("status").textContent = "the preview is not running";
  }}
  setTimeout(poll, {poll_ms});
}}
poll();
</script>
</body></html>
"""
# How often the page asks for news (ms): as often as the files are polled, and a JSON of a few
# hundred bytes from the loopback costs nothing.
PAGE_POLL_MS = 100


def make_server(preview: Preview, port: int = 0) -> ThreadingHTTPServer:
    """An HTTP server on 127.0.0.1:``port`` (0: a free port) serving ``preview``'s page, its
    state (``/state.json``) and its latest image (``/image.png``)."""
    page = PAGE.format(name=html.escape(Path(preview.scene).name), poll_ms=PAGE_POLL_MS).encode()

    class Handler(BaseHTTPRequestHandler):
        def do_GET(self):
            path = self.path.split("?", 1)[0]
            if path == "/":
                self._send(200, "text/html; charset=utf-8", page)
            elif path == "/state.json":
                self._send(200, "application/json", json.dumps(preview.snapshot()[0]).encode())
            elif path == "/image.png":
                png = preview.snapshot()[1]
                if png:
                    self._send(200, "image/png", png)
                else:
                    self._send(404, "text/plain", b"no image yet")
            elif path.startswith("/diff/"):
                self._send_report_file(path[len("/diff/") :])
            else:
                self._send(404, "text/plain", b"not found")

        def do_POST(self):
            if self.path.split("?", 1)[0] == "/diff":
                preview.diff_requested.set()
                self._send(202, "text/plain", b"diff requested")
            else:
                self._send(404, "text/plain", b"not found")

        def _send_report_file(self, name: str) -> None:
            # The report's own files only (flat folder): no path leads out of it.
            kinds = {".html": "text/html; charset=utf-8", ".png": "image/png", ".json": "application/json"}
            file = preview.diff_folder / name
            if "/" in name or name.startswith(".") or file.suffix not in kinds or not file.is_file():
                self._send(404, "text/plain", b"not found")
            else:
                self._send(200, kinds[file.suffix], file.read_bytes())

        def _send(self, status: int, kind: str, body: bytes) -> None:
            self.send_response(status)
            self.send_header("Content-Type", kind)
            self.send_header("Content-Length", str(len(body)))
            self.send_header("Cache-Control", "no-store")
            self.end_headers()
            self.wfile.write(body)

        def log_message(self, format, *args):
            pass  # one line per poll would drown the terminal

    server = ThreadingHTTPServer((HOST, port), Handler)
    server.daemon_threads = True
    return server


def serve_in_thread(server: ThreadingHTTPServer) -> threading.Thread:
    thread = threading.Thread(
        target=server.serve_forever, kwargs={"poll_interval": 0.1}, daemon=True, name="phongscene-preview-http"
    )
    thread.start()
    return thread
