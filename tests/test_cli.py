# SPDX-License-Identifier: Apache-2.0
"""The command line as a whole: one module holds every subcommand (that importing it loads no
heavy module is tested in test_public_api.py)."""

from __future__ import annotations

from phongscene.cli import build_parser

COMMANDS = ("diff", "compare", "info", "validate", "import", "render", "compile")


def test_every_command_is_registered_with_help():
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    assert tuple(sub.choices) == COMMANDS
    for name in COMMANDS:
        assert "Exit codes:" in sub.choices[name].format_help()
