# SPDX-License-Identifier: Apache-2.0
"""Native/Cycles ratios inside the glass ball and the glass slab of the scene glass_scene.py wrote
to OUT (run from the repository root: .venv/bin/python benchmarks/cycles/glass_compare.py OUT).
An object's pixels are those whose camera ray meets it first well inside its outline (the ball
within 85 % of its radius, the slab within 85 % of its half extents across the view), so
silhouettes are not compared; the ratio is per pixel (sum of channels), reported as its median,
its 10th and 90th percentiles and the share below 0.5x, with the dielectric (max_depth 8) and
without secondary rays (max_depth 0: the look before issue 24). Blender's export writes the
glass as an OpenPBR MaterialX network (transmission_weight 1), which the reader takes as the
book's dielectric; its UsdPreviewSurface fallback says opacity 1 (transmission is not exported
there)."""

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
scene = load_usd(OUT / "glass.usda")
settings = dataclasses.replace(scene.settings, width=w, height=h, max_depth=8)
nat = render(scene, "native", settings).astype(np.float64)
nodepth = render(scene, "native", dataclasses.replace(settings, max_depth=0)).astype(np.float64)
sx, sy = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
o, d = oracle.camera_rays(scene.camera, w, h, sx, sy)
# Blender's (x, y, z) is USD's (x, z, -y) in this export (Y up).
BALL, BALL_R = np.array([-1.3, 1.0, 0.0]), 1.0
SLAB, SLAB_HALF = np.array([1.6, 0.9, 0.0]), np.array([0.7, 0.9, 0.15])
BEHIND = [(np.array([-2.6 + 2.6 * j, 0.7, -3.2]), 0.7) for j in range(3)]


def sphere_t(c, r):
    oc = o - c
    b = np.einsum("ij,ij->i", oc, d)
    disc = b * b - (np.einsum("ij,ij->i", oc, oc) - r * r)
    return np.where(disc > 0, -b - np.sqrt(np.maximum(disc, 0)), np.inf)


def box_t(c, half):
    with np.errstate(divide="ignore", invalid="ignore"):
        t1, t2 = (c - half - o) / d, (c + half - o) / d
    near = np.minimum(t1, t2).max(axis=1)
    far = np.maximum(t1, t2).min(axis=1)
    return np.where((near <= far) & (far > 0), near, np.inf)


ts = np.array([sphere_t(BALL, BALL_R), box_t(SLAB, SLAB_HALF)] + [sphere_t(c, r) for c, r in BEHIND])
nearest = np.argmin(ts, axis=0)
cores = {
    "glass ball": (nearest == 0) & np.isfinite(sphere_t(BALL, 0.85 * BALL_R)),
    "glass slab": (nearest == 1) & np.isfinite(box_t(SLAB, SLAB_HALF * np.array([0.85, 0.85, 1.0]))),
}
for name, core in cores.items():
    mask = core.reshape(h, w)
    cycles_sum = np.maximum(cyc[mask].sum(axis=1), 1e-6)
    ratio, ratio0 = nat[mask].sum(axis=1) / cycles_sum, nodepth[mask].sum(axis=1) / cycles_sum
    p10, p50, p90 = np.percentile(ratio, [10, 50, 90])
    print(
        f"{name:10s} px {int(mask.sum()):4d}  native/cycles median {p50:.3f} (10th {p10:.3f}, 90th {p90:.3f}), "
        f"below 0.5x {100 * np.mean(ratio < 0.5):.0f}%   without secondary rays: median {np.median(ratio0):.3f}, "
        f"below 0.5x {100 * np.mean(ratio0 < 0.5):.0f}%"
    )
write_image(
    OUT / "side_by_side.png", np.concatenate([cyc, nat, nodepth], axis=1).astype(np.float32)
)  # Cycles | native | none
