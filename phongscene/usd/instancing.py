# SPDX-License-Identifier: Apache-2.0
"""Instances stay instances: USD's two kinds of instancing read into ``Prototype`` and
``Instances`` (phongscene/scene.py), each prototype read once.

* A ``PointInstancer``: each prototype target is read once, in its own space (its root's
  transform is part of each instance's, ``IncludeProtoXform``); the instances are the
  instancer's transforms (positions, orientations, scales, and velocities / angular velocities
  at the time read: ``ComputeInstanceTransformsAtTime``), masked by ``invisibleIds`` and
  ``inactiveIds`` (``ComputeMaskAtTime``), grouped by ``protoIndices``.
* Instanceable references and payloads (USD's native instancing, ``prim.IsInstance()``): the
  prototype USD shares (``GetPrototype()``) is read once, through the first instance's proxies
  (so errors name a real prim path and materials resolve as USD resolves them there), in the
  instance prim's space. A material bound on the instance prim (or above it) reaches the
  prototype's gprims that bind none of their own, so instances are grouped by the prototype
  *and* that inherited binding: the only override USD allows an instance.
* Nesting: an instancer or an instance inside a prototype becomes nested placements, composed
  with the outer copies' transforms when the scene is built (the backends see one level).
* Per-copy colours: a prototype mesh whose material's cd a primvar reader gives
  (primvar_colors.py) takes each copy's value, a PointInstancer's per-instance array or a
  constant primvar on (or above) the instanceable prim, into ``Instances.colors``; a copy
  without one keeps the reader's fallback. Nested copies take their own placement's values.

Flattening stays where it is cheaper or needed: a prototype with a single instance on the
stage, or one holding lights (which the model places in the world), is read as ordinary
geometry through instance proxies. Spheres and intrinsic prims (Cube, Cylinder, Cone, Capsule,
Plane) in prototypes are placed in the world per copy (each is already an affine map of a
canonical shape: flattening costs nothing). Instances that a light's light or shadow link tells
apart are flattened by ``linking.link_lights``.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from pxr import Usd, UsdGeom, UsdLux, UsdShade

from ..scene import Instances, Intrinsic, Points, Prototype, Sphere
from .context import ReadContext, gf_to_numpy
from .materials import MaterialReader
from .primvar_colors import PrimvarColor, constant_primvar, per_instance

# A prototype whose instances on the stage are fewer than this is flattened (one copy: the
# instance machinery would only add a transform to every ray).
MIN_INSTANCES = 2


@dataclass
class _PrototypeRead:
    """A prototype read in its own space."""

    source: str
    meshes: list = field(default_factory=list)
    spheres: list = field(default_factory=list)  # (Sphere in prototype space)
    nested: list = field(default_factory=list)  # (key, (K, 4, 4) prototype-from-nested, sources, colours)
    prototype: Prototype | None = None  # built once it is placed


class Instancing:
    """Collects placements while the reader walks the stage, then builds the model's instances.

    ``gprim(prim, transform, spheres, meshes)`` reads one gprim (the reader's), ``renderable()``
    makes a visibility/purpose filter for one traversal (the reader's)."""

    def __init__(self, ctx: ReadContext, gprim: Callable, renderable: Callable, materials: MaterialReader):
        self.ctx, self.gprim, self.renderable, self.materials = ctx, gprim, renderable, materials
        self.prototypes: dict[tuple, _PrototypeRead] = {}
        # key -> [(transforms, sources, colours (K, 3) or None)]
        self.placements: dict[tuple, list] = defaultdict(list)
        self.reading: list[str] = []  # prototype roots being read (a cycle is a problem)
        self._instance_choice: dict[str, bool] = {}

    # -- instanceable references -------------------------------------------------------------

    def keeps_instanced(self, prim: Usd.Prim) -> bool:
        """Whether the instance ``prim`` is read as an instance (else the reader flattens it)."""
        prototype = prim.GetPrototype()
        path = str(prototype.GetPath())
        if path not in self._instance_choice:
            lights = any(p.HasAPI(UsdLux.LightAPI) for p in Usd.PrimRange(prototype))
            self._instance_choice[path] = not lights and len(prototype.GetInstances()) >= MIN_INSTANCES
        return self._instance_choice[path]

    def instance(self, prim: Usd.Prim, world: np.ndarray) -> None:
        """Place the instance ``prim`` (world transform ``world``)."""
        key = self._instance_key(prim)
        if self._read_prototype(key, prim):
            self.placements[key].append((world[None], (str(prim.GetPath()),), self._instance_colour(key, prim)))

    def _instance_colour(self, key: tuple, prim: Usd.Prim, stop: Usd.Prim | None = None) -> np.ndarray | None:
        """The instance ``prim``'s colour (1, 3) for its prototype's primvar reader: a constant
        primvar on it or an ancestor (up to ``stop``), or None."""
        reads = self._primvar_color(key)
        value = None if reads is None else constant_primvar(prim, reads.name, self.ctx.time, stop=stop)
        return None if value is None else np.array([reads.of(value)])

    def _primvar_color(self, key: tuple) -> PrimvarColor | None:
        """What the prototype's per-copy cd reads (its meshes' materials with instance_color):
        one primvar per prototype; a second is named in a warning and its meshes keep their
        fallback."""
        read = self.prototypes[key]
        found = {}
        for m in read.meshes:
            reads = self.materials.primvar_colors.get(m.material)
            if reads is not None:
                found.setdefault(reads, m.source)
        if len(found) > 1:
            self.ctx.unsupported[
                "prototypes whose meshes read different per-instance primvars (the first is used)"
            ].append(read.source)
        return next(iter(found), None)

    def _instance_key(self, prim: Usd.Prim) -> tuple:
        bound, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()
        return ("instance", str(prim.GetPrototype().GetPath()), str(bound.GetPath()) if bound else "")

    # -- PointInstancers ---------------------------------------------------------------------

    def instancer(self, prim: Usd.Prim, world: np.ndarray, into: list | None = None) -> None:
        """Place a PointInstancer's copies (``world``: the instancer's transform). ``into``:
        the nested list of the prototype being read (else the scene's placements)."""
        ctx = self.ctx
        instancer = UsdGeom.PointInstancer(prim)
        prototypes = instancer.GetPrototypesRel().GetForwardedTargets()
        for target in prototypes:
            if any(str(target) == r or r.startswith(str(target) + "/") for r in (*self.reading, str(prim.GetPath()))):
                ctx.problem(prim, "prototypes", f"the prototype {target} contains this instancer (a cycle)")
                return
        proto_indices = instancer.GetProtoIndicesAttr().Get(ctx.time)
        if proto_indices is None or not prototypes or not len(proto_indices):
            return
        proto_indices = np.asarray(proto_indices, dtype=np.int64)
        bad = (proto_indices < 0) | (proto_indices >= len(prototypes))
        if bad.any():
            ctx.problem(prim, "protoIndices", f"{int(bad.sum())} indices out of range [0, {len(prototypes)})")
            return
        # One entry per instance in every per-instance array that is authored (USD only warns and
        # places no instance at all): a problem naming the array that is off.
        for name in ("positions", "orientations", "orientationsf", "scales", "velocities", "angularVelocities"):
            attr = prim.GetAttribute(name)
            values = attr.Get(ctx.time) if attr else None
            count = 0 if values is None else len(values)
            if (name == "positions" and count == 0) or (count and count != len(proto_indices)):
                got = "none" if count == 0 else str(count)
                ctx.problem(
                    prim, name, f"must have one entry per instance ({len(proto_indices)} protoIndices), got {got}"
                )
                return
        transforms = instancer.ComputeInstanceTransformsAtTime(
            ctx.time, ctx.time, UsdGeom.PointInstancer.IncludeProtoXform, UsdGeom.PointInstancer.IgnoreMask
        )
        if len(transforms) != len(proto_indices):  # USD gives none when positions and protoIndices disagree
            ctx.problem(
                prim,
                "positions",
                f"{len(proto_indices)} protoIndices but the instance transforms could not be "
                "computed (positions, orientations or scales of another length)",
            )
            return
        # Gf matrices are row-vector: transpose into the model's column-vector convention.
        local = np.array(transforms, dtype=np.float64).reshape(-1, 4, 4).transpose(0, 2, 1)
        placed = np.matmul(world, local)
        mask = instancer.ComputeMaskAtTime(ctx.time)
        keep = np.ones(len(proto_indices), bool) if not mask else np.asarray(mask, bool)
        ids = instancer.GetIdsAttr().Get(ctx.time)
        ids = (
            np.asarray(ids, np.int64)
            if ids is not None and len(ids) == len(proto_indices)
            else np.arange(len(proto_indices))
        )
        path = str(prim.GetPath())
        for j, target in enumerate(prototypes):
            chosen = np.flatnonzero(keep & (proto_indices == j))
            if not len(chosen):
                continue
            key = ("instancer", str(target))
            proto = ctx.stage.GetPrimAtPath(target)
            if not proto or not self._read_prototype(key, proto):
                continue
            sources = tuple(f"{path}[{ids[k]}]" for k in chosen)  # each copy by its id (for errors)
            reads = self._primvar_color(key)
            colours = None if reads is None else per_instance(prim, reads.name, len(proto_indices), ctx.time)
            if colours is not None:
                colours = colours[chosen] * np.asarray(reads.scale)
            if into is not None:
                into.append((key, placed[chosen], sources, colours))
            else:
                self.placements[key].append((placed[chosen], sources, colours))

    # -- reading a prototype once ------------------------------------------------------------

    def _read_prototype(self, key: tuple, root: Usd.Prim) -> bool:
        """Read the prototype ``key`` from the subtree at ``root`` (once); False when it cannot
        be (a cycle, already reported)."""
        if key in self.prototypes:
            return True
        ctx = self.ctx
        root_path = str(root.GetPath())
        if root_path in self.reading:
            ctx.problem(root, "prototypes", "this prototype contains itself (a cycle)")
            return False
        self.reading.append(root_path)
        outer_root, self.materials.prototype_root = self.materials.prototype_root, root
        read = _PrototypeRead(root_path)
        it = iter(Usd.PrimRange(root, Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)))
        renderable = self.renderable()
        for prim in it:
            if not renderable(prim):
                it.PruneChildren()
                continue
            if prim == root:
                local = np.eye(4)
            else:
                relative, _ = ctx.xforms.ComputeRelativeTransform(prim, root)
                local = gf_to_numpy(relative)
            if prim != root and prim.IsInstance():
                it.PruneChildren()
                nested_key = self._instance_key(prim)
                if self._read_prototype(nested_key, prim):
                    colour = self._instance_colour(nested_key, prim, stop=root)
                    read.nested.append((nested_key, local[None], (str(prim.GetPath()),), colour))
            elif prim.IsA(UsdGeom.PointInstancer):
                it.PruneChildren()
                self.instancer(prim, local, into=read.nested)
            elif prim.IsA(UsdGeom.Gprim):
                self.gprim(prim, local, read.spheres, read.meshes)
            elif prim.HasAPI(UsdLux.LightAPI):
                ctx.unsupported["lights inside PointInstancer prototypes (ignored)"].append(str(prim.GetPath()))
        self.reading.pop()
        self.materials.prototype_root = outer_root
        self.prototypes[key] = read
        return True

    # -- the model ---------------------------------------------------------------------------

    def _place(self, flat: dict, key: tuple, transforms: np.ndarray, sources: tuple, colours) -> None:
        """Add copies of ``key`` to ``flat``, and the copies of what it nests (a method, not a
        recursive closure: that would be a reference cycle keeping the stage, and USD's layer
        registry would hand its stale layer to the next open of the same file)."""
        flat[key].append((transforms, sources, colours))
        for nested_key, inner, inner_sources, inner_colours in self.prototypes[key].nested:
            # every outer copy times every inner one: (K, 1) @ (1, J) -> K·J (copy k·J + j)
            composed = np.matmul(transforms[:, None], inner[None]).reshape(-1, 4, 4)
            tiled = None if inner_colours is None else np.tile(inner_colours, (len(transforms), 1))
            self._place(flat, nested_key, composed, inner_sources, tiled)

    def _colours(self, key: tuple, entries: list) -> np.ndarray | None:
        """Every copy's colour (K, 3), in the entries' order: a placement without values takes
        the prototype's fallback cd; None where no placement has values."""
        if all(c is None for _, _, c in entries):
            return None
        reads = self._primvar_color(key)
        fallback = next(
            m.material.diffuse_color
            for m in self.prototypes[key].meshes
            if self.materials.primvar_colors.get(m.material) == reads
        )
        return np.concatenate([np.tile(fallback, (len(t), 1)) if c is None else c for t, _, c in entries])

    def build(self, spheres: list, meshes: list) -> tuple[Instances, ...]:
        """The scene's instances; the spheres of prototypes are appended to ``spheres`` (placed
        in the world), and a prototype placed exactly once is flattened into ``meshes``."""
        flat: dict[tuple, list] = defaultdict(list)  # key -> [(transforms, sources)], nesting composed
        for key, entries in self.placements.items():
            for transforms, sources, colours in entries:
                self._place(flat, key, transforms, sources, colours)
        out = []
        for key, entries in flat.items():
            read = self.prototypes[key]
            transforms = np.concatenate([t for t, _, _ in entries])
            sources = tuple(s for _, srcs, _ in entries for s in srcs)
            colours = self._colours(key, entries)
            if len(sources) != len(transforms):  # a nested copy is named by its prim in the prototype
                sources = ()
            for s in read.spheres:
                suffix = s.source[len(read.source) :] if s.source.startswith(read.source) else ""
                for k, m in enumerate(transforms):
                    source = sources[k] + suffix if sources else s.source
                    material = _copy_material(s.material, colours, k)
                    if isinstance(s, Points):  # each copy as its own spheres, as a Sphere is placed
                        spheres.extend(Sphere(m @ one.world_from_object, material, source) for one in s.spheres())
                    else:
                        spheres.append(Sphere(m @ s.world_from_object, material, source))
            # Intrinsic prims (Cube, Cylinder, ...) are placed in the world per copy, as spheres:
            # each is already an affine map of a canonical shape (docs/instancing.md).
            for i in (i for i in read.meshes if isinstance(i, Intrinsic)):
                suffix = i.source[len(read.source) :] if i.source.startswith(read.source) else ""
                for k, m in enumerate(transforms):
                    source = sources[k] + suffix if sources else i.source
                    meshes.append(
                        replace(
                            i,
                            world_from_object=m @ i.world_from_object,
                            source=source,
                            material=_copy_material(i.material, colours, k),
                        )
                    )
            triangle_meshes = [m for m in read.meshes if not isinstance(m, Intrinsic)]
            if not triangle_meshes:
                continue
            if read.prototype is None:
                read.prototype = Prototype(tuple(triangle_meshes), read.source)
            group = Instances(read.prototype, transforms, sources[0] if sources else read.source, sources, colours)
            if len(transforms) == 1:  # one copy: flattening costs nothing
                meshes.extend(group.placed_meshes(0))
                continue
            out.append(group)
            self.ctx.nodes.append(
                (
                    read.source,
                    f"Instances ({len(transforms)} copies of {read.prototype.triangle_count} triangles"
                    + (", a colour each)" if colours is not None else ")"),
                )
            )
        return tuple(out)


def _copy_material(material, colours: np.ndarray | None, k: int):
    """A prototype's sphere or intrinsic prim placed as copy k: its cd the copy's colour where
    its material reads one (as ``Instances.material_of`` does for the meshes)."""
    if colours is None or not material.instance_color:
        return material
    return replace(material, diffuse_color=tuple(float(c) for c in colours[k]), instance_color=False)
