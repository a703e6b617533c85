# SPDX-License-Identifier: Apache-2.0
"""The package's public names: each resolves to a function or class, and ``import phongscene``
(or ``phongscene.cli``, for a fast ``--help``) stays light: the heavy modules load on first use."""

from __future__ import annotations

import inspect
import subprocess
import sys

import pytest

import phongscene

HEAVY_MODULES = ("pxr", "OpenImageIO", "phongscene.backends.native", "phongscene.backends.povray")


def test_every_public_name_resolves_to_a_function_or_class():
    for name in phongscene.__all__:
        value = getattr(phongscene, name)
        assert inspect.isclass(value) or inspect.isfunction(value), (name, value)
        assert value.__name__ == name, (name, value)


def test_functions_share_names_with_no_module():
    # The modules are comparison, crossvalidation and rendering, so nothing shadows the functions.
    from phongscene.comparison import compare
    from phongscene.crossvalidation import diff
    from phongscene.rendering import render

    assert (phongscene.compare, phongscene.diff, phongscene.render) == (compare, diff, render)


def test_unknown_names_raise_attribute_error():
    assert not hasattr(phongscene, "no_such_name")


@pytest.mark.parametrize("module", ["phongscene", "phongscene.cli"])
def test_importing_the_package_or_the_cli_loads_no_heavy_module(module):
    probe = (
        f"import sys, {module}\n"
        f"heavy = [m for m in {HEAVY_MODULES!r} if m in sys.modules]\n"
        "assert not heavy, heavy\n"
    )
    subprocess.run([sys.executable, "-c", probe], check=True)
