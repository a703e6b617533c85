# SPDX-License-Identifier: Apache-2.0
"""The POV-Ray backend's mappings (``exact``, ``classic``): how it renders each specular
convention of the model (``RenderSettings.specular``). A module of its own, so that a native
render, which names a mapping (the CLI's ``--mapping``), imports neither the compiler nor the
runner (issue 15: start-up)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from phongscene.errors import Problem, SceneError

if TYPE_CHECKING:
    from phongscene.scene import RenderSettings, Scene


# POV-Ray mapping -> the specular convention of the model (RenderSettings.specular) it reproduces.
# The convention is the one knob; a mapping is how this backend renders it.
SPECULAR_OF_MAPPING: dict[str, str] = {"exact": "seed", "classic": "povray-classic"}
MAPPING_OF_SPECULAR: dict[str, str] = {v: k for k, v in SPECULAR_OF_MAPPING.items()}
MAPPINGS: tuple[str, ...] = tuple(SPECULAR_OF_MAPPING)


def check_mapping(mapping: str) -> str:
    """``mapping`` if it is a POV-Ray mapping; otherwise ValueError naming the known ones."""
    if mapping not in SPECULAR_OF_MAPPING:
        raise ValueError(f"unknown POV-Ray mapping {mapping!r}; expected one of {', '.join(MAPPINGS)}")
    return mapping


def specular_of(mapping: str) -> str:
    """The model's specular convention that POV-Ray ``mapping`` reproduces."""
    return SPECULAR_OF_MAPPING[check_mapping(mapping)]


def resolve_mapping(settings: RenderSettings, mapping: str | None) -> str:
    """The mapping to use: ``mapping`` if given, else the one matching ``settings.specular``."""
    if mapping is None:
        mapping = MAPPING_OF_SPECULAR.get(settings.specular)
        if mapping is None:
            raise SceneError(
                Problem(
                    f"unknown specular convention {settings.specular!r}",
                    settings.source,
                    "specular",
                    node="RenderSettings",
                )
            )
    return check_mapping(mapping)


def exact_mapping_obstacle(scene: Scene) -> str | None:
    """Why the exact mapping cannot render ``scene`` (``compile_pov`` refuses it there), or None:
    a transmissive material with a highlight, whose highlight the exact mapping's average
    texture would have to split from its transmission (POV-Ray then splits total internal
    reflection too). ``diff`` without a mapping compares such a scene in the classic one."""
    for obj in (*scene.objects, *(m for p in scene.prototypes for m in p.meshes)):
        material = obj.material
        if material.ks > 0 and material.transmits:
            name = material.source or getattr(obj, "source", "") or "a material"
            return f"{name} is transmissive with a highlight (ks {material.ks:g}, kt {material.kt:g})"
    return None
