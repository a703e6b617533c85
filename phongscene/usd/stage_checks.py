# SPDX-License-Identifier: Apache-2.0
"""The checks of a stage that do not depend on the time read (made once per opened stage, an
``OpenStage`` replays them): composition errors, unknown ``phong:`` attributes (errors), names
nothing reads (``typos``)."""

from __future__ import annotations

from pxr import Usd

from . import typos
from .context import ReadContext
from .names import PHONG_ATTRIBUTES

# Composition errors name their arc in the text; report it as the "attribute" (a metadata field).
_ARC_ATTRIBUTE = {"for reference": "references", "for payload": "payload", "sublayer": "subLayers"}


def check_stage(ctx: ReadContext) -> None:
    """What is read of the stage whatever the time: composition errors, unknown ``phong:``
    attributes, names nothing reads (typos)."""
    for error in ctx.stage.GetCompositionErrors():
        # As USD and usdview do: a reference, payload or sublayer that cannot be composed (a
        # missing file, a .mtlx without USD's MaterialX plugin) is said, and the rest is drawn.
        site = getattr(error, "rootSite", None)
        text = str(error)
        arc = next((a for k, a in _ARC_ATTRIBUTE.items() if k in text), "")
        where = (str(site.path) if site is not None else "") + (f".{arc}" if arc else "")
        ctx.warn(f"{where}: {text} (not composed; the rest of the stage is drawn)")
    _check_phong_namespace(ctx)
    typos.check_names(ctx)


def _check_phong_namespace(ctx: ReadContext) -> None:
    """Unknown attributes in our `phong:` namespace are errors."""
    predicate = Usd.TraverseInstanceProxies(Usd.PrimAllPrimsPredicate)
    for prim in Usd.PrimRange(ctx.stage.GetPseudoRoot(), predicate):
        props = prim.GetAuthoredPropertiesInNamespace("phong")
        if not props:
            continue
        allowed = PHONG_ATTRIBUTES.get(prim.GetTypeName(), {})
        for prop in props:
            name = prop.GetName()
            if name not in allowed:
                where = f"on a {prim.GetTypeName() or 'typeless prim'}"
                known = f" (known here: {', '.join(allowed)})" if allowed else ""
                ctx.problem(prim, name, f"unknown attribute in the phong: namespace {where}{known}")
