# SPDX-License-Identifier: Apache-2.0
"""``phongscene preview`` (issue 26 part 2): the page, its state and its image over HTTP; an
edit of the scene (a colour, a texture) renders again; a broken edit shows its error on the page
and the next good edit recovers; the coarse pass comes before the full one; Ctrl-C ends the
command with one line and exit 130; the page in headless Chromium shows the image."""

from __future__ import annotations

import contextlib
import json
import shutil
import signal
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from pathlib import Path

import numpy as np
import pytest

from phongscene.cli import EXIT_INTERRUPTED
from phongscene.images import read_image
from phongscene.overrides import RenderOverrides
from phongscene.preview import COARSE_DIVISOR, Preview, make_server, serve_in_thread
from support.paths import EXAMPLES, SCENES, chromium

SCENE = EXAMPLES / "seed_exponents.usda"
ORANGE, BLUE = "(0.8, 0.3, 0.1)", "(0.1, 0.3, 0.8)"  # the spheres' Phong diffuse colour, and an edit of it
WIDTH = 32  # small: each render is a few milliseconds
# How long a test waits for the preview to show an edit: far above the 0.5 s goal, for a loaded
# 2-core machine; a preview that never re-renders fails instead of blocking the suite.
WAIT_SECONDS = 30
PHONGSCENE = Path(sys.executable).with_name("phongscene")


def _get(url: str) -> bytes:
    with urllib.request.urlopen(url, timeout=WAIT_SECONDS) as response:
        return response.read()


def _state(base: str) -> dict:
    return json.loads(_get(base + "state.json"))


def _wait_for(base: str, accept, after: int = 0) -> dict:
    """The first state newer than generation ``after`` that ``accept`` takes."""
    deadline = time.monotonic() + WAIT_SECONDS
    while time.monotonic() < deadline:
        state = _state(base)
        if state["generation"] > after and accept(state):
            return state
        time.sleep(0.02)
    raise AssertionError(f"no accepted state within {WAIT_SECONDS} s; last: {state}")


def _full(state: dict) -> bool:
    return state["pass"] == "full"


def _image(base: str, tmp_path: Path) -> np.ndarray:
    png = _get(base + "image.png")
    assert png.startswith(b"\x89PNG\r\n\x1a\n")
    path = tmp_path / "served.png"
    path.write_bytes(png)
    return read_image(path)


@contextlib.contextmanager
def _serving(scene: Path):
    """A preview of ``scene`` at WIDTH serving on a free port: the page's address."""
    preview = Preview(scene, RenderOverrides(width=WIDTH))
    server = make_server(preview, 0)
    serve_in_thread(server)
    loop = threading.Thread(target=preview.run, daemon=True)
    loop.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}/"
    finally:
        preview.stop.set()
        loop.join(WAIT_SECONDS)
        server.shutdown()
        server.server_close()
        preview.close()


@pytest.fixture
def served(tmp_path):
    """A preview of a copy of the example scene in tmp_path: (the scene's path, the page's address)."""
    scene = tmp_path / "scene.usda"
    shutil.copy(SCENE, scene)
    with _serving(scene) as base:
        yield scene, base


def _edit(scene: Path, old: str, new: str) -> None:
    text = scene.read_text()
    assert old in text
    scene.write_text(text.replace(old, new))


def test_the_page_and_image_are_served_and_an_edit_renders_again(served, tmp_path):
    scene, base = served
    page = _get(base).decode()
    assert '<img id="image"' in page and "state.json" in page and "scene.usda" in page
    first = _wait_for(base, _full)
    assert (first["width"], first["height"], first["errors"]) == (WIDTH, WIDTH * 3 // 4, [])
    before = _image(base, tmp_path)
    assert before.shape == (WIDTH * 3 // 4, WIDTH, 3)
    _edit(scene, ORANGE, BLUE)
    second = _wait_for(base, _full, after=first["generation"])
    after = _image(base, tmp_path)
    # The spheres turned from orange to blue: the image's blue grows, its red falls.
    assert after[..., 2].mean() > before[..., 2].mean()
    assert after[..., 0].mean() < before[..., 0].mean()
    assert second["generation"] > first["generation"]


def test_a_broken_edit_shows_its_error_and_a_fixed_one_recovers(served, tmp_path):
    scene, base = served
    first = _wait_for(base, _full)
    good = _image(base, tmp_path)
    _edit(scene, "double radius = 1\n", "double radius = -1\n")
    broken = _wait_for(base, lambda s: s["pass"] == "error", after=first["generation"])
    assert any("radius" in e and "/World/Geometry/" in e for e in broken["errors"]), broken["errors"]
    assert np.array_equal(_image(base, tmp_path), good)  # the last good image stays on the page
    _edit(scene, "double radius = -1\n", "double radius = 1\n")
    fixed = _wait_for(base, _full, after=broken["generation"])
    assert fixed["errors"] == []
    assert np.array_equal(_image(base, tmp_path), good)


def test_a_file_that_does_not_parse_shows_an_error_and_recovers(served):
    scene, base = served
    first = _wait_for(base, _full)
    text = scene.read_text()
    scene.write_text(text + "\ndef Xform {{{\n")
    broken = _wait_for(base, lambda s: s["pass"] == "error", after=first["generation"])
    assert broken["errors"] and "scene.usda" in " ".join(broken["errors"])
    scene.write_text(text)
    _wait_for(base, _full, after=broken["generation"])


def test_a_texture_edit_renders_again(tmp_path):
    """A texture the model reads is watched as the layers are."""
    from phongscene.images import write_image

    shutil.copytree(SCENES / "blender_textured", tmp_path / "scene")
    scene = tmp_path / "scene" / "textured_glossy.usdc"
    texture = tmp_path / "scene" / "textures" / "textured_glossy_grid.png"
    with _serving(scene) as base:
        first = _wait_for(base, _full)
        assert first["errors"] == []
        bright = _image(base, tmp_path)
        write_image(texture, np.full((4, 4, 3), 0.01, np.float32))
        _wait_for(base, _full, after=first["generation"])
        assert _image(base, tmp_path).mean() < bright.mean()  # the textured object went dark


def test_the_coarse_pass_comes_first(tmp_path):
    scene = tmp_path / "scene.usda"
    shutil.copy(SCENE, scene)
    preview = Preview(scene, RenderOverrides(width=WIDTH))
    seen: list = []
    publish = preview._publish

    def record(**kwargs):
        seen.append((kwargs["stage"], kwargs.get("png")))
        publish(**kwargs)

    preview._publish = record
    try:
        preview.render_once()
    finally:
        preview.close()
    assert [stage for stage, _ in seen] == ["coarse", "full"]
    widths = []
    for i, (_, png) in enumerate(seen):
        (tmp_path / f"{i}.png").write_bytes(png)
        widths.append(read_image(tmp_path / f"{i}.png").shape[1])
    assert widths == [WIDTH // COARSE_DIVISOR, WIDTH]


@pytest.mark.subprocess
def test_the_command_serves_and_ctrl_c_ends_it_with_one_line(tmp_path):
    scene = tmp_path / "scene.usda"
    shutil.copy(SCENE, scene)
    child = subprocess.Popen(
        [str(PHONGSCENE), "preview", str(scene), "--port", "0", "--width", str(WIDTH)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        line = child.stdout.readline()
        assert line.startswith(f"previewing {scene} on http://127.0.0.1:"), line
        base = line.split(" on ", 1)[1].split(" ", 1)[0]
        _wait_for(base, _full)
        child.send_signal(signal.SIGINT)
        out, err = child.communicate(timeout=WAIT_SECONDS)
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
    assert child.returncode == EXIT_INTERRUPTED
    assert err == "interrupted\n"


def test_a_port_in_use_is_a_usage_error(tmp_path, capsys):
    from phongscene.cli import EXIT_SCENE, main

    scene = tmp_path / "scene.usda"
    shutil.copy(SCENE, scene)
    preview = Preview(scene)
    taken = make_server(preview, 0)
    try:
        assert main(["preview", str(scene), "--port", str(taken.server_address[1])]) == EXIT_SCENE
    finally:
        taken.server_close()
        preview.close()
    assert "phongscene preview: error: --port" in capsys.readouterr().err


@pytest.mark.chromium
@pytest.mark.slow
def test_the_page_in_chromium_shows_the_image(served):
    _, base = served
    state = _wait_for(base, _full)
    dom = subprocess.run(
        [chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--virtual-time-budget=3000", "--dump-dom", base],
        check=True,
        capture_output=True,
        text=True,
        timeout=WAIT_SECONDS * 2,
    ).stdout
    # The page's script ran: the image element points at the latest image, at the scene's size.
    assert f'src="image.png?g={state["generation"]}"' in dom, dom
    assert f'width="{WIDTH}"' in dom and "full pass" in dom and "POV-Ray diff" in dom


@pytest.mark.povray
@pytest.mark.slow
def test_the_diff_button_runs_the_povray_diff_and_serves_its_report(served):
    _, base = served
    first = _wait_for(base, _full)
    request = urllib.request.Request(base + "diff", method="POST")
    with urllib.request.urlopen(request, timeout=WAIT_SECONDS) as response:
        assert response.status == 202
    done = _wait_for(base, lambda s: s["diff"] in ("done", "error"), after=first["generation"])
    assert done["diff"] == "done" and done["diff_summary"].startswith("agree: max error "), done
    report = _get(base + "diff/index.html").decode()
    assert 'src="povray.png"' in report
    assert _get(base + "diff/povray.png").startswith(b"\x89PNG")
    with pytest.raises(urllib.error.HTTPError):
        _get(base + "diff/%2e%2e%2fscene.usda")  # nothing outside the report's folder
