# SPDX-License-Identifier: Apache-2.0
"""Warnings that read (phongscene/warning_groups.py): one line per message however many prims
it is about, and at most MAX_WARNING_LINES lines from a command."""

from __future__ import annotations

from phongscene.cli import main
from phongscene.warning_groups import MAX_WARNING_LINES, PRIMS_SHOWN, capped, grouped


def test_the_same_message_about_many_prims_is_one_line_in_place():
    warnings = ["first, about no prim"] + [
        f"/Set/Teapot{i}.inputs:x: not an input of Foo (ignored)" for i in range(500)
    ]
    warnings += ["/Other: something else", "last"]
    lines = grouped(warnings)
    assert lines[0] == "first, about no prim"
    assert lines[1].startswith("500 prims: not an input of Foo (ignored) (/Set/Teapot0.inputs:x, ")
    assert lines[1].endswith(f"and {500 - PRIMS_SHOWN} more)")
    assert lines[2:] == ["/Other: something else", "last"]


def test_a_message_about_one_prim_reads_as_before():
    assert grouped(["/A.inputs:intensty: not an input of SphereLight (ignored)"]) == [
        "/A.inputs:intensty: not an input of SphereLight (ignored)"
    ]


def test_distinct_messages_are_capped_with_a_count():
    lines = capped([f"cause {i}" for i in range(50)])
    assert len(lines) == MAX_WARNING_LINES
    assert lines[-1].startswith(f"... and {50 - MAX_WARNING_LINES + 1} more warnings")


def test_render_prints_at_most_the_cap_and_info_lists_every_warning(tmp_path, capsys):
    scene = tmp_path / "typos.usda"
    # 30 distinct typos (different attributes), each on its own light: 30 distinct warnings.
    body = "".join(f'def SphereLight "L{i}" {{\n    float inputs:typo{i} = 1\n}}\n' for i in range(30))
    scene.write_text('#usda 1.0\ndef Sphere "S" {\n}\n' + body)
    assert main(["render", str(scene), "-o", str(tmp_path / "out.exr"), "--width", "8", "--height", "8"]) == 0
    rendered = [line for line in capsys.readouterr().err.splitlines() if line.startswith("warning:")]
    assert len(rendered) <= MAX_WARNING_LINES and "more warnings" in rendered[-1]
    assert main(["info", str(scene)]) == 0
    listed = [line for line in capsys.readouterr().out.splitlines() if "inputs:typo" in line]
    assert len(listed) == 30
