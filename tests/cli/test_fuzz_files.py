# SPDX-License-Identifier: Apache-2.0
"""Fuzzing (issue 10): corrupt copies of valid USD files (.usda, .usdc, .usdz) given to the CLI
end in exit 0, 2 or 3 with short ``error:`` / ``warning:`` lines: never a traceback, a signal
(a crash inside USD), a hang, or USD's own diagnostics on stderr.

Seeds: the examples and tests/scenes (valid, warned and invalid ones), each also written as
.usdc and packed as .usdz. Mutations: bytes overwritten, inserted or deleted, a chunk
duplicated, or the file truncated, at positions Hypothesis draws. Each file is run as
``python -m phongscene validate`` in a child process with a timeout, two at a time (the machine
has two cores)."""

from __future__ import annotations

import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
from hypothesis import given, seed
from hypothesis import strategies as st

from support.fuzz import SEED, fuzz_settings
from support.paths import EXAMPLES, REPO

FILES_PER_EXAMPLE = 4  # run two at a time
BATCHES = 3  # x PHONGSCENE_FUZZ_BUDGET (12 files in CI: ~25 s on a loaded 2-core machine)
# One validate of a small scene takes ~1 s (interpreter, pxr and the sandbox child); a hang is
# forever. Generous for a loaded 2-core machine.
TIMEOUT_S = 60
# What a clear answer looks like: a few lines (a corrupt file may have several problems, and a
# warned seed its warnings), none longer than a screenful.
MAX_STDERR_LINES = 40
MAX_LINE_CHARS = 2000
ALLOWED_EXIT = {0, 2, 3}


def _seeds(root: Path) -> list[Path]:
    """The seed files: every .usda, and a .usdc and a .usdz of each one that opens."""
    from pxr import Sdf, UsdUtils

    texts = sorted(EXAMPLES.glob("*.usda")) + sorted((REPO / "tests" / "scenes").rglob("*.usda"))
    out = list(texts)
    for i, path in enumerate(texts):
        layer = Sdf.Layer.FindOrOpen(str(path))
        if layer is None:
            continue
        crate = root / f"s{i}_{path.stem}.usdc"
        layer.Export(str(crate))
        out.append(crate)
        package = root / f"s{i}_{path.stem}.usdz"
        if UsdUtils.CreateNewUsdzPackage(str(crate), str(package)):
            out.append(package)
    return out


@pytest.fixture(scope="module")
def seeds(tmp_path_factory) -> list[Path]:
    return _seeds(tmp_path_factory.mktemp("seeds"))


@st.composite
def mutation(draw):
    """One edit: (kind, position as a fraction of the length, bytes or a length)."""
    kind = draw(st.sampled_from(["overwrite", "insert", "delete", "duplicate", "truncate"]))
    where = draw(st.floats(0.0, 1.0))
    if kind in ("overwrite", "insert"):
        return kind, where, draw(st.binary(min_size=1, max_size=16))
    return kind, where, draw(st.integers(1, 4096))


def mutate(data: bytes, edits) -> bytes:
    for kind, where, arg in edits:
        at = int(where * len(data))
        if kind == "overwrite":
            data = data[:at] + arg + data[at + len(arg) :]
        elif kind == "insert":
            data = data[:at] + arg + data[at:]
        elif kind == "delete":
            data = data[:at] + data[at + arg :]
        elif kind == "duplicate":
            data = data[:at] + data[at : at + arg] + data[at:]
        else:
            data = data[:at]
    return data


def _validate(path: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "phongscene", "validate", str(path)], capture_output=True, timeout=TIMEOUT_S
    )


def check_clear_answer(path: Path, result: subprocess.CompletedProcess) -> None:
    err = result.stderr.decode("utf-8", "replace")
    where = f"{path.name}: exit {result.returncode}\n{err[-3000:]}"
    assert result.returncode in ALLOWED_EXIT, where  # a negative code is a signal (a crash)
    assert "Traceback" not in err, where
    lines = err.splitlines()
    assert len(lines) <= MAX_STDERR_LINES, where
    for line in lines:
        assert line.startswith(("error: ", "warning: ")) and len(line) <= MAX_LINE_CHARS, where
    if result.returncode == 2:
        assert any(line.startswith("error: ") for line in lines), where


@pytest.mark.subprocess
@seed(SEED)
@fuzz_settings(BATCHES)
@given(
    st.lists(
        st.tuples(st.integers(0, 2**16), st.lists(mutation(), min_size=1, max_size=3)),
        min_size=FILES_PER_EXAMPLE,
        max_size=FILES_PER_EXAMPLE,
    )
)
def test_corrupt_files_get_a_clear_answer(seeds, tmp_path_factory, files):
    root = tmp_path_factory.mktemp("mutants")
    paths = []
    for i, (which, edits) in enumerate(files):
        original = seeds[which % len(seeds)]
        path = root / f"m{i}_{original.name}"
        path.write_bytes(mutate(original.read_bytes(), edits))
        paths.append(path)
    with ThreadPoolExecutor(max_workers=2) as pool:
        results = list(pool.map(_validate, paths))
    for path, result in zip(paths, results):
        check_clear_answer(path, result)


# -- texture files (issue 29, item 6) ------------------------------------------------------------

# A quad whose Phong material's diffuse colour samples a texture file: the scene every corrupt
# image below is read through (the image is decoded while the scene is read, so validate decodes it).
TEXTURED_SCENE = """#usda 1.0
(
    defaultPrim = "World"
    upAxis = "Y"
)
def Xform "World"
{
    def Mesh "Quad" (
        prepend apiSchemas = ["MaterialBindingAPI"]
    )
    {
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        point3f[] points = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
        texCoord2f[] primvars:st = [(0, 0), (1, 0), (1, 1), (0, 1)] (
            interpolation = "faceVarying"
        )
        uniform token subdivisionScheme = "none"
        rel material:binding = </World/Looks/Mat>
    }
    def Scope "Looks"
    {
        def Material "Mat"
        {
            token outputs:phong:surface.connect = </World/Looks/Mat/Surface.outputs:surface>
            def Shader "Reader"
            {
                uniform token info:id = "UsdPrimvarReader_float2"
                token inputs:varname = "st"
                float2 outputs:result
            }
            def Shader "Texture"
            {
                uniform token info:id = "UsdUVTexture"
                asset inputs:file = @./IMAGE@
                float2 inputs:st.connect = </World/Looks/Mat/Reader.outputs:result>
                float3 outputs:rgb
            }
            def Shader "Surface"
            {
                uniform token info:id = "phongscene_PhongSurface"
                color3f inputs:diffuseColor.connect = </World/Looks/Mat/Texture.outputs:rgb>
                token outputs:surface
            }
        }
    }
    def Camera "Camera"
    {
        double3 xformOp:translate = (0, 0, 4)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def SphereLight "Light"
    {
        float inputs:intensity = 20
        bool treatAsPoint = 1
        double3 xformOp:translate = (0.5, 1, 3)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
}
"""
# The image seeds: every format and pixel type the reader converts differently.
IMAGE_SEEDS = [
    ("rgb8.png", "uint8", 3),
    ("grey16.png", "uint16", 1),
    ("rgba.exr", "half", 4),
    ("float.tif", "float", 3),
    ("grey.jpg", "uint8", 1),
]
TEXTURES_PER_BATCH = 4  # run two at a time
TEXTURE_BATCHES = 2  # x PHONGSCENE_FUZZ_BUDGET
HEADER_BYTES = 64  # where an image's size, channels and pixel type sit (a header edit)


@pytest.fixture(scope="module")
def image_seeds(tmp_path_factory) -> list[Path]:
    import numpy as np
    import OpenImageIO as oiio

    root = tmp_path_factory.mktemp("images")
    rng = np.random.default_rng(29)
    out = []
    for name, kind, channels in IMAGE_SEEDS:
        pixels = rng.uniform(0, 1, (12, 16, channels)).astype(np.float32)
        assert oiio.ImageBuf(pixels).write(str(root / name), kind)
        out.append(root / name)
    return out


@st.composite
def image_mutation(draw):
    """A mutation anywhere (as for scene files), or one overwriting header bytes (a size, a
    channel count or a pixel type the decoder trusts)."""
    if draw(st.booleans()):
        return draw(mutation())
    return "header", draw(st.integers(0, HEADER_BYTES - 1)), draw(st.binary(min_size=1, max_size=8))


def mutate_image(data: bytes, edits) -> bytes:
    for edit in edits:
        if edit[0] == "header":
            _, at, arg = edit
            data = data[:at] + arg + data[at + len(arg) :]
        else:
            data = mutate(data, [edit])
    return data


def _validate_in_process(path: Path) -> subprocess.CompletedProcess:
    # In process, no sandbox: a crash in OpenImageIO's decoder would be this command's signal.
    return subprocess.run(
        [sys.executable, "-m", "phongscene", "validate", "--no-sandbox", str(path)],
        capture_output=True,
        timeout=TIMEOUT_S,
    )


@pytest.mark.subprocess
@seed(SEED)
@fuzz_settings(TEXTURE_BATCHES)
@given(
    st.lists(
        st.tuples(st.integers(0, 2**16), st.lists(image_mutation(), min_size=1, max_size=3)),
        min_size=TEXTURES_PER_BATCH,
        max_size=TEXTURES_PER_BATCH,
    )
)
def test_corrupt_texture_files_get_a_clear_answer(image_seeds, tmp_path_factory, files):
    paths = []
    for which, edits in files:
        original = image_seeds[which % len(image_seeds)]
        folder = tmp_path_factory.mktemp("texture")
        (folder / original.name).write_bytes(mutate_image(original.read_bytes(), edits))
        scene = folder / "scene.usda"
        scene.write_text(TEXTURED_SCENE.replace("IMAGE", original.name))
        paths.append(scene)
    with ThreadPoolExecutor(max_workers=2) as pool:
        results = list(pool.map(_validate_in_process, paths))
    for path, result in zip(paths, results):
        check_clear_answer(path, result)
