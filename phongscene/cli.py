# SPDX-License-Identifier: Apache-2.0
"""The ``phongscene`` command line. Exit codes: 0 success, 1 images differ (diff/compare),
2 bad scene or usage, 3 backend failure, 130 interrupted."""

from __future__ import annotations

import argparse
import sys

from . import __version__
from .errors import BackendError, SceneError

EXIT_OK, EXIT_DIFFERENT, EXIT_SCENE, EXIT_BACKEND, EXIT_INTERRUPTED = 0, 1, 2, 3, 130


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="phongscene",
        description="Author Phong scenes in USD, compile them to POV-Ray, render natively, diff the backends.",
        epilog="Exit codes: 0 ok, 1 images differ, 2 bad scene or usage, 3 backend failure.",
    )
    parser.add_argument("--version", action="version", version=f"phongscene {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    # Each subcommand registers itself here: add_parser(...).set_defaults(func=...).
    from .diff import add_compare_command, add_diff_command

    add_diff_command(sub)
    add_compare_command(sub)
    from .usd_cli import add_usd_commands

    add_usd_commands(sub)
    _add_render_command(sub)
    from .backends.povray.cli import add_compile_command

    add_compile_command(sub)
    return parser


def _add_render_command(sub) -> None:
    """``phongscene render SCENE -o out.exr|png``: one backend, one image."""
    from .diff import _positive_int

    p = sub.add_parser(
        "render",
        help="render a scene to an image (native tracer by default, or POV-Ray)",
        description="Render SCENE (USD) with one backend and write a linear EXR (float) or an sRGB PNG. "
        "A progress bar is drawn on stderr when it is a terminal (logs stay free of carriage returns).",
        epilog="Exit codes: 0 ok, 2 bad scene or usage, 3 backend failure, 130 interrupted (Ctrl-C).",
    )
    p.add_argument("scene", metavar="SCENE", help="USD file (.usda, .usdc, .usd, .usdz)")
    p.add_argument("-o", "--output", required=True, metavar="IMAGE", help="output image, .exr or .png (atomic write)")
    p.add_argument("--backend", choices=("native", "povray"), default="native", help="renderer (default: native)")
    p.add_argument("--mapping", choices=("exact", "classic"),
                   help="specular convention: exact (the seed model) or classic (plain POV-Ray phong, native "
                   "'povray-classic'); default: the scene's")
    p.add_argument("--width", type=_positive_int, metavar="W", help="image width (alone: keeps the aspect ratio)")
    p.add_argument("--height", type=_positive_int, metavar="H", help="image height (alone: keeps the aspect ratio)")
    p.add_argument("--spp", type=_positive_int, metavar="N", help="anti-aliasing: N x N samples per pixel")
    p.add_argument("--threads", type=int, metavar="N", help="worker threads (0 = all cores)")
    p.set_defaults(func=_run_render)


def _run_render(args) -> int:
    import time

    from .diff import ProgressBar, diff_settings, load_scene
    from .images import WRITABLE, write_image
    from .render import render

    if not args.output.lower().endswith(WRITABLE):
        print(f"error: {args.output}: the output must end in one of {', '.join(WRITABLE)}", file=sys.stderr)
        return EXIT_SCENE
    scene, warnings = load_scene(args.scene)
    for w in warnings:
        print(f"warning: {w}", file=sys.stderr)
    settings = diff_settings(scene, args.mapping, width=args.width, height=args.height, samples=args.spp,
                             threads=args.threads)
    bar = ProgressBar(args.backend)
    start = time.perf_counter()
    image = render(scene, args.backend, settings, progress=bar)
    bar.done(time.perf_counter() - start)
    write_image(args.output, image)
    print(f"{args.output}: {settings.width} x {settings.height}, {args.backend}, specular {settings.specular}")
    return EXIT_OK


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except SceneError as e:
        for p in e.problems:
            print(f"error: {p}", file=sys.stderr)
        return EXIT_SCENE
    except BackendError as e:
        print(f"error: {e}", file=sys.stderr)
        return EXIT_BACKEND
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
