# SPDX-License-Identifier: Apache-2.0
"""Whole-process costs (issue 15): trimesh (and the scipy it pulls in, ~0.35 s) is imported only
when a prim needs tessellation; OpenImageIO only when an image is read or written; EXRs are
written uncompressed (images.EXR_COMPRESSION), the fastest lossless choice."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

from phongscene.images import EXR_COMPRESSION, read_image, write_image

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "seed_lobe.usda"

CUBE_SCENE = """#usda 1.0
(
    upAxis = "Z"
)
def Cube "box"
{
    double size = 1
}
"""


def loaded_modules(code: str) -> set[str]:
    """The top-level module names loaded after running ``code`` in a fresh interpreter."""
    probe = code + "\nimport sys\nprint(' '.join(sorted({m.split('.')[0] for m in sys.modules})))\n"
    out = subprocess.run([sys.executable, "-c", probe], check=True, capture_output=True, text=True).stdout
    return set(out.split())


def test_reading_a_scene_without_tessellated_prims_imports_no_trimesh_nor_scipy():
    loaded = loaded_modules(f"from phongscene.usd import load_usd\nload_usd({str(EXAMPLE)!r})")
    assert "pxr" in loaded
    assert not {"trimesh", "scipy"} & loaded


def test_a_cube_prim_imports_trimesh_when_it_is_tessellated(tmp_path):
    # The probe above can fail: the import happens, only later.
    path = tmp_path / "cube.usda"
    path.write_text(CUBE_SCENE)
    loaded = loaded_modules(f"from phongscene.usd import read_usd\nread_usd({str(path)!r})")
    assert "trimesh" in loaded


def test_building_the_cli_parser_and_comparison_import_no_openimageio():
    loaded = loaded_modules("import phongscene.comparison\nfrom phongscene.cli import build_parser\nbuild_parser()")
    assert "OpenImageIO" not in loaded


def test_exr_is_written_with_the_speed_default_compression_and_reads_back_bit_identical(tmp_path):
    rng = np.random.default_rng(15)
    image = rng.random((9, 16, 3), dtype=np.float32)
    path = write_image(tmp_path / "a.exr", image)
    assert EXR_COMPRESSION == "none"
    assert oiio.ImageInput.open(str(path)).spec().get_string_attribute("compression") == EXR_COMPRESSION
    assert np.array_equal(read_image(path), image)


def test_reading_an_untextured_usd_file_imports_no_openimageio(tmp_path):
    path = tmp_path / "cube.usda"
    path.write_text(CUBE_SCENE)
    assert "OpenImageIO" not in loaded_modules(f"from phongscene.usd import read_usd\nread_usd({str(path)!r})")
