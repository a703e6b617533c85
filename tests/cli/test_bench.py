# SPDX-License-Identifier: Apache-2.0
"""`phongscene bench` (phongscene/bench.py): the Pareto front, the dominance ratio and the
target query on rows whose answers are known, the reference's error bound, and an end-to-end
run on a tiny scene."""

from __future__ import annotations

import csv
import dataclasses
import json

import numpy as np
import pytest

from phongscene import bench
from phongscene.cli import main
from phongscene.usd import write_usd
from support import calibration

# Tiny images: the point is that every part runs and its numbers are consistent, not the figures.
TINY = (24, 18)


def _row(backend, label, cpu, error, family=bench.AA):
    return {"family": family, "label": label, "backend": backend, "cpu": cpu, "wall": cpu, "rms": error}


def test_pareto_front_keeps_only_undominated_points_by_increasing_cost():
    points = [(1.0, 5.0), (2.0, 3.0), (2.5, 4.0), (3.0, 1.0), (0.5, 9.0), (3.0, 2.0)]
    assert bench.pareto_front(points) == [4, 0, 1, 3]


def test_dominance_is_povrays_cost_over_natives_cheapest_at_each_povray_level():
    rows = [
        _row("povray", "p1", 1.0, 1e-2),
        _row("povray", "p2", 4.0, 1e-3),
        _row("povray", "slow", 5.0, 2e-2),
        _row("native", "n1", 0.1, 2e-2),
        _row("native", "n2", 0.2, 5e-3),
        _row("native", "n3", 1.0, 1e-3),
    ]
    d = bench.dominance(rows, bench.AA, "cpu")
    # POV-Ray's front: p1 (1e-2 at 1 s) and p2 (1e-3 at 4 s); native reaches 1e-2 at 0.2 s (5x)
    # and 1e-3 at 1 s (4x).
    assert [(x["povray"], x["native"]) for x in d["levels"]] == [("p1", "n2"), ("p2", "n3")]
    assert d["min_ratio"] == pytest.approx(4.0)


def test_dominance_counts_only_levels_the_reference_resolves():
    rows = [
        _row("povray", "p1", 1.0, 1e-2),
        _row("povray", "p2", 4.0, 1e-3),
        _row("native", "n1", 0.1, 1e-2),
        _row("native", "n2", 2.0, 1e-3),
    ]
    rows[1]["resolved"] = False  # p2's error is within 10x of the reference's own
    d = bench.dominance(rows, bench.AA, "cpu")
    assert [x["resolved"] for x in d["levels"]] == [True, False]
    assert d["min_ratio"] == pytest.approx(10.0)  # p2's 2x is listed, not counted
    assert "1 level(s) below what the reference resolves not counted" in bench.table(
        {"rows": [], "dominance": {bench.AA: {"cpu": d}}}
    )


def test_target_names_the_cheapest_setting_that_reaches_the_error():
    rows = [_row("native", "a", 0.3, 1e-3), _row("native", "b", 0.2, 2e-3), _row("povray", "c", 1.0, 5e-3)]
    lines = bench.target({"rows": rows}, 2e-3)
    assert any("native, by cpu time: b (0.200 s" in line for line in lines)
    assert any("povray, by cpu time: no setting reaches it" in line for line in lines)


def test_box_down_averages_blocks():
    image = np.arange(4 * 6 * 3, dtype=np.float32).reshape(4, 6, 3)
    down = bench.box_down(image, 2)
    assert down.shape == (2, 3, 3)
    assert down[0, 0, 0] == pytest.approx(np.mean(image[:2, :2, 0]))


def test_the_reference_error_bound_shrinks_with_the_reference():
    """The bound is the measured difference to the coarser twin over (ratio - 1): a finer scene
    (more samples) must not get a larger bound, and the bound is positive where edges exist."""
    scene = calibration.point_light()
    settings = dataclasses.replace(scene.settings, width=TINY[0], height=TINY[1])
    from phongscene.rendering import render

    ref = bench.reference(bench.AA, scene, settings, lambda s, st: render(s, "native", st))
    assert ref["image"].shape == (TINY[1], TINY[0], 3)
    assert 0 < ref["rms_error_bound"] < 1e-2


@pytest.mark.slow
def test_bench_cli_native_only_writes_table_csv_json_and_plot(tmp_path, capsys):
    path = write_usd(calibration.rect_area_light(), tmp_path / "scene.usda")
    out = tmp_path / "bench"
    code = main(
        [
            "bench",
            str(path),
            "-o",
            str(out),
            "--width",
            str(TINY[0]),
            "--repeat",
            "1",
            "--quick",
            "--native-only",
            "--target-rms",
            "1e-2",
        ]
    )
    assert code == 0
    printed = capsys.readouterr().out
    assert "am2 R3 A0.1" in printed and "area 9 adaptive 1" in printed and "target RMS 1.00e-02" in printed
    with (out / "bench.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert {r["family"] for r in rows} == {bench.AA, bench.AREA}
    data = json.loads((out / "bench.json").read_text())
    assert len(data["rows"]) == len(rows)
    # More samples of the same estimator never increase the error by much (grid 1 -> 3).
    grid = {r["label"]: float(r["rms"]) for r in rows if r["label"].startswith("grid")}
    assert grid["grid 3"] < grid["grid 1"]
    assert (out / "bench.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.slow
@pytest.mark.povray
def test_bench_measures_both_backends_and_povrays_estimators_match_natives(tmp_path):
    scene = calibration.point_light()
    settings = dataclasses.replace(scene.settings, width=TINY[0], height=TINY[1], specular="povray-classic")
    result = bench.run(scene, settings, repeat=1, quick=True, log=lambda line: None)
    by = {(r["label"], r["backend"]): r for r in result["rows"]}
    assert ("stratified 4 t0.03", "povray") not in by  # the native tracer's own estimator
    for label, backend in by:
        if backend == "native" and (label, "povray") in by:
            # The same estimator on both backends has the same error (to half precision).
            assert by[(label, "povray")]["rms"] == pytest.approx(by[(label, "native")]["rms"], rel=0.05, abs=1e-5)
    d = result["dominance"][bench.AA]["cpu"]
    assert d["min_ratio"] is not None and d["levels"]
    assert all(r["cpu"] > 0 and r["wall"] > 0 for r in result["rows"])


@pytest.mark.dask
def test_bench_settings_as_dask_tasks_measure_what_the_serial_run_measures(tmp_path):
    """Two workers, one task each: every row's errors equal the serial bench.run's (the renders
    are deterministic), in the same order, and the result says how many ran at once."""
    from phongscene import bench_tasks
    from phongscene.rendering import load_scene

    path = write_usd(calibration.rect_area_light(), tmp_path / "scene.usda")
    scene, _ = load_scene(path)
    settings = dataclasses.replace(scene.settings, width=TINY[0], height=TINY[1], threads=1)
    lines = []
    tasks = bench_tasks.run(
        str(path), scene, settings, repeat=1, quick=True, backends=("native",), workers=2, log=lines.append
    )
    serial = bench.run(scene, settings, repeat=1, quick=True, backends=("native",), log=lambda line: None)
    errors = lambda result: [(r["family"], r["label"], r["rms"], r["max"], r["bias"]) for r in result["rows"]]  # noqa: E731
    assert errors(tasks) == errors(serial)
    assert tasks["references"] == {
        f: r | {"seconds": tasks["references"][f]["seconds"]} for f, r in serial["references"].items()
    }
    assert tasks["concurrency"] == 2 and lines[0].startswith("2 settings at once: 2 Dask workers (LocalCluster)")
    assert len({r["pid"] for r in tasks["rows"]}) == 2  # both workers measured


def test_a_task_never_shares_its_cores():
    from phongscene.bench_tasks import slots_per_host

    assert [slots_per_host(2, t) for t in (0, 1, 2, 3)] == [1, 2, 1, 1]
    assert [slots_per_host(8, t) for t in (0, 1, 2, 3, 8)] == [1, 8, 4, 2, 1]
