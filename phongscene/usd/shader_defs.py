# SPDX-License-Identifier: Apache-2.0
"""Registers phongscene's Phong surface with USD's shader registry (Sdr) and describes its inputs.

The definition lives in ``schemas/phongShaderDefs.usda`` (packaged as ``phongscene.schemas``).
Sdr registration works at any time, also after stages were opened (usd-oiio-trimesh-notes §1a),
so importing this module late is fine.
"""

from __future__ import annotations

import importlib.resources

from pxr import Sdf, Sdr, Usd, UsdShade

PHONG_SHADER_ID = "phongscene_PhongSurface"  # Sdr identifier = the definition prim's name
PHONG_RENDER_CONTEXT = "phong"  # materials connect our shader to outputs:phong:surface
DEFINITIONS_FILE = "phongShaderDefs.usda"

# USD input name -> (PhongMaterial field, Sdf value type). The one attribute <-> field table.
PHONG_INPUTS: dict[str, tuple[str, Sdf.ValueTypeName]] = {
    "ka": ("ka", Sdf.ValueTypeNames.Float),
    "kd": ("kd", Sdf.ValueTypeNames.Float),
    "ks": ("ks", Sdf.ValueTypeNames.Float),
    "exponent": ("exponent", Sdf.ValueTypeNames.Float),
    "diffuseColor": ("diffuse_color", Sdf.ValueTypeNames.Color3f),
    "specularColor": ("specular_color", Sdf.ValueTypeNames.Color3f),
}


def register_phong_shader() -> None:
    """Add the Phong surface's definition to ``Sdr.Registry()`` (idempotent)."""
    registry = Sdr.Registry()
    if PHONG_SHADER_ID in registry.GetShaderNodeIdentifiers():
        return
    with importlib.resources.as_file(importlib.resources.files("phongscene.schemas") / DEFINITIONS_FILE) as path:
        defs = Usd.Stage.Open(str(path))
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
        out[name] = tuple(float(c) for c in value) if hasattr(value, "__len__") else float(value)
    return out
