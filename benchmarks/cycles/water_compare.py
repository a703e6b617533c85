# SPDX-License-Identifier: Apache-2.0
"""Native/Cycles ratios through the glass of water of the scene water_scene.py wrote to OUT (run
from the repository root: .venv/bin/python benchmarks/cycles/water_compare.py OUT). A region's
pixels are those whose camera ray meets the tumbler's outer wall within 80 % of its radius from
the axis across the view, below the water line ("water") or above it ("glass above water"), 0.1
away from the line, the bottom and the rim; the ratio is per pixel (sum of channels), reported as
its median, its 10th and 90th percentiles and the share below 0.5x, in both transmission
conventions: the book's (the default: a surface met from behind is left for the air, as Cycles
treats each surface) and POV-Ray's (nested media: water refracts against the glass by 1.33/1.5,
the overlap of the water's side with the wall belongs to the water)."""

import dataclasses
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests"))
from phongscene.images import read_image, write_image
from phongscene.rendering import render
from phongscene.usd import load_usd
from support import oracle

OUT = Path(sys.argv[1])
# Supersampling per axis: paths that bounce inside the glass wall and the 5 mm overlap change from
# one point of a pixel to the next, so one ray per pixel shows them as speckle (Cycles averages
# 256 paths a pixel).
SAMPLES = 4
cyc = read_image(OUT / "cycles.exr")[..., :3].astype(np.float64)
h, w = cyc.shape[:2]
scene = load_usd(OUT / "water.usda")
settings = dataclasses.replace(scene.settings, width=w, height=h, max_depth=12, samples=SAMPLES)
images = {
    convention: render(scene, "native", dataclasses.replace(settings, transmission=convention)).astype(np.float64)
    for convention in ("book", "povray")
}
# water_scene.py's tumbler; Blender's (x, y, z) is USD's (x, z, -y) in this export (Y up): its axis
# is USD's y through the origin.
OUTER_R, HEIGHT, BOTTOM, WATER_TOP = 0.8, 2.0, 0.15, 1.4
sx, sy = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
o, d = oracle.camera_rays(scene.camera, w, h, sx, sy)
# the first hit of the infinite cylinder x² + z² = R²
a = d[:, 0] ** 2 + d[:, 2] ** 2
b = o[:, 0] * d[:, 0] + o[:, 2] * d[:, 2]
c = o[:, 0] ** 2 + o[:, 2] ** 2 - OUTER_R**2
disc = b * b - a * c
t = np.where(disc > 0, (-b - np.sqrt(np.maximum(disc, 0))) / np.maximum(a, 1e-300), np.inf)
hit = o + t[:, None] * d
inner = np.isfinite(t) & (np.abs(hit[:, 0]) < 0.8 * OUTER_R)
height = hit[:, 1]
regions = {
    "water": inner & (height > BOTTOM + 0.1) & (height < WATER_TOP - 0.1),
    "glass above water": inner & (height > WATER_TOP + 0.1) & (height < HEIGHT - 0.1),
}
for name, region in regions.items():
    mask = region.reshape(h, w)
    cycles_sum = np.maximum(cyc[mask].sum(axis=1), 1e-6)
    for convention, image in images.items():
        ratio = image[mask].sum(axis=1) / cycles_sum
        p10, p50, p90 = np.percentile(ratio, [10, 50, 90])
        print(
            f"{name:18s} px {int(mask.sum()):5d}  {convention:6s}  native/cycles median {p50:.3f} "
            f"(10th {p10:.3f}, 90th {p90:.3f}), below 0.5x {100 * np.mean(ratio < 0.5):.0f}%"
        )
write_image(
    OUT / "side_by_side.png", np.concatenate([cyc, images["book"], images["povray"]], axis=1).astype(np.float32)
)  # Cycles | book | povray
