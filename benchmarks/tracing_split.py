# SPDX-License-Identifier: Apache-2.0
"""Where native's tracing time goes against Embree's single rays: the peers' rays of `run.py`'s
table 2 (the camera's primary rays, then a shadow ray per hit and shadow target) split into the
primary and the shadow rays, one thread, best of --repeat in each of --rounds rounds.

Native: its primary packets (``Scene.intersect_packets``) and its shadow rays
(``Scene.occluded``) timed apart (``compiled_peers.native_trace``). Embree: its single-ray peer
on the full rays file and on one written without the lights (primary rays only); its shadow
rays' share is the difference. Each round runs both, one after the other:

    .venv/bin/python benchmarks/tracing_split.py S2 [--repeat 5] [--rounds 3]
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
from pathlib import Path

import compiled_peers
from run import scene_path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene", help="S1, S2, S3 or S2-10k / S2-100k")
    parser.add_argument("--repeat", type=int, default=5, help="runs of each part in a round; the best counts")
    parser.add_argument("--rounds", type=int, default=3, help="rounds, native then Embree in each")
    args = parser.parse_args()
    from phongscene.backends import native
    from phongscene.usd import load_usd

    scene = load_usd(scene_path(args.scene))
    settings = dataclasses.replace(scene.settings, threads=1)
    built = native.build(scene, threads=1)
    embree = compiled_peers.embree_binary()
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


if __name__ == "__main__":
    main()
