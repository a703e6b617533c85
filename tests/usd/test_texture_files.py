# SPDX-License-Identifier: Apache-2.0
"""Texture files are opened as layers are (issue 29, item 1): a FIFO, a device, a folder or
/proc/self/fd/0 is the fallback with a warning, promptly (it used to hang ``render``, deaf to
Ctrl-C); the header is checked against the bounds before a pixel is decoded (a 875 KB PNG of
30000² grey grew past 8 GB); the scene's texels are budgeted, naming the texture over the budget;
pixels are decoded in their stored precision and converted a block at a time (a 65 KB PNG of
8192² grey cost 5.1 GB: ~75 bytes a texel)."""

from __future__ import annotations

import os
import struct
import subprocess
import sys
import tracemalloc
import zlib

import numpy as np
import OpenImageIO as oiio
import pytest
from test_textures import textured_stage, write_png

from phongscene import limits, load_usd
from phongscene.errors import SceneError
from phongscene.limits import MAX_TEXTURE_SIDE
from phongscene.usd import texture_files

# Reading a scene whose texture is not a regular file: interpreter start-up and a stat; far below
# this on a loaded 2-core machine, and far below "forever" (the hang this replaces).
PROMPT_TIMEOUT_S = 60
# The model's texels (float32 RGB) and an 8-bit grey file's decoded bytes, per texel.
MODEL_BYTES_PER_TEXEL = 12
GREY8_BYTES_PER_TEXEL = 1
# Beyond those, a read may allocate one conversion block's temporaries and the small rest of a
# read (USD values, the scene's other arrays): 64 MiB bounds both (texture_files.BLOCK_TEXELS is
# 2^18 texels, ~130 bytes each), and is far below the ~75 bytes a texel (300 MB here) it replaces.
READ_SLACK_BYTES = 64 << 20
BIG_SIDE = 2048  # a texture big enough that bytes per texel dominate the slack above


def _cli(*args, stdin=subprocess.DEVNULL) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "phongscene", *args],
        capture_output=True,
        text=True,
        timeout=PROMPT_TIMEOUT_S,
        stdin=stdin,
    )


def _png_header_only(path, width: int, height: int) -> str:
    """A PNG whose header says width × height 8-bit grey, with only one row of pixel data: read
    whole it would decode width × height bytes (or fail on the truncation); its header alone is
    a few bytes."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    idat = zlib.compress(b"\0" * (width + 1))
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", idat) + chunk(b"IEND", b""))
    return str(path)


@pytest.mark.subprocess
@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs POSIX FIFOs")
@pytest.mark.parametrize("kind", ["fifo", "folder", "device", "stdin"])
def test_a_texture_that_is_not_a_regular_file_is_the_fallback_with_a_warning_promptly(tmp_path, kind):
    image = {"fifo": "pipe.png", "folder": "folder.png", "device": "/dev/zero", "stdin": "/proc/self/fd/0"}[kind]
    if kind == "fifo":
        os.mkfifo(tmp_path / image)
    elif kind == "folder":
        (tmp_path / image).mkdir()
    scene = textured_stage(tmp_path / "s.usda", image, phong=True)
    # stdin a pipe nobody writes to: reading /proc/self/fd/0 would block forever.
    result = _cli("validate", "--no-sandbox", scene, stdin=subprocess.PIPE)
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    (warning,) = [line for line in result.stderr.splitlines() if "/World/Looks/Mat/Texture.inputs:file" in line]
    what = {"fifo": "a FIFO", "folder": "a folder", "device": "a device", "stdin": "a FIFO"}[kind]
    assert f"is {what}" in warning and "the fallback is used" in warning


def test_a_side_beyond_the_bound_is_an_error_from_the_header(tmp_path):
    _png_header_only(tmp_path / "wide.png", MAX_TEXTURE_SIDE + 1, 1)
    with pytest.raises(SceneError) as info:
        load_usd(textured_stage(tmp_path / "s.usda", "wide.png"))
    (problem,) = info.value.problems
    assert (problem.prim, problem.attribute) == ("/World/Looks/Mat/Texture", "inputs:file")
    assert f"{MAX_TEXTURE_SIDE + 1} x 1 texels (its header)" in problem.message


@pytest.mark.subprocess
def test_a_decompression_bomb_is_refused_before_decoding(tmp_path):
    # 30000² in the header, one row of data: decoding would take 900 MB (or fail on the missing
    # rows); the header check refuses it first, in a few kilobytes.
    _png_header_only(tmp_path / "bomb.png", 30000, 30000)
    scene = textured_stage(tmp_path / "s.usda", "bomb.png")
    result = _cli("validate", scene)
    assert result.returncode == 2
    (line,) = result.stderr.splitlines()
    assert line.startswith(f"error: {scene}: /World/Looks/Mat/Texture.inputs:file: ")
    assert "30000 x 30000 texels (its header)" in line


def test_the_scene_texel_budget_names_the_texture_over_it(tmp_path, monkeypatch):
    write_png(tmp_path / "a.png", np.zeros((40, 50, 3), np.uint8))
    scene = textured_stage(tmp_path / "s.usda", "a.png")
    monkeypatch.setattr(limits, "MAX_SCENE_TEXELS", 2000)  # exactly this texture: it fits
    assert load_usd(scene).meshes[0].material.diffuse_texture is not None
    monkeypatch.setattr(limits, "MAX_SCENE_TEXELS", 1999)
    with pytest.raises(SceneError) as info:
        load_usd(scene)
    (problem,) = info.value.problems
    assert (problem.prim, problem.attribute) == ("/World/Looks/Mat/Texture", "inputs:file")
    assert problem.message.startswith(f"{tmp_path / 'a.png'} (50 x 40) would bring the scene's textures to 2000 texels")
    assert "more than the 1999" in problem.message


def test_an_8bit_texture_is_decoded_as_bytes_and_converted_a_block_at_a_time(tmp_path):
    pixels = np.random.default_rng(5).integers(0, 256, (BIG_SIDE, BIG_SIDE, 1), dtype=np.uint8)
    write_png(tmp_path / "grey.png", pixels)
    header = texture_files.read_header(str(tmp_path / "grey.png"), "grey.png")
    assert header.stored == "uint8" and texture_files.decode(header, "grey.png").dtype == np.uint8
    scene = textured_stage(tmp_path / "s.usda", "grey.png")
    tracemalloc.start()
    try:
        loaded = load_usd(scene)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    (mesh,) = loaded.meshes
    image = mesh.material.diffuse_texture.image
    assert image.dtype == np.float32 and image.shape == (BIG_SIDE, BIG_SIDE, 3)
    texels = BIG_SIDE * BIG_SIDE
    assert peak <= texels * (MODEL_BYTES_PER_TEXEL + GREY8_BYTES_PER_TEXEL) + READ_SLACK_BYTES, peak / texels
    # The values: OpenImageIO's own decoding of the file to float, then sRGB → linear.
    buf = oiio.ImageBuf(str(tmp_path / "grey.png"))
    assert buf.read(0, 0, True, oiio.TypeFloat)  # to float first: colorconvert keeps the pixel type
    buf = oiio.ImageBufAlgo.colorconvert(buf, "sRGB", "linear")
    expected = np.asarray(buf.get_pixels(oiio.TypeFloat), np.float32).reshape(BIG_SIDE, BIG_SIDE, 1)
    np.testing.assert_array_equal(image, np.repeat(expected, 3, axis=2))


def test_a_dome_texture_bomb_is_refused_from_its_header(tmp_path):
    _png_header_only(tmp_path / "bomb.png", 30000, 30000)
    (tmp_path / "s.usda").write_text(
        '#usda 1.0\ndef DomeLight "Dome" {\n    asset inputs:texture:file = @./bomb.png@\n}\ndef Sphere "Ball" {\n}\n'
    )
    with pytest.raises(SceneError) as info:
        load_usd(tmp_path / "s.usda")
    (problem,) = info.value.problems
    assert (problem.prim, problem.attribute) == ("/Dome", "inputs:texture:file")
    assert "30000 x 30000 texels (its header)" in problem.message
