# SPDX-License-Identifier: Apache-2.0
"""UsdSkel: a mesh bound to a skeleton is posed at the time read, by usd-core's own skinning.

Inside a ``SkelRoot``, ``UsdSkel.Cache`` resolves which skeleton (and ``SkelAnimation``) drives
which mesh; the skeleton query's skinning transforms at the read time code and the mesh's
skinning query (``ComputeSkinnedPoints``: linear blend or dual quaternion, as authored, with its
``geomBindTransform``) give the posed points. They are in the *skeleton's* space (UsdSkel's
rule: the mesh's own transform does not apply), so the skeleton's local-to-world places them.
An animated ``SkelAnimation`` is read frame by frame like any other time sample.

Authored normals are skinned too (``UsdSkel.SkinNormals``: each normal by its point's joint
influences, with the inverse transposes of the skinning transforms and of the geomBindTransform,
as UsdSkel's imaging skins them). Not modelled (a warning lists the meshes): blend shapes (the
posed points without them).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from pxr import Gf, Usd, UsdSkel, Vt

if TYPE_CHECKING:
    from .context import ReadContext


@dataclass(frozen=True)
class NormalSkinning:
    """What skins a mesh's normals: the method, the inverse transposes of the geomBindTransform's
    and of each (mesh-ordered) skinning transform's linear part, and each point's influences."""

    method: str
    geom_bind: Gf.Matrix3d
    joints: Vt.Matrix3dArray
    indices: np.ndarray  # (N, k) int, or (1, k) for a rigidly deformed mesh
    weights: np.ndarray  # (N, k) float, likewise

    def skin(self, normals: np.ndarray, points: np.ndarray) -> np.ndarray:
        """``normals`` (K, 3), each that of point ``points[i]``, skinned and made unit."""
        k = self.indices.shape[1]
        rows = np.zeros(len(points), dtype=np.int64) if len(self.indices) == 1 else points
        skinned = Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(normals, dtype=np.float32))
        UsdSkel.SkinNormals(
            self.method,
            self.geom_bind,
            self.joints,
            Vt.IntArray.FromNumpy(np.ascontiguousarray(self.indices[rows].ravel(), dtype=np.int32)),
            Vt.FloatArray.FromNumpy(np.ascontiguousarray(self.weights[rows].ravel(), dtype=np.float32)),
            k,
            skinned,
        )
        out = np.asarray(skinned, dtype=np.float64).reshape(-1, 3)
        lengths = np.linalg.norm(out, axis=1, keepdims=True)
        # A normal its joints' weights cancel (zero weights): the normal as authored.
        return np.where(lengths > 0, out / np.where(lengths > 0, lengths, 1.0), normals)


@dataclass(frozen=True)
class Pose:
    """A skinned mesh's posed points (skeleton space) and the skeleton's local-to-world."""

    points: np.ndarray  # (N, 3) float64
    world: np.ndarray  # (4, 4) column-vector, model space
    normals: NormalSkinning | None = None  # None: the mesh's influences could not be read


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
        return Pose(
            np.asarray(posed, dtype=np.float64).reshape(-1, 3),
            self.ctx.world(skeleton_prim),
            _normal_skinning(target, xforms, time),
        )


def _inverse_transposes(matrices: np.ndarray) -> np.ndarray:
    """The inverse transposes of the linear parts of (J, 4, 4) Gf (row-vector) matrices; a
    singular one (a zero scale) gives zeros (its normals then keep their authored direction)."""
    linear = matrices[:, :3, :3]
    out = np.zeros_like(linear)
    ok = np.abs(np.linalg.det(linear)) > 0
    out[ok] = np.linalg.inv(linear[ok]).transpose(0, 2, 1)
    return out


def _normal_skinning(target: UsdSkel.SkinningQuery, xforms, time) -> NormalSkinning | None:
    influences = target.ComputeJointInfluences(time)
    if not influences:
        return None
    indices, weights = influences
    k = target.GetNumInfluencesPerComponent()
    mapper = target.GetJointMapper()
    if mapper and not mapper.IsNull() and not mapper.IsIdentity():
        mapped = Vt.Matrix4dArray(len(target.GetJointOrder() or []))
        xforms = mapper.RemapTransforms(xforms, mapped) or mapped
    joints = _inverse_transposes(np.asarray(xforms, dtype=np.float64).reshape(-1, 4, 4))
    bind = _inverse_transposes(np.asarray(target.GetGeomBindTransform(time), dtype=np.float64).reshape(1, 4, 4))[0]
    return NormalSkinning(
        str(target.GetSkinningMethod()),
        Gf.Matrix3d(*bind.ravel().tolist()),
        Vt.Matrix3dArray.FromNumpy(np.ascontiguousarray(joints)),
        np.asarray(indices, dtype=np.int64).reshape(-1, k),
        np.asarray(weights, dtype=np.float64).reshape(-1, k),
    )


def _enclosing_root(prim: Usd.Prim) -> UsdSkel.Root | None:
    p = prim.GetParent()
    while p and not p.IsPseudoRoot():
        if p.IsA(UsdSkel.Root):
            return UsdSkel.Root(p)
        p = p.GetParent()
    return None
