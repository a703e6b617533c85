# SPDX-License-Identifier: Apache-2.0
"""How close a scene's colours are to a reference render that is not the same view: the
distribution of the lit pixels' hues, ours against the reference's.

Made for the intent-vfx teapot scene (usd-wg/assets ``intent-vfx``; its layer
``assets/teapot/teapot_animCycle.usd`` is not stored there and is rebuilt by the asset's own
``build_teapot_animcycle.py``), whose README shows a Karma render from another camera
(``images/render_karma.png``, a usdview window: crop it to the viewport). Pixels compared: those
brighter than LIT of the image's brightest percentile; each is binned by hue (HUE_BINS) where its
saturation is at least SATURATED, else counted as grey. Reported: the share of grey pixels and the
total-variation distance (½ Σ |p − q|, 0 = the same distribution, 1 = disjoint) between the
reference's bins and ours, and the same for our render with per-instance colours left out
(every "rgb" teapot in its reader's fallback grey, as before they were read).

Usage: ``.venv/bin/python benchmarks/palette_fidelity.py SCENE REFERENCE.png [--crop X0 Y0 X1 Y1]
[--width W]``
"""

from __future__ import annotations

import argparse
import colorsys
import dataclasses

import numpy as np
import OpenImageIO as oiio

from phongscene import render
from phongscene.usd import load_usd

# A pixel is compared where its brightest channel is at least this fraction of the image's 99th
# percentile: the background and the deepest shade are left out (their hue is noise).
LIT = 0.15
# Below this saturation (HSV) a pixel is grey: white and grey teapots, highlights.
SATURATED = 0.25
HUE_BINS = 12


def palette(rgb: np.ndarray) -> np.ndarray:
    """Shares of the lit pixels: [grey, hue bin 0, ..., hue bin HUE_BINS − 1] (display values)."""
    flat = rgb.reshape(-1, 3).astype(np.float64)
    peak = np.percentile(flat.max(axis=1), 99)
    lit = flat[flat.max(axis=1) >= LIT * peak]
    hsv = np.array([colorsys.rgb_to_hsv(*p) for p in lit])
    counts = np.zeros(HUE_BINS + 1)
    grey = hsv[:, 1] < SATURATED
    counts[0] = grey.sum()
    bins = np.minimum((hsv[~grey, 0] * HUE_BINS).astype(int), HUE_BINS - 1)
    np.add.at(counts, 1 + bins, 1)
    return counts / counts.sum()


def to_display(linear: np.ndarray) -> np.ndarray:
    """Linear radiance to sRGB-encoded [0, 1] (the reference is a screenshot)."""
    c = np.clip(linear / max(float(np.percentile(linear, 99.5)), 1e-12), 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene")
    parser.add_argument("reference")
    parser.add_argument("--crop", type=int, nargs=4, metavar=("X0", "Y0", "X1", "Y1"))
    parser.add_argument("--width", type=int, default=640)
    args = parser.parse_args()

    reference = oiio.ImageBuf(args.reference).get_pixels(oiio.FLOAT)[..., :3]
    if args.crop:
        x0, y0, x1, y1 = args.crop
        reference = reference[y0:y1, x0:x1]
    scene = load_usd(args.scene)
    aspect = scene.settings.height / scene.settings.width
    settings = dataclasses.replace(scene.settings, width=args.width, height=round(args.width * aspect))
    ours = render(scene, "native", settings, explain=False)
    uncoloured = dataclasses.replace(
        scene, instances=tuple(dataclasses.replace(g, colors=None) for g in scene.instances)
    )
    before = render(uncoloured, "native", settings, explain=False)

    ref = palette(reference)
    print(f"reference {args.reference}: grey {ref[0]:.3f}")
    for label, image in (("ours", ours), ("per-instance colours left out", before)):
        p = palette(to_display(image))
        distance = 0.5 * np.abs(p - ref).sum()
        print(f"{label}: grey {p[0]:.3f}, total-variation distance to the reference {distance:.3f}")


if __name__ == "__main__":
    main()
