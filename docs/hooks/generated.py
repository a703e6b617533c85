# SPDX-License-Identifier: Apache-2.0
"""MkDocs hook: the reference pages' generated parts, written from the code at every build.

A page asks for one with a marker line, ``<!-- generated: NAME -->``; an unknown marker, or a
code-side name without its documentation here, fails the build (so the pages cannot fall behind
the code):

- ``cli``: every subcommand's ``--help``, from the argparse parser the ``phongscene`` command uses;
- ``phong-shader``: the Phong shader's inputs (names.PHONG_INPUTS, with their Sdr defaults and help
  from schemas/phongscene_PhongSurface.usda);
- ``phong-attributes``: our ``phong:`` attributes (names.PHONG_ATTRIBUTES: prim types, value
  types), with the meaning of each from PHONG_ATTRIBUTE_MEANINGS below;
- ``model-fields``: the scene model's fields and the USD attribute each is read from
  (names.USD_ATTRIBUTES).
"""

from __future__ import annotations

import os
import re

from mkdocs.exceptions import PluginError

MARKER = re.compile(r"^<!-- generated: ([a-z-]+) -->$", re.MULTILINE)
HELP_COLUMNS = "100"  # argparse wraps help to $COLUMNS: fixed, so the page is the same everywhere


def _choices(values) -> str:
    return " \\| ".join(f"`{v}`" for v in values)


def _attribute_meanings() -> dict[str, str]:
    from phongscene.scene import SAMPLE_PATTERNS
    from phongscene.usd import names

    return {
        names.SHADOW_SAMPLES: "area-light shadow grid: 2^k+1 points per axis (default 9)",
        names.SHADOW_ADAPTIVE: "POV-Ray's `adaptive n` on the grid; unset: every grid point is traced",
        names.SHADOW_CELL_SAMPLES: "the native cells shadow estimator: K×K points per partial grid cell, "
        "K a power of 2 up to 16",
        names.FADE_DISTANCE: "seed point lights: POV-Ray's `fade_distance` d0 of the fade "
        "2/(1 + (d/d0)^p), world units; > 0 when the power is",
        names.FADE_POWER: "seed point lights: POV-Ray's `fade_power` p (default 0: no fade)",
        names.LIGHT_MODEL: f"{_choices(names.LIGHT_MODELS)}: UsdLux's units (the default) or the seed's constant light",
        names.SAMPLES: "anti-aliasing: N×N samples per pixel (`stratified`: at most N×N; `adaptive`: cells "
        "down to 1/N pixel)",
        names.SAMPLE_PATTERN: f"{_choices(SAMPLE_PATTERNS)}: the pixel estimator",
        names.AA_THRESHOLD: "POV-Ray's `+A`, 0…1 (default 0); `stratified`: its stopping tolerance, "
        "`adaptive`: its split threshold",
        names.SPECULAR_CONVENTION: "`seed` \\| `povray-classic`: the specular convention (the POV-Ray mapping "
        "`exact` \\| `classic`)",
        names.BACKGROUND: "the colour of rays that hit nothing, linear RGB (default black)",
        names.MAX_DEPTH: "the deepest reflected or refracted ray (the camera ray is depth 0; default 5; "
        "deeper rays return black)",
        names.TRANSMISSION_CONVENTION: "`book` \\| `povray`: the radiance of refracted rays, kt/η²·L (the book) "
        "or kt·L (POV-Ray)",
        names.TESSELLATE: "an intrinsic prim as triangles (64 segments around the axis) instead of its exact surface "
        "(default false)",
        names.SUBDIVISION_LEVEL: "a subdivision surface's uniform refinement level by OpenSubdiv, 0…8 (default 2; "
        "0: the control cage); `--subdivision-level` overrides it",
        names.INFINITE: "a Plane as the whole plane (POV-Ray `plane`), outside the scene's bounds (default false: "
        "its width × length rectangle)",
    }


def _cli() -> str:
    import argparse

    os.environ["COLUMNS"] = HELP_COLUMNS
    from phongscene.cli import build_parser

    parser = build_parser()
    (commands,) = (a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    parts = ["## `phongscene`", "", "```text", parser.format_help().rstrip(), "```", ""]
    for name, sub in commands.choices.items():
        parts += [f"## `phongscene {name}`", "", "```text", sub.format_help().rstrip(), "```", ""]
    return "\n".join(parts)


def _phong_shader() -> str:
    from phongscene.usd import names
    from phongscene.usd.shader_defs import phong_input_defaults, phong_input_help

    defaults, helps = phong_input_defaults(), phong_input_help()
    rows = ["| input | type | default | meaning | model field (`PhongMaterial`) |", "|---|---|---|---|---|"]
    for name, (field, type_name) in names.PHONG_INPUTS.items():
        default = defaults[name]
        shown = "(" + ", ".join(f"{c:g}" for c in default) + ")" if isinstance(default, tuple) else f"{default:g}"
        rows.append(f"| `inputs:{name}` | `{type_name}` | {shown} | {helps[name]} | `{field}` |")
    return "\n".join(rows)


def _phong_attributes() -> str:
    from phongscene.usd import names

    meanings = _attribute_meanings()
    by_attribute: dict[str, list[str]] = {}
    types: dict[str, tuple[str, ...]] = {}
    for prim_type, attributes in names.PHONG_ATTRIBUTES.items():
        for attribute, value_types in attributes.items():
            by_attribute.setdefault(attribute, []).append(prim_type)
            types[attribute] = value_types
    undocumented = sorted(set(by_attribute) - set(meanings))
    stale = sorted(set(meanings) - set(by_attribute))
    if undocumented or stale:
        raise PluginError(
            f"docs/hooks/generated.py: PHONG_ATTRIBUTES and the meanings disagree: undocumented {undocumented}, "
            f"documented but unknown {stale}"
        )
    fields: dict[str, set[str]] = {}
    for node, table in names.USD_ATTRIBUTES.items():
        for field, attribute in table.items():
            fields.setdefault(attribute, set()).add(f"{node}.{field}")
    rows = ["| attribute | on | value types | meaning | model field |", "|---|---|---|---|---|"]
    for attribute, prim_types in by_attribute.items():
        on = ", ".join(f"`{t}`" for t in prim_types)
        value_types = ", ".join(f"`{t}`" for t in types[attribute])
        model = ", ".join(f"`{f}`" for f in sorted(fields.get(attribute, ()))) or "—"
        rows.append(f"| `{attribute}` | {on} | {value_types} | {meanings[attribute]} | {model} |")
    return "\n".join(rows)


def _model_fields() -> str:
    from phongscene.usd import names

    rows = ["| model node | field | USD attribute |", "|---|---|---|"]
    for node, table in names.USD_ATTRIBUTES.items():
        for field, attribute in table.items():
            rows.append(f"| `{node}` | `{field}` | `{attribute}` |")
    return "\n".join(rows)


GENERATORS = {
    "cli": _cli,
    "phong-shader": _phong_shader,
    "phong-attributes": _phong_attributes,
    "model-fields": _model_fields,
}


def on_page_markdown(markdown: str, page, config, files) -> str:
    def generated(match: re.Match) -> str:
        name = match.group(1)
        if name not in GENERATORS:
            raise PluginError(f"{page.file.src_path}: unknown generated part {name!r} (known: {sorted(GENERATORS)})")
        return GENERATORS[name]()

    return MARKER.sub(generated, markdown)
