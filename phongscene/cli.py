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
    return parser


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
