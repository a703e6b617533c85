# SPDX-License-Identifier: Apache-2.0
"""Speed against error on the benchmark scenes: ``phongscene bench`` (phongscene/bench.py) on

* S1 (four spheres, two point lights): the anti-aliasing estimators;
* S3 (S1 with one light a 2×2 rect area light): the area-light shadow estimators;
* M (a smooth displaced torus of 100k triangles over the ground, one point light): the
  anti-aliasing estimators on a mesh;

every estimator on both backends (the native ``stratified`` and ``adaptive`` ones natively only), wall and CPU
time, best of --repeat, against references whose own RMS error is measured. Writes
results/speed_vs_error.md (tables, dominance), .csv, .json and .png (log-log, each backend's
Pareto front, CPU and wall time, one row per scene).

    .venv/bin/python benchmarks/speed_vs_error.py [--width 320] [--threads 0] [--repeat 3] [--mapping classic]
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import datetime
import io
import json
import os
import platform
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
RESULTS = HERE / "results"
STEM = "speed_vs_error"
MESH_TRIANGLES = 100_000  # enough for a BVH to matter, small enough to build in a second
# The anti-aliasing references at 6x the resolution (96² stratified points per pixel): at 3x
# (48²) the bound on their own RMS error (7.3e-5 on S1) was above a tenth of POV-Ray's lowest
# errors (~4e-4); 6x quadruples the reference's cost (~2.5 min per scene on 2 cores).
REFERENCE_RESOLUTION = 6
# The shadow reference: the 257² grid (the model's largest; its twin 129²): at 129² (twin 65²) the
# bound (1.6e-5 on S3) was above a tenth of POV-Ray's lowest errors (~7e-5).
REFERENCE_SHADOW_SAMPLES = 257

# (name, what, how to get the scene, the families studied)
STUDIES = (
    ("S1", "four spheres, two point lights", "S1", ("anti-aliasing",)),
    ("S3", "S1 with a 2x2 rect area light", "S3", ("area-light shadows",)),
    ("M", f"smooth displaced torus, {MESH_TRIANGLES // 1000}k triangles, one point light", "mesh", ("anti-aliasing",)),
)


def load(which: str):
    from make_scenes import FILES, make, s2_torus

    from phongscene.usd import load_usd

    if which == "mesh":
        return s2_torus(MESH_TRIANGLES)
    if not (HERE / "scenes" / FILES[which]).exists():
        make(which=(which,))
    return load_usd(HERE / "scenes" / FILES[which])


def git_commit() -> str:
    def git(*args: str) -> str:
        return subprocess.run(["git", *args], cwd=HERE, check=True, capture_output=True, text=True).stdout.strip()

    try:
        commit = git("rev-parse", "--short", "HEAD")
        return commit + (
            " (native sources modified)" if git("status", "--porcelain", "--", "../backends/native") else ""
        )
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def markdown(results: dict, meta: dict) -> str:
    from phongscene import bench

    lines = [
        "# Speed against error",
        "",
        f"{meta['width']}x{meta['height']} px, {meta['threads']} threads on {meta['cores']} cores, mapping "
        f"{meta['mapping']}, best of {meta['repeat']}, {meta['date']}, commit {meta['commit']}. Command: "
        f"`{meta['command']}`.",
        "",
        "Wall and CPU seconds are end to end (POV-Ray's include its start-up); CPU counts this process and "
        "POV-Ray's. RMS / max / bias (mean signed error) against the family's reference; `*`: the RMS error is "
        f"within {bench.REFERENCE_MARGIN:g}x of the reference's own error bound (not resolved).",
    ]
    for name, data in results.items():
        lines += ["", f"## {name}: {data['what']}", ""]
        for family, ref in data["result"]["references"].items():
            lines.append(
                f"Reference ({family}): {ref['what']}, {ref['seconds']:.1f} s; its RMS error <= "
                f"{ref['rms_error_bound']:.1e}."
            )
        lines += [
            "",
            "| estimator | backend | wall s | CPU s | RMS | max | bias |",
            "| --- | --- | ---: | ---: | ---: | ---: | ---: |",
        ]
        for r in data["result"]["rows"]:
            lines.append(
                f"| {r['label']} | {r['backend']} | {r['wall']:.3f} | {r['cpu']:.3f} | {r['rms']:.2e}"
                f"{'' if r['resolved'] else ' *'} | {r['max']:.3f} | {r['bias']:+.1e} |"
            )
        lines.append("")
        for family, d in data["result"]["dominance"].items():
            for cost, info in d.items():
                counted = [x for x in info["levels"] if x["resolved"]]
                worst = min(counted, key=lambda x: x["ratio"]) if counted else None
                if worst:
                    lines.append(
                        f"- {family}, {cost} time: at every RMS level on POV-Ray's Pareto front native is "
                        f">= {info['min_ratio']:.1f}x cheaper (least at POV-Ray's {worst['povray']}, "
                        f"RMS {worst['rms']:.2e}, against native {worst['native']})."
                    )
                for x in info["levels"]:
                    if not x["resolved"]:
                        lines.append(
                            f"- {family}, {cost} time: POV-Ray's {x['povray']} (RMS {x['rms']:.2e}) is below "
                            f"what the reference resolves and not counted ({x['ratio']:.1f}x)."
                        )
    return "\n".join(lines) + "\n"


def plot(results: dict, path: Path, meta: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from phongscene import bench
    from phongscene.files import atomic_path

    fig, axes = plt.subplots(len(results), 2, figsize=(13, 5.2 * len(results)), layout="constrained", squeeze=False)
    for row, (name, data) in zip(axes, results.items()):
        for ax, cost in zip(row, ("cpu", "wall")):
            bench.draw(ax, data["result"], cost)
            ax.set_title(
                f"{name} ({data['what']}): RMS error against {'CPU' if cost == 'cpu' else 'wall'} time", fontsize=9
            )
            ax.legend(fontsize=7, loc="upper right")
    fig.suptitle(
        f"Speed against error, {meta['width']}x{meta['height']}, {meta['threads']} threads, "
        f"best of {meta['repeat']} (lines: Pareto fronts)"
    )
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=90)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--width", type=int, default=320, help="image width (16:9)")
    parser.add_argument("--threads", type=int, default=0, help="threads for both renderers (0 = all cores)")
    parser.add_argument("--repeat", type=int, default=3, help="runs per renderer and setting; the best counts")
    parser.add_argument(
        "--mapping",
        choices=("classic", "exact"),
        default="classic",
        help="POV-Ray mapping (classic = one idiomatic pass; exact = one pass per light)",
    )
    parser.add_argument("--outdir", type=Path, default=RESULTS)
    args = parser.parse_args()
    if args.threads < 0 or args.repeat < 1 or args.width < 16:
        parser.error("--threads must be >= 0, --repeat >= 1, --width >= 16")

    from phongscene import bench
    from phongscene.backends.povray import SPECULAR_OF_MAPPING
    from phongscene.files import write_text_atomic

    threads = args.threads or os.cpu_count() or 1
    height = round(args.width * 9 / 16)
    meta = {
        "width": args.width,
        "height": height,
        "threads": threads,
        "cores": os.cpu_count(),
        "mapping": args.mapping,
        "repeat": args.repeat,
        "commit": git_commit(),
        "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
        "platform": platform.platform(),
        "command": "python benchmarks/speed_vs_error.py " + " ".join(sys.argv[1:]),
    }
    results = {}
    for name, what, which, families in STUDIES:
        scene = load(which)
        settings = dataclasses.replace(
            scene.settings, width=args.width, height=height, threads=threads, specular=SPECULAR_OF_MAPPING[args.mapping]
        )
        print(f"{name}: {what}", flush=True)
        result = bench.run(
            scene,
            settings,
            repeat=args.repeat,
            families=families,
            reference_resolution=REFERENCE_RESOLUTION,
            reference_shadow_samples=REFERENCE_SHADOW_SAMPLES,
            log=lambda line: print("  " + line, flush=True),
        )
        results[name] = {"what": what, "result": result}
        print(bench.table(result), flush=True)

    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["scene", "family", "label", "backend", "wall", "cpu", "rms", "max", "bias", "resolved"])
    for name, data in results.items():
        for r in data["result"]["rows"]:
            writer.writerow(
                [
                    name,
                    r["family"],
                    r["label"],
                    r["backend"],
                    r["wall"],
                    r["cpu"],
                    r["rms"],
                    r["max"],
                    r["bias"],
                    r["resolved"],
                ]
            )
    write_text_atomic(args.outdir / f"{STEM}.csv", out.getvalue())
    write_text_atomic(args.outdir / f"{STEM}.json", json.dumps({"meta": meta, "results": results}, indent=1) + "\n")
    write_text_atomic(args.outdir / f"{STEM}.md", markdown(results, meta))
    plot(results, args.outdir / f"{STEM}.png", meta)
    print(f"wrote {args.outdir / STEM}.md, .csv, .json, .png")


if __name__ == "__main__":
    main()
