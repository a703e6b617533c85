# SPDX-License-Identifier: Apache-2.0
"""Diffuse colours read from primvars: a primvar reader shader on a material's diffuse colour.

A material whose diffuse colour (UsdPreviewSurface ``diffuseColor``, Standard Surface / OpenPBR
``base_color``, OmniPBR ``diffuse_color_constant``, our shader's ``diffuseColor``) is connected
to a primvar reader (``UsdPrimvarReader_float3``, MaterialX ``geompropvalue`` and the
``ND_UsdPrimvarReader_*`` nodes) takes cd from the gprim it is bound to: the primvar of that
name, constant, authored on the gprim or inherited from an ancestor (USD's primvar inheritance).
On an instance's prototype the value belongs to the copy: a PointInstancer's per-instance array
(one entry per instance) or a constant primvar on each instanceable prim, read into
``Instances.colors``; the prototype's mesh keeps ``PhongMaterial.instance_color``. Where no
value is found, the reader's fallback is cd.

The material mapping may scale the colour it reads (Standard Surface's base · (1 − metalness)):
the primvar's value is scaled alike, channel by channel, by the ratio the mapping gave the
fallback (``PrimvarColor.scale``). A metal's F0 tint keeps the fallback's colour.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pxr import Usd, UsdGeom, UsdShade

from .textures import source_output

# Shaders that output a primvar's value, and the inputs that name the primvar and its fallback.
PRIMVAR_READERS = {
    "UsdPrimvarReader_float3": ("varname", "fallback"),
    "UsdPrimvarReader_color3": ("varname", "fallback"),
    "ND_UsdPrimvarReader_vector3": ("varname", "fallback"),
    "ND_UsdPrimvarReader_color3": ("varname", "fallback"),
    "ND_geompropvalue_color3": ("geomprop", "default"),
    "ND_geompropvalue_vector3": ("geomprop", "default"),
}
# The inputs that are cd in some material mapping (see the module docstring).
DIFFUSE_COLOUR_INPUTS = frozenset({"diffuseColor", "base_color", "diffuse_color_constant"})
# The interpolations that give a PointInstancer's primvar one value per instance.
PER_INSTANCE_INTERPOLATIONS = (UsdGeom.Tokens.vertex, UsdGeom.Tokens.varying, UsdGeom.Tokens.uniform)


@dataclass(frozen=True)
class PrimvarColor:
    """A material's cd read from primvar ``name``, times ``scale`` (the mapping's)."""

    name: str
    scale: tuple[float, float, float]

    def of(self, value) -> tuple[float, float, float]:
        return tuple(float(v) * s for v, s in zip(value, self.scale))


def primvar_reader(shader: UsdShade.Shader, input_name: str, time) -> tuple[str, tuple] | None:
    """(primvar name, fallback colour) when ``input_name`` of ``shader`` is fed by a primvar
    reader; None otherwise (or when the reader names no primvar)."""
    source = source_output(shader.GetInput(input_name))
    if source is None:
        return None
    reader, _ = source
    inputs = PRIMVAR_READERS.get(reader.GetShaderId() or "")
    if inputs is None:
        return None
    name_input, fallback_input = (reader.GetInput(n) for n in inputs)
    name = name_input.Get(time) if name_input else None
    if not name:
        return None
    fallback = fallback_input.Get(time) if fallback_input else None
    colour = (0.0, 0.0, 0.0) if fallback is None else tuple(float(c) for c in fallback)
    return str(name), colour


def _colour(values) -> tuple[float, float, float] | None:
    try:
        arr = np.asarray(values, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        return None
    if arr.shape != (3,) or not np.all(np.isfinite(arr)) or np.any(arr < 0):
        return None
    return tuple(float(c) for c in arr)


def constant_primvar(prim: Usd.Prim, name: str, time, stop: Usd.Prim | None = None):
    """The constant primvar ``name`` of ``prim`` or its nearest ancestor that has one (USD's
    inheritance), as a colour; with ``stop``, a prototype's root, only prims of the prototype
    count: ``stop`` and below, or only below where ``stop`` is an instance prim (read through
    the first instance, the prototype must not take that instance's value). None where none is
    found or the value is not 3 finite numbers >= 0."""
    stop_path = stop.GetPath() if stop is not None else None
    exclusive = stop is not None and stop.IsInstance()
    p = prim
    while p and not p.IsPseudoRoot():
        if exclusive and p.GetPath() == stop_path:
            return None
        primvar = UsdGeom.PrimvarsAPI(p).GetPrimvar(name)
        if primvar and primvar.HasAuthoredValue() and primvar.GetInterpolation() == UsdGeom.Tokens.constant:
            return _colour(primvar.ComputeFlattened(time))
        if stop_path is not None and p.GetPath() == stop_path:
            return None
        p = p.GetParent()
    return None


def per_instance(instancer: Usd.Prim, name: str, count: int, time) -> np.ndarray | None:
    """A PointInstancer's primvar ``name`` with one colour per instance ((count, 3)), or a
    constant one broadcast; None where it has neither (or the values are not colours >= 0)."""
    primvar = UsdGeom.PrimvarsAPI(instancer).GetPrimvar(name)
    if not primvar or not primvar.HasAuthoredValue():
        value = constant_primvar(instancer, name, time)
        return None if value is None else np.tile(value, (count, 1))
    values = primvar.ComputeFlattened(time)
    if primvar.GetInterpolation() == UsdGeom.Tokens.constant:
        value = _colour(values)
        return None if value is None else np.tile(value, (count, 1))
    if primvar.GetInterpolation() not in PER_INSTANCE_INTERPOLATIONS or values is None or len(values) != count:
        return None
    arr = np.asarray(values, dtype=np.float64).reshape(count, -1)
    if arr.shape[1] != 3 or not np.all(np.isfinite(arr)) or np.any(arr < 0):
        return None
    return arr
