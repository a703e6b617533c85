# SPDX-License-Identifier: Apache-2.0
"""RenderOverrides (phongscene/overrides.py): one typed, frozen set of the render knobs that the
command line, ``render``, ``diff`` and the frame tasks all take."""

from __future__ import annotations

from dataclasses import FrozenInstanceError, fields

import pytest

from phongscene.overrides import RenderOverrides
from phongscene.rendering import settings_with
from phongscene.scene import PointLight, RectAreaLight, RenderSettings, Scene

SCENE = Scene(
    settings=RenderSettings(width=320, height=240, samples=3, threads=2),
    lights=(
        RectAreaLight(center=(0.0, 4.0, 0.0), axis_u=(1.0, 0.0, 0.0), axis_v=(0.0, 0.0, 1.0), color=(1.0, 1.0, 1.0)),
        PointLight(position=(0.0, 5.0, 0.0), color=(1.0, 1.0, 1.0)),
    ),
)


def test_an_unknown_field_is_an_error_at_construction():
    with pytest.raises(TypeError, match="spp"):
        RenderOverrides(spp=2)  # the field is `samples`; a typo never reads as None later
    with pytest.raises(TypeError):
        RenderOverrides(**{"widht": 64})  # dict-style construction too


def test_it_is_frozen():
    with pytest.raises(FrozenInstanceError):
        RenderOverrides().width = 3


def test_settings_are_the_ones_settings_with_gives():
    overrides = RenderOverrides(
        mapping="classic", width=40, samples=1, threads=0, sample_pattern="povray-am2", aa_threshold=0.1
    )
    assert overrides.settings(SCENE) == settings_with(
        SCENE, "classic", width=40, samples=1, threads=0, sample_pattern="povray-am2", aa_threshold=0.1
    )
    assert (overrides.settings(SCENE).width, overrides.settings(SCENE).height) == (40, 30)
    assert RenderOverrides().settings(SCENE) == SCENE.settings


def test_the_shadow_fields_change_every_area_light_and_nothing_else():
    scene, settings = RenderOverrides(shadow_adaptive=2, shadow_cells=4).apply(SCENE)
    area, point = scene.lights
    assert (area.adaptive, area.cell_samples) == (2, 4) and point == SCENE.lights[1]
    assert settings == SCENE.settings
    assert RenderOverrides().scene(SCENE) is SCENE


def test_every_field_has_its_command_line_option():
    """A field added to RenderOverrides needs its option (phongscene/cli/options.py): `render`
    takes them all, each with the field's name as its dest."""
    import argparse

    from phongscene.cli import build_parser

    commands = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    dests = {action.dest for action in commands.choices["render"]._actions}
    assert {f.name for f in fields(RenderOverrides)} <= dests


def test_a_frame_task_refuses_a_plain_dict(tmp_path):
    from phongscene.animation import render_frame

    with pytest.raises(TypeError, match="RenderOverrides"):
        render_frame("scene.usda", 1, str(tmp_path / "out.exr"), "native", {"width": 8})
