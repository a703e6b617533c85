# SPDX-License-Identifier: Apache-2.0
"""The source assets the Phong shader's Sdr definition names (schemas/phong.h for a C++
renderer, schemas/phong.inc for POV-Ray) compute what they say: phong.h the seed's light term,
phong.inc the classic mapping's texture, pixel for pixel what the compiler writes."""

from __future__ import annotations

import dataclasses
import math
import shutil
import subprocess

import numpy as np
import pytest

from phongscene.backends.povray import compile_pov, prepare, run
from phongscene.scene import PhongMaterial, PointLight, RenderSettings, Scene, Sphere
from support.paths import REPO

SCHEMAS = REPO / "schemas"
# phong.h and the formula below are the same double expression up to operation order.
PHONG_H_RELATIVE = 1e-14


@pytest.mark.subprocess
@pytest.mark.skipif(shutil.which("g++") is None, reason="g++ not installed")
def test_phong_h_is_the_seed_light_term(tmp_path):
    cases = [  # kd, cd, ks, cs, e, n·l, r·wo, light
        (0.6, 0.8, 0.3, 1.0, 32.0, 0.7, 0.9, 3.0),
        (1.0, 0.5, 0.5, 0.25, 1000.0, 0.2, 0.999, 1.0),
        (0.2, 1.0, 1.0, 1.0, 0.0, 1.0, -0.1, 2.0),  # r·wo <= 0: no highlight, also for e = 0
    ]
    program = tmp_path / "probe.cpp"
    calls = "\n".join(f'    std::printf("%.17g\\n", phong_light_term({", ".join(map(repr, c))}));' for c in cases)
    program.write_text(f'#include <cstdio>\n#include "phong.h"\nint main() {{\n{calls}\n}}\n')
    subprocess.run(["g++", "-std=c++17", "-I", str(SCHEMAS), str(program), "-o", str(tmp_path / "probe")], check=True)
    out = [
        float(x)
        for x in subprocess.run([str(tmp_path / "probe")], capture_output=True, text=True, check=True).stdout.split()
    ]
    for value, (kd, cd, ks, cs, e, n_dot_l, r_dot_wo, light) in zip(out, cases):
        specular = ks * cs * r_dot_wo**e if r_dot_wo > 0 else 0.0
        expected = (kd * cd / math.pi + specular) * light * n_dot_l
        assert value == pytest.approx(expected, rel=PHONG_H_RELATIVE)


@pytest.mark.slow
@pytest.mark.povray
def test_phong_inc_macro_renders_the_classic_mapping(tmp_path):
    material = PhongMaterial(ka=0.2, kd=0.7, ks=0.4, exponent=25.0, diffuse_color=(0.9, 0.4, 0.2))
    scene = Scene(
        lights=(PointLight((2.0, 3.0, 4.0), (1.5, 1.5, 1.5)),),
        spheres=(Sphere.at((0.0, 0.0, -4.0), 1.0, material),),
        settings=RenderSettings(width=48, height=36, specular="povray-classic"),
    )
    job = prepare(scene, scene.settings, "classic")
    sdl = compile_pov(scene, mapping="classic")
    declared = next(line for line in sdl.splitlines() if line.startswith("#declare Material_0 = "))
    cd = ", ".join(repr(c) for c in material.diffuse_color)
    macro = f'#include "phong.inc"\n#declare Material_0 = PhongSurface({material.ka!r}, {material.kd!r}, {material.ks!r}, {material.exponent!r}, <{cd}>)'
    edited = sdl.replace(declared, macro)
    with_macro = dataclasses.replace(job, write_sdl=lambda out: out.write(edited))
    shutil.copy(SCHEMAS / "phong.inc", tmp_path / "phong.inc")
    (compiled,) = run._run(job, "compiled", None, str(tmp_path), lambda n: None)
    (from_macro,) = run._run(with_macro, "macro", None, str(tmp_path), lambda n: None)
    assert compiled.max() > 0.1  # the sphere is lit
    assert np.array_equal(from_macro, compiled)
