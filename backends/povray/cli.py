# SPDX-License-Identifier: Apache-2.0
"""``phongscene compile SCENE -o out.pov``: write the SDL and an ``.ini`` beside it, print the
povray command line that renders it."""

from __future__ import annotations

import shlex
import sys
from pathlib import Path

from phongscene.files import write_text_atomic

from .run import prepare


def add_compile_command(sub) -> None:
    """Register the ``compile`` subcommand on an argparse subparsers object."""
    from phongscene.diff import _positive_int

    p = sub.add_parser(
        "compile",
        help="compile a scene to POV-Ray 3.7 SDL (.pov) and an .ini with the render options",
        description="Compile SCENE (USD) to POV-Ray 3.7 SDL. Writes OUT.pov and OUT.ini (atomically) and prints "
        "the povray command line. The exact mapping renders one frame per light: add the linear frame images "
        "(phongscene render --backend povray does all of this for you).",
        epilog="Exit codes: 0 ok, 2 bad scene or usage.",
    )
    p.add_argument("scene", metavar="SCENE", help="USD file (.usda, .usdc, .usd, .usdz)")
    p.add_argument("-o", "--output", required=True, metavar="OUT.pov", help="the SDL file to write")
    p.add_argument("--mapping", choices=("exact", "classic"),
                   help="exact (the seed model, one pass per light) or classic (one plain POV-Ray finish per "
                   "material); default: the scene's specular convention")
    p.add_argument("--width", type=_positive_int, metavar="W", help="image width (alone: keeps the aspect ratio)")
    p.add_argument("--height", type=_positive_int, metavar="H", help="image height (alone: keeps the aspect ratio)")
    p.add_argument("--spp", type=_positive_int, metavar="N", help="anti-aliasing: N x N samples per pixel")
    p.set_defaults(func=run_compile)


def run_compile(args) -> int:
    from phongscene.diff import diff_settings, load_scene

    out = Path(args.output)
    if out.suffix.lower() != ".pov":
        print(f"error: {out}: the output must end in .pov", file=sys.stderr)
        return 2
    scene, warnings = load_scene(args.scene)
    for w in warnings:
        print(f"warning: {w}", file=sys.stderr)
    settings = diff_settings(scene, args.mapping, width=args.width, height=args.height, samples=args.spp)
    job = prepare(scene, settings, args.mapping)
    ini, image = out.with_suffix(".ini"), out.with_suffix(".exr")
    write_text_atomic(out, job.sdl, encoding="ascii")
    write_text_atomic(ini, job.ini(out.name, image.name), encoding="ascii")
    mapping = args.mapping or ("exact" if settings.specular == "seed" else "classic")
    print(f"{out}: {mapping} mapping, {job.frames} frame(s), {settings.width} x {settings.height}")
    print(f"{ini}: the same options; render in {out.parent or '.'} with: povray {ini.name}")
    print("  " + shlex.join(job.command(out.name, image.name)))
    if job.frames > 1:
        print(f"  then add the {job.frames} linear frame images (one per light)")
    if job.supersample > 1:
        print(f"  then average {job.supersample} x {job.supersample} pixel blocks (grid anti-aliasing)")
    return 0

