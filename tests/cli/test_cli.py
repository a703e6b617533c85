# SPDX-License-Identifier: Apache-2.0
"""The command line as a whole: one module holds every subcommand (that importing it loads no
heavy module is tested in test_public_api.py)."""

from __future__ import annotations

import pytest

from phongscene.cli import build_parser, main
from support.paths import REPO

COMMANDS = ("diff", "compare", "info", "validate", "import", "render", "compile", "bench", "preview")


def test_every_command_is_registered_with_help():
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    assert tuple(sub.choices) == COMMANDS
    for name in COMMANDS:
        assert "Exit codes:" in sub.choices[name].format_help()


OUTPUT = {"render": ["-o", "x.png"], "diff": ["-o", "outdir"], "compile": ["-o", "x.pov"]}
# --spp 10..16 is the stratified pattern's range: validation rejects it for the others (test_adaptive.py).
BAD_OPTIONS = [
    ["--spp", "0"],
    ["--spp", "17"],
    ["--width", "0"],
    ["--spp", "two"],
    ["--aa-threshold", "1.5"],
    ["--shadow-adaptive", "-1"],
    ["--sample-pattern", "jitter"],
]


@pytest.mark.parametrize(
    "command, option",
    [(c, o) for c in OUTPUT for o in BAD_OPTIONS] + [(c, ["--threads", "-1"]) for c in ("render", "diff")],
)
def test_out_of_range_options_are_usage_errors(command, option, capsys):
    with pytest.raises(SystemExit) as e:
        main([command, "scene.usda", *OUTPUT[command], *option])
    assert e.value.code == 2  # argparse's usage error, before any file is read
    assert f"argument {option[0]}" in capsys.readouterr().err


@pytest.mark.parametrize("command, output", [("render", "x.png"), ("compile", "x.pov")])
def test_an_unwritable_output_is_an_error_naming_it(command, output, tmp_path, capsys):
    blocked = tmp_path / "a-file"  # a regular file where the output's folder should be
    blocked.write_text("")
    assert main([command, str(REPO / "examples" / "seed_lobe.usda"), "-o", str(blocked / output), "--width", "8"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("error: ") and str(blocked) in err[-1]


def test_mapping_choices_are_the_povray_backends():
    from phongscene.backends.povray import MAPPINGS
    from phongscene.cli import MAPPING_CHOICES

    assert MAPPING_CHOICES == MAPPINGS


def test_backend_choices_are_the_renderers():
    from phongscene.cli import BACKEND_CHOICES
    from phongscene.rendering import BACKENDS

    assert BACKEND_CHOICES == BACKENDS
