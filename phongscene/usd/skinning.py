# SPDX-License-Identifier: Apache-2.0
"""UsdSkel: a mesh bound to a skeleton is posed at the time read, by usd-core's own skinning.

Inside a ``SkelRoot``, ``UsdSkel.Cache`` resolves which skeleton (and ``SkelAnimation``) drives
which mesh; the skeleton query's skinning transforms at the read time code and the mesh's
skinning query (``ComputeSkinnedPoints``: linear blend or dual quaternion, as authored, with its
``geomBindTransform``) give the posed points. They are in the *skeleton's* space (UsdSkel's
rule: the mesh's own transform does not apply), so the skeleton's local-to-world places them.
An animated ``SkelAnimation`` is read frame by frame like any other time sample.

Not modelled (a warning lists the meshes): blend shapes (the posed points without them) and
authored normals of a skinned mesh (bind-pose normals would be wrong in the pose, so they are
dropped and the triangles' geometric normals are used).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from pxr import Usd, UsdSkel, Vt

if TYPE_CHECKING:
    from .context import ReadContext


@dataclass(frozen=True)
class Pose:
    """A skinned mesh's posed points (skeleton space) and the skeleton's local-to-world."""

    points: np.ndarray  # (N, 3) float64
    world: np.ndarray  # (4, 4) column-vector, model space


class Skinning:
    """The skinning targets of a stage (found once per SkelRoot) and their poses at ctx.time."""

    def __init__(self, ctx: ReadContext):
        self.ctx = ctx
        self.cache = UsdSkel.Cache()
        self.roots_seen: set[str] = set()
        self.targets: dict[str, tuple[UsdSkel.SkeletonQuery, UsdSkel.SkinningQuery]] = {}

    def _populate(self, root: UsdSkel.Root) -> None:
        key = str(root.GetPath())
        if key in self.roots_seen:
            return
        self.roots_seen.add(key)
        predicate = Usd.TraverseInstanceProxies()
        self.cache.Populate(root, predicate)
        for binding in self.cache.ComputeSkelBindings(root, predicate):
            skel_query = self.cache.GetSkelQuery(binding.GetSkeleton())
            for target in binding.GetSkinningTargets():
                self.targets[str(target.GetPrim().GetPath())] = (skel_query, target)

    def pose(self, prim: Usd.Prim, points: np.ndarray) -> Pose | None:
        """The posed points of ``prim`` (its authored ``points``), or None if no skeleton drives it."""
        root = _enclosing_root(prim)
        if root is None:
            return None
        self._populate(root)
        found = self.targets.get(str(prim.GetPath()))
        if found is None:
            return None
        skel_query, target = found
        path = str(prim.GetPath())
        time = self.ctx.time
        xforms = skel_query.ComputeSkinningTransforms(time)
        posed = Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(points, dtype=np.float32))
        if xforms is None or not target.ComputeSkinnedPoints(xforms, posed, time):
            self.ctx.unsupported["skinned meshes USD cannot pose (drawn in their bind pose)"].append(path)
            return None
        if target.HasBlendShapes():
            self.ctx.unsupported["blend shapes (the skinned pose without them)"].append(path)
        skeleton_prim = skel_query.GetSkeleton().GetPrim()
        return Pose(np.asarray(posed, dtype=np.float64).reshape(-1, 3), self.ctx.world(skeleton_prim))


def _enclosing_root(prim: Usd.Prim) -> UsdSkel.Root | None:
    p = prim.GetParent()
    while p and not p.IsPseudoRoot():
        if p.IsA(UsdSkel.Root):
            return UsdSkel.Root(p)
        p = p.GetParent()
    return None
