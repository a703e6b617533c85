# SPDX-License-Identifier: Apache-2.0
"""``phongscene import``: a mesh file (OBJ, PLY, STL, GLB, ...) to a USD scene."""

from __future__ import annotations

import argparse

from .process import EXIT_OK


def add_import_command(sub) -> None:
    p = sub.add_parser(
        "import",
        help="convert a mesh file (OBJ, PLY, STL, GLB, ...) to a USD scene",
        description="Read MESHFILE with trimesh and write a USD file with one Mesh (subdivisionScheme none) per "
        "object of the file (a GLB's nodes, named after them), bound to a default Phong material; a part with its "
        "own colours (PLY vertex or face colours, a GLB material's base colour) keeps them as displayColor "
        "instead. Normals: the file's when it has them, else smooth across "
        "edges and split at creases (faces meeting at more than --crease-angle). The scene has no camera or "
        "lights, so renderers use the framing camera and the head light.",
        epilog="Exit codes: 0 ok, 2 unreadable input or bad output path.",
    )
    p.add_argument("mesh", metavar="MESHFILE", help="any format trimesh.load reads")
    p.add_argument("-o", "--output", required=True, metavar="OUT", help="USD file to write (.usda, .usdc, .usd)")
    p.add_argument(
        "--crease-angle",
        type=_degrees,
        default=None,
        metavar="DEG",
        help="for files without normals: split normals where faces meet at more than DEG degrees "
        "(default 30, Blender's auto smooth; 0 = flat, 180 = smooth everywhere)",
    )
    p.set_defaults(func=run_import)


def _degrees(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an angle in degrees, got {text!r}") from None
    if not 0.0 <= value <= 180.0:
        raise argparse.ArgumentTypeError(f"expected an angle in 0..180 degrees, got {value:g}")
    return value


def run_import(args) -> int:
    from ..usd import import_mesh

    extra = {} if args.crease_angle is None else {"crease_angle_deg": args.crease_angle}
    path = import_mesh(args.mesh, args.output, **extra)
    print(f"wrote {path}")
    return EXIT_OK
