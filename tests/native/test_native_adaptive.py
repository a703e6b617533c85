# SPDX-License-Identifier: Apache-2.0
"""POV-Ray's adaptive estimators in the native tracer (issue 12): `adaptive n` area lights and
+AM1 / +AM2 with a threshold. Their agreement with POV-Ray is in tests/cross/test_cross_backend.py
(``ADAPTIVE_SCENES``); here: the scenes really exercise the adaptive rules (so that agreement
means something), the estimators are deterministic for any thread count, and the knobs travel
through validation, USD and the POV-Ray command line."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from phongscene.backends.povray.compile import compile_pov
from phongscene.backends.povray.run import render_switches
from phongscene.errors import SceneError
from phongscene.rendering import render
from phongscene.scene import RenderSettings
from phongscene.usd import load_usd, write_usd
from phongscene.validate import validate
from support import calibration

# The adaptive estimators' scenes are dimly lit on purpose (partial shadows at low radiance):
# the image checks' "too dark" ImageWarning is not what these tests test.
pytestmark = pytest.mark.filterwarnings("ignore::phongscene.errors.ImageWarning")

R = dataclasses.replace
# A pixel counts as changed by the adaptive rule when it moves by more than float32 rounding
# of values near 1 (2^-23 ≈ 1.2e-7), with margin.
CHANGED = 1e-6


def _full(scene):
    """The same scene with the non-adaptive estimator (every grid point / every sample)."""
    lights = tuple(R(light, adaptive=None) if hasattr(light, "adaptive") else light for light in scene.lights)
    return R(scene, lights=lights, settings=R(scene.settings, aa_threshold=0.0))


@pytest.mark.parametrize(
    "name, at_least",
    [
        ("adaptive_rect_light_levels", 100),  # 9 grid points of 289 change the whole penumbra
        ("adaptive_sphere_light_threshold", 5),  # only where a region's corners agree
        ("adaptive_am1", 1000),  # unsupersampled pixels keep their centre colour
        ("adaptive_am2", 1000),
        ("adaptive_glass_rect_light", 100),  # regions across the glass shadow's edge do not split
        ("adaptive_glass_sphere_light", 100),
    ],
)
def test_adaptive_scenes_differ_from_the_full_estimators(name, at_least):
    scene = calibration.ADAPTIVE_SCENES[name]()
    adaptive = render(scene, "native")
    full = render(_full(scene), "native")
    changed = int((np.abs(adaptive - full) > CHANGED).any(axis=2).sum())
    assert changed >= at_least, f"{name}: only {changed} pixels differ from the full estimator"


def test_adaptive_am1_supersamples_only_near_edges():
    scene = calibration.ADAPTIVE_SCENES["adaptive_am1"]()
    one = render(R(scene, settings=R(scene.settings, samples=1, sample_pattern="grid")), "native")
    adaptive = render(scene, "native")
    same = (np.abs(adaptive - one) <= CHANGED).all(axis=2)
    # Most pixels (flat shading) keep the centre sample; the supersampled ones are a minority.
    assert 0.5 < same.mean() < 1.0


@pytest.mark.parametrize("name", sorted(calibration.ADAPTIVE_SCENES))
def test_adaptive_estimators_are_the_same_for_any_thread_count(name):
    scene = calibration.ADAPTIVE_SCENES[name]()
    images = [render(scene, "native", R(scene.settings, threads=t)) for t in (1, 2, 7)]
    assert all(np.array_equal(images[0], im) for im in images[1:])


def test_threshold_and_adaptive_are_validated():
    scene = calibration.ADAPTIVE_SCENES["adaptive_rect_light_levels"]()
    bad = R(scene, settings=R(scene.settings, aa_threshold=1.5), lights=(R(scene.lights[0], adaptive=-1),))
    fields = {problem.attribute for problem in validate(bad)}
    assert {"aa_threshold", "adaptive"} <= fields
    with pytest.raises(SceneError, match="adaptive"):
        render(bad, "native")


def test_knobs_round_trip_through_usd(tmp_path):
    scene = calibration.ADAPTIVE_SCENES["adaptive_rect_light_levels"]()
    scene = R(scene, settings=R(scene.settings, sample_pattern="povray-am2", samples=3, aa_threshold=0.05))
    back = load_usd(write_usd(scene, tmp_path / "s.usda"))
    assert back.lights[0].adaptive == 1
    assert back.settings.sample_pattern == "povray-am2"
    assert back.settings.aa_threshold == pytest.approx(0.05)
    assert "phong:shadowAdaptive = 1" in (tmp_path / "s.usda").read_text()


def test_povray_gets_the_adaptive_switches_and_sdl():
    *_, switches = render_switches(RenderSettings(samples=3, sample_pattern="povray-am1", aa_threshold=0.03))
    assert {"+AM1", "+A0.03", "+R3"} <= set(switches) and "-A" not in switches
    *_, switches = render_switches(RenderSettings(samples=2, sample_pattern="povray-am2", aa_threshold=0.0))
    assert {"+AM2", "+A0.0", "+R2"} <= set(switches) and "-A" not in switches
    sdl = compile_pov(calibration.ADAPTIVE_SCENES["adaptive_sphere_light_threshold"](), mapping="classic")
    assert " adaptive 0 circular orient" in sdl


def test_exact_mapping_passes_decide_adaptive_aa_on_their_own():
    """With several lights the exact mapping's POV-Ray passes supersample different pixels than
    the summed image would (the cross-backend test shows the per-pass image is POV-Ray's)."""
    from phongscene.crossvalidation import render_native_as_povray
    from phongscene.rendering import settings_for

    scene = calibration.ADAPTIVE_SCENES["adaptive_am1_two_lights"]()
    settings = settings_for(scene, mapping="exact")
    whole = render(scene, "native", settings)
    passes = render_native_as_povray(scene, settings, "exact")
    assert int((np.abs(whole - passes) > CHANGED).any(axis=2).sum()) > 10
    # Without a threshold (every pixel supersampled) the passes add up to the whole image.
    full = R(settings, aa_threshold=0.0)
    assert np.array_equal(render_native_as_povray(scene, full, "exact"), render(scene, "native", full))


# -- the native stratified estimator ------------------------------------------------------------


def _stratified(scene, n, threshold, size=(48, 36)):
    settings = R(
        scene.settings, width=size[0], height=size[1], samples=n, sample_pattern="stratified", aa_threshold=threshold
    )
    return render(scene, "native", settings).astype(np.float64)


def test_stratified_converges_to_the_grid_limit():
    """Without early stop, 4, 16, 64 and 256 points of the (0,2)-sequence approach the pixel's
    box-filtered value (here: the 9×9 grid at 3× resolution box-filtered, 27² points): the RMS
    error falls at every step and ends well below the 6×6 grid's."""
    from phongscene.bench import box_down

    scene = calibration.point_light()
    big = R(scene.settings, width=144, height=108, samples=9, sample_pattern="grid")
    reference = box_down(render(scene, "native", big), 3)
    errors = [float(np.sqrt(np.mean((_stratified(scene, n, 0.0) - reference) ** 2))) for n in (2, 4, 8, 16)]
    assert all(b < a for a, b in zip(errors, errors[1:])), errors
    grid6 = render(scene, "native", R(scene.settings, width=48, height=36, samples=6, sample_pattern="grid"))
    assert errors[2] < float(np.sqrt(np.mean((grid6 - reference) ** 2)))


def test_stratified_with_a_threshold_keeps_flat_pixels_at_their_corner_mean():
    scene = calibration.point_light()
    full = _stratified(scene, 8, 0.0)
    adaptive = _stratified(scene, 8, 0.05)
    changed = (np.abs(adaptive - full) > CHANGED).any(axis=2)
    # Flat (shaded, smooth) pixels take the corner mean, which differs from the 64-point mean
    # by the shading's curvature only; edge pixels are refined and agree to a few percent.
    assert 0 < changed.mean() < 1
    assert float(np.max(np.abs(adaptive - full))) < 0.05


def test_stratified_is_the_same_for_any_thread_count():
    scene = calibration.ADAPTIVE_SCENES["adaptive_am1"]()
    settings = R(scene.settings, sample_pattern="stratified", samples=8, aa_threshold=0.02)
    images = [render(scene, "native", R(settings, threads=t)) for t in (1, 3)]
    assert np.array_equal(images[0], images[1])


def test_stratified_is_native_only_and_may_use_up_to_16_per_axis():
    scene = calibration.point_light()
    ok = R(scene.settings, width=8, height=6, samples=16, sample_pattern="stratified")
    assert not validate(R(scene, settings=ok))
    assert {p.attribute for p in validate(R(scene, settings=R(ok, sample_pattern="grid")))} == {"samples"}
    with pytest.raises(SceneError, match="native tracer's own"):
        render_switches(R(ok, samples=4))


def test_cli_rejects_more_than_9_samples_except_for_stratified(tmp_path, capsys):
    from phongscene.cli import main

    path = write_usd(calibration.point_light(), tmp_path / "scene.usda")
    assert main(["render", str(path), "-o", str(tmp_path / "a.exr"), "--spp", "10"]) == 2
    assert "phong:samples" in capsys.readouterr().err
    assert (
        main(
            [
                "render",
                str(path),
                "-o",
                str(tmp_path / "b.exr"),
                "--spp",
                "10",
                "--width",
                "8",
                "--sample-pattern",
                "stratified",
                "--aa-threshold",
                "0.05",
            ]
        )
        == 0
    )


@pytest.mark.parametrize(
    "change",
    [
        {"samples": 10, "sample_pattern": "povray-am2"},
        {"aa_threshold": float("nan")},
        {"samples": 17, "sample_pattern": "stratified"},
    ],
)
def test_the_extension_refuses_settings_validation_would_reject(change):
    """Validation runs in Python; the extension still refuses what would make it misbehave (a
    2^(n-1)-sized +AM2 buffer, a NaN threshold), with an error and not a crash."""
    from phongscene.backends import native

    scene = calibration.point_light()
    built = native.build(scene)
    settings = native._settings(R(scene.settings, width=4, height=3, **change))
    with pytest.raises(ValueError):
        built.render(native._camera(scene.camera), settings)


# -- the native adaptive quadtree (adaptive_pixels.hpp) -------------------------------------------

# The split rule's side exponent (adaptive_pixels.hpp, kAdaptiveSideExponent).
SIDE_EXPONENT = 1.5
# A cell whose weighted spread is this close to the threshold (relative) may split in one
# implementation and not the other from float rounding alone (native and oracle agree to ~1e-7):
# its pixel is not compared.
DECISION_MARGIN = 1e-5
# Native against the oracle: the project's 1e-6 relative (plus an absolute floor for zeros).
ORACLE_RELATIVE, ORACLE_ABSOLUTE = 1e-6, 1e-9


def _quadtree_from_lattice(lattice, width, height, n, threshold):
    """The adaptive estimator written from its definition over a traced lattice (spacing 1/n):
    (image, mask of the pixels whose every split decision is clear of the threshold)."""
    image = np.zeros((height, width, 3))
    clear = np.ones((height, width), dtype=bool)

    def cell(j, i, x, y, s):
        c = lattice[[y, y, y + s, y + s], [x, x + s, x, x + s]]
        if s > 1:
            weighted = float(np.sum(c.max(axis=0) - c.min(axis=0))) * (s / n) ** SIDE_EXPONENT
            if threshold > 0 and abs(weighted - threshold) <= DECISION_MARGIN * threshold:  # at 0 all split
                clear[j, i] = False
            if weighted >= threshold:
                h = s // 2
                return (
                    cell(j, i, x, y, h)
                    + cell(j, i, x + h, y, h)
                    + cell(j, i, x, y + h, h)
                    + cell(j, i, x + h, y + h, h)
                ) / 4
        return c.mean(axis=0)

    for j in range(height):
        for i in range(width):
            image[j, i] = cell(j, i, i * n, j * n, n)
    return image, clear


@pytest.mark.parametrize("n, threshold", [(4, 0.05), (8, 0.01), (2, 0.0)])
def test_adaptive_equals_the_quadtree_over_oracle_rays(n, threshold):
    from support import oracle

    scene = calibration.point_light()
    width, height = 32, 24
    settings = R(
        scene.settings, width=width, height=height, samples=n, sample_pattern="adaptive", aa_threshold=threshold
    )
    xs, ys = np.meshgrid(np.arange(width * n + 1) / n, np.arange(height * n + 1) / n, indexing="xy")
    origins, directions = oracle.camera_rays(scene.camera, width, height, xs, ys)
    lattice = oracle.trace_rays(scene, origins, directions, settings).reshape(height * n + 1, width * n + 1, 3)
    expected, clear = _quadtree_from_lattice(lattice, width, height, n, threshold)
    native = render(scene, "native", settings).astype(np.float64)
    assert clear.mean() > 0.95
    np.testing.assert_allclose(native[clear], expected[clear], rtol=ORACLE_RELATIVE, atol=ORACLE_ABSOLUTE)
    if threshold > 0:  # the rule really is adaptive here: some pixels split, most do not
        full, _ = _quadtree_from_lattice(lattice, width, height, n, 0.0)
        split = (np.abs(expected - full) > CHANGED).any(axis=2)
        assert 0.01 < split.mean() < 0.9


@pytest.mark.slow
def test_adaptive_error_falls_with_depth_and_threshold():
    """Against a 48²-point stratified reference: finer cells (n) and lower thresholds reduce the
    RMS error; n = 16 at t = 0.001 ends below the 6×6 grid's error."""
    from phongscene.bench import box_down

    scene = calibration.point_light()
    big = R(scene.settings, width=144, height=108, samples=16, sample_pattern="stratified", aa_threshold=0.0)
    reference = box_down(render(scene, "native", big), 3)

    def error(**change):
        s = R(scene.settings, width=48, height=36, sample_pattern="adaptive", **change)
        return float(np.sqrt(np.mean((render(scene, "native", s) - reference) ** 2)))

    by_depth = [error(samples=n, aa_threshold=0.001) for n in (1, 2, 4, 8, 16)]
    assert all(b < a for a, b in zip(by_depth, by_depth[1:])), by_depth
    assert error(samples=8, aa_threshold=0.001) <= error(samples=8, aa_threshold=0.1)
    grid6 = render(scene, "native", R(scene.settings, width=48, height=36, samples=6, sample_pattern="grid"))
    assert by_depth[-1] < float(np.sqrt(np.mean((grid6 - reference) ** 2)))


def test_adaptive_is_the_same_for_any_thread_count():
    scene = calibration.ADAPTIVE_SCENES["adaptive_am1"]()
    settings = R(scene.settings, sample_pattern="adaptive", samples=16, aa_threshold=0.003)
    images = [render(scene, "native", R(settings, threads=t)) for t in (1, 3)]
    assert np.array_equal(images[0], images[1])


def test_adaptive_needs_a_power_of_two_and_is_native_only(tmp_path, capsys):
    from phongscene.backends import native
    from phongscene.cli import main

    scene = calibration.point_light()
    ok = R(scene.settings, width=8, height=6, samples=16, sample_pattern="adaptive", aa_threshold=0.01)
    assert not validate(R(scene, settings=ok))
    problems = validate(R(scene, settings=R(ok, samples=6)))
    assert [p.attribute for p in problems] == ["samples"] and "power of 2" in problems[0].message
    with pytest.raises(SceneError, match="native tracer's own"):
        render_switches(ok)
    with pytest.raises(ValueError, match="power of 2"):
        native.build(scene).render(native._camera(scene.camera), native._settings(R(ok, samples=6)))
    path = write_usd(R(scene, settings=ok), tmp_path / "scene.usda")
    assert load_usd(path).settings.sample_pattern == "adaptive"
    assert (
        main(
            [
                "render",
                str(path),
                "-o",
                str(tmp_path / "a.exr"),
                "--spp",
                "8",
                "--sample-pattern",
                "adaptive",
                "--aa-threshold",
                "0.01",
            ]
        )
        == 0
    )
    assert main(["render", str(path), "-o", str(tmp_path / "b.exr"), "--spp", "6", "--sample-pattern", "adaptive"]) == 2
    assert "power of 2" in capsys.readouterr().err


# -- the native cells shadow estimator (area_cells.hpp) ---------------------------------------------


def _with_light(scene, **change):
    return R(
        scene, lights=tuple(R(light, **change) if hasattr(light, "cell_samples") else light for light in scene.lights)
    )


def _shadow_rms(scene, reference, **change):
    image = render(_with_light(scene, **change), "native").astype(np.float64)
    return float(np.sqrt(np.mean((image - reference) ** 2)))


@pytest.mark.slow
@pytest.mark.parametrize("light", ["rect_area_light", "sphere_area_light"])
def test_cells_beat_their_grid_and_change_only_the_penumbra(light):
    """Against the 129² grid: the cells estimator on a 9² grid (4² points per partial cell) errs
    less than the 9² grid alone, and less than the 17² grid, which traces more rays everywhere;
    pixels in full light or full shadow (every grid point agrees) are the grid's, bit for bit."""
    scene = getattr(calibration, light)()
    reference = render(_with_light(scene, samples=129, adaptive=None), "native").astype(np.float64)
    cells = _shadow_rms(scene, reference, samples=9, adaptive=None, cell_samples=4)
    assert cells < _shadow_rms(scene, reference, samples=9, adaptive=None)
    assert cells < _shadow_rms(scene, reference, samples=17, adaptive=None)
    grid9 = render(_with_light(scene, samples=9, adaptive=None), "native")
    with_cells = render(_with_light(scene, samples=9, adaptive=None, cell_samples=4), "native")
    grid17 = render(_with_light(scene, samples=17, adaptive=None), "native")
    settled = (grid9 == grid17).all(axis=2) & (grid9 == reference.astype(np.float32)).all(axis=2)
    assert settled.mean() > 0.5
    assert np.array_equal(with_cells[settled], grid9[settled])
    assert not np.array_equal(with_cells, grid9)


def test_cells_on_povray_adaptive_refine_only_its_partial_cells():
    """`adaptive 2` with cells: POV-Ray's recursion, then the grid cells whose corners disagree
    are sampled inside; closer to the reference than `adaptive 2` alone."""
    scene = calibration.rect_area_light()
    reference = render(_with_light(scene, samples=129, adaptive=None), "native").astype(np.float64)
    alone = _shadow_rms(scene, reference, samples=17, adaptive=2)
    assert _shadow_rms(scene, reference, samples=17, adaptive=2, cell_samples=4) < alone


def test_cells_are_the_same_for_any_thread_count():
    scene = _with_light(calibration.sphere_area_light(), samples=9, adaptive=1, cell_samples=4)
    images = [render(scene, "native", R(scene.settings, threads=t)) for t in (1, 3)]
    assert np.array_equal(images[0], images[1])


def test_cells_knob_is_validated_travels_through_usd_and_the_cli_and_povray_refuses_it(tmp_path, capsys):
    from phongscene.cli import main

    scene = _with_light(calibration.rect_area_light(), cell_samples=4)
    assert not validate(scene)
    for bad in (3, 1, 32, True):
        assert [p.attribute for p in validate(_with_light(scene, cell_samples=bad))] == ["cell_samples"]
    path = write_usd(scene, tmp_path / "s.usda")
    assert "phong:shadowCellSamples = 4" in path.read_text()
    assert load_usd(path).lights[0].cell_samples == 4
    with pytest.raises(SceneError, match="shadowCellSamples|cell_samples"):
        compile_pov(scene, mapping="classic")
    plain = write_usd(calibration.rect_area_light(), tmp_path / "plain.usda")
    out = tmp_path / "a.exr"
    assert main(["render", str(plain), "-o", str(out), "--width", "24", "--shadow-cells", "4"]) == 0
    with pytest.raises(SystemExit) as usage:  # argparse's usage error
        main(["render", str(plain), "-o", str(out), "--width", "24", "--shadow-cells", "3"])
    assert usage.value.code == 2 and "power of 2" in capsys.readouterr().err


def test_command_line_estimator_combinations_name_the_option_not_the_file(tmp_path, capsys):
    """A bad --spp / --sample-pattern pair from the command line is an argparse-style error naming
    the option, before the scene is read (the file's /Render/Settings attribute is not at fault)."""
    from phongscene.cli import main

    scene = write_usd(calibration.point_light(), tmp_path / "scene.usda")
    runs = {
        ("render", "-o", str(tmp_path / "a.exr"), "--sample-pattern", "adaptive", "--spp", "3"): "argument --spp",
        (
            "render",
            "-o",
            str(tmp_path / "a.exr"),
            "--backend",
            "povray",
            "--sample-pattern",
            "adaptive",
        ): "argument --sample-pattern",
        ("diff", "-o", str(tmp_path / "report"), "--sample-pattern", "stratified"): "argument --sample-pattern",
        ("compile", "-o", str(tmp_path / "s.pov"), "--sample-pattern", "adaptive"): "argument --sample-pattern",
    }
    for (command, *options), named in runs.items():
        assert main([command, str(scene), *options]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"phongscene {command}: error: {named}") and "/Render" not in err, err
    assert (
        not (tmp_path / "a.exr").exists() and not (tmp_path / "report").exists() and not (tmp_path / "s.pov").exists()
    )
