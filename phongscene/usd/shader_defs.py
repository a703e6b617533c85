# SPDX-License-Identifier: Apache-2.0
"""Registers phongscene's Phong surface with USD's shader registry (Sdr) and describes its inputs.

The definition lives in ``schemas/phongscene_PhongSurface.usda`` (packaged as ``phongscene.schemas``,
which also says how other USD tools find it).
Sdr registration works at any time, also after stages were opened (Sdr.Registry accepts discovery results at any time),
so importing this module late is fine.
"""

from __future__ import annotations

from pxr import Sdf, Sdr, Usd, UsdShade

from ..schemas import DEFINITIONS_FILE, folder
from .names import PHONG_INPUTS, PHONG_RENDER_CONTEXT, PHONG_SHADER_ID

__all__ = [
    "DEFINITIONS_FILE",
    "PHONG_RENDER_CONTEXT",
    "PHONG_SHADER_ID",
    "phong_inputs",
    "phong_input_defaults",
    "phong_input_help",
    "register_phong_shader",
]


def phong_inputs() -> dict[str, tuple[str, Sdf.ValueTypeName]]:
    """The Phong shader's inputs: USD input name -> (PhongMaterial field, Sdf value type)."""
    return {name: (field, Sdf.ValueTypeNames.Find(type_name)) for name, (field, type_name) in PHONG_INPUTS.items()}


def register_phong_shader() -> None:
    """Add the Phong surface's definition to ``Sdr.Registry()`` (idempotent)."""
    registry = Sdr.Registry()
    if PHONG_SHADER_ID in registry.GetShaderNodeIdentifiers():
        return
    defs = Usd.Stage.Open(str(folder() / DEFINITIONS_FILE))
    prim = defs.GetPrimAtPath(f"/{PHONG_SHADER_ID}")
    for result in UsdShade.ShaderDefUtils.GetDiscoveryResults(UsdShade.Shader(prim), defs.GetRootLayer().realPath):
        registry.AddDiscoveryResult(result)
    if PHONG_SHADER_ID not in registry.GetShaderNodeIdentifiers():
        raise ImportError(f"phongscene: could not register the Sdr node {PHONG_SHADER_ID} from {DEFINITIONS_FILE}")


def phong_input_defaults() -> dict[str, object]:
    """The Sdr default of every Phong input, by USD input name (Python floats and tuples)."""
    node = Sdr.Registry().GetShaderNodeByIdentifier(PHONG_SHADER_ID)
    out = {}
    for name in PHONG_INPUTS:
        value = node.GetShaderInput(name).GetDefaultValue()
        # Sdr has no bool type (it holds a bool input's default as an int): ours says which are.
        out[name] = (
            tuple(float(c) for c in value)
            if hasattr(value, "__len__")
            else bool(value)
            if PHONG_INPUTS[name][1] == "bool"
            else float(value)
        )
    return out


def phong_input_help() -> dict[str, str]:
    """The Sdr help text of every Phong input, by USD input name (the documentation's table)."""
    node = Sdr.Registry().GetShaderNodeByIdentifier(PHONG_SHADER_ID)
    return {name: node.GetShaderInput(name).GetHelp() for name in PHONG_INPUTS}
