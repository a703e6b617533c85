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
    # The lights stand in front of the sphere, so the image is lit (no image warning joins these).
    body = "".join(
        f'def SphereLight "L{i}" {{\n    float inputs:typo{i} = 1\n    double3 xformOp:translate = (0, 0, 4)\n'
        '    uniform token[] xformOpOrder = ["xformOp:translate"]\n}\n'
        for i in range(30)
    )
    scene.write_text('#usda 1.0\ndef Sphere "S" {\n}\n' + body)
    assert main(["render", str(scene), "-o", str(tmp_path / "out.exr"), "--width", "8", "--height", "8"]) == 0
    rendered = [line for line in capsys.readouterr().err.splitlines() if line.startswith("warning:")]
    assert len(rendered) <= MAX_WARNING_LINES and "more warnings" in rendered[-1]
    assert main(["info", str(scene)]) == 0
    listed = [line for line in capsys.readouterr().out.splitlines() if "inputs:typo" in line]
    assert len(listed) == 30


# usd-wg's teapotScene_animCycle.usd: 548 teapot prims reference one missing layer, each through
# one of 24 prims of its own ("... introduced by @scene.usd@</_teapot_animCycle_offset_N>").
OFFSET_PRIMS = 24
TEAPOTS = 548


def _through_offsets(i: int) -> str:
    return (
        f"/Scene/teapot{i}.references: Could not open asset @teapot.usd@ for reference introduced by "
        f"@scene.usd@</_offset_{i % OFFSET_PRIMS}>. (not composed)"
    )


def test_messages_that_name_different_prims_are_one_line_where_capped():
    warnings = [_through_offsets(i) for i in range(TEAPOTS)]
    (line,) = grouped(warnings, merge_named_paths=True)
    assert line.startswith(
        f"{TEAPOTS} prims: Could not open asset @teapot.usd@ for reference introduced by @scene.usd@</_offset_0> "
        f"(or another of {OFFSET_PRIMS} paths). (not composed) (/Scene/teapot0.references, "
    )
    assert len(grouped(warnings)) == OFFSET_PRIMS  # info keeps each named prim apart


def test_the_same_named_prim_and_different_assets_are_kept():
    same = [f"/P{i}.material:binding: targets /Looks/Gone, which does not exist" for i in range(2)]
    assert grouped(same, merge_named_paths=True) == [
        "2 prims: targets /Looks/Gone, which does not exist (/P0.material:binding, /P1.material:binding)"
    ]
    assets = [f"/P{i}.references: Could not open asset @/data/a{i}.usd@" for i in range(3)]  # three causes
    assert len(grouped(assets, merge_named_paths=True)) == 3


def test_a_missing_layer_through_many_prims_is_one_line_from_render(tmp_path, capsys):
    scene = tmp_path / "refs.usda"
    bases = "".join(f'class "Base{j}" (references = @missing.usda@) {{}}\n' for j in range(OFFSET_PRIMS))
    users = "".join(
        f'def Xform "T{i}" (references = </Base{i % OFFSET_PRIMS}>) {{}}\n' for i in range(2 * OFFSET_PRIMS)
    )
    scene.write_text("#usda 1.0\n" + bases + users)
    assert main(["render", str(scene), "-o", str(tmp_path / "out.exr"), "--width", "8", "--height", "8"]) == 0
    rendered = [line for line in capsys.readouterr().err.splitlines() if "missing.usda" in line]
    assert len(rendered) == 1 and f"(or another of {OFFSET_PRIMS} paths)" in rendered[0]
    assert main(["info", str(scene)]) == 0
    assert len([line for line in capsys.readouterr().out.splitlines() if "missing.usda" in line]) == OFFSET_PRIMS


def test_the_image_check_warning_counts_within_the_cap(tmp_path, capsys):
    # usd-wg's teapotScene_animCycle.usd printed 20 capped reader lines, then "nothing in view": 21.
    scene = tmp_path / "dark.usda"
    body = "".join(f'def SphereLight "L{i}" {{\n    float inputs:typo{i} = 1\n}}\n' for i in range(30))
    scene.write_text("#usda 1.0\n" + body)  # no geometry: nothing in view
    for command, output in (("render", "out.exr"), ("compile", "out.pov")):
        extra = ["--width", "8", "--height", "8"] if command == "render" else []
        assert main([command, str(scene), "-o", str(tmp_path / output), *extra]) == 0
        printed = capsys.readouterr()
        lines = [line for line in (printed.err + printed.out).splitlines() if line.startswith("warning:")]
        assert len(lines) == MAX_WARNING_LINES, command
        assert "more warnings" in lines[-2] and lines[-1].startswith("warning: nothing in view"), command


def test_warnings_printed_in_two_parts_share_one_cap():
    """``render --frames`` prints the first frame's warnings, then the later frames' new ones:
    together at most MAX_WARNING_LINES lines (they were 20 + 20)."""
    import io

    from phongscene.cli.options import print_warnings
    from phongscene.warning_groups import MAX_WARNING_LINES

    out = io.StringIO()
    first = print_warnings([f"message {i}" for i in range(15)], out)
    print_warnings([f"later {i}" for i in range(15)], out, leave=first)
    lines = out.getvalue().splitlines()
    assert first == 15 and len(lines) == MAX_WARNING_LINES
    assert lines[-1].startswith("warning: ... and ")
    out = io.StringIO()
    full = print_warnings([f"message {i}" for i in range(30)], out)
    print_warnings(["later"], out, leave=full)  # the cap is spent: one line still says so
    assert len(out.getvalue().splitlines()) == MAX_WARNING_LINES + 1
