# SPDX-License-Identifier: Apache-2.0
"""POV-Ray 3.7's reflection, refraction and transparency, as docs/povray-3.7-semantics.md §18
states them: each measured fact re-measured on a tiny SDL scene (the centre pixel of a 4×4
render), all scenes as the frames of one POV-Ray process. Predictions are closed forms written
from the document, compared at POV-Ray's output precision (half float)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from phongscene.backends.povray.run import PovJob, _run

pytestmark = [pytest.mark.povray, pytest.mark.slow]  # one POV-Ray process of 45 frames: ~10 s on 2 cores

# POV-Ray writes half floats: a value is its prediction rounded to 11 significant bits, so within
# 2^-11 relative (one half-float rounding plus float32 arithmetic, far below it).
HALF_RELATIVE = 2.0**-11
SIZE = 4  # pixels per side; the centre pixel is read

ORTHO_DOWN_Z = "camera { orthographic location <0,0,5> look_at <0,0,0> right x*1 up y*1 }"


def _settings(extra: str = "", ambient_light: str = "1") -> str:
    return f"global_settings {{ assumed_gamma 1.0 ambient_light rgb {ambient_light} {extra} }}"


# The plane z = 0 under an orthographic camera looking down −z: its reflection ray leaves
# along +z, to the background B.
PIGMENT = np.array([0.5, 0.25, 0.1])
B = np.array([0.2, 0.4, 0.8])


def _plane(finish: str, pigment: str = "rgb <0.5, 0.25, 0.1>", interior: str = "") -> str:
    return (
        f"{_settings('adc_bailout 0')}\nbackground {{ color rgb <0.2, 0.4, 0.8> }}\n{ORTHO_DOWN_Z}\n"
        f"plane {{ z, 0 pigment {{ {pigment} }} finish {{ {finish} }} {interior} }}"
    )


def _mirrors(max_trace_level: str, bailout: str = "adc_bailout 0") -> str:
    """Facing mirrors z = 0 (red) and z = 10 (green), ambient 1 and reflection 0.5, blue background."""
    return (
        f"{_settings(f'{bailout} {max_trace_level}')}\nbackground {{ color rgb <0, 0, 1> }}\n{ORTHO_DOWN_Z}\n"
        "plane { z, 0 pigment { rgb <1, 0, 0> } finish { ambient 1 diffuse 0 reflection 0.5 } }\n"
        "plane { z, 10 pigment { rgb <0, 1, 0> } finish { ambient 1 diffuse 0 reflection 0.5 } }"
    )


def _mirror_series(levels: int) -> np.ndarray:
    return sum(0.5**k * np.array([1.0, 0.0, 0.0] if k % 2 == 0 else [0.0, 1.0, 0.0]) for k in range(levels))


K = np.array([0.8, 0.6, 0.4])  # the backdrop behind the glass
BACKDROP = "plane { z, -5 pigment { rgb <0.8, 0.6, 0.4> } finish { ambient 1 diffuse 0 } }"


def _glass(shape: str, pigment: str, interior: str, finish: str = "") -> str:
    return (
        f"{_settings('adc_bailout 0 max_trace_level 10')}\nbackground {{ color rgb 0 }}\n{ORTHO_DOWN_Z}\n{BACKDROP}\n"
        f"{shape} pigment {{ {pigment} }} finish {{ ambient 0 diffuse 0 {finish} }} interior {{ {interior} }} }}"
    )


SLAB = "box { <-100, -100, -2>, <100, 100, 0>"  # 2 units thick
HALF_SPACE = "plane { z, 0"  # glass below z = 0: the backdrop is inside it


def _tir(pigment: str, ior: float, finish: str = "", ambient: str = "0", max_trace_level: int = 10) -> str:
    """A camera inside a glass box looking up at 60° from the normal of its top face."""
    s, c = math.sin(math.radians(60)), math.cos(math.radians(60))
    return (
        f"{_settings(f'adc_bailout 0 max_trace_level {max_trace_level}')}\nbackground {{ color rgb <0, 0, 1> }}\n"
        f"camera {{ orthographic location <0, 0, 0> direction <{s}, {c}, 0> right <0, 0, 0.01> up <{-c}, {s}, 0>*0.01 }}\n"
        "plane { y, -5 pigment { rgb <0.8, 0.6, 0.4> } finish { ambient 1 diffuse 0 } }\n"
        f"box {{ <-1000, -10, -1000>, <1000, 10, 1000> pigment {{ {pigment} }}"
        f" finish {{ ambient {ambient} diffuse 0 {finish} }} interior {{ ior {ior} }} }}"
    )


def _inside_up(finish: str) -> str:
    """A camera inside a faded glass box looking straight up at its top face, 10 units away."""
    return (
        f"{_settings('adc_bailout 0 max_trace_level 10')}\nbackground {{ color rgb 0 }}\n"
        "camera { orthographic location <0, 0, 0> direction <0, 1, 0> right <0, 0, 0.01> up <0.01, 0, 0> }\n"
        "plane { y, -5 pigment { rgb <0.8, 0.6, 0.4> } finish { ambient 1 diffuse 0 } }\n"
        f"box {{ <-1000, -10, -1000>, <1000, 10, 1000> pigment {{ rgbf <1, 1, 1, 1> }} finish {{ ambient 0 diffuse 0 {finish} }}"
        " interior { ior 1.5 fade_distance 100 fade_power 1001 fade_color <0.5, 0.5, 0.5> } }"
    )


def _shadow(occluder: str) -> str:
    """A white floor (diffuse 1) lit from straight above, seen from above; the occluder between
    them is `no_image` (it casts shadows but is not seen)."""
    return (
        f"{_settings('adc_bailout 0 max_trace_level 10', ambient_light='0')}\nbackground {{ color rgb 0 }}\n"
        "camera { orthographic location <0, 20, 0> look_at <0, 0, 0> right x*1 up z*1 }\n"
        "light_source { <0, 10, 0> color rgb 1 }\n"
        "plane { y, 0 pigment { rgb 1 } finish { ambient 0 diffuse 1 } }\n" + occluder
    )


def _disc(pigment: str) -> str:
    return f"disc {{ <0, 5, 0>, y, 3 pigment {{ {pigment} }} finish {{ ambient 0 diffuse 0 }} no_image }}"


def _box(pigment: str, interior: str = "", finish: str = "") -> str:
    return (
        f"box {{ <-3, 4, -3>, <3, 6, 3> pigment {{ {pigment} }} finish {{ ambient 0 diffuse 0 {finish} }}"
        f" interior {{ ior 1 {interior} }} no_image }}"
    )


def _fade(c, d: float, fd: float, power: float) -> np.ndarray:
    """POV-Ray's interior fade over distance d (§18)."""
    c = np.asarray(c, dtype=np.float64)
    if power >= 1000:
        return np.exp(-(d / fd) * (1 - c))
    return c + (1 - c) / (1 + (d / fd) ** power)


def _fresnel(cos_i: float, n1: float, n2: float) -> float:
    """Unpolarised Fresnel reflectance (the mean of the s and p reflectances)."""
    sin_t = n1 / n2 * math.sqrt(1 - cos_i**2)
    cos_t = math.sqrt(1 - sin_t**2)
    rs = ((n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t)) ** 2
    rp = ((n1 * cos_t - n2 * cos_i) / (n1 * cos_t + n2 * cos_i)) ** 2
    return (rs + rp) / 2


OCCLUDER = np.array([0.5, 0.8, 1.0])
LOCAL = PIGMENT  # ambient 1, ambient_light 1
F15 = ((1.5 - 1) / (1.5 + 1)) ** 2  # Fresnel at normal incidence, ior 1.5: 0.04
F_INSIDE_11 = _fresnel(math.cos(math.radians(60)), 1.1, 1.0)

# (name, SDL, predicted centre pixel)
CASES = [
    # reflection is added on top of the pigment, unweighted
    ("reflection adds kr·B", _plane("ambient 1 diffuse 0 reflection 0.5"), LOCAL + 0.5 * B),
    (
        "reflection colour adds cr·B",
        _plane("ambient 1 diffuse 0 reflection rgb <0.5, 0.3, 0.1>"),
        LOCAL + np.array([0.5, 0.3, 0.1]) * B,
    ),
    (
        "metallic reflection is tinted by the pigment",
        _plane("ambient 1 diffuse 0 reflection { 0.5 metallic }"),
        LOCAL + 0.5 * PIGMENT * B,
    ),
    (
        "conserve_energy changes nothing when opaque",
        _plane("ambient 1 diffuse 0 reflection 0.5 conserve_energy"),
        LOCAL + 0.5 * B,
    ),
    (
        "fresnel without an interior: ior 1, no reflection",
        _plane("ambient 1 diffuse 0 reflection { 0, 1 fresnel on }"),
        LOCAL,
    ),
    (
        "fresnel at normal incidence, ior 1.5",
        _plane("ambient 0 diffuse 0 reflection { 0, 1 fresnel on }", interior="interior { ior 1.5 }"),
        F15 * B,
    ),
    (
        "fresnel at normal incidence, ior 2",
        _plane("ambient 0 diffuse 0 reflection { 0, 1 fresnel on }", interior="interior { ior 2 }"),
        (1 / 3) ** 2 * B,
    ),
    (
        "fresnel blends min and max",
        _plane("ambient 0 diffuse 0 reflection { 0.2, 0.6 fresnel on }", interior="interior { ior 1.5 }"),
        (0.2 + 0.4 * F15) * B,
    ),
    (
        "reflection is not scaled by transmit",
        _plane("ambient 1 diffuse 0 reflection 0.5", pigment="rgbt <0.5, 0.25, 0.1, 0.5>"),
        0.5 * LOCAL + 0.5 * B + 0.5 * B,
    ),
    # depth: max_trace_level N shades N surfaces, then black (not the background)
    *[(f"max_trace_level {n}", _mirrors(f"max_trace_level {n}"), _mirror_series(n)) for n in (1, 2, 3, 6)],
    ("max_trace_level defaults to 5", _mirrors(""), _mirror_series(5)),
    ("adc_bailout 1/255 stops after 8 levels", _mirrors("max_trace_level 20", bailout=""), _mirror_series(8)),
    # transparency: no 1/η², c·f + t per crossing
    *[(f"no 1/eta^2 inside ior {ior}", _glass(HALF_SPACE, "rgbf <1, 1, 1, 1>", f"ior {ior}"), K) for ior in (1.5, 2.0)],
    ("slab filter 0.5: squared", _glass(SLAB, "rgbf <0.5, 0.5, 0.5, 1>", "ior 1.5"), 0.25 * K),
    ("slab rgb 0.5 filter 0.5: (0.25)^2", _glass(SLAB, "rgbf <0.5, 0.5, 0.5, 0.5>", "ior 1.5"), 0.0625 * K),
    ("slab transmit 0.5: squared", _glass(SLAB, "rgbt <0.5, 0.5, 0.5, 0.5>", "ior 1.5"), 0.25 * K),
    # fresnel with conserve_energy: (1 − F) per crossing, plus the internal echo F²(1 − F)²
    (
        "slab fresnel conserve_energy",
        _glass(SLAB, "rgbf <1, 1, 1, 1>", "ior 1.5", "reflection { 0, 1 fresnel on } conserve_energy"),
        K * (1 - F15) ** 2 * (1 + F15**2),
    ),
    (
        "slab fresnel alone: the echo only",
        _glass(SLAB, "rgbf <1, 1, 1, 1>", "ior 1.5", "reflection { 0, 1 fresnel on }"),
        K * (1 + F15**2),
    ),
    # Beer-Lambert fade over the slab's 2 units
    *[
        (
            f"fade_power {p}",
            _glass(SLAB, "rgbf <1, 1, 1, 1>", f"ior 1 fade_distance 1 fade_power {p} fade_color <0.5, 0.25, 1>"),
            K * _fade((0.5, 0.25, 1.0), 2.0, 1.0, p),
        )
        for p in (1, 2, 1001)
    ],
    (
        "negative fade_color: Beer-Lambert 0.2^2",
        _glass(
            SLAB,
            "rgbf <1, 1, 1, 1>",
            f"ior 1.5 fade_distance 1 fade_power 1001 fade_color <{1 + math.log(0.2)}, {1 + math.log(0.5)}, 1>",
        ),
        K * np.array([0.04, 0.25, 1.0]),
    ),
    (
        "only the transmitted branch is faded: TIR",
        _tir("rgbf <1, 1, 1, 1>", 1.5).replace(
            "interior { ior 1.5 }", "interior { ior 1.5 fade_distance 100 fade_power 1001 fade_color <0.5, 0.5, 0.5> }"
        ),
        K * math.exp(-0.2 * 0.5),
    ),
    ("reflection inside is not faded", _inside_up("reflection 0.5"), 0.5 * K),
    # total internal reflection: full weight, unfiltered, no reflection term; att·local still added
    ("TIR at full weight", _tir("rgbf <1, 1, 1, 1>", 1.5), K),
    ("TIR is not filtered", _tir("rgbf <0.5, 0.5, 0.5, 1>", 1.5), K),
    ("TIR ignores transmit", _tir("rgbt <0.5, 0.5, 0.5, 0.5>", 1.5), K),
    ("TIR adds no reflection term", _tir("rgbf <1, 1, 1, 1>", 1.5, "reflection 0.3"), K),
    ("TIR plus att·local", _tir("rgbf <0.5, 0.5, 0.5, 0.5>", 1.5, ambient="1"), 0.25 + K),
    (
        "TIR is the next trace level",
        _tir("rgbf <0.5, 0.5, 0.5, 0.5>", 1.5, ambient="1", max_trace_level=1),
        np.array([0.25, 0.25, 0.25]),
    ),
    (
        "below the critical angle: F reflected, 1 − F transmitted",
        _tir("rgbf <1, 1, 1, 1>", 1.1, "reflection { 0, 1 fresnel on } conserve_energy"),
        F_INSIDE_11 * K + (1 - F_INSIDE_11) * np.array([0.0, 0.0, 1.0]),
    ),
    # shadows: c·f + t per crossing, fade inside, no refraction, no Fresnel
    ("unshadowed floor", _shadow(""), np.ones(3)),
    ("shadow through a filter disc", _shadow(_disc("rgbf <0.5, 0.8, 1, 1>")), OCCLUDER),
    ("shadow through a filter box: two crossings", _shadow(_box("rgbf <0.5, 0.8, 1, 1>")), OCCLUDER**2),
    ("shadow through a filter 0.6 disc", _shadow(_disc("rgbf <0.5, 0.8, 1, 0.6>")), 0.6 * OCCLUDER),
    ("shadow through a transmit 0.6 box", _shadow(_box("rgbt <0.5, 0.8, 1, 0.6>")), np.full(3, 0.36)),
    ("shadow through filter and transmit", _shadow(_disc("rgbft <0.5, 0.8, 1, 0.3, 0.4>")), 0.3 * OCCLUDER + 0.4),
    ("shadow rays are not refracted", _shadow(_box("rgbf <0.5, 0.8, 1, 1>", "ior 1.5")), OCCLUDER**2),
    ("an opaque occluder blocks", _shadow(_disc("rgb <0.5, 0.8, 1>")), np.zeros(3)),
    (
        "shadow rays fade inside",
        _shadow(_box("rgbf <1, 1, 1, 1>", "fade_distance 1 fade_power 1 fade_color <0.5, 0.25, 1>")),
        _fade((0.5, 0.25, 1.0), 2.0, 1.0, 1),
    ),
    (
        "Fresnel does not dim shadows",
        _shadow(_box("rgbf <1, 1, 1, 1>", "ior 1.5", "reflection { 0, 1 fresnel on } conserve_energy")),
        np.ones(3),
    ),
]


@pytest.fixture(scope="module")
def measured() -> dict[str, np.ndarray]:
    """Every case's centre pixel, the cases as frames of one POV-Ray process."""
    body = ["#version 3.7;", "#switch (frame_number)"]
    for i, (_, sdl, _) in enumerate(CASES):
        body += [f"#case ({i})", sdl, "#break"]
    body.append("#end")
    switches = ("+FE", f"+W{SIZE}", f"+H{SIZE}", "-D", "-V", "-GD", "-GR", "-GS", "+Q9", "-J", "-A")
    text = "\n".join(body) + "\n"
    job = PovJob(lambda out: out.write(text), len(CASES), SIZE, SIZE, 1, switches)
    frames = _run(job, "semantics", None, None, lambda _: None)
    return {name: frame[SIZE // 2, SIZE // 2].astype(np.float64) for (name, _, _), frame in zip(CASES, frames)}


@pytest.mark.parametrize(
    ("name", "expected"), [(name, expected) for name, _, expected in CASES], ids=[c[0] for c in CASES]
)
def test_povray_behaves_as_the_semantics_document_says(measured, name, expected):
    got = measured[name]
    assert np.all(np.abs(got - expected) <= HALF_RELATIVE * np.abs(expected) + 2.0**-24), f"{name}: {got} != {expected}"
