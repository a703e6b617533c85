# SPDX-License-Identifier: Apache-2.0
"""Whole-process costs (issue 15): trimesh (and the scipy it pulls in, ~0.35 s) is imported only
when a prim needs tessellation; OpenImageIO only when an image is read or written; EXRs are
written uncompressed (images.EXR_COMPRESSION), the fastest lossless choice. A render imports
neither the USD writer nor numpy.ma, importlib.resources or secrets (benchmarks/startup.py
measures them); the ``phongscene`` process starts numpy with one BLAS thread unless told
otherwise, and ends without the interpreter's teardown but with its exit handlers run and its
output flushed (phongscene/console.py)."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import OpenImageIO as oiio
import pytest

from phongscene.images import EXR_COMPRESSION, read_image, write_image
from support.paths import EXAMPLES

EXAMPLE = EXAMPLES / "seed_lobe.usda"
# Modules a render does not need, each a measurable share of its start-up (benchmarks/startup.py).
NOT_FOR_A_RENDER = (
    "phongscene.usd.writer",
    "numpy.ma",
    "importlib.resources",
    "secrets",
    "phongscene.backends.povray.compile",
    "phongscene.backends.povray.run",
)

CUBE_SCENE = """#usda 1.0
(
    upAxis = "Z"
)
def Cube "box"
{
    double size = 1
    custom bool phong:tessellate = 1
}
"""


def loaded_modules(code: str) -> set[str]:
    """The top-level module names loaded after running ``code`` in a fresh interpreter."""
    probe = code + "\nimport sys\nprint(' '.join(sorted({m.split('.')[0] for m in sys.modules})))\n"
    out = subprocess.run([sys.executable, "-c", probe], check=True, capture_output=True, text=True).stdout
    return set(out.split())


@pytest.mark.subprocess
def test_reading_a_scene_without_tessellated_prims_imports_no_trimesh_nor_scipy():
    loaded = loaded_modules(f"from phongscene.usd import load_usd\nload_usd({str(EXAMPLE)!r})")
    assert "pxr" in loaded
    assert not {"trimesh", "scipy"} & loaded


@pytest.mark.subprocess
def test_a_cube_prim_imports_trimesh_when_it_is_tessellated(tmp_path):
    # The probe above can fail: the import happens, only later.
    path = tmp_path / "cube.usda"
    path.write_text(CUBE_SCENE)
    loaded = loaded_modules(f"from phongscene.usd import read_usd\nread_usd({str(path)!r})")
    assert "trimesh" in loaded


@pytest.mark.subprocess
def test_an_exact_cube_prim_imports_no_trimesh(tmp_path):
    path = tmp_path / "cube.usda"
    path.write_text(CUBE_SCENE.replace("    custom bool phong:tessellate = 1\n", ""))
    loaded = loaded_modules(f"from phongscene.usd import read_usd\nread_usd({str(path)!r})")
    assert not {"trimesh", "scipy"} & loaded


@pytest.mark.subprocess
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


@pytest.mark.subprocess
def test_reading_an_untextured_usd_file_imports_no_openimageio(tmp_path):
    path = tmp_path / "cube.usda"
    path.write_text(CUBE_SCENE)
    assert "OpenImageIO" not in loaded_modules(f"from phongscene.usd import read_usd\nread_usd({str(path)!r})")


@pytest.mark.subprocess
def test_a_native_render_imports_no_usd_writer_povray_compiler_numpy_ma_importlib_resources_or_secrets(tmp_path):
    # The whole command in process, the EXR write included: each name is imported by a call a
    # render used to make (np.median, importlib.resources.files, secrets.token_hex, a package's
    # __init__, the --mapping's vocabulary).
    code = (
        f"from phongscene.cli import main\n"
        f"assert main(['render', {str(EXAMPLE)!r}, '-o', {str(tmp_path / 'a.exr')!r}, '--width', '8', '--height', '6']) == 0\n"
        f"import sys\nprint(' '.join(sorted(sys.modules)))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True).stdout
    loaded = set(out.split())
    assert "phongscene.usd.reader" in loaded and "OpenImageIO" in loaded  # the probe did render
    assert not set(NOT_FOR_A_RENDER) & loaded


@pytest.mark.subprocess
def test_the_usd_writer_and_the_povray_compiler_are_still_reachable_from_their_packages():
    loaded = loaded_modules(
        "from phongscene.usd import write_usd, define_sphere\nassert callable(write_usd)\n"
        "from phongscene.backends import povray\nassert callable(povray.compile_pov)\n"
        "assert povray.INSTALL_HINT and povray.MAPPINGS == ('exact', 'classic')"
    )
    assert "pxr" in loaded


def test_the_lights_median_is_numpys_median():
    from phongscene.usd.scene_checks import _median

    rng = np.random.default_rng(15)
    for n in (1, 2, 3, 4, 1023, 1024):  # odd and even counts: the middle one, the middle two's mean
        values = rng.random(n) * 10.0 ** rng.integers(-6, 6, n)
        assert _median(values) == float(np.median(values))


def console_run(args: list[str], env_extra: dict) -> subprocess.CompletedProcess:
    """``python -m phongscene ARGS`` with an exit handler that prints the BLAS thread variable:
    it shows that exit handlers run and that block-buffered output (a pipe, no
    PYTHONUNBUFFERED) is flushed before the process ends."""
    env = {
        k: v
        for k, v in os.environ.items()
        if k not in ("PYTHONUNBUFFERED", "OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS")
    }
    env.update(env_extra)
    code = (
        "import atexit, os, runpy, sys\n"
        "atexit.register(lambda: print('at exit: OPENBLAS_NUM_THREADS', os.environ.get('OPENBLAS_NUM_THREADS')))\n"
        f"sys.argv = ['phongscene', *{args!r}]\n"
        "runpy.run_module('phongscene', run_name='__main__')\n"
    )
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)


@pytest.mark.subprocess
def test_the_phongscene_process_uses_one_blas_thread_runs_exit_handlers_and_flushes_output(tmp_path):
    out = tmp_path / "a.exr"
    done = console_run(["render", str(EXAMPLE), "-o", str(out), "--width", "8", "--height", "6"], {})
    assert done.returncode == 0, done.stderr
    assert f"{out}: 8 x 6" in done.stdout
    assert done.stdout.rstrip().endswith("at exit: OPENBLAS_NUM_THREADS 1")
    assert np.array_equal(read_image(out).shape, (6, 8, 3))


@pytest.mark.subprocess
def test_the_phongscene_process_keeps_a_users_blas_threads_and_its_exit_status(tmp_path):
    done = console_run(
        ["render", str(tmp_path / "missing.usda"), "-o", str(tmp_path / "a.exr")], {"OMP_NUM_THREADS": "2"}
    )
    assert done.returncode == 2
    assert "file not found" in done.stderr
    assert done.stdout.rstrip().endswith("at exit: OPENBLAS_NUM_THREADS None")
