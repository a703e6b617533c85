# SPDX-License-Identifier: Apache-2.0
"""The POV-Ray compiler declares each prototype mesh once and writes one ``object`` per copy:
the SDL grows by one line per instance, not by its triangles."""

from __future__ import annotations

import re

import numpy as np

from phongscene.backends.povray.compile import compile_pov
from phongscene.usd import load_usd
from support.instanced_stages import point_instancer_stage, reference_stage


def test_prototype_declared_once_and_one_object_per_copy(tmp_path):
    scene = load_usd(point_instancer_stage(tmp_path / "pi.usda", 300, rings=12, sides=8))
    sdl = compile_pov(scene)
    assert sdl.count("#declare Prototype_0_0 = mesh2 {") == 1
    assert sdl.count("mesh2 {") == 1
    assert sdl.count("face_indices { 192,") == 1
    objects = re.findall(r"object \{ Prototype_0_0 matrix <([^>]*)> texture \{ Material_\d+ \} \}", sdl)
    assert len(objects) == 300
    # Copy 0's matrix: the model's columns of the 3x3 part, then its translation (row-vector form).
    m = scene.instances[0].world_from_prototype[0]
    numbers = np.array([float(x) for x in objects[0].split(",")])
    assert np.array_equal(numbers, np.concatenate([m[:3, :3].T.reshape(-1), m[:3, 3]]))
    # The declared mesh carries no texture (each object adds its own, after its matrix).
    declared = sdl[sdl.index("#declare Prototype_0_0") :]
    assert "texture" not in declared[: declared.index("\n}")]
    # A tenfold scene is only longer by its object lines.
    longer = compile_pov(load_usd(point_instancer_stage(tmp_path / "pi3000.usda", 3000, rings=12, sides=8)))
    assert len(longer) - len(sdl) < 2700 * max(len(line) for line in sdl.splitlines() if line.startswith("object"))


def test_material_variants_are_prototypes_of_their_own(tmp_path):
    scene = load_usd(reference_stage(tmp_path / "refs.usda", 8, rings=6, sides=4, red_every=4))
    sdl = compile_pov(scene)
    assert sdl.count(" = mesh2 {") == 2 and sdl.count("object { Prototype_") == 8
    assert len(re.findall(r"^sphere \{", sdl, re.M)) == 8  # the asset's spheres, placed in the world
