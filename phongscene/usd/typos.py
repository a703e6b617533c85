# SPDX-License-Identifier: Apache-2.0
"""Names USD accepts silently but nothing reads: a light input no schema defines
(``inputs:intensty``), a material binding to a prim that does not exist, a prim type no schema
knows (``def Sphre``), a surface shader id nobody registered. Each is a warning naming the prim
and attribute, with "did you mean …" where a close known name exists (``validate --strict``
turns warnings into errors)."""

from __future__ import annotations

import difflib
from collections import defaultdict

from pxr import Sdr, Tf, Usd, UsdLux, UsdShade

from .context import ReadContext
from .materialx_documents import is_node_definition
from .pbr_networks import MTLX_NETWORKS

# difflib's similarity ratio from which a known name is offered as the one meant: 0.8 catches
# one or two dropped, doubled or swapped letters in names of 6+ characters, not unrelated names.
CLOSE_NAME_RATIO = 0.8
# Shaders named in one grouped "no shader is registered" warning (the count says the rest).
UNREGISTERED_SHOWN = 3


def did_you_mean(name: str, known) -> str:
    """`` (did you mean X?)`` for the closest known name, or ""."""
    close = difflib.get_close_matches(name, list(known), n=1, cutoff=CLOSE_NAME_RATIO)
    return f" (did you mean {close[0]}?)" if close else ""


def _schema_type_names() -> list[str]:
    typed = Tf.Type.FindByName("UsdTyped")
    return sorted(n for n in (Usd.SchemaRegistry.GetSchemaTypeName(t) for t in typed.GetAllDerivedTypes()) if n)


def check_names(ctx: ReadContext) -> None:
    """Warn about every unread name on the stage (see the module's doc)."""
    type_names = None
    unregistered: dict[str, list[str]] = defaultdict(list)
    predicate = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)
    for prim in Usd.PrimRange(ctx.stage.GetPseudoRoot(), predicate):
        if prim.IsPseudoRoot():
            continue
        path = prim.GetPath()  # formatted only in a warning: a path's text grows with nesting depth
        type_name = prim.GetTypeName()
        if type_name and not prim.GetPrimTypeInfo().GetSchemaType():
            type_names = type_names or _schema_type_names()
            ctx.warn(
                f"{path}: prim type {type_name!r} is defined by no schema (ignored){did_you_mean(type_name, type_names)}"
            )
        if prim.HasAPI(UsdLux.LightAPI):
            defined = set(prim.GetPrimDefinition().GetPropertyNames())
            inputs = [name for name in defined if name.startswith("inputs:")]
            for attr in prim.GetAuthoredAttributes():
                name = attr.GetName()
                if name.startswith("inputs:") and name not in defined:
                    ctx.warn(
                        f"{path}.{name}: not an input of {type_name or 'this light'} (ignored){did_you_mean(name, inputs)}"
                    )
        binding = prim.GetRelationship("material:binding")
        if binding:
            for target in binding.GetTargets():
                if not ctx.stage.GetPrimAtPath(target):
                    ctx.warn(
                        f"{path}.material:binding: targets {target}, which does not exist (the prim renders without it)"
                    )
        if prim.IsA(UsdShade.Shader):
            shader_id = UsdShade.Shader(prim).GetShaderId()
            # The MaterialX surfaces the reader maps (pbr_networks) need no registered node, nor
            # does any node MaterialX defines (usd-core registers none of them: it has no usdMtlx).
            if (
                shader_id
                and shader_id not in MTLX_NETWORKS
                and Sdr.Registry().GetShaderNodeByIdentifier(shader_id) is None
                and not is_node_definition(shader_id)
            ):
                unregistered[shader_id].append(str(path))
    # One warning per unknown id, however many shaders use it (a set of 524 instanced teapots
    # is one line, not 524).
    for shader_id, paths in unregistered.items():
        known = Sdr.Registry().GetShaderNodeIdentifiers()
        hint = did_you_mean(shader_id, known)
        if len(paths) == 1:
            ctx.warn(f"{paths[0]}.info:id: no shader {shader_id!r} is registered{hint}")
        else:
            shown = ", ".join(paths[:UNREGISTERED_SHOWN]) + (
                f" and {len(paths) - UNREGISTERED_SHOWN} more" if len(paths) > UNREGISTERED_SHOWN else ""
            )
            ctx.warn(f"info:id {shader_id!r} of {len(paths)} shaders: no shader is registered{hint} ({shown})")
