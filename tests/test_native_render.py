# SPDX-License-Identifier: Apache-2.0
"""The native tracer's images: per-pixel agreement with the independent numpy oracle on every
calibration scene (both specular conventions), scale invariance from 1e-6 to 1e6 units, hard
shading cases, thread-count determinism, progress, Ctrl-C and memory."""

from __future__ import annotations

import _thread
import dataclasses
import math
import threading
import time

import calibration
import numpy as np
import oracle
import pytest

from phongscene.backends import native
from phongscene.scene import (
    AmbientLight,
    PhongMaterial,
    PointLight,
    RenderSettings,
    Scene,
    Sphere,
)

# The native image is stored as float32, whose rounding is 2^-24 ≈ 6e-8 relative; everything
# before that is float64 in both renderers. 1e-6 relative leaves 16x headroom for the different
# (but equally exact) formulas, and no more: a pixel whose shadow or silhouette decision differs
# is off by orders of magnitude more.
ORACLE_RELATIVE_TOLERANCE = 1e-6
# Shading sums non-negative terms, so there is no cancellation and exact zeros (unlit black) come
# out exactly zero in both; the floor only absorbs float32 rounding of denormal-sized values.
ORACLE_ABSOLUTE_FLOOR = 1e-30


def assert_matches_oracle(image: np.ndarray, expected: np.ndarray) -> None:
    assert image.dtype == np.float32 and image.shape == expected.shape
    error = np.abs(image.astype(np.float64) - expected)
    allowed = ORACLE_RELATIVE_TOLERANCE * np.abs(expected) + ORACLE_ABSOLUTE_FLOOR
    bad = np.argwhere((error > allowed).any(axis=2))
    assert len(bad) == 0, (
        f"{len(bad)} pixels differ from the oracle, e.g. (row, col) {bad[:5].tolist()}: "
        f"native {image[tuple(bad[0])]}, oracle {expected[tuple(bad[0])]}"
    )


@pytest.mark.parametrize("convention", ["seed", "povray-classic"])
@pytest.mark.parametrize("name", list(calibration.SCENES))
def test_native_matches_oracle_on_calibration_scene(name, convention):
    scene = calibration.SCENES[name]()
    if convention == "povray-classic":
        scene = calibration.classic_variant(scene)
    else:
        scene = dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, specular="seed"))
    assert_matches_oracle(native.render(scene), oracle.render(scene))


# ---------------------------------------------------------------------------------------------
# Scale invariance: our tolerances are relative to the scene's magnitude (src/math.hpp).

# Scaling by 1e±6 is not exact in binary, so coordinates differ by ~1 ulp between the scaled
# copies; a pixel's value then moves by ~1e-15 relative, far below float32's 6e-8. 1e-6 relative
# (as for the oracle) still catches any changed shadow, silhouette or highlight decision.
SCALE_RELATIVE_TOLERANCE = 1e-6


def scaled(scene: Scene, k: float) -> Scene:
    """The scene with every length multiplied by k (geometry, camera, lights, fade distance)."""
    s = np.diag([k, k, k, 1.0])

    def pos(p):
        return tuple(k * np.asarray(p, dtype=np.float64))

    lights = []
    for light in scene.lights:
        changes = {}
        for field in ("position", "center", "axis_u", "axis_v"):
            if hasattr(light, field):
                changes[field] = pos(getattr(light, field))
        for field in ("radius", "fade_distance"):
            if hasattr(light, field):
                changes[field] = k * getattr(light, field)
        lights.append(dataclasses.replace(light, **changes))
    return dataclasses.replace(
        scene,
        camera=dataclasses.replace(scene.camera, position=pos(scene.camera.position),
                                   ortho_width=k * scene.camera.ortho_width),
        lights=tuple(lights),
        spheres=tuple(dataclasses.replace(sp, world_from_object=s @ sp.world_from_object) for sp in scene.spheres),
        meshes=tuple(dataclasses.replace(m, points=k * m.points) for m in scene.meshes),
    )


@pytest.mark.parametrize("name", ["shadows_two_lights", "rect_area_light", "sphere_area_light", "smooth_mesh",
                                  "orthographic", "fade"])
def test_native_image_is_the_same_from_1e_minus_6_to_1e6_units(name):
    scene = calibration.SCENES[name]()
    reference = native.render(scene).astype(np.float64)
    for k in (1e-6, 1e6):
        image = native.render(scaled(scene, k)).astype(np.float64)
        error = np.abs(image - reference)
        assert (error <= SCALE_RELATIVE_TOLERANCE * np.abs(reference) + ORACLE_ABSOLUTE_FLOOR).all(), (
            f"scale {k}: {int((error > SCALE_RELATIVE_TOLERANCE * np.abs(reference)).any(axis=2).sum())} pixels differ"
        )


def test_povray_absolute_tolerances_lose_shadows_at_1e_minus_6_units():
    # The oracle uses POV-Ray's absolute tolerances (shadow occluders need t > 1e-3): at 1e-6
    # units every shadow vanishes, which is what POV-Ray renders; ours keeps them (above).
    scene = calibration.SCENES["shadows_two_lights"]()
    small = scaled(scene, 1e-6)
    assert np.abs(oracle.render(small) - oracle.render(scene)).max() > 0.05
    assert np.abs(native.render(small) - native.render(scene)).max() < 1e-5


# ---------------------------------------------------------------------------------------------
# Hard shading cases


def _highlight_scene(exponent: float, convention: str, size: int = 33) -> Scene:
    # Light at the eye, sphere on the axis: the highlight peak r·wo = 1 sits on the centre pixel.
    camera = calibration.look_at((0.0, 0.0, 4.0), (0.0, 0.0, 0.0), horizontal_fov_deg=40.0)
    material = PhongMaterial(ka=0.1, kd=0.6, ks=0.7, exponent=exponent, diffuse_color=(0.8, 0.5, 0.3))
    return Scene(
        camera=camera,
        ambient=AmbientLight((0.2, 0.2, 0.2)),
        lights=(PointLight((0.0, 0.0, 4.0), (1.5, 1.5, 1.5)),),
        spheres=(Sphere.at((0.0, 0.0, 0.0), 1.0, material),),
        settings=RenderSettings(width=size, height=size, specular=convention),
    )


@pytest.mark.parametrize("convention", ["seed", "povray-classic"])
@pytest.mark.parametrize("exponent", [1e4, 1e6])
def test_huge_exponents_give_finite_pixels_and_the_exact_peak(exponent, convention):
    scene = _highlight_scene(exponent, convention)
    image = native.render(scene)
    assert np.isfinite(image).all()
    # Upper bound anywhere: ka·cd·La + (kd·cd/π + ks)·L (all cosines <= 1).
    m = scene.spheres[0].material
    bound = m.ka * np.array(m.diffuse_color) * 0.2 + (m.kd * np.array(m.diffuse_color) / math.pi + m.ks) * 1.5
    assert (image <= bound * (1 + 1e-6)).all()
    assert_matches_oracle(image, oracle.render(scene))
    # The centre pixel looks straight at the peak: r·wo = 1 up to rounding, so the highlight is
    # ks·L·(n·l = 1) even at e = 1e6 (1 - 1e-16)^1e6 = 1 - 1e-10.
    centre = image[16, 16].astype(np.float64)
    assert centre == pytest.approx(bound, rel=1e-5)


# ---------------------------------------------------------------------------------------------
# Threads, progress, interruption, memory


@pytest.mark.parametrize("light", ["rect", "sphere"])
def test_area_light_shadows_of_a_mesh_match_the_oracle(light):
    # Area-light shadow rays are traced as bundles against the primitives their pyramid can
    # reach (native src/scene.cpp), or, past a few dozen candidates, one BVH walk per ray. A
    # flat 320-triangle icosphere and a sphere over a ground quad give both kinds of points (and
    # points whose floor drops out of the bundle), each checked against the oracle.
    scene = calibration.smooth_mesh()
    mesh = calibration.icosphere(2, (0.07, 1.08, -0.13), 1.03, calibration.GOLD, smooth=False)
    area = (
        calibration.RectAreaLight(center=(2.37, 4.11, 1.63), axis_u=(1.7, 0.0, 0.3), axis_v=(-0.2, 0.1, 1.3),
                                  color=(3.2, 3.1, 2.9), samples=5)
        if light == "rect"
        else calibration.SphereAreaLight(center=(-2.13, 3.61, 2.27), radius=0.63, color=(3.1, 3.0, 3.2), samples=5)
    )
    scene = dataclasses.replace(
        scene,
        lights=(area,),
        spheres=(Sphere.at((1.63, 0.61, 0.93), 0.4, calibration.RED),),
        meshes=(mesh, scene.meshes[1]),
    )
    assert_matches_oracle(native.render(scene), oracle.render(scene))


def test_thread_count_does_not_change_a_single_bit():
    scene = calibration.SCENES["rect_area_light"]()
    images = [native.render(scene, dataclasses.replace(scene.settings, threads=n)) for n in (1, 2, 3)]
    assert images[0].tobytes() == images[1].tobytes() == images[2].tobytes()


def test_progress_reports_tiles_in_order_and_ends_complete():
    scene = calibration.SCENES["point_light"]()
    calls: list[tuple[int, int]] = []
    native.render(scene, progress=lambda done, total: calls.append((done, total)))
    assert calls, "progress was never called"
    totals = {t for _, t in calls}
    assert totals == {math.ceil(64 / 16) * math.ceil(48 / 16)}  # 16-pixel tiles
    done = [d for d, _ in calls]
    assert done == sorted(done) and done[-1] == calls[-1][1]


def _slow_scene() -> Scene:
    # ~ several seconds of work: a big image with a 17x17 area light.
    scene = calibration.SCENES["rect_area_light"]()
    light = dataclasses.replace(scene.lights[0], samples=17)
    return dataclasses.replace(scene, lights=(light,), settings=RenderSettings(width=640, height=480, threads=2))


# Ctrl-C must stop the render within this long: the calling thread polls every 50 ms and the
# workers finish their current 16x16 tile (milliseconds), on a machine shared with other jobs.
INTERRUPT_LATENCY_S = 1.0


def test_progress_callback_exception_stops_the_render_and_the_next_render_works():
    scene = _slow_scene()

    def stop(done, total):
        raise KeyboardInterrupt

    start = time.perf_counter()
    with pytest.raises(KeyboardInterrupt):
        native.render(scene, progress=stop)
    assert time.perf_counter() - start < INTERRUPT_LATENCY_S
    small = calibration.SCENES["point_light"]()
    assert_matches_oracle(native.render(small), oracle.render(small))


def test_ctrl_c_raises_keyboard_interrupt_promptly():
    scene = _slow_scene()
    fired = []

    def interrupt():
        fired.append(time.perf_counter())
        _thread.interrupt_main()  # as if SIGINT arrived

    timer = threading.Timer(0.3, interrupt)
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            native.render(scene)
        raised = time.perf_counter()
    finally:
        timer.cancel()
    assert fired and raised - fired[0] < INTERRUPT_LATENCY_S
    assert native.render(calibration.SCENES["point_light"]()).shape == (48, 64, 3)


def _rss_bytes() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096


# 100 renders of a 64x48 scene allocate ~100 x 37 kB of images plus the scene copies; a leak of
# any of them per render would exceed 4 MB. Allocator caching and Python's own growth stay below.
MEMORY_GROWTH_LIMIT_BYTES = 4 * 1024 * 1024


def test_no_memory_growth_over_100_renders():
    scene = calibration.SCENES["smooth_mesh"]()
    for _ in range(10):  # warm up allocator pools and caches
        native.render(scene)
    before = _rss_bytes()
    for _ in range(100):
        native.render(scene)
    assert _rss_bytes() - before < MEMORY_GROWTH_LIMIT_BYTES
