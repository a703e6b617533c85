# SPDX-License-Identifier: Apache-2.0
"""`make demo`: list every example scene, then cross-validate the seed's exponent series
(examples/seed_exponents.usda): render it with POV-Ray and with the native tracer, compare the
two at half-float precision and write the report (images, heat map, metrics.json, index.html)
to out/demo/. Prints both timings and the agreement; exits 0 when the backends agree, 1 when
they differ, 2 for a bad scene, 3 when a backend fails (e.g. POV-Ray is not installed)."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from phongscene.cli import EXIT_BACKEND, EXIT_DIFFERENT, EXIT_OK, EXIT_SCENE
from phongscene.comparison import HALF_ROUNDING_RELATIVE
from phongscene.crossvalidation import diff
from phongscene.errors import BackendError, SceneError
from phongscene.usd import read_usd

HERE = Path(__file__).resolve().parent
DEMO_SCENE = HERE / "seed_exponents.usda"
DEFAULT_OUTDIR = HERE.parent / "out" / "demo"


def describe(path: Path) -> str:
    result = read_usd(path)
    s = result.scene
    exponents = sorted({round(x.material.exponent, 6) for x in (*s.spheres, *s.meshes)})
    return (
        f"{path.name}: {len(s.spheres)} spheres, {len(s.meshes)} meshes ({s.triangle_count} triangles), "
        f"{len(s.lights)} lights, ambient {s.ambient.color}, exponents {exponents}, "
        f"{s.settings.width}x{s.settings.height}" + "".join(f"\n  warning: {w}" for w in result.warnings)
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "-o", "--outdir", type=Path, default=DEFAULT_OUTDIR, help=f"report folder (default {DEFAULT_OUTDIR})"
    )
    args = parser.parse_args(argv)

    print("Example scenes:")
    for path in sorted(HERE.glob("*.usda")):
        print(describe(path))
    print(f"\nCross-validating {DEMO_SCENE.name} (POV-Ray exact mapping vs native 'seed' convention):")
    try:
        result = diff(DEMO_SCENE, args.outdir, mapping="exact", progress=sys.stderr)
    except SceneError as e:
        print(f"error: {e}", file=sys.stderr)
        return EXIT_SCENE
    except BackendError as e:
        print(f"error: {e}", file=sys.stderr)
        return EXIT_BACKEND
    r, s = result.report, result.settings
    print(f"  image       {s.width} x {s.height}")
    print(f"  POV-Ray     {result.timings['povray']:.3f} s")
    print(f"  native      {result.timings['native']:.3f} s")
    verdict = "agree" if r.ok else "DIFFER"
    print(
        f"  agreement   {verdict}: max error {r.max_error:.3g}"
        f" (relative {r.max_relative_error / HALF_ROUNDING_RELATIVE:.2f} x 2^-11; half-float rounding is up to 1 x 2^-11),"
        f" {r.failing_pixels} of {r.pixels} pixels outside half-float precision"
    )
    print(f"  report      {result.outdir / 'index.html'}")
    # The CLI is in the virtual environment make created, not on PATH (README.md, "A short example").
    bin_dir = os.path.relpath(Path(sys.prefix) / "bin")
    print(f"\nNext: {bin_dir}/phongscene --help   (or: source {bin_dir}/activate, then phongscene --help)")
    return EXIT_OK if r.ok else EXIT_DIFFERENT


if __name__ == "__main__":
    sys.exit(main())
