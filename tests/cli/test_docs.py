# SPDX-License-Identifier: Apache-2.0
"""The documentation site (mkdocs.yml, docs/): it builds with warnings as errors, and its
generated parts follow the code (docs/hooks/generated.py)."""

from __future__ import annotations

import argparse
import importlib.util
import subprocess
import sys

import pytest

from support.paths import REPO

mkdocs = pytest.importorskip("mkdocs", reason="the docs extra is not installed (pip install '.[docs]')")
from mkdocs.exceptions import PluginError  # noqa: E402


def hook():
    spec = importlib.util.spec_from_file_location("docs_generated_hook", REPO / "docs" / "hooks" / "generated.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


class Page:
    class file:
        src_path = "trial.md"


def test_cli_reference_has_every_subcommand():
    from phongscene.cli import build_parser

    (commands,) = (a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    text = hook().on_page_markdown("# CLI\n\n<!-- generated: cli -->\n", Page, None, None)
    assert "<!-- generated" not in text
    for name in commands.choices:
        assert f"## `phongscene {name}`" in text and f"usage: phongscene {name}" in text


def test_attribute_table_lists_every_phong_attribute():
    from phongscene.usd import names

    text = hook().on_page_markdown("<!-- generated: phong-attributes -->\n", Page, None, None)
    for attributes in names.PHONG_ATTRIBUTES.values():
        for attribute in attributes:
            assert f"| `{attribute}` |" in text


def test_a_phong_attribute_without_a_meaning_fails_the_build(monkeypatch):
    from phongscene.usd import names

    monkeypatch.setitem(
        names.PHONG_ATTRIBUTES, "DomeLight", {**names.PHONG_ATTRIBUTES["DomeLight"], "phong:new": ("int",)}
    )
    with pytest.raises(PluginError, match="phong:new"):
        hook().on_page_markdown("<!-- generated: phong-attributes -->\n", Page, None, None)


def test_an_unknown_marker_fails_the_build():
    with pytest.raises(PluginError, match="trial.md.*'nonsense'"):
        hook().on_page_markdown("<!-- generated: nonsense -->\n", Page, None, None)


def test_shader_table_has_the_schema_defaults():
    from phongscene.usd.shader_defs import phong_input_defaults

    text = hook().on_page_markdown("<!-- generated: phong-shader -->\n", Page, None, None)
    assert f"| `inputs:exponent` | `float` | {phong_input_defaults()['exponent']:g} |" in text


@pytest.mark.slow
@pytest.mark.subprocess
def test_site_builds_with_warnings_as_errors(tmp_path):
    run = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--quiet", "--site-dir", str(tmp_path / "site")],
        cwd=REPO,
        capture_output=True,
        text=True,
        env={"NO_MKDOCS_2_WARNING": "1", "PATH": "/usr/bin:/bin"},
    )
    assert run.returncode == 0, run.stderr
    assert (tmp_path / "site" / "tutorial" / "first-scene" / "index.html").is_file()
    assert (tmp_path / "site" / "validation" / "speed_vs_error.png").is_file()
