# SPDX-License-Identifier: Apache-2.0
"""``RenderOverrides``: the render knobs a caller sets over what the scene file says (image size,
anti-aliasing, threads, the POV-Ray mapping, the area lights' shadow estimators, the USD time),
as one typed, frozen value. The command line builds one from its options
(``phongscene.cli.options.overrides_from_args``); ``render``, ``diff``, the ``--frames`` tasks
and ``bench`` all take one, so a knob is spelled out once. A field that is None leaves the
scene's own value. An unknown field is a TypeError at construction (``RenderOverrides(spp=2)``),
never a value read as None later.

Adding a knob (a max trace depth, a display mode, ...) is one field here: its ``metadata`` says
where it applies, and ``settings``/``scene`` apply it by that, with no other code to change:

- ``_setting()``: the ``RenderSettings`` field of the same name;
- ``_area_light("field")``: that field of every rect and sphere area light;
- neither (``mapping``, ``time``, or a new kind): read by name where it is used.

Its command-line option goes in ``phongscene/cli/options.py`` (``add_override_options``; its
``dest`` is the field's name, so ``overrides_from_args`` picks it up), and
``tests/test_overrides.py`` fails until it has one.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields, replace
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .scene import RenderSettings, Scene

# Where a field applies (its dataclass metadata key): "settings" (a RenderSettings field of the
# same name) or "area_light" (the named field of every area light).
APPLIES_TO = "applies_to"


def _setting():
    return field(default=None, metadata={APPLIES_TO: ("settings", None)})


def _area_light(name: str):
    return field(default=None, metadata={APPLIES_TO: ("area_light", name)})


@dataclass(frozen=True)
class RenderOverrides:
    """Render knobs over the scene's own (None: the scene's). Keyword arguments only, in practice:
    ``RenderOverrides(width=64, samples=2)``."""

    # "exact" or "classic": the specular convention the POV-Ray mapping reproduces (--mapping).
    mapping: str | None = None
    # Image size; one alone keeps the scene's aspect ratio (--width, --height).
    width: int | None = _setting()
    height: int | None = _setting()
    # Anti-aliasing samples per axis, RenderSettings.samples (--spp).
    samples: int | None = _setting()
    threads: int | None = _setting()  # 0 = all cores (--threads)
    sample_pattern: str | None = _setting()  # --sample-pattern
    aa_threshold: float | None = _setting()  # --aa-threshold
    # The deepest secondary ray, RenderSettings.max_depth (--max-depth).
    max_depth: int | None = _setting()
    # POV-Ray's 'adaptive N' on every area light (--shadow-adaptive).
    shadow_adaptive: int | None = _area_light("adaptive")
    # The native cells estimator, K x K points per partial cell, on every area light (--shadow-cells).
    shadow_cells: int | None = _area_light("cell_samples")
    # The USD time code to read the stage at (--time; None: the reader's choice).
    time: float | None = None
    # The Camera prim to render through (--camera; None: the RenderSettings' camera, else the first).
    camera: str | None = None
    # Every subdivision surface's refinement level (--subdivision-level; None: the scene's).
    subdivision_level: int | None = None

    def given(self) -> dict:
        """The fields that are set (not None), by name."""
        return {f.name: getattr(self, f.name) for f in fields(self) if getattr(self, f.name) is not None}

    def settings(self, scene: Scene, settings: RenderSettings | None = None) -> RenderSettings:
        """``settings`` (default: the scene's) with these overrides applied, and the specular
        convention that the POV-Ray ``mapping`` reproduces (ValueError for an unknown one).
        Giving only one of width/height keeps the aspect ratio."""
        from .rendering import settings_for

        s = settings_for(scene, settings, mapping=self.mapping)
        changes = {
            f.name: getattr(self, f.name) for f in fields(self) if f.metadata.get(APPLIES_TO, ("",))[0] == "settings"
        }
        width, height = changes["width"], changes["height"]
        if width is not None and height is None:
            changes["height"] = max(1, round(width * s.height / s.width))
        elif height is not None and width is None:
            changes["width"] = max(1, round(height * s.width / s.height))
        return replace(s, **{k: v for k, v in changes.items() if v is not None})

    def scene(self, scene: Scene) -> Scene:
        """``scene`` with the area-light overrides on every rect and sphere area light."""
        from .scene import RectAreaLight, SphereAreaLight

        for f in fields(self):
            kind, name = f.metadata.get(APPLIES_TO, ("", None))
            value = getattr(self, f.name)
            if kind == "area_light" and value is not None:
                scene = replace(
                    scene,
                    lights=tuple(
                        replace(light, **{name: value})
                        if isinstance(light, (RectAreaLight, SphereAreaLight))
                        else light
                        for light in scene.lights
                    ),
                )
        return scene

    def apply(self, scene: Scene) -> tuple[Scene, RenderSettings]:
        """The scene with the light overrides, and its settings with the others."""
        scene = self.scene(scene)
        return scene, self.settings(scene)
