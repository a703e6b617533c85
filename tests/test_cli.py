# SPDX-License-Identifier: Apache-2.0
"""The command line as a whole: one module holds every subcommand, and loading it (or printing
its help) imports neither pxr, OpenImageIO nor a backend."""

from __future__ import annotations

import subprocess
import sys

from phongscene.cli import build_parser

COMMANDS = ("diff", "compare", "info", "validate", "import", "render", "compile")
HEAVY_MODULES = ("pxr", "OpenImageIO", "phongscene.backends.native", "phongscene.backends.povray")


def test_every_command_is_registered_with_help():
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    assert tuple(sub.choices) == COMMANDS
    for name in COMMANDS:
        assert "Exit codes:" in sub.choices[name].format_help()


def test_importing_the_cli_loads_no_heavy_module():
    probe = (
        "import sys, phongscene.cli\n"
        f"heavy = [m for m in {HEAVY_MODULES!r} if m in sys.modules]\n"
        "assert not heavy, heavy\n"
    )
    subprocess.run([sys.executable, "-c", probe], check=True)
