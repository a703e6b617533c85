# SPDX-License-Identifier: Apache-2.0
"""How close the native tracer's look of a public asset is to the asset's own reference render:
usd-wg/assets' "cards" (``cards/<asset>_ZPos.png``: usdrecord/Storm renders along −Z,
orthographic, tight to the bounding box, lit by Storm's camera light, alpha = coverage).

For each asset the script writes a small stage that references it (its default variant), adds an
orthographic camera looking down −Z at the card's framing and the card's resolution, renders it
with ``phongscene render`` (no lights in the asset: the head light at the camera, as Storm's), and
compares inside the card's silhouette (alpha > ½ in both):

- **chroma**: the distance between the mean colours' chromaticities (r, g)/(r + g + b), linear;
  "grey" is the same for the uniform grey the reader gave MaterialX-only pieces before;
- **luma ratio**: mean luminance ours / card's (the lights' strengths differ: a scale, not an error).

Only means are compared: the cards' camera is not exactly an orthographic view of the bounds (the
king's knob under its cross, inside the crown seen level, shows in its card), so pixels do not
correspond one to one.

Usage: ``.venv/bin/python benchmarks/card_fidelity.py ASSET.usd [ASSET.usd ...] [--out DIR]``,
the cards found beside each asset (``cards/<stem>_ZPos.png``). OpenChessSet: ``git archive`` of
usd-wg/assets ``full_assets/OpenChessSet``, then ``assets/*/<Piece>.usd``.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import OpenImageIO as oiio
from pxr import Usd, UsdGeom

from phongscene.usd.diagnostics import usd_output

# A card pixel counts as the asset where its alpha is above this (antialiased edges excluded).
COVERAGE = 0.5
# Rec. 709 luminance weights (linear RGB).
LUMA = np.array([0.2126, 0.7152, 0.0722])


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def card_stage(asset: Path, coverage: np.ndarray, folder: Path) -> Path:
    """A stage referencing ``asset`` with an orthographic camera looking along −Z that puts its
    bounds where the card's silhouette (``coverage``, H × W booleans) is: the cards are not
    framed exactly to the bounds usd-core computes, so the framing is fitted to the card."""
    with usd_output([]):  # usd-core's own complaint about the .mtlx reference, not ours
        stage = Usd.Stage.Open(str(asset))
    bounds = UsdGeom.BBoxCache(Usd.TimeCode.Default(), ["default", "render"]).ComputeWorldBound(stage.GetPseudoRoot())
    box = bounds.ComputeAlignedRange()
    lo, hi = np.array(box.GetMin()), np.array(box.GetMax())
    size = hi - lo
    height, width = coverage.shape
    rows, cols = np.flatnonzero(coverage.any(axis=1)), np.flatnonzero(coverage.any(axis=0))
    # World units per pixel, from the silhouette's extent in both directions (averaged).
    pixel = 0.5 * (size[0] / (cols[-1] - cols[0] + 1) + size[1] / (rows[-1] - rows[0] + 1))
    centre = (lo[0] + (width / 2 - cols[0]) * pixel, hi[1] - (height / 2 - rows[0]) * pixel)
    up = UsdGeom.GetStageUpAxis(stage)
    text = f"""#usda 1.0
(
    upAxis = "{up}"
    metersPerUnit = {UsdGeom.GetStageMetersPerUnit(stage)}
    defaultPrim = "World"
)
def Xform "World" {{
    def "Asset" ( prepend references = @{asset.resolve()}@ ) {{ }}
    def Camera "Card" {{
        token projection = "orthographic"
        float horizontalAperture = {pixel * width * 10.0}
        float verticalAperture = {pixel * height * 10.0}
        float2 clippingRange = ({size[2] * 0.01}, {size[2] * 100.0})
        double3 xformOp:translate = ({centre[0]}, {centre[1]}, {hi[2] + size[2]})
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }}
}}
def RenderSettings "Render" {{
    int2 resolution = ({width}, {height})
}}
"""
    path = folder / f"{asset.stem}_card.usda"
    path.write_text(text)
    return path


def read_rgba(path: Path) -> np.ndarray:
    buf = oiio.ImageBuf(str(path))
    pixels = buf.get_pixels(oiio.FLOAT)
    if pixels.shape[2] == 3:
        pixels = np.concatenate([pixels, np.ones_like(pixels[..., :1])], axis=2)
    return pixels


def chroma(rgb: np.ndarray) -> np.ndarray:
    return rgb[:2] / max(float(rgb.sum()), 1e-12)


def measure(asset: Path, out: Path) -> dict:
    card_path = asset.parent / "cards" / f"{asset.stem}_ZPos.png"
    card = read_rgba(card_path)
    if not (card[..., 3] > COVERAGE).any():
        return {"asset": asset.stem, "empty": True}  # usd-wg's Bishop card is blank
    with tempfile.TemporaryDirectory() as tmp:
        stage = card_stage(asset, card[..., 3] > COVERAGE, Path(tmp))
        image = out / f"{asset.stem}_ours.exr"
        command = [
            sys.executable,
            "-m",
            "phongscene",
            "render",
            str(stage),
            "--camera",
            "/World/Card",
            "-o",
            str(image),
        ]
        done = subprocess.run(command, capture_output=True, text=True)
        if done.returncode != 0:
            raise SystemExit(f"{asset}: render failed:\n{done.stdout}{done.stderr}")
    ours = read_rgba(image)[..., :3]
    theirs = srgb_to_linear(card[..., :3])
    mask = card[..., 3] > COVERAGE
    mask &= ours.sum(axis=2) > 0  # our silhouette too (a miss is black)
    a, b = ours[mask], theirs[mask]
    mean_a, mean_b = a.mean(axis=0), b.mean(axis=0)
    la, lb = a @ LUMA, b @ LUMA
    grey = np.full(3, 1.0 / 3.0)
    return {
        "asset": asset.stem,
        "pixels": int(mask.sum()),
        "card mean": mean_b,
        "our mean": mean_a,
        "chroma": float(np.linalg.norm(chroma(mean_a) - chroma(mean_b))),
        "grey chroma": float(np.linalg.norm(grey[:2] - chroma(mean_b))),
        "luma ratio": float(la.mean() / lb.mean()),
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.RawTextHelpFormatter
    )
    parser.add_argument("assets", nargs="+", type=Path, help="asset files with a cards/<stem>_ZPos.png beside them")
    parser.add_argument(
        "--out", type=Path, default=Path("card_fidelity"), help="folder for our renders (default: %(default)s)"
    )
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    os.environ.setdefault("PHONGSCENE_NO_PROGRESS", "1")
    print(
        f"{'asset':<14} {'pixels':>7} {'card mean (linear)':>24} {'our mean':>24} {'chroma':>7} {'grey':>7} {'ratio':>6}"
    )
    for asset in args.assets:
        r = measure(asset, args.out)
        if r.get("empty"):
            print(f"{r['asset']:<14} (its card is empty: nothing to compare)")
            continue
        fmt = lambda c: "(" + ", ".join(f"{x:.3f}" for x in c) + ")"  # noqa: E731
        print(
            f"{r['asset']:<14} {r['pixels']:>7} {fmt(r['card mean']):>24} {fmt(r['our mean']):>24} "
            f"{r['chroma']:>7.4f} {r['grey chroma']:>7.4f} {r['luma ratio']:>6.2f}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
