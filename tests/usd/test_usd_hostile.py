# SPDX-License-Identifier: Apache-2.0
"""Hostile USD files that used to end in a Python traceback: each is now one clear problem
naming the file, the prim and the attribute (and `phongscene validate` exits 2)."""

from __future__ import annotations

import pytest

from phongscene.cli import main
from phongscene.errors import SceneError
from phongscene.usd import read_usd

CASES = {
    "xform_op_typo": (
        '#usda 1.0\ndef Sphere "Ball" {\n    double3 xformOp:translate = (1, 0, 0)\n'
        '    uniform token[] xformOpOrder = ["xformOp:tranlate"]\n}\n',
        "/Ball",
        "xformOpOrder",
        "Invalid xform opType token 'tranlate'",
    ),
    "instancer_is_its_own_prototype": (
        '#usda 1.0\ndef PointInstancer "I" {\n    rel prototypes = </I>\n    int[] protoIndices = [0]\n'
        "    point3f[] positions = [(0, 0, 0)]\n}\n",
        "/I",
        "prototypes",
        "contains this instancer (a cycle)",
    ),
    "preview_string_roughness": (
        '#usda 1.0\ndef Material "M" {\n    token outputs:surface.connect = </M/S.outputs:surface>\n'
        '    def Shader "S" {\n        uniform token info:id = "UsdPreviewSurface"\n'
        '        string inputs:roughness = "rough"\n        token outputs:surface\n    }\n}\n'
        'def Sphere "B" (prepend apiSchemas = ["MaterialBindingAPI"]) {\n    rel material:binding = </M>\n}\n',
        "/M/S",
        "inputs:roughness",
        "must be a number, got 'rough'",
    ),
    "preview_negative_ior": (
        '#usda 1.0\ndef Material "M" {\n    token outputs:surface.connect = </M/S.outputs:surface>\n'
        '    def Shader "S" {\n        uniform token info:id = "UsdPreviewSurface"\n'
        "        float inputs:ior = -1\n        token outputs:surface\n    }\n}\n"
        'def Sphere "B" (prepend apiSchemas = ["MaterialBindingAPI"]) {\n    rel material:binding = </M>\n}\n',
        "/M/S",
        "inputs:ior",
        "must be > 0, got -1.0",
    ),
}


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(CASES))
def test_hostile_file_is_one_clear_problem(tmp_path, name, capsys):
    text, prim, attribute, message = CASES[name]
    path = tmp_path / f"{name}.usda"
    path.write_text(text)
    with pytest.raises(SceneError) as info:
        read_usd(path)
    (problem,) = info.value.problems
    assert (problem.prim, problem.attribute) == (prim, attribute) and message in problem.message
    assert main(["validate", str(path)]) == 2
    assert "Traceback" not in capsys.readouterr().err


def test_a_file_that_is_not_utf8_is_a_clear_error(tmp_path, capsys):
    path = tmp_path / "bytes.usda"
    path.write_bytes(b'#usda 1.0\ndef Sphere "B\xff" {\n}\n')
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert "not valid UTF-8" in err and "Traceback" not in err


@pytest.mark.parametrize(
    ("op", "message"),
    [("double3 xformOp:translate = (nan, 0, 0)", "not finite"), ("double3 xformOp:scale = (0, 1, 1)", "singular")],
)
def test_a_sphere_transform_fault_names_the_xform_ops(tmp_path, op, message):
    kind = op.split()[1].split(":")[1]
    path = tmp_path / "ball.usda"
    path.write_text(
        f'#usda 1.0\ndef Sphere "Ball" {{\n    {op}\n    uniform token[] xformOpOrder = ["xformOp:{kind}"]\n}}\n'
    )
    with pytest.raises(SceneError) as info:
        read_usd(path)
    (problem,) = info.value.problems
    assert (problem.prim, problem.attribute) == ("/Ball", "xformOpOrder") and message in problem.message
