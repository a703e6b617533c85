# SPDX-License-Identifier: Apache-2.0
"""The ``phongscene`` command line: ``main`` (what the console script, ``python -m phongscene``
and the tests call) and ``build_parser``. Each command group has its module, with its parser and
a thin ``run_<command>`` that calls the public API and prints the result: ``render`` (render,
compile), ``diff`` (diff, compare), ``info`` (info, validate), ``mesh_import`` (import),
``bench``, ``preview``; ``frames`` runs --frames for render, compile and diff. The options more than one
command takes, the render overrides among them, are in ``options``; the exit statuses, signals
and deferred imports in ``process``.

Exit codes: 0 success, 1 images differ (diff/compare), 2 bad scene or usage, 3 backend failure,
130 interrupted. Every usage error a command finds after argparse (options that do not go
together, an output name it cannot write) is an ``options.UsageError``, printed by ``main`` as
argparse prints a bad option.

pxr, OpenImageIO and the backends are imported inside the run functions, so ``import
phongscene.cli`` and ``phongscene --help`` stay fast."""

from __future__ import annotations

import argparse
import sys

from .. import __version__
from ..errors import BackendError, PhongSceneError, SceneError
from .bench import add_bench_command
from .diff import add_compare_command, add_diff_command
from .info import add_info_command, add_validate_command
from .mesh_import import add_import_command
from .options import BACKEND_CHOICES, MAPPING_CHOICES, UsageError, check_estimator_options
from .preview import add_preview_command
from .process import (
    EXIT_BACKEND,
    EXIT_DIFFERENT,
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_SCENE,
    PREIMPORTS,
    Terminated,
    install_signal_handlers,
    preimport,
    restore_signal_handlers,
)
from .render import add_compile_command, add_render_command

__all__ = [
    "BACKEND_CHOICES",
    "EXIT_BACKEND",
    "EXIT_DIFFERENT",
    "EXIT_INTERRUPTED",
    "EXIT_OK",
    "EXIT_SCENE",
    "MAPPING_CHOICES",
    "build_parser",
    "main",
]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="phongscene",
        description="Author Phong scenes in USD, compile them to POV-Ray, render natively, diff the backends.",
        epilog="Exit codes: 0 ok, 1 images differ, 2 bad scene or usage, 3 backend failure.",
    )
    parser.add_argument("--version", action="version", version=f"phongscene {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for add_command in (
        add_diff_command,
        add_compare_command,
        add_info_command,
        add_validate_command,
        add_import_command,
        add_render_command,
        add_compile_command,
        add_bench_command,
        add_preview_command,
    ):
        add_command(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    previous = install_signal_handlers()
    try:
        return _main(argv)
    finally:
        restore_signal_handlers(previous)


def _main(argv: list[str] | None) -> int:
    args = None
    try:
        # The parser's option types import the scene model and with it numpy (~0.1 s): a Ctrl-C
        # there must wait for the import's end (one interrupted inside numpy's class set-up is
        # re-raised as a RuntimeError, a traceback), as the command's own imports do.
        preimport(("numpy",))
        parser = build_parser()
        args = parser.parse_args(argv)
        check_estimator_options(args)  # as argparse reports a bad option: before the scene is read
        preimport(PREIMPORTS.get(args.command, ()))
        return int(args.func(args) or 0)
    except UsageError as e:
        print(f"phongscene {args.command}: error: {e}", file=sys.stderr)
        return EXIT_SCENE
    except Terminated as e:
        import signal

        print(f"terminated by {signal.Signals(e.signum).name}", file=sys.stderr)
        return 128 + e.signum
    except SceneError as e:
        from ..rendering import in_file_terms

        for p in in_file_terms(e).problems:
            print(f"error: {p}", file=sys.stderr)
        return EXIT_SCENE
    except BackendError as e:
        print(f"error: {e}", file=sys.stderr)
        return EXIT_BACKEND
    except (PhongSceneError, OSError) as e:  # an output that cannot be written, an unreadable input
        print(f"error: {e}", file=sys.stderr)
        return EXIT_SCENE
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
