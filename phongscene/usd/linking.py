# SPDX-License-Identifier: Apache-2.0
"""UsdLux shadows and linking → the model's ``Linking`` of each light: ShadowAPI's
``inputs:shadow:enable``, and the light's ``collection:lightLink`` (which geometry it
illuminates) and ``collection:shadowLink`` (which geometry casts its shadows), resolved by
usd-core's own UsdCollectionAPI membership (includeRoot, includes, excludes, expansion rule:
``ComputeMembershipQuery``) against the ``source`` prim of every geometry node.

Applied once the whole stage is read (a collection can name geometry read after the light), to
every light whose ``source`` is a light prim. The ShadowAPI and ShapingAPI inputs the model has
no term for (``shadow:color``, ``shadow:distance``, ``shadow:falloff``, ``shadow:falloffGamma``,
``shaping:ies:*``), when authored with a non-default value, are one warning naming the prims
and attributes (``info --strict`` then fails)."""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np
from pxr import Sdf, Usd, UsdLux

from ..scene import Linking, Scene
from .context import ReadContext

SHADOW_ENABLE = "inputs:shadow:enable"
# A PointInstancer copy's name (instancing.py): the instancer's path, [id], then the path below
# its prototype.
_INSTANCER_COPY = re.compile(r"\[-?\d+\].*$")
# What the model does not render, with the value that changes nothing (UsdLux's fallbacks).
UNSUPPORTED_INPUTS = {
    "inputs:shadow:color": (0.0, 0.0, 0.0),
    "inputs:shadow:distance": -1.0,
    "inputs:shadow:falloff": -1.0,
    "inputs:shadow:falloffGamma": 1.0,
    "inputs:shaping:ies:file": None,
    "inputs:shaping:ies:angleScale": 0.0,
    "inputs:shaping:ies:normalize": False,
}


def link_lights(ctx: ReadContext, stage: Usd.Stage, scene: Scene) -> Scene:
    """``scene`` with each light's ``Linking`` from its prim on ``stage``. Instances whose copies
    a light or shadow link collection tells apart (it leaves some copy out) are flattened first,
    each copy named by its own prim (docs/instancing.md): the backends link world geometry."""
    if scene.instances and _links_tell_copies_apart(stage, scene):
        scene = _flattened_per_copy(scene)
    sources = [obj.source for obj in scene.objects]
    paths = [_membership_path(s) for s in sources]
    lights = []
    for light in scene.lights:
        prim = stage.GetPrimAtPath(light.source) if Sdf.Path.IsValidPathString(light.source) else None
        if not prim or not prim.HasAPI(UsdLux.LightAPI):
            lights.append(light)  # a default light of the reader's own
            continue
        _warn_unsupported(ctx, prim)
        linking = Linking(
            shadows=_shadows(ctx, prim),
            illuminates=_members(UsdLux.LightAPI(prim).GetLightLinkCollectionAPI(), sources, paths),
            shadowed_by=_members(UsdLux.LightAPI(prim).GetShadowLinkCollectionAPI(), sources, paths),
        )
        lights.append(light if linking.default else replace(light, linking=linking))
    return replace(scene, lights=tuple(lights))


def _membership_path(source: str) -> Sdf.Path | None:
    """The prim path a collection's membership is asked about for a node named ``source``: a
    PointInstancer copy (``/World/Scatter[3]``, the reader's name for it, and what follows) is
    no prim, a collection can only name its instancer, so the instancer's path; None for a name
    that is no path."""
    path = _INSTANCER_COPY.sub("", source, count=1)
    return Sdf.Path(path) if path and Sdf.Path.IsValidPathString(path) else None


def _copy_meshes(scene: Scene):
    """(group, k, mesh, source) for every mesh of every instance copy, ``source`` naming that
    copy's prim: the copy's prim plus the mesh's path below the prototype's root."""
    for group in scene.instances:
        root = group.prototype.source
        for mesh in group.prototype.meshes:
            suffix = mesh.source[len(root) :] if root and mesh.source.startswith(root) else ""
            for k in range(len(group)):
                yield group, k, mesh, (group.source_of(k) + suffix if group.source_of(k) else mesh.source)


def _links_tell_copies_apart(stage: Usd.Stage, scene: Scene) -> bool:
    """Whether some light's lightLink or shadowLink leaves out some geometry (a world node or an
    instance copy) while the scene has instances."""
    sources = [obj.source for obj in scene.objects] + [source for *_, source in _copy_meshes(scene)]
    paths = [p for p in map(_membership_path, set(sources)) if p is not None]
    for light in scene.lights:
        prim = stage.GetPrimAtPath(light.source) if Sdf.Path.IsValidPathString(light.source) else None
        if not prim or not prim.HasAPI(UsdLux.LightAPI):
            continue
        api = UsdLux.LightAPI(prim)
        for collection in (api.GetLightLinkCollectionAPI(), api.GetShadowLinkCollectionAPI()):
            query = collection.ComputeMembershipQuery()
            if not all(query.IsPathIncluded(p) for p in paths):
                return True
    return False


def _flattened_per_copy(scene: Scene) -> Scene:
    """``scene.flattened()`` with each copy's meshes named by the copy's prim."""
    meshes = list(scene.meshes)
    for group, k, mesh, source in _copy_meshes(scene):
        a, t = group.world_from_prototype[k][:3, :3], group.world_from_prototype[k][:3, 3]
        normals = mesh.normals
        if normals is not None:
            normals = normals @ np.linalg.inv(a)
            normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
        meshes.append(replace(mesh, points=mesh.points @ a.T + t, normals=normals, source=source))
    return replace(scene, meshes=tuple(meshes), instances=())


def _shadows(ctx: ReadContext, prim: Usd.Prim) -> bool:
    """ShadowAPI's switch (True by default). Without the API applied the attribute is not the
    schema's, and the reader's check of unknown inputs says it is ignored: it is."""
    if not prim.HasAPI(UsdLux.ShadowAPI):
        return True
    return bool(ctx.get(prim, SHADOW_ENABLE, ("bool",), True))


def _members(collection: Usd.CollectionAPI, sources: list[str], paths: list) -> frozenset[str] | None:
    """The sources the collection includes; None when it includes all of them (the default
    collection, includeRoot, includes everything)."""
    query = collection.ComputeMembershipQuery()
    included = [s for s, p in zip(sources, paths) if p is not None and query.IsPathIncluded(p)]
    if len(included) == len(sources):
        return None
    return frozenset(included)


def _warn_unsupported(ctx: ReadContext, prim: Usd.Prim) -> None:
    for name, neutral in UNSUPPORTED_INPUTS.items():
        attr = prim.GetAttribute(name)
        if not attr or not attr.HasAuthoredValue():
            continue
        value = attr.Get(ctx.time)
        if neutral is None:
            changed = bool(value and getattr(value, "path", value))
        elif isinstance(neutral, tuple):
            changed = tuple(float(c) for c in value) != neutral
        else:
            changed = value != neutral
        if changed:
            ctx.unsupported[f"light {name} (not rendered: the model has no such term)"].append(str(prim.GetPath()))
