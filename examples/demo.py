# SPDX-License-Identifier: Apache-2.0
"""`make demo`: load every example scene and print what it contains."""

from __future__ import annotations

import sys
from pathlib import Path

from phongscene.usd import read_usd

HERE = Path(__file__).resolve().parent


def describe(path: Path) -> str:
    result = read_usd(path)
    s = result.scene
    exponents = sorted({round(x.material.exponent, 6) for x in (*s.spheres, *s.meshes)})
    return (
        f"{path.name}: {len(s.spheres)} spheres, {len(s.meshes)} meshes ({s.triangle_count} triangles), "
        f"{len(s.lights)} lights, ambient {s.ambient.color}, exponents {exponents}, "
        f"{s.settings.width}x{s.settings.height}" + "".join(f"\n  warning: {w}" for w in result.warnings)
    )


def main() -> int:
    for path in sorted(HERE.glob("*.usda")):
        print(describe(path))
    return 0


if __name__ == "__main__":
    sys.exit(main())
