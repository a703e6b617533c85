# SPDX-License-Identifier: Apache-2.0
"""Per-sphere native/Cycles ratios of the scene metals_scene.py wrote to OUT (run from the repository
root: .venv/bin/python benchmarks/cycles/metals_compare.py OUT). A sphere's pixels are those whose
camera ray meets it first within 85 % of its radius (no silhouette pixels); the ratio is per pixel
(sum of channels), reported as its median and the share below 0.25x, with the mirror term
(max_depth 5) and without it (max_depth 0: the Phong look before issue 24)."""

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
cyc = read_image(OUT / "cycles.exr")[..., :3].astype(np.float64)
h, w = cyc.shape[:2]
scene = load_usd(OUT / "metals.usda")
settings = dataclasses.replace(scene.settings, width=w, height=h)
nat = render(scene, "native", settings).astype(np.float64)
nodepth = render(scene, "native", dataclasses.replace(settings, max_depth=0)).astype(np.float64)
names = ["Chrome0", "Chrome01", "Chrome03", "Gold0", "Gold01", "Gold03"]
centres = [((i % 3 - 1) * 2.4, 1.0, -(0 if i < 3 else 2.6)) for i in range(6)]
others = [(-4.5, 0.7, -1.3), (4.5, 0.7, -1.3)]
sx, sy = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
o, d = oracle.camera_rays(scene.camera, w, h, sx, sy)


def hit_t(c, r):
    oc = o - np.asarray(c)
    b = np.einsum("ij,ij->i", oc, d)
    disc = b * b - (np.einsum("ij,ij->i", oc, oc) - r * r)
    return np.where(disc > 0, -b - np.sqrt(np.maximum(disc, 0)), np.inf)


ts = np.array([hit_t(c, 1.0) for c in centres] + [hit_t(c, 0.7) for c in others])
nearest = np.argmin(ts, axis=0)
rows = []
for i, name in enumerate(names):
    core = (nearest == i) & np.isfinite(hit_t(centres[i], 0.85))  # inside 85 % of the radius: no silhouette pixels
    mask = core.reshape(h, w)
    ratio = nat[mask].sum(axis=1) / np.maximum(cyc[mask].sum(axis=1), 1e-6)
    ratio0 = nodepth[mask].sum(axis=1) / np.maximum(cyc[mask].sum(axis=1), 1e-6)
    rows.append(
        (
            name,
            int(mask.sum()),
            float(np.median(ratio)),
            float(np.mean(ratio < 0.25)),
            float(np.median(ratio0)),
            float(np.mean(ratio0 < 0.25)),
        )
    )
for r in rows:
    print(
        "%-9s px %4d  median native/cycles %.3f  below 0.25x %.0f%%   without mirror: median %.3f below 0.25x %.0f%%"  # noqa: UP031
        % (r[0], r[1], r[2], 100 * r[3], r[4], 100 * r[5])
    )
write_image(
    OUT / "side_by_side.png", np.concatenate([cyc, nat, nodepth], axis=1).astype(np.float32)
)  # Cycles | native | no mirror
