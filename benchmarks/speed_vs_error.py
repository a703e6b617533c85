# SPDX-License-Identifier: Apache-2.0
"""Speed against error: how much each quality setting costs and how much error it removes, for
the native tracer and POV-Ray side by side (same machine, same moment, same thread count, best
of --repeat runs), and how closely the two backends agree at every setting.

Two studies, each at 480×270:

* anti-aliasing: S1 (four spheres, two point lights) with n×n grid samples per pixel,
  n = 1, 2, 3, 4, 6; the reference is the native tracer at n = 9 (the most RenderSettings
  allows);
* area-light shadows: S3 (S1 with one light a 2×2 rect area light) with the light's shadow grid
  at 3, 5, 9, 17 points per axis and one sample per pixel; the reference is the native tracer
  at 33 points per axis.

Each image is judged against its study's reference (RMS error, max error, share of pixels off
by more than one half-float rounding) and against the other backend's image at the same setting
(``phongscene.compare``: max error and failing pixels at half-float precision). The native RMS
errors of the coarse settings are fitted with C·h^p (h = sample spacing) to estimate the
reference's own error; POV-Ray's fixed start-up is timed with a 1×1-pixel render. Writes a markdown
table, a JSON file with every number and a log-log plot (time against error) under
benchmarks/results/; what the numbers mean: benchmarks/README.md, "Speed against error".

    .venv/bin/python benchmarks/speed_vs_error.py [--threads 0] [--repeat 3] [--mapping classic]
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import json
import os
import platform
import subprocess
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from timing import best_time  # noqa: E402  (benchmarks/ is not a package)
RESULTS = HERE / "results"
STEM = "speed_vs_error"

WIDTH, HEIGHT = 480, 270  # big enough for many edge and penumbra pixels, small enough for 5 min
AA_SAMPLES = (1, 2, 3, 4, 6)  # n: n×n grid samples per pixel
AA_REFERENCE_SAMPLES = 9  # the largest n RenderSettings allows
AREA_SAMPLES = (3, 5, 9, 17)  # shadow grid points per axis, 2^k + 1
AREA_REFERENCE_SAMPLES = 33  # the next 2^k + 1: its trapezoid grid contains every grid above
AA, AREA = "anti-aliasing", "area-light shadows"
STUDIES = {
    # study: (benchmark scene, settings studied, reference setting, what the setting is)
    AA: ("S1", AA_SAMPLES, AA_REFERENCE_SAMPLES, "n×n samples per pixel"),
    AREA: ("S3", AREA_SAMPLES, AREA_REFERENCE_SAMPLES, "shadow grid points per axis"),
}
# The convergence fit uses only settings at most this fraction of the reference's (in samples
# per axis): their error is several times the reference's own (for order p ≈ 1.5, 3^1.5 ≈ 5x),
# so "error against the reference" stands for "true error" there.
FIT_MAX_FRACTION_OF_REFERENCE = 1 / 3


def beyond_half_thresholds():
    """A pixel is counted "beyond half" when a channel differs from the reference by more than
    one half-float rounding (2⁻¹¹ relative to the mean of the two values, OIIO's measure; the
    absolute floor is one subnormal half step): a difference a half-float EXR can represent."""
    from phongscene.comparison import HALF_FLOAT, HALF_ROUNDING_RELATIVE

    return dataclasses.replace(HALF_FLOAT, fail_relative=HALF_ROUNDING_RELATIVE)


def error_against_reference(reference: np.ndarray, image: np.ndarray) -> dict:
    """How far ``image`` is from ``reference``: RMS over every channel value, max |Δ| over every
    channel value, and the percentage of pixels beyond half precision (``beyond_half_thresholds``)."""
    from phongscene.comparison import compare

    report = compare(reference, image, beyond_half_thresholds())
    return {"rms": report.rms_error, "max": report.max_error, "beyond_half_percent": report.failing_percent}


def grid_spacing(study: str, setting: int) -> float:
    """The sample spacing h a setting gives, as a fraction of what is integrated: a pixel's width
    for the n×n midpoint grid (1/n); the light's edge for the trapezoid grid of s points (1/(s−1))."""
    return 1.0 / setting if study == AA else 1.0 / (setting - 1)


def convergence(spacings, errors, reference_spacing: float) -> dict:
    """Fit error ≈ C·h^p (least squares in log-log) and extrapolate it to the reference's
    spacing: the observed order p, and an estimate of the reference's own error."""
    log_h, log_e = np.log(np.asarray(spacings, float)), np.log(np.asarray(errors, float))
    p, log_c = np.polyfit(log_h, log_e, 1)
    return {"order": float(p), "reference_error_estimate": float(np.exp(log_c) * reference_spacing**p),
            "fitted_settings": len(spacings)}


def cross_backend(native: np.ndarray, povray: np.ndarray, study: str) -> dict:
    """Native against POV-Ray at the same setting, judged as the cross-backend tests judge it:
    at half-float precision everywhere, with POV-Ray's shadow-cache allowance for area lights."""
    from phongscene.comparison import HALF_FLOAT, HALF_ROUNDING_RELATIVE, POVRAY_SHADOW_CACHE, compare

    if study == AREA:
        name, thresholds = "POVRAY_SHADOW_CACHE", POVRAY_SHADOW_CACHE
    else:
        name, thresholds = "HALF_FLOAT", HALF_FLOAT
    report = compare(native, povray, thresholds)
    return {
        "thresholds": name,
        "max": report.max_error,
        "max_relative_in_half_roundings": report.max_relative_error / HALF_ROUNDING_RELATIVE,
        "failing_pixels": report.failing_pixels,
        "failing_percent": report.failing_percent,
        "ok": report.ok,
    }


def scene_at(scene, study: str, setting: int, settings):
    """(scene, settings) for one point of a study."""
    from phongscene.scene import RectAreaLight

    if study == AA:
        return scene, dataclasses.replace(settings, samples=setting, sample_pattern="grid")
    lights = tuple(dataclasses.replace(light, samples=setting) if isinstance(light, RectAreaLight) else light
                   for light in scene.lights)
    return dataclasses.replace(scene, lights=lights), dataclasses.replace(settings, samples=1)


def run_study(study: str, scene, base_settings, repeat: int) -> dict:
    from phongscene import render

    _, settings_list, reference_setting, _ = STUDIES[study]
    ref_scene, ref_settings = scene_at(scene, study, reference_setting, base_settings)
    t_ref, reference = best_time(lambda: render(ref_scene, "native", ref_settings), 1)
    print(f"  {study}: reference {reference_setting} (native) {t_ref:.3f} s", flush=True)
    rows = []
    for setting in settings_list:
        s_scene, s_settings = scene_at(scene, study, setting, base_settings)
        # Both backends back to back at each setting, so that they see the same machine load.
        t_native, native = best_time(lambda: render(s_scene, "native", s_settings), repeat)
        t_povray, povray = best_time(lambda: render(s_scene, "povray", s_settings), repeat)
        row = {
            "setting": setting,
            "native": {"seconds": t_native, **error_against_reference(reference, native)},
            "povray": {"seconds": t_povray, **error_against_reference(reference, povray)},
            "cross": cross_backend(native, povray, study),
        }
        print(f"    {setting:>3}: native {t_native:.3f} s rms {row['native']['rms']:.3g}, "
              f"povray {t_povray:.3f} s rms {row['povray']['rms']:.3g}, "
              f"cross max {row['cross']['max']:.3g} ({row['cross']['failing_pixels']} px fail)", flush=True)
        rows.append(row)
    fitted = [row for row in rows if row["setting"] <= FIT_MAX_FRACTION_OF_REFERENCE * reference_setting]
    fit = convergence([grid_spacing(study, row["setting"]) for row in fitted],
                      [row["native"]["rms"] for row in fitted], grid_spacing(study, reference_setting))
    return {"scene": STUDIES[study][0], "setting_meaning": STUDIES[study][3],
            "reference": {"setting": reference_setting, "backend": "native", "seconds": t_ref,
                          "rms_convergence": fit},
            "rows": rows}


def povray_startup(scene, settings, repeat: int) -> float:
    """POV-Ray's fixed cost per render: the best time of a 1×1-pixel render of ``scene``."""
    from phongscene import render

    tiny = dataclasses.replace(settings, width=1, height=1, samples=1)
    return best_time(lambda: render(scene, "povray", tiny), repeat)[0]


# --------------------------------------------------------------------------------------------
# Output


def markdown(result: dict) -> str:
    m = result["machine"]
    lines = [
        "# Speed against error",
        "",
        f"{result['width']}×{result['height']} px, {m['threads']} threads on {m['cores']} cores, "
        f"mapping {result['mapping']}, best of {result['repeat']} runs, {result['date']}, commit {result['commit']}.",
        f"Times are end to end; POV-Ray's include its fixed start-up, {result['povray_startup_seconds']:.2f} s "
        "(a 1×1-pixel render). Errors are in linear radiance units, against the study's reference; "
        "\"> 2⁻¹¹\" is the share of pixels off the reference by more than one half-float rounding. "
        "The last three columns compare the two backends at the same setting.",
    ]
    for study, data in result["studies"].items():
        ref = data["reference"]
        lines += [
            "",
            f"## {study} ({data['scene']}; setting = {data['setting_meaning']}; "
            f"reference: native at {ref['setting']}, {ref['seconds']:.2f} s)",
            "",
            "| setting | native s | native RMS | native max | native > 2⁻¹¹ "
            "| POV-Ray s | POV-Ray RMS | POV-Ray max | POV-Ray > 2⁻¹¹ "
            "| speed-up | native vs POV-Ray max | failing px | agree |",
            "| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | :---: |",
        ]
        for row in data["rows"]:
            n, p, c = row["native"], row["povray"], row["cross"]
            lines.append(
                f"| {row['setting']} | {n['seconds']:.3f} | {n['rms']:.2e} | {n['max']:.3f} | "
                f"{n['beyond_half_percent']:.1f} % | {p['seconds']:.3f} | {p['rms']:.2e} | {p['max']:.3f} | "
                f"{p['beyond_half_percent']:.1f} % | {p['seconds'] / n['seconds']:.1f}× | {c['max']:.2e} | "
                f"{c['failing_pixels']} | {'yes' if c['ok'] else 'NO'} ({c['thresholds']}) |"
            )
        fit = ref["rms_convergence"]
        lines += [
            "",
            f"Native RMS error ≈ C·h^p with p = {fit['order']:.2f} (h = sample spacing; least squares over the "
            f"{fit['fitted_settings']} coarsest settings); extrapolated, the reference's own RMS error is "
            f"≈ {fit['reference_error_estimate']:.1e}, so each row's RMS error against the reference may differ "
            "from its true RMS error by up to that much (triangle inequality).",
        ]
    return "\n".join(lines) + "\n"


def plot(result: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from phongscene.files import atomic_path

    colours = {AA: "tab:blue", AREA: "tab:orange"}
    styles = {"native": ("-", "o", "native"), "povray": ("--", "s", "POV-Ray")}
    fig, axes = plt.subplots(1, 2, figsize=(12, 6), layout="constrained")
    for ax, metric, title in ((axes[0], "rms", "RMS error"), (axes[1], "max", "max error")):
        for study, data in result["studies"].items():
            for backend, (linestyle, marker, label) in styles.items():
                times = [row[backend]["seconds"] for row in data["rows"]]
                errors = [row[backend][metric] for row in data["rows"]]
                ax.plot(times, errors, linestyle=linestyle, marker=marker, color=colours[study],
                        label=f"{study} ({data['scene']}), {label}")
                for row, t, e in zip(data["rows"], times, errors):
                    ax.annotate(str(row["setting"]), (t, e), textcoords="offset points", xytext=(4, 4),
                                fontsize=8, color=colours[study])
        ax.axvline(result["povray_startup_seconds"], color="grey", linestyle=":", linewidth=1)
        ax.annotate("POV-Ray start-up", (result["povray_startup_seconds"], 0.02), xycoords=("data", "axes fraction"),
                    rotation=90, fontsize=8, color="grey", xytext=(-10, 0), textcoords="offset points")
        if metric == "rms":
            for study, data in result["studies"].items():
                estimate = data["reference"]["rms_convergence"]["reference_error_estimate"]
                ax.axhline(estimate, color=colours[study], linestyle=":", linewidth=1,
                           label=f"{study}: reference's own RMS error (estimate)")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("render time, end to end (s)")
        ax.set_ylabel(f"{title} against the reference (linear radiance units)")
        ax.set_title(f"{title} (labels: samples per axis)")
        ax.grid(True, which="both", alpha=0.3)
    # One legend below both panels (the RMS panel has every entry), clear of the data.
    fig.legend(*axes[0].get_legend_handles_labels(), loc="outside lower center", ncol=3, fontsize=8)
    m = result["machine"]
    fig.suptitle(f"Speed against error, {result['width']}×{result['height']}, {m['threads']} threads, "
                 f"best of {result['repeat']}")
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=110)
    plt.close(fig)


def git_commit() -> str:
    """The commit the figures belong to, flagged when the native sources had uncommitted changes
    (the installed extension may then be built from them)."""
    def git(*args: str) -> str:
        return subprocess.run(["git", *args], cwd=HERE, check=True, capture_output=True, text=True).stdout.strip()

    try:
        commit = git("rev-parse", "--short", "HEAD")
        return commit + (" (native sources modified)" if git("status", "--porcelain", "--", "../backends/native") else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--threads", type=int, default=0, help="threads for both renderers (0 = all cores)")
    parser.add_argument("--repeat", type=int, default=3, help="runs per renderer and setting; the best counts")
    parser.add_argument("--mapping", choices=("classic", "exact"), default="classic",
                        help="POV-Ray mapping (classic = one idiomatic pass; exact = one pass per light)")
    parser.add_argument("--outdir", type=Path, default=RESULTS, help="where the .md, .json and .png go")
    args = parser.parse_args()
    if args.threads < 0 or args.repeat < 1:
        parser.error("--threads must be >= 0 and --repeat >= 1")

    from make_scenes import FILES, make

    from phongscene.errors import PhongSceneError
    from phongscene.files import write_text_atomic
    from phongscene.backends.povray import SPECULAR_OF_MAPPING
    from phongscene.usd import load_usd

    threads = args.threads or os.cpu_count() or 1
    names = sorted({scene for scene, *_ in STUDIES.values()})
    if missing := [name for name in names if not (HERE / "scenes" / FILES[name]).exists()]:
        make(which=tuple(missing))
    result = {
        "width": WIDTH, "height": HEIGHT, "mapping": args.mapping, "repeat": args.repeat,
        "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"), "commit": git_commit(),
        "machine": {"threads": threads, "cores": os.cpu_count(), "platform": platform.platform(),
                    "python": platform.python_version()},
        "povray_startup_seconds": None,
        "studies": {},
    }
    print(f"{WIDTH}x{HEIGHT}, threads {threads}, mapping {args.mapping}, best of {args.repeat}", flush=True)
    try:
        s1 = load_usd(HERE / "scenes" / FILES["S1"])
        result["povray_startup_seconds"] = povray_startup(
            s1, dataclasses.replace(s1.settings, threads=threads, specular=SPECULAR_OF_MAPPING[args.mapping]),
            args.repeat)
        print(f"  POV-Ray start-up (1x1 px): {result['povray_startup_seconds']:.3f} s", flush=True)
        for study, (name, *_) in STUDIES.items():
            scene = load_usd(HERE / "scenes" / FILES[name])
            settings = dataclasses.replace(scene.settings, width=WIDTH, height=HEIGHT, threads=threads,
                                           specular=SPECULAR_OF_MAPPING[args.mapping])
            result["studies"][study] = run_study(study, scene, settings, args.repeat)
    except PhongSceneError as e:
        raise SystemExit(f"speed_vs_error: {e}") from e

    table = markdown(result)
    print("\n" + table)
    write_text_atomic(args.outdir / f"{STEM}.md", table)
    write_text_atomic(args.outdir / f"{STEM}.json", json.dumps(result, indent=1) + "\n")
    plot(result, args.outdir / f"{STEM}.png")
    print(f"wrote {args.outdir / STEM}.md, .json, .png")


if __name__ == "__main__":
    main()
