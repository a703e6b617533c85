# SPDX-License-Identifier: Apache-2.0
"""POV-Ray renders of every calibration scene agree with the independent numpy oracle to
half-float precision under both mappings (exact ↔ seed, classic ↔ povray-classic); and the
runner's failure modes: POV-Ray missing, failing, timing out; temporary files; progress.

All calibration renders run in one ``render_many`` call: one POV-Ray process per distinct
image size / anti-aliasing switches, each scene (and each exact-mapping pass) a frame.

POV-Ray facts cite ``docs/povray-3.7-semantics.md`` as "ref §n"."""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from phongscene.backends import povray
from phongscene.backends.povray import run
from phongscene.errors import BackendError, SceneError
from phongscene.scene import PhongMaterial, PointLight, RenderSettings, Scene, Sphere, TriangleMesh
from support import calibration, oracle

# POV-Ray writes half-float EXR (ref §2): round-to-nearest half is within 2^-11 relative of the
# value it stores.
HALF_ULP_REL = 2.0**-11
# What POV-Ray computes before that rounding differs from the float64 oracle by float32 colour
# arithmetic (~1e-7 relative) and, in the exact mapping, by the NdotL colour_map's linear
# interpolation of sin (< (pi/256)^2/8 = 1.9e-5 relative, see test_ndotl_map_inverts_the_slope_value).
INTERNAL_REL = 2e-5
# Below 2^-14 half floats are subnormal with a fixed spacing of 2^-24: the relative bound no
# longer holds there, one subnormal step does.
HALF_SUBNORMAL_STEP = 2.0**-24
# POV-Ray's shadow cache (ref §6) tests the last occluder with the looser window t >= 1e-4
# instead of t > 1e-3, so a few pixels on a self-shadow terminator (area-light samples, smooth
# mesh normals) depend on the previous pixel. +WT1 does not remove it (the cache is per thread,
# one thread still has one). Such pixels are allowed only if the oracle reproduces them with
# that window, and only this many per image (ref §5 saw 1-7 of 6912).
SHADOW_CACHE_MAX_PIXELS = 8
SHADOW_CACHE_WINDOW = 1e-4  # = oracle.MIN_ISECT_DEPTH: the cached occluder's lower bound

MAPPING_CONVENTION = {"exact": "seed", "classic": "povray-classic"}
CASES = [(name, mapping) for name in calibration.SCENES for mapping in MAPPING_CONVENTION]


def _variant(name: str, mapping: str) -> Scene:
    scene = calibration.SCENES[name]()
    # POV-Ray's refracted rays carry kt, without the book's 1/η², and it fades only what a surface
    # transmits (docs/reflection.md): the oracle renders in its transmission convention.
    return dataclasses.replace(
        scene, settings=dataclasses.replace(scene.settings, specular=MAPPING_CONVENTION[mapping], transmission="povray")
    )


def _within(image: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """Per-pixel agreement: every channel within half-float precision of the oracle."""
    tolerance = (HALF_ULP_REL + INTERNAL_REL) * np.abs(ref) + HALF_SUBNORMAL_STEP
    return np.all(np.abs(image.astype(np.float64) - ref) <= tolerance, axis=-1)


@pytest.fixture(scope="module")
def calibration_renders(tmp_path_factory):
    keep = tmp_path_factory.mktemp("povray-calibration")
    scenes = [_variant(name, mapping) for name, mapping in CASES]
    images = povray.render_many([(s, None, m) for s, (_, m) in zip(scenes, CASES)], keep_dir=str(keep))
    return dict(zip(CASES, zip(scenes, images))), keep


@pytest.mark.slow
@pytest.mark.povray
@pytest.mark.parametrize("name,mapping", CASES, ids=[f"{n}-{m}" for n, m in CASES])
def test_calibration_scene_matches_oracle(calibration_renders, name, mapping, monkeypatch):
    scene, image = calibration_renders[0][(name, mapping)]
    s = scene.settings
    assert image.shape == (s.height, s.width, 3) and image.dtype == np.float32
    ref = oracle.render(oracle.with_half_texels(scene))
    ok = _within(image, ref)
    if ok.all():
        return
    outliers = np.argwhere(~ok)
    assert len(outliers) <= SHADOW_CACHE_MAX_PIXELS, (
        f"{len(outliers)} pixels off, e.g. (row, col) {outliers[:5].tolist()}"
    )
    monkeypatch.setattr(oracle, "SHADOW_TOLERANCE", SHADOW_CACHE_WINDOW)
    cached = oracle.render(oracle.with_half_texels(scene))
    explained = _within(image, cached)
    for row, col in outliers:
        assert explained[row, col], (
            f"pixel (col {col}, row {row}): POV {image[row, col]} vs oracle {ref[row, col]}, "
            f"not explained by the shadow cache either ({cached[row, col]})"
        )


@pytest.mark.povray
@pytest.mark.slow
def test_calibration_runs_one_process_per_image_format(calibration_renders):
    _, keep = calibration_renders
    formats = {run.render_switches(scene.settings) for scene, _ in calibration_renders[0].values()}
    assert len(list(Path(keep).glob("*.pov"))) == len(formats) < len(CASES)


def _two_light_scene() -> Scene:
    return Scene(
        camera=calibration.look_at((0.0, 1.0, 5.0), (0.0, 0.0, 0.0)),
        lights=(PointLight((3.0, 4.0, 5.0), (1.0, 0.9, 0.8)), PointLight((-4.0, 2.0, 3.0), (0.3, 0.4, 0.5))),
        spheres=(
            Sphere.at((0.0, 0.0, 0.0), 1.0, PhongMaterial(ks=0.5, exponent=30.0, specular_color=(0.9, 0.6, 0.3))),
        ),
        settings=RenderSettings(width=24, height=18, background=(0.05, 0.1, 0.2)),
    )


@pytest.mark.povray
def test_progress_temporary_files_and_pass_sum(tmp_path, monkeypatch):
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    calls = []
    scene = _two_light_scene()
    image = povray.render(scene, progress=lambda done, total: calls.append((done, total)))
    assert calls[0] == (0, 2) and calls[-1] == (2, 2)
    assert all(a[0] <= b[0] for a, b in zip(calls, calls[1:]))
    assert list(tmp_path.iterdir()) == []  # the temporary render directory is gone
    # Two passes summed = the seed model with both lights (and the background only once).
    assert _within(image, oracle.render(scene)).all()


def test_missing_povray_is_one_clear_line(monkeypatch, tmp_path):
    monkeypatch.setenv("PATH", str(tmp_path))
    with pytest.raises(BackendError) as e:
        povray.render(_two_light_scene())
    assert "\n" not in str(e.value)
    assert "apt-get install povray" in str(e.value)


@pytest.mark.povray
def test_a_compile_error_while_the_sdl_is_written_keeps_no_half_file(tmp_path):
    # The SDL is compiled into the .pov as it is written; a number the compiler refuses after
    # the camera and lights are out (float32 overflow) removes the partial file, kept folder or not.
    huge = TriangleMesh([[0, 0, 0], [1e100, 0, 0], [0, 1, 0]], [[0, 1, 2]], source="/World/Huge")
    scene = dataclasses.replace(_two_light_scene(), meshes=(huge,))
    kept = tmp_path / "kept"
    with pytest.raises(SceneError, match=r"/World/Huge\.points"):
        povray.render(scene, keep_dir=str(kept))
    assert not list(kept.glob("*.pov"))


@pytest.mark.povray
def test_povray_failure_reports_the_tail_and_keeps_the_pov(monkeypatch, tmp_path):
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    monkeypatch.setattr(run, "write_pov", lambda out, **k: out.write("#version 3.7;\nsphere { <0, 0, 0>, 1 oops }\n"))
    with pytest.raises(BackendError) as e:
        povray.render(_two_light_scene())
    assert "POV-Ray failed" in str(e.value)
    assert "Parse Error" in e.value.detail and "line 2" in e.value.detail
    kept = Path(e.value.kept)
    assert kept.exists() and "oops" in kept.read_text()
    assert str(kept) in str(e.value)


@pytest.mark.povray
def test_timeout_stops_povray_and_keeps_the_pov(monkeypatch, tmp_path):
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    scene = _two_light_scene()
    scene = dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, width=1200, height=900))
    with pytest.raises(BackendError, match="timed out after 0.2 s") as e:
        povray.render(scene, timeout=0.2)
    assert Path(e.value.kept).exists()


@pytest.mark.povray
def test_keep_dir_holds_the_sdl_ini_and_frames(tmp_path):
    povray.render(_two_light_scene(), keep_dir=str(tmp_path))
    names = sorted(p.name for p in tmp_path.iterdir())
    assert {"scene.pov", "scene.ini", "scene0.exr", "scene1.exr"} <= set(names)
    conf = (tmp_path / "home" / ".povray" / "3.7" / "povray.conf").read_text()
    assert "restricted" in conf and "forbidden" in conf
    assert os.path.getsize(tmp_path / "scene.pov") > 0


@pytest.mark.povray
def test_interrupt_removes_the_temporary_directory(monkeypatch, tmp_path):
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))

    def interrupted(path):
        raise KeyboardInterrupt

    monkeypatch.setattr(run, "read_image", interrupted)
    with pytest.raises(KeyboardInterrupt):
        povray.render(_two_light_scene())
    assert list(tmp_path.iterdir()) == []


def _light_on_the_surface() -> Scene:
    from phongscene.scene import Camera, TriangleMesh

    quad = TriangleMesh(
        [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]],
        [[0, 1, 2], [0, 2, 3]],
        material=PhongMaterial(ka=0.5, diffuse_color=(1, 1, 1)),
    )
    return Scene(
        camera=Camera((0, 0, 5), (0, 0, -1), (0, 1, 0), horizontal_fov_deg=20),
        ambient=dataclasses.replace(Scene().ambient, color=(0.2, 0.2, 0.2)),
        lights=(PointLight((0.0, 0.0, 0.0), (1, 1, 1)),),
        meshes=(quad,),
        settings=RenderSettings(width=9, height=9),
    )


def test_native_light_exactly_on_a_surface_point_gives_the_ambient_term():
    from phongscene.backends import native

    image = native.render(_light_on_the_surface())
    assert np.isfinite(image).all()
    np.testing.assert_allclose(image[4, 4], 0.5 * 0.2, rtol=1e-6)  # ka·cd·La only


@pytest.mark.povray
def test_povray_non_finite_pixels_are_an_error_not_an_image():
    with pytest.raises(BackendError, match=r"non-finite pixels, e.g. \(4, 4\)"):
        povray.render(_light_on_the_surface())


# A render's passes (one per light) are added as POV-Ray writes them (issue 29, item 4): its memory
# is the float64 sum, the frame being added and the float32 result, a few frames' worth whatever
# the light count (all passes kept, then copied to float64 and stacked, took ~80 frames' worth at
# 16 lights). The bound leaves room for OpenImageIO's read buffer and the reshape in between.
MANY_LIGHTS = 16
FRAMES_OF_MEMORY = 8


def _many_light_scene(lights: int, size: int) -> Scene:
    ring = [(4 * np.cos(a), 3.0, 4 * np.sin(a) + 2) for a in np.linspace(0, 2 * np.pi, lights, endpoint=False)]
    return Scene(
        camera=calibration.look_at((0.0, 1.0, 6.0), (0.0, 0.0, 0.0)),
        lights=tuple(PointLight(tuple(float(c) for c in p), (0.8 / lights,) * 3) for p in ring),
        spheres=(Sphere.at((0.0, 0.0, 0.0), 1.0, PhongMaterial(kd=0.6, ks=0.3, exponent=20.0)),),
        settings=RenderSettings(width=size, height=size),
    )


@pytest.mark.povray
@pytest.mark.slow
def test_passes_are_summed_as_they_arrive_in_memory_independent_of_the_light_count(tmp_path):
    size = 96
    scene = _many_light_scene(MANY_LIGHTS, size)
    kept = tmp_path / "kept"
    kept.mkdir()
    reference = povray.render(scene, keep_dir=str(kept))  # every frame file stays
    frames = [run.read_image(kept / f"scene{i:02d}.exr") for i in range(MANY_LIGHTS)]
    # The sum in pass order, as adding the whole list at once gave (float64, then float32).
    expected = np.sum([f.astype(np.float64) for f in frames], axis=0).astype(np.float32)
    np.testing.assert_array_equal(reference, expected)
    # Measured in a process of its own: tracemalloc counts every thread's allocations, and a
    # thread an earlier test left in this worker (a Dask cluster's event loop, say) once added
    # ~4 MB to the peak under a loaded full suite.
    code = (
        "import sys, tracemalloc, numpy as np\n"
        "sys.path.insert(0, sys.argv[1])\n"
        "from test_povray_render import _many_light_scene\n"
        "from phongscene.backends import povray\n"
        f"scene = _many_light_scene({MANY_LIGHTS}, {size})\n"
        "tracemalloc.start()\n"
        "image = povray.render(scene)\n"
        "_, peak = tracemalloc.get_traced_memory()\n"
        "tracemalloc.stop()\n"
        "np.save(sys.argv[2], image)\n"
        "print(peak)\n"
    )
    here = Path(__file__).parent
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(here.parent), os.environ.get("PYTHONPATH", "")])}
    out = tmp_path / "image.npy"
    done = subprocess.run(
        [sys.executable, "-c", code, str(here), str(out)], capture_output=True, text=True, env=env, check=False
    )
    assert done.returncode == 0, done.stderr
    peak = int(done.stdout.split()[-1])
    np.testing.assert_array_equal(np.load(out), reference)
    assert peak <= FRAMES_OF_MEMORY * size * size * 3 * 4, peak / (size * size * 12)


def test_the_sdl_is_written_as_it_is_compiled_in_pieces_and_whole(tmp_path, monkeypatch):
    # The compiler writes each line to the stream as it goes (lines longer than
    # SDL_WRITE_CHUNK in pieces: a large SDL is never encoded into one bytes copy); the file is
    # compile_pov's whole string, across piece boundaries, for the render path's save too.
    from phongscene.backends.povray import compile as pov_compile

    scene = calibration.smooth_mesh()  # a mesh2: lines of many pieces
    whole = povray.compile_pov(scene)
    writes: list[int] = []

    class Recording:
        def __init__(self, out):
            self.out = out

        def write(self, text: str) -> int:
            writes.append(len(text))
            return self.out.write(text)

    monkeypatch.setattr(pov_compile, "SDL_WRITE_CHUNK", 7)
    with open(tmp_path / "scene.pov", "w", encoding="ascii") as out:
        povray.write_pov(Recording(out), scene)
    assert (tmp_path / "scene.pov").read_text(encoding="ascii") == whole
    assert max(writes) <= 7 and len(writes) > len(whole) / 7
    povray.prepare(scene).save_sdl(tmp_path / "saved.pov")
    assert (tmp_path / "saved.pov").read_text(encoding="ascii") == whole


def test_mesh_lists_formatted_a_slice_at_a_time_are_the_whole_lists():
    # MESH_ROWS_PER_PIECE rows a piece, joined with ",\n": the same text as formatting a list at
    # once (int_vectors puts four entries a line, so the slice must be a multiple of four).
    from phongscene.backends.povray import compile as pov_compile

    scene = calibration.smooth_mesh()
    mesh = scene.meshes[0]  # the icosphere, with normals
    n = len(mesh.points)
    uvs = np.stack([np.linspace(0.0, 1.0, n), np.linspace(1.0, 0.0, n)], axis=1)
    # normal_indices other than the faces' (so they are written), uvs indexed per triangle
    textured = dataclasses.replace(
        mesh, uvs=uvs, uv_indices=mesh.triangles[::-1].copy(), normal_indices=mesh.triangles[:, ::-1].copy()
    )
    scene = dataclasses.replace(scene, meshes=(textured, *scene.meshes[1:]))
    whole = povray.compile_pov(scene)
    assert len(mesh.triangles) > 8 and "uv_vectors" in whole and "normal_indices" in whole
    old = pov_compile.MESH_ROWS_PER_PIECE
    try:
        for rows in (4, 8):
            pov_compile.MESH_ROWS_PER_PIECE = rows
            assert povray.compile_pov(scene) == whole
    finally:
        pov_compile.MESH_ROWS_PER_PIECE = old
