# SPDX-License-Identifier: Apache-2.0
"""phongscene against Blender Cycles on the scenes ``build_scenes.py`` exported (run that first,
with Blender's Python: ``pip install bpy`` in a separate venv, Python 3.11).

Usage: .venv/bin/python benchmarks/blender/compare.py [DIR]   (default: this folder)

For each NAME.usda next to NAME_cycles.exr (direct light only), renders NAME.usda natively at the
same size (3×3 anti-aliasing) and prints the ratio native / Cycles of the median luminance over
pixels lit in both, of the centre 5×5 patch, and the median per-pixel ratio; and each image's
peak / median luminance (how strong the highlights are).
"""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np

from phongscene import load_usd, render
from phongscene.images import read_image


def luminance(image: np.ndarray) -> np.ndarray:
    return image[..., 0] * 0.2126 + image[..., 1] * 0.7152 + image[..., 2] * 0.0722


def main() -> None:
    folder = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parent
    for scene_file in sorted(folder.glob("*.usda")):
        reference_file = scene_file.with_name(scene_file.stem + "_cycles.exr")
        if not reference_file.exists():
            continue
        reference = luminance(read_image(reference_file))
        scene = load_usd(scene_file)
        h, w = reference.shape
        settings = dataclasses.replace(scene.settings, width=w, height=h, samples=3)
        ours = luminance(render(scene, "native", settings))
        lit = (reference > 0) & (ours > 0)
        centre = (slice(h // 2 - 2, h // 2 + 3), slice(w // 2 - 2, w // 2 + 3))
        print(
            f"{scene_file.stem:20s} {w}x{h}  median {np.median(ours[lit]) / np.median(reference[lit]):.3f}"
            f"  centre {ours[centre].mean() / reference[centre].mean():.3f}"
            f"  per-pixel median {np.median(ours[lit] / reference[lit]):.3f}"
            f"  peak/median: Cycles {reference.max() / np.median(reference[lit]):.1f}, native {ours.max() / np.median(ours[lit]):.1f}"
        )


if __name__ == "__main__":
    main()
