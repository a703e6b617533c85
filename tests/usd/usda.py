# SPDX-License-Identifier: Apache-2.0
"""Reading a scene written as usda text in a test, and the tolerances the reader's tests share."""

from __future__ import annotations

import textwrap

from phongscene.usd import read_usd

EXACT = 1e-12  # double-precision arithmetic on small integers and unit vectors
FLOAT32 = 1e-6  # values stored as float in USD


def read(tmp_path, body: str, up: str = "Y"):
    path = tmp_path / "scene.usda"
    # One-line prim bodies ("{ double size = 3 }") are written out on lines, as usda requires.
    body = textwrap.dedent(body).replace("{ ", "{\n").replace(" }", "\n}")
    path.write_text(f'#usda 1.0\n(\n    upAxis = "{up}"\n)\n\n' + body)
    return read_usd(path)
