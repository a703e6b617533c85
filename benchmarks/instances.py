# SPDX-License-Identifier: Apache-2.0
"""Instancing at scale: peak RSS and wall time of whole ``phongscene render`` processes on K
copies of one 10,000-triangle torus (a PointInstancer, K = 100 ... 10,000) and on 2,000
instanceable references of it, at 320×180, native beside POV-Ray (``--backend povray``: one
``#declare``d mesh2 and an ``object`` per copy) and Embree's instancing (``peers/embree_instances.cpp``,
Debian's ``libembree-dev``: one prototype scene, K instance geometries, the native camera's
primary rays; its process reads a file of the model's prototype, transforms and rays). Peak RSS
from ``/usr/bin/time -v``. Embree's hits are checked against the native tracer's on the same rays.

    .venv/bin/python benchmarks/instances.py [--k 100 1000 3000 10000] [--refs 2000] [--no-povray] [--no-embree]

Scenes are written with raw pxr (tests/support/instanced_stages.py) into a temporary folder.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))

import numpy as np  # noqa: E402

from support.instanced_stages import point_instancer_stage, reference_stage  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))

RINGS, SIDES = 100, 50  # 2·100·50 = 10,000 triangles per copy
WIDTH, HEIGHT = 320, 180


def measure(scene: Path, backend: str, out: Path, threads: int) -> tuple[float, float]:
    """(peak RSS in MiB, wall seconds) of one ``phongscene render`` process."""
    command = [
        str(REPO / ".venv" / "bin" / "phongscene"),
        "render",
        str(scene),
        "-o",
        str(out),
        "--backend",
        backend,
        "--width",
        str(WIDTH),
        "--height",
        str(HEIGHT),
        "--threads",
        str(threads),
    ]
    rss, seconds, _ = timed(command)
    return rss, seconds


def timed(command: list[str]) -> tuple[float, float, str]:
    """(peak RSS in MiB, wall seconds, standard output) of one process, by ``/usr/bin/time -v``."""
    done = subprocess.run(["/usr/bin/time", "-v", *command], capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed:\n{done.stderr[-2000:]}")
    rss = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", done.stderr).group(1)) / 1024
    wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): (?:(\d+):)?(\d+):([\d.]+)", done.stderr)
    seconds = int(wall.group(1) or 0) * 3600 + int(wall.group(2)) * 60 + float(wall.group(3))
    return rss, seconds, done.stdout


EMBREE_MAGIC = 0x49525045  # embree_instances.cpp


def embree_instances(scene_file: Path, work: Path, threads: int) -> tuple[float, float, dict] | str:
    """(peak RSS MiB, wall s, the peer's JSON with "agree") of Embree's instancing on
    ``scene_file``'s one prototype and its copies (and its spheres), or why it was not run. The file it reads is
    written here from the model (the same prototype triangles and transforms the native tracer
    gets) with the native camera's primary rays; "agree" is the fraction of those rays on which
    Embree and the native tracer agree whether anything is hit."""
    import dataclasses

    from compiled_peers import COMMON, _compile
    from peer_rays import primary_rays, sphere_centre_radius

    from phongscene.backends import native
    from phongscene.rendering import load_scene

    if not Path("/usr/include/embree3/rtcore.h").exists():
        return "libembree-dev not installed (apt-get install libembree-dev)"
    binary = _compile("c++", "embree_instances.cpp", (*COMMON, "-std=c++17"), ("-lembree3", "-lpthread"))
    if isinstance(binary, str):
        return binary
    scene, _ = load_scene(scene_file)
    groups = scene.instances
    spheres = [sphere_centre_radius(s) for s in scene.spheres]
    if len(groups) != 1 or scene.meshes or any(s is None for s in spheres):
        return "not one prototype's copies and round spheres"
    meshes = groups[0].prototype.meshes
    offsets = np.cumsum([0] + [len(m.points) for m in meshes])
    points = np.concatenate([np.asarray(m.points, np.float32) for m in meshes])
    triangles = np.concatenate([np.asarray(m.triangles, np.int64) + o for m, o in zip(meshes, offsets)])
    transforms = np.ascontiguousarray(groups[0].world_from_prototype[:, :3, :], dtype=np.float32)
    settings = dataclasses.replace(scene.settings, width=WIDTH, height=HEIGHT)
    origins, dirs = primary_rays(scene, settings)
    path = work / f"{scene_file.stem}.instances.bin"
    balls = np.asarray([[*c, r] for c, r in spheres], np.float32).reshape(-1, 4)
    head = np.array([EMBREE_MAGIC, WIDTH, HEIGHT, len(points), len(triangles), len(transforms), len(balls)], np.int32)
    with open(path, "wb") as f:
        for array in (head, points, triangles.astype(np.uint32), transforms, balls, origins, dirs):
            f.write(np.ascontiguousarray(array).tobytes())
    rss, seconds, out = timed([str(binary), str(path), str(threads)])
    figures = json.loads(out.strip().splitlines()[-1])
    start = time.perf_counter()
    built = native.build(scene)
    figures["native_build"] = time.perf_counter() - start
    t, _ = built.intersect(origins.astype(np.float64), dirs.astype(np.float64))
    figures["native_hits"] = int(np.count_nonzero(np.isfinite(t)))
    return rss, seconds, figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--k", type=int, nargs="*", default=[100, 1000, 3000, 10000], help="PointInstancer copies")
    parser.add_argument("--refs", type=int, default=2000, help="instanceable references (0: none)")
    parser.add_argument("--no-povray", action="store_true")
    parser.add_argument("--no-embree", action="store_true")
    parser.add_argument("--threads", type=int, default=2)
    args = parser.parse_args()
    backends = ["native"] + ([] if args.no_povray else ["povray"])
    with tempfile.TemporaryDirectory() as folder:
        tmp = Path(folder)
        cases = [
            (
                f"PointInstancer, K = {k}",
                lambda k=k: point_instancer_stage(
                    tmp / f"pi_{k}.usdc", k, RINGS, SIDES, 1.2, width=WIDTH, height=HEIGHT
                ),
            )
            for k in args.k
        ]
        if args.refs:
            cases.append(
                (
                    f"instanceable references, K = {args.refs}",
                    lambda: reference_stage(
                        tmp / f"refs_{args.refs}.usdc", args.refs, RINGS, SIDES, 1.2, width=WIDTH, height=HEIGHT
                    ),
                )
            )
        columns = [f"{b} peak RSS | {b} wall" for b in backends]
        if not args.no_embree:
            columns.append(
                "Embree peak RSS | Embree wall (build + render) | native build (in process) | Embree hits / native hits"
            )
        print(
            f"| scene ({2 * RINGS * SIDES} triangles per copy, {WIDTH}x{HEIGHT}, {args.threads} threads) | "
            + " | ".join(columns)
            + " |"
        )
        print("| --- |" + " --- | --- |" * len(backends) + ("" if args.no_embree else " --- | --- | --- | --- |"))
        for name, make in cases:
            scene = Path(make())
            cells = []
            for backend in backends:
                rss, seconds = measure(scene, backend, tmp / f"{scene.stem}_{backend}.exr", args.threads)
                cells += [f"{rss:.0f} MiB", f"{seconds:.1f} s"]
            if not args.no_embree:
                peer = embree_instances(scene, tmp, args.threads)
                if isinstance(peer, str):
                    cells += [peer, "", "", ""]
                else:
                    rss, seconds, figures = peer
                    cells += [
                        f"{rss:.0f} MiB",
                        f"{seconds:.2f} s ({figures['build']:.3f} + {figures['render']:.3f} s)",
                        f"{figures['native_build']:.3f} s",
                        f"{figures['hits']} / {figures['native_hits']}",
                    ]
            print(f"| {name} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
