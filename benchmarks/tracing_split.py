# SPDX-License-Identifier: Apache-2.0
"""Where native's tracing time goes against Embree's single rays: the peers' rays of `run.py`'s
table 2 (the camera's primary rays, then a shadow ray per hit and shadow target) split into the
primary and the shadow rays, one thread, best of --repeat in each of --rounds rounds.

Native: its primary packets (``Scene.intersect_packets``) and its shadow rays
(``Scene.occluded``) timed apart (``compiled_peers.native_trace``). Embree: its single-ray peer
on the full rays file and on one written without the lights (primary rays only); its shadow
rays' share is the difference. Each round runs both, one after the other:

    .venv/bin/python benchmarks/tracing_split.py S2 [--repeat 5] [--rounds 3] [--by-surface]

--by-surface splits the shadow rays further by the surface their shading point lies on (the
spheres, or each mesh in the scene's order): native's ``Scene.occluded`` on that group's rays
alone, Embree's single-ray peer on rays files of that group's pixels only, with and without the
lights. On S2 it found the gap to Embree in the rays from the torus, not the ground
(benchmarks/README.md, "Issue 25: leaves of eight for the prefilter").
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
import time
from pathlib import Path

import compiled_peers
import numpy as np
from run import scene_path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene", help="S1, S2, S3 or S2-10k / S2-100k")
    parser.add_argument("--repeat", type=int, default=5, help="runs of each part in a round; the best counts")
    parser.add_argument("--rounds", type=int, default=3, help="rounds, native then Embree in each")
    parser.add_argument("--by-surface", action="store_true", help="the shadow rays split by the surface they start on")
    args = parser.parse_args()
    from phongscene.backends import native
    from phongscene.usd import load_usd

    scene = load_usd(scene_path(args.scene))
    settings = dataclasses.replace(scene.settings, threads=1)
    built = native.build(scene, threads=1)
    embree = compiled_peers.embree_binary()
    if args.by_surface:
        by_surface(args, scene, settings, built, embree)
        return
    with tempfile.TemporaryDirectory() as tmp:
        full, primary_only, hits = Path(tmp) / "rays.bin", Path(tmp) / "primary.bin", Path(tmp) / "hits.bin"
        compiled_peers.write_rays(scene, settings, full)
        compiled_peers.write_rays(dataclasses.replace(scene, lights=()), settings, primary_only)
        for _ in range(args.rounds):
            own = compiled_peers.native_trace(scene, settings, built, args.repeat)
            line = f"{args.scene} native: primary {own['primary']:.4f} s, shadow {own['shadow']:.4f} s"
            if isinstance(embree, str):
                line += f"; Embree: {embree}"
            else:

                def embree_render(rays: Path) -> float:
                    cmd = [str(embree), str(rays), str(hits), "single", "1", str(args.repeat)]
                    return compiled_peers.run_peer(cmd)["render"]

                whole, primary = embree_render(full), embree_render(primary_only)
                line += (
                    f"; Embree single: primary {primary:.4f} s, shadow ~{whole - primary:.4f} s (whole {whole:.4f} s)"
                )
            print(line, flush=True)


def surfaces(scene, prim: np.ndarray) -> list[tuple[str, np.ndarray]]:
    """(name, pixel mask) of each surface the primary rays hit: the spheres, then each mesh (a
    primitive id numbers the spheres first, then the meshes' triangles in order; a miss is -1)."""
    groups = [("the spheres", (prim >= 0) & (prim < len(scene.spheres)))]
    first = len(scene.spheres)
    for k, mesh in enumerate(scene.meshes):
        n = len(mesh.triangles)
        groups.append((f"mesh {k} ({n} triangles)", (prim >= first) & (prim < first + n)))
        first += n
    return [(name, mask) for name, mask in groups if mask.any()]


def by_surface(args, scene, settings, built, embree) -> None:
    origins, dirs = (a.astype(np.float64) for a in compiled_peers.primary_rays(scene, settings))
    t, prim = built.intersect(origins, dirs, compiled_peers.NATIVE_TRACE_T_MIN)
    hit = np.isfinite(t)
    targets = [compiled_peers.shadow_targets(light).astype(np.float64) for light in scene.lights]
    with tempfile.TemporaryDirectory() as tmp:
        groups = []
        for k, (name, mask) in enumerate(surfaces(scene, np.where(hit, prim, -1))):
            points = origins[mask] + dirs[mask] * t[mask, None]
            shadow = []  # (origins, directions, t_max) of the group's shadow rays, as native_trace makes them
            for grid in targets:
                for target in grid:
                    to_light = target - points
                    dist = np.linalg.norm(to_light, axis=1)
                    to_light /= dist[:, None]
                    shadow.append(
                        (
                            points + to_light * compiled_peers.SHADOW_OFFSET,
                            to_light,
                            dist - 2 * compiled_peers.SHADOW_OFFSET,
                        )
                    )
            full, primary_only = Path(tmp) / f"rays{k}.bin", Path(tmp) / f"primary{k}.bin"
            compiled_peers.write_rays(scene, settings, full, only=mask)
            compiled_peers.write_rays(dataclasses.replace(scene, lights=()), settings, primary_only, only=mask)
            groups.append((name, shadow, full, primary_only))
        hits = Path(tmp) / "hits.bin"
        for _ in range(args.rounds):
            for name, shadow, full, primary_only in groups:
                rays = sum(len(o) for o, _, _ in shadow)
                best = float("inf")
                for _ in range(args.repeat):
                    start = time.perf_counter()
                    for o, d, t_max in shadow:
                        built.occluded(o, d, t_max, compiled_peers.NATIVE_TRACE_T_MIN)
                    best = min(best, time.perf_counter() - start)
                line = f"{args.scene} shadow rays from {name}, {rays} rays: native {best:.4f} s ({best / rays * 1e9:.0f} ns a ray)"
                if isinstance(embree, str):
                    line += f"; Embree: {embree}"
                else:

                    def embree_render(rays_file: Path) -> float:
                        cmd = [str(embree), str(rays_file), str(hits), "single", "1", str(args.repeat)]
                        return compiled_peers.run_peer(cmd)["render"]

                    theirs = embree_render(full) - embree_render(primary_only)
                    line += f"; Embree single ~{theirs:.4f} s ({theirs / rays * 1e9:.0f} ns a ray)"
                print(line, flush=True)


if __name__ == "__main__":
    main()
