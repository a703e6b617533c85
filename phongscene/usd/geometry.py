# SPDX-License-Identifier: Apache-2.0
"""USD gprims → model geometry in world space.

* ``Sphere`` stays analytic: ``world_from_object = world · diag(r, r, r, 1)``.
* ``Mesh`` is fan-triangulated with numpy (no per-face Python loop; exact for convex faces),
  honours ``holeIndices`` and ``orientation`` and keeps authored normals of every
  interpolation, ``primvars:normals`` (indexed or not) taking precedence over ``normals``.
  Normals of the wrong type are ignored with a warning (as USD renderers draw such a mesh), and
  zero-length ones are replaced by their triangles' geometric normals with a warning (one bad
  normal does not refuse a scene); of the wrong count or non-finite they are *problems* (errors).
  A mesh whose ``points`` have the wrong type is skipped with a warning, the rest is drawn.
* ``Cube``, ``Cylinder`` (and ``Cylinder_1``), ``Cone``, ``Capsule`` (and ``Capsule_1``) and
  ``Plane`` are exact surfaces (``intrinsic``: the model's ``Intrinsic``), a Plane with
  ``phong:infinite = true`` the whole plane. Where a prim says ``phong:tessellate = true`` it
  becomes triangles instead (not the two-radius ``_1`` prims: they stay exact, with a warning)
  (``primitive``): ``Cube`` and ``Plane`` flat triangles; ``Cylinder``, ``Cone`` and ``Capsule``
  tessellated by ``trimesh.creation`` with ``SEGMENTS`` segments around the axis (capsule:
  ``SEGMENTS`` × ``SEGMENTS // 2`` rings) and analytic smooth normals on the curved surface
  (flat caps keep the face normal).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from pxr import Usd, UsdGeom, UsdSkel

from ..scene import Intrinsic, PhongMaterial, Points, Sphere, TriangleMesh
from ..tolerances import UNIT_TOLERANCE, is_singular
from . import subdivision, textures
from .context import ReadContext
from .names import BOOL_TYPES, INFINITE, TESSELLATE

if TYPE_CHECKING:
    import trimesh

# A tessellated face whose unit normal is within this of ±Z (|n_z| > 1 − tol) is a flat cap of a
# cylinder or cone (caps are exactly axial; side faces have |n_z| = 0 on a cylinder and
# r/√(r²+h²) < 1 on a cone).
CAP_NORMAL_TOLERANCE = 1e-9
# Corners closer than this to the primitive's axis (a cone's apex) have no radial direction.
ON_AXIS_DISTANCE = 1e-12

SEGMENTS = 64  # around the axis of Cylinder, Cone, Capsule: chord error r·(1 − cos(π/64)) ≈ 1.2e-3·r
POINT_TYPES = ("point3f[]", "point3d[]", "float3[]", "double3[]")
NORMAL_TYPES = tuple(
    t + "[]" for t in ("normal3f", "normal3d", "normal3h", "vector3f", "vector3d", "float3", "double3", "half3")
)
# Cyclic permutations taking the object's Z axis to the USD `axis` (proper rotations, det +1).
AXIS_FROM_Z = {
    "X": np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
    "Y": np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]),
    "Z": np.eye(3),
}


def sphere(ctx: ReadContext, prim: Usd.Prim, world: np.ndarray, material: PhongMaterial) -> Sphere:
    radius = ctx.number(prim, "radius", 1.0, minimum=0.0, strict=True)
    # The transform's faults are the xformOps' (the model would blame its matrix, i.e. the radius);
    # reported here once, with identity in its place.
    if not np.all(np.isfinite(world)):
        ctx.problem(prim, "xformOpOrder", "the transform is not finite (a NaN or infinite xformOp value)")
        world = np.eye(4)
    elif is_singular(world[:3, :3]):
        ctx.problem(prim, "xformOpOrder", "the transform is singular (a zero or degenerate scale)")
        world = np.eye(4)
    return Sphere(world @ np.diag([radius, radius, radius, 1.0]), material, str(prim.GetPath()))


def _to_world(points: np.ndarray, world: np.ndarray) -> np.ndarray:
    if np.array_equal(world, np.eye(4)):
        return points
    return points @ world[:3, :3].T + world[:3, 3]


def _normals_to_world(ctx: ReadContext, prim: Usd.Prim, normals: np.ndarray, world: np.ndarray) -> np.ndarray | None:
    """Normals transform by the inverse transpose. Rows already unit within the model's
    tolerance (float32 storage leaves ~1e-8) are kept bit-for-bit, so re-reading a written
    mesh is exact; others are divided by their length. A singular transform (a zero scale)
    has no inverse: a problem is recorded and None returned."""
    a = world[:3, :3]
    if not np.array_equal(a, np.eye(3)):
        if is_singular(a):
            ctx.problem(
                prim,
                "xformOpOrder",
                "the world transform is singular (a zero or degenerate scale): its normals cannot be transformed",
            )
            return None
        normals = normals @ np.linalg.inv(a)
    lengths = np.linalg.norm(normals, axis=1)
    rescale = np.abs(lengths - 1.0) > UNIT_TOLERANCE
    if rescale.any():
        normals = normals.copy()
        normals[rescale] /= lengths[rescale, None]
    return normals


# Quads per block of the concave-quad test: its temporaries (~200 B a quad) stay ~100 MiB (a
# 5M-quad mesh tested at once peaked at 2.7 GiB, over the reader's whole model).
QUAD_BLOCK = 500_000


def _bad_quad_fans(fv, corners, quads, first_tri) -> np.ndarray:
    """The quads (of ``quads``) whose fan (0,1,2), (0,2,3) is wrong: its two triangles turn
    opposite ways, A1·A2 < 0. Block by block."""
    bad = []
    for start in range(0, len(quads), QUAD_BLOCK):
        block = quads[start : start + QUAD_BLOCK]
        row = first_tri[block]
        p0, p1, p2, p3 = corners(fv[row, 0]), corners(fv[row, 1]), corners(fv[row, 2]), corners(fv[row + 1, 2])
        d1, d2, d3 = p1 - p0, p2 - p0, p3 - p0
        a1 = np.cross(d1, d2)
        a2 = np.cross(d2, d3)
        bad.append(block[a1[:, 0] * a2[:, 0] + a1[:, 1] * a2[:, 1] + a1[:, 2] * a2[:, 2] < 0])  # as summed before
    return np.concatenate(bad) if bad else np.zeros(0, dtype=np.int64)


def _ear_clip_concave_faces(fv, corners, counts, first_tri) -> None:
    """Re-triangulate, in place in ``fv`` (the fan's face-vertex triples, ``first_tri`` the first
    row of each face, ``counts`` its corner count; ``corners(ids)`` the positions of face-vertex
    ids, computed where needed, not for every corner at once), the faces whose fan is wrong, by ear clipping
    in the face's plane. A fan from a face's first corner tiles the face exactly when every fan
    triangle turns the same way as the face (their area vectors sum to the face's normal); a
    concave face seen badly from that corner has a fan triangle turned against it. Convex faces
    (nearly all) keep their fan; triangles cost nothing here."""
    big = np.flatnonzero(counts >= 5)
    quads = np.flatnonzero(counts == 4)
    if quads.size:
        # A quad's fan (0,1,2), (0,2,3) is right when both triangles turn the same way: A1·A2 >= 0.
        bad = _bad_quad_fans(fv, corners, quads, first_tri)
        big = np.union1d(big, bad)  # those go through the general test and ear clipping below
    if not big.size:
        return
    per_face = counts[big] - 2
    rows = np.repeat(first_tri[big], per_face) + (
        np.arange(int(per_face.sum())) - np.repeat(np.cumsum(per_face) - per_face, per_face)
    )
    a, b, c = corners(fv[rows, 0]), corners(fv[rows, 1]), corners(fv[rows, 2])
    e1, e2 = b - a, c - a
    area = np.empty_like(e1)  # twice the fan triangles' area vectors, e1 × e2
    area[:, 0] = e1[:, 1] * e2[:, 2] - e1[:, 2] * e2[:, 1]
    area[:, 1] = e1[:, 2] * e2[:, 0] - e1[:, 0] * e2[:, 2]
    area[:, 2] = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    normal = np.add.reduceat(area, np.cumsum(per_face) - per_face, axis=0)
    against = np.einsum("ij,ij->i", area, np.repeat(normal, per_face, axis=0)) < 0
    for j in np.unique(np.repeat(np.arange(len(big)), per_face)[against]):
        row = int(first_tri[big[j]])
        ids = np.concatenate(
            [fv[row : row + per_face[j], 0][:1], fv[row : row + per_face[j], 1], fv[row + per_face[j] - 1, 2:]]
        )
        triangles = _ear_clip(corners(ids), normal[j])
        if triangles is not None:  # else degenerate or self-intersecting: keep the fan
            fv[row : row + len(triangles)] = ids[np.asarray(triangles)]


def _ear_clip(points: np.ndarray, normal: np.ndarray) -> list[tuple[int, int, int]] | None:
    """Triangles (indices into ``points``, counter-clockwise about ``normal``) of a simple
    polygon, by ear clipping; None if none is found (a degenerate or self-intersecting face)."""
    length = float(np.linalg.norm(normal))
    if length == 0:
        return None
    nz = normal / length
    helper = np.array([1.0, 0.0, 0.0]) if abs(nz[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    ux = np.cross(helper, nz)
    ux /= np.linalg.norm(ux)
    uy = np.cross(nz, ux)
    xy = np.stack([points @ ux, points @ uy], axis=1)

    def cross(o, p, q):
        return (p[0] - o[0]) * (q[1] - o[1]) - (p[1] - o[1]) * (q[0] - o[0])

    remaining = list(range(len(points)))
    out = []
    while len(remaining) > 3:
        for i in range(len(remaining)):
            a, b, c = remaining[i - 1], remaining[i], remaining[(i + 1) % len(remaining)]
            if cross(xy[a], xy[b], xy[c]) <= 0:
                continue  # reflex or flat corner: not an ear
            inside = any(
                cross(xy[a], xy[b], xy[q]) >= 0 and cross(xy[b], xy[c], xy[q]) >= 0 and cross(xy[c], xy[a], xy[q]) >= 0
                for q in remaining
                if q not in (a, b, c)
            )
            if not inside:
                out.append((a, b, c))
                remaining.pop(i)
                break
        else:
            return None
    out.append(tuple(remaining))
    return out


def _frozen(array: np.ndarray) -> np.ndarray:
    """``array`` made read-only, for the model to keep as it is (``scene._readonly``): an array
    that owns its memory; a view (of a USD array, say) stays writable and is copied there."""
    if array.base is None:
        array.setflags(write=False)
    return array


def _winding_flipped(world: np.ndarray) -> bool:
    # A mirroring transform turns a counter-clockwise (front) face clockwise in world space.
    return bool(np.linalg.det(world[:3, :3]) < 0)


def mesh(
    ctx: ReadContext,
    prim: Usd.Prim,
    world: np.ndarray,
    material: PhongMaterial,
    subsets: list[tuple[str, PhongMaterial, np.ndarray]] = (),
    st=None,
) -> tuple[TriangleMesh, ...]:
    """Fan-triangulate a UsdGeom.Mesh into world space: one TriangleMesh, or one per material
    GeomSubset (source: the subset's path; faces in no subset keep ``material``, a face in two
    takes the first). ``st`` (a ``textures.StSource``): read that st primvar as the mesh's
    uvs. Nothing (after recording problems) if broken."""
    whole = _mesh(ctx, prim, world, material, st)
    if whole is None:
        return ()
    mesh_, face_of_tri, n_faces = whole
    if not subsets:
        return (mesh_,)
    part_of_face = np.full(n_faces, -1, dtype=np.int64)
    for j, (source, _, faces) in enumerate(subsets):
        if faces.min() < 0 or faces.max() >= n_faces:
            ctx.problem(
                source, "indices", f"face indices must be in [0, {n_faces}), got {int(faces.min())}..{int(faces.max())}"
            )
            return ()
        free = faces[part_of_face[faces] == -1]
        part_of_face[free] = j
    part_of_tri = part_of_face[face_of_tri]
    out = []
    for j, (source, part_material) in enumerate([(mesh_.source, material)] + [(s, m) for s, m, _ in subsets], start=-1):
        keep = part_of_tri == j
        if mesh_.uvs is None and part_material.textures:
            part_material = part_material.without_textures()  # no st: the fallback colours
        if keep.any():
            out.append(
                TriangleMesh(
                    mesh_.points,
                    mesh_.triangles[keep],
                    mesh_.normals,
                    None if mesh_.normal_indices is None else mesh_.normal_indices[keep],
                    part_material,
                    source,
                    mesh_.uvs,
                    None if mesh_.uv_indices is None else mesh_.uv_indices[keep],
                )
            )
    return tuple(out)


def _mesh(ctx: ReadContext, prim: Usd.Prim, world: np.ndarray, material: PhongMaterial, st=None):
    """(TriangleMesh, face index of each triangle, face count), or None (after recording problems)."""
    n_problems = len(ctx.problems)
    path = str(prim.GetPath())
    points_attr = prim.GetAttribute("points")
    if points_attr and ctx.authored_type(points_attr) not in POINT_TYPES:
        # As USD renderers do (usdrecord draws the other meshes): this mesh is skipped, the
        # scene is drawn; `validate --strict` still refuses it.
        ctx.unsupported[f"meshes whose points are not {' or '.join(POINT_TYPES)} (skipped)"].append(
            f"{path}.points ({ctx.authored_type(points_attr)})"
        )
        return None
    points = ctx.get(prim, "points", POINT_TYPES)
    counts = ctx.get(prim, "faceVertexCounts", ("int[]",))
    indices = ctx.get(prim, "faceVertexIndices", ("int[]",))
    if len(ctx.problems) > n_problems:
        return None
    if points is None or counts is None or indices is None or len(points) == 0:
        ctx.unsupported["meshes without points or faces (skipped)"].append(path)
        return None
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    counts = np.asarray(counts, dtype=np.int64)
    # USD's int[] is 32-bit: kept so (an int64 copy was 24 MB of a 1M-triangle mesh's peak).
    idx = np.asarray(indices, dtype=np.int32)
    if not np.all(np.isfinite(p)):
        ctx.problem(prim, "points", f"{int(np.count_nonzero(~np.isfinite(p).all(axis=1)))} points are not finite")
    pose = ctx.skinning.pose(prim, p) if prim.HasAPI(UsdSkel.BindingAPI) and len(ctx.problems) == n_problems else None
    bind_points = p
    if pose is not None:
        # Posed in the skeleton's space, placed by the skeleton (UsdSkel: the mesh's transform
        # does not apply to skinned points).
        p, world = pose.points, pose.world
    if (counts < 0).any():
        ctx.problem(prim, "faceVertexCounts", f"must be >= 0, got {int(counts.min())}")
        return None
    if int(counts.sum()) != len(idx):
        ctx.problem(
            prim, "faceVertexCounts", f"sums to {int(counts.sum())}, but faceVertexIndices has {len(idx)} entries"
        )
        return None
    out_of_range = (idx < 0) | (idx >= len(p))
    if out_of_range.any():
        ctx.problem(
            prim,
            "faceVertexIndices",
            f"{int(out_of_range.sum())} indices out of range [0, {len(p)}), e.g. {int(idx[out_of_range][0])}",
        )
        return None

    scheme = ctx.get(prim, "subdivisionScheme", ("token",), UsdGeom.Tokens.catmullClark)
    if scheme != UsdGeom.Tokens.none and _polygon_export(ctx, prim):
        ctx.unsupported[
            "meshes with normals and no subdivisionScheme, drawn as the polygon meshes their normals describe "
            '(USD\'s fallback is catmullClark: author subdivisionScheme = "catmullClark", phong:subdivisionLevel '
            "or --subdivision-level to refine them)"
        ].append(path)
        scheme = UsdGeom.Tokens.none
    if scheme != UsdGeom.Tokens.none:
        if scheme not in subdivision.SCHEMES:
            allowed = ", ".join([*subdivision.SCHEMES, UsdGeom.Tokens.none])
            ctx.problem(prim, "subdivisionScheme", f"must be one of {allowed}, got {scheme!r}")
            return None
        level = subdivision.level_of(ctx, prim)
        if level is None:
            return None
        if level > 0:
            refined = _subdivided(ctx, prim, world, material, st, scheme, level, p, counts, idx)
            if refined is not None or len(ctx.problems) > n_problems:
                return refined
            # else OpenSubdiv could not refine it (a warning says so): the cage, as before

    # Fan triangulation: face f with n vertices starting at s gives (s, s+k, s+k+1), k = 1..n−2.
    starts = np.cumsum(counts) - counts
    keep = counts >= 3
    if (counts < 3).any():
        ctx.unsupported["faces with fewer than 3 vertices (skipped)"].append(path)
    holes = ctx.get(prim, "holeIndices", ("int[]",))
    if holes is not None and len(holes):
        holes = np.asarray(holes, dtype=np.int64)
        if ((holes < 0) | (holes >= len(counts))).any():
            ctx.problem(prim, "holeIndices", f"indices out of range [0, {len(counts)})")
            return None
        keep[holes] = False
    # Face and corner ids in 32 bits where they fit (USD's own int[] are): at 5M quads the
    # int64 fan and its temporaries were 600 MiB of the reader's peak (benchmarks/README.md).
    index_type = np.int32 if len(idx) <= np.iinfo(np.int32).max else np.int64
    if keep.all() and (counts == 3).all():
        # A triangle mesh (the common case): the fan below is the identity, built without its
        # ~150 MB of temporaries at 1M triangles; the same arrays.
        faces = face_of_tri = np.arange(len(counts), dtype=index_type)
        fv = np.arange(len(idx), dtype=index_type).reshape(-1, 3)
        identity = True
    else:
        faces = np.flatnonzero(keep).astype(index_type)
        per_face = counts[faces] - 2
        face_of_tri = np.repeat(faces, per_face)
        first_tri = np.cumsum(per_face) - per_face
        # Face-vertex (corner) ids (s, s + k, s + k + 1), written column by column in place.
        fv = np.empty((len(face_of_tri), 3), dtype=index_type)
        fv[:, 0] = np.repeat(starts[faces].astype(index_type), per_face)
        k = np.arange(len(face_of_tri), dtype=index_type)
        k -= np.repeat(first_tri.astype(index_type), per_face)
        np.add(fv[:, 0], k, out=fv[:, 1])
        del k
        fv[:, 1] += 1
        np.add(fv[:, 1], 1, out=fv[:, 2])
        identity = False
        _ear_clip_concave_faces(fv, lambda corner: p[idx[corner]], counts[faces], first_tri)
        del per_face, first_tri
    del starts, keep, faces
    left = ctx.get(prim, "orientation", ("token",), UsdGeom.Tokens.rightHanded) == UsdGeom.Tokens.leftHanded
    if left != _winding_flipped(world):
        fv = fv[:, [0, 2, 1]]
        identity = False
    # The identity fan's triangles are the indices themselves (a view, not a 1M-row gather).
    triangles = idx.reshape(-1, 3) if identity else idx[fv]

    if pose is not None and pose.normals is None and _has_authored_normals(prim):
        ctx.unsupported[
            "authored normals of skinned meshes without readable joint influences (geometric normals are used)"
        ].append(path)
        normals = None
    else:
        # A skinned mesh's normals are read in the bind pose (a zero one takes its bind-pose
        # triangle's normal), then skinned, each by the influences of its corner's point.
        normals = _mesh_normals(ctx, prim, len(p), len(idx), len(counts), fv, triangles, face_of_tri, bind_points)
        if normals is not None and pose is not None:
            normals = _skinned_normals(pose.normals, *normals, triangles)
    if len(ctx.problems) > n_problems:
        return None
    uvs = (
        None
        if st is None
        else textures.mesh_uvs(ctx, prim, st, (len(p), len(idx), len(counts)), fv, triangles, face_of_tri)
    )
    if len(ctx.problems) > n_problems:
        return None
    uv_values, uv_indices = (None, None) if uvs is None else uvs
    if uvs is None and material.textures:
        material = material.without_textures()  # no st: the fallback colours
    world_points = _to_world(p, world)
    # What the model keeps is handed over frozen (read-only, owning its memory), which the model
    # takes without copying; the rest goes first: a 10M-triangle mesh's copies were ~350 MiB of
    # the reader's peak (benchmarks/README.md).
    p = bind_points = fv = None
    world_points, triangles = _frozen(world_points), _frozen(triangles)
    if normals is None:
        return (
            TriangleMesh(world_points, triangles, material=material, source=path, uvs=uv_values, uv_indices=uv_indices),
            face_of_tri,
            len(counts),
        )
    values, normal_indices = normals
    world_normals = _normals_to_world(ctx, prim, values, world)
    if world_normals is None:
        return None
    return (
        TriangleMesh(world_points, triangles, world_normals, normal_indices, material, path, uv_values, uv_indices),
        face_of_tri,
        len(counts),
    )


def _subdivided(ctx: ReadContext, prim: Usd.Prim, world, material, st, scheme, level, p, counts, idx):
    """_mesh's answer for a subdivision surface refined ``level`` times (subdivision.py), or None:
    after a problem, or where OpenSubdiv cannot refine it (the caller then draws the cage)."""
    path = str(prim.GetPath())
    n_problems = len(ctx.problems)
    n_faces = len(counts)
    keep = counts >= 3
    if not keep.all():
        ctx.unsupported["faces with fewer than 3 vertices (skipped)"].append(path)
    holes = ctx.get(prim, "holeIndices", ("int[]",))
    holes = np.zeros(0, dtype=np.int64) if holes is None else np.asarray(holes, dtype=np.int64)
    if ((holes < 0) | (holes >= n_faces)).any():
        ctx.problem(prim, "holeIndices", f"indices out of range [0, {n_faces})")
        return None
    kept = np.flatnonzero(keep)
    corner_kept = np.repeat(keep, counts)
    cage_face = np.full(n_faces, -1, dtype=np.int64)
    cage_face[kept] = np.arange(len(kept))
    cage_holes = cage_face[holes]
    cage_holes = cage_holes[cage_holes >= 0]
    uv_values = uv_of_corner = None
    if st is not None:
        # st as OpenSubdiv's face-varying channel: a value index for every face corner.
        corners = np.arange(len(idx))
        face_of_corner = np.repeat(np.arange(n_faces), counts)
        uvs = textures.mesh_uvs(
            ctx, prim, st, (len(p), len(idx), n_faces), corners[:, None], idx[:, None], face_of_corner
        )
        if len(ctx.problems) > n_problems:
            return None
        if uvs is not None:
            uv_values, element = uvs
            uv_of_corner = element[:, 0][corner_kept]
    if _has_authored_normals(prim):
        # Often a polygon mesh exported without subdivisionScheme = "none": say how to get it back.
        ctx.unsupported[
            "authored normals of subdivision surfaces (the limit surface's normals are used; "
            "phong:subdivisionLevel = 0 or --subdivision-level 0 renders the cage with them)"
        ].append(path)
    refined = subdivision.refine(
        ctx, prim, scheme, p, counts[keep], idx[corner_kept], cage_holes, level, uv_values, uv_of_corner
    )
    if refined is None:
        return None
    triangles, uv_triangles, normals = refined.triangles, refined.uv_triangles, refined.normals
    # The limit normals point to the side the cage's counter-clockwise faces face; a leftHanded
    # mesh faces the other way. Winding as the fan path winds it.
    left = ctx.get(prim, "orientation", ("token",), UsdGeom.Tokens.rightHanded) == UsdGeom.Tokens.leftHanded
    if left:
        normals = -normals
    if left != _winding_flipped(world):
        triangles = triangles[:, [0, 2, 1]]
        uv_triangles = None if uv_triangles is None else uv_triangles[:, [0, 2, 1]]
    # A vertex no triangle uses may have no normal (OpenSubdiv's limit at an isolated point):
    # any unit vector serves.
    normals = np.where(np.linalg.norm(normals, axis=1)[:, None] > 0.0, normals, np.array([0.0, 0.0, 1.0]))
    world_normals = _normals_to_world(ctx, prim, normals, world)
    if world_normals is None:
        return None
    if uv_values is None and material.textures:
        material = material.without_textures()  # no st: the fallback colours
    uvs_out = None if uv_values is None else refined.uvs
    mesh_ = TriangleMesh(
        _to_world(refined.points, world), triangles, world_normals, triangles, material, path, uvs_out, uv_triangles
    )
    return mesh_, kept[refined.base_face], n_faces


def _polygon_export(ctx: ReadContext, prim: Usd.Prim) -> bool:
    """Whether a mesh is a polygon model exported without ``subdivisionScheme = "none"``: the
    scheme is not authored (USD's fallback, catmullClark, applies), the mesh authors normals
    (which a subdivision surface ignores: the exporter meant them), and no refinement level is
    asked for (``phong:subdivisionLevel``, ``--subdivision-level``). Refined, such a model loses
    its shape (its hard edges rounded, its small parts shrunk); Storm draws its cage by default too."""
    return (
        not prim.GetAttribute("subdivisionScheme").HasAuthoredValue()
        and ctx.subdivision_level is None
        and not prim.GetAttribute(subdivision.SUBDIVISION_LEVEL).HasAuthoredValue()
        and _has_authored_normals(prim)
    )


def _has_authored_normals(prim: Usd.Prim) -> bool:
    return any(prim.GetAttribute(name).HasAuthoredValue() for name in ("normals", "primvars:normals"))


def _mesh_normals(ctx, prim, n_points, n_corners, n_faces, fv, triangles, face_of_tri, points):
    """(normals (K,3), normal_indices (M,3)) from primvars:normals or normals; None if absent."""
    primvar = UsdGeom.PrimvarsAPI(prim).GetPrimvar("normals")
    if primvar and primvar.HasAuthoredValue():
        name, attr = "primvars:normals", primvar.GetAttr()
        interpolation = primvar.GetInterpolation()
        element_indices = primvar.GetIndices(ctx.time) if primvar.IsIndexed() else None
    else:
        attr = UsdGeom.Mesh(prim).GetNormalsAttr()
        if not attr.HasAuthoredValue():
            return None
        name, interpolation, element_indices = "normals", UsdGeom.Mesh(prim).GetNormalsInterpolation(), None
    type_name = ctx.authored_type(attr)
    if type_name not in NORMAL_TYPES:
        # As USD renderers do: the mesh is drawn, without the normals it cannot read.
        ctx.warn(
            f"{prim.GetPath()}.{name}: has type {type_name}, expected normal3f[] (ignored: the mesh is flat-shaded)"
        )
        return None
    values = np.asarray(attr.Get(ctx.time), dtype=np.float64).reshape(-1, 3)
    expected = {
        UsdGeom.Tokens.vertex: n_points,
        UsdGeom.Tokens.varying: n_points,
        UsdGeom.Tokens.faceVarying: n_corners,
        UsdGeom.Tokens.uniform: n_faces,
        UsdGeom.Tokens.constant: 1,
    }.get(interpolation)
    if expected is None:
        ctx.problem(prim, name, f"has unknown interpolation {interpolation!r}")
        return None
    n_elements = len(element_indices) if element_indices is not None else len(values)
    if n_elements != expected:
        what = "indices" if element_indices is not None else "values"
        ctx.problem(prim, name, f"has {n_elements} {what}, expected {expected} for {interpolation} interpolation")
        return None
    if element_indices is not None:
        element_indices = np.asarray(element_indices, dtype=np.int64)
        bad = (element_indices < 0) | (element_indices >= len(values))
        if bad.any():
            ctx.problem(prim, f"{name}:indices", f"{int(bad.sum())} indices out of range [0, {len(values)})")
            return None
    if not np.all(np.isfinite(values)):
        ctx.problem(prim, name, "values must be finite")
        return None
    zero = np.linalg.norm(values, axis=1) == 0
    if zero.any():
        # One bad normal must not refuse a 269k-triangle robot: the corners that use a zero
        # normal take their triangle's geometric normal (what a renderer does with no normal).
        ctx.unsupported["zero-length normals (their triangles' geometric normals are used)"].append(
            f"{prim.GetPath()}.{name} ({int(zero.sum())}, e.g. element {int(np.flatnonzero(zero)[0])})"
        )
    # Element (vertex / corner / face / 0) of each triangle corner.
    if interpolation in (UsdGeom.Tokens.vertex, UsdGeom.Tokens.varying):
        element = triangles
    elif interpolation == UsdGeom.Tokens.faceVarying:
        element = fv
    elif interpolation == UsdGeom.Tokens.uniform:
        element = np.repeat(face_of_tri[:, None], 3, axis=1)
    else:
        element = np.zeros_like(fv)
    corner = element_indices[element] if element_indices is not None else element
    if zero.any():
        values, corner = _geometric_normals_for_zero(values, corner, zero, points, triangles)
    return values, corner


def _skinned_normals(skinning, values, corner, triangles):
    """(normals, normal_indices) skinned: one normal per distinct (authored normal, point) pair
    the corners use (a normal shared by points of different joints poses differently at each)."""
    pairs = np.stack([np.asarray(corner, dtype=np.int64).ravel(), np.asarray(triangles, dtype=np.int64).ravel()], 1)
    unique, inverse = np.unique(pairs, axis=0, return_inverse=True)
    skinned = skinning.skin(values[unique[:, 0]], unique[:, 1])
    return skinned, inverse.reshape(np.shape(corner))


def _geometric_normals_for_zero(values, corner, zero, points, triangles):
    """``values``/``corner`` with every corner that indexes a zero normal pointed at its
    triangle's geometric normal (appended to ``values``; unit length, or +y for a degenerate
    triangle, which no ray hits)."""
    bad = zero[corner]
    rows = np.flatnonzero(bad.any(axis=1))
    a, b, c = (points[triangles[rows, k]] for k in range(3))
    n = np.cross(b - a, c - a)
    length = np.linalg.norm(n, axis=1)
    n = np.where(length[:, None] > 0, n / np.where(length > 0, length, 1.0)[:, None], [0.0, 1.0, 0.0])
    corner = np.array(corner, dtype=np.int64, copy=True)
    first = len(values)
    for i, row in enumerate(rows):
        corner[row][bad[row]] = first + i
    # The zero rows are referenced by no corner now; a unit placeholder keeps the model's
    # "every normal has length" invariant.
    values = np.where(zero[:, None], [0.0, 1.0, 0.0], values)
    return np.concatenate([values, n]), corner


# -- tessellated primitives -----------------------------------------------------------------


def _smooth_corner_normals(tm: trimesh.Trimesh, surface_normal) -> tuple[np.ndarray, np.ndarray]:
    """Per-corner normals: ``surface_normal(points, face_normals)`` on curved faces, the face
    normal on flat caps (faces whose normal is along the Z axis)."""
    corners = tm.vertices[tm.faces].reshape(-1, 3)
    face_n = np.repeat(tm.face_normals, 3, axis=0)
    normals = surface_normal(corners, face_n)
    cap = np.abs(face_n[:, 2]) > 1 - CAP_NORMAL_TOLERANCE  # flat discs of cylinder and cone
    normals[cap] = face_n[cap]
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    return normals, np.arange(len(corners), dtype=np.int64).reshape(-1, 3)


def _radial(points: np.ndarray, face_n: np.ndarray) -> np.ndarray:
    """Unit radial direction in XY; at the axis (a cone's apex) the face normal's XY is used.
    Corners of flat caps may get any value here: the caller replaces them by the face normal."""
    xy = points[:, :2].copy()
    on_axis = np.linalg.norm(xy, axis=1) < ON_AXIS_DISTANCE
    xy[on_axis] = face_n[on_axis, :2]
    length = np.linalg.norm(xy, axis=1)
    xy[length == 0] = (1.0, 0.0)
    length[length == 0] = 1.0
    return xy / length[:, None]


# -- intrinsic prims as exact surfaces ----------------------------------------------------------

INTRINSIC_TYPES = ("Cube", "Cylinder", "Cylinder_1", "Cone", "Capsule", "Capsule_1", "Plane")


def tessellated(ctx: ReadContext, prim: Usd.Prim) -> bool:
    """Whether the scene asks for this intrinsic prim as a triangle mesh (phong:tessellate)."""
    return bool(ctx.get(prim, TESSELLATE, BOOL_TYPES, False))


def intrinsic(ctx: ReadContext, prim: Usd.Prim, world: np.ndarray, material: PhongMaterial) -> Intrinsic | None:
    """Cube, Cylinder, Cylinder_1, Cone, Capsule, Capsule_1 or Plane → an exact ``Intrinsic``: the prim's
    transform times its axis (USD's X or Y onto the model's Z) times its size. A Plane with
    ``phong:infinite = true`` is the whole plane. Per-prim normals and extents do not apply."""
    type_name = prim.GetTypeName()
    path = str(prim.GetPath())
    n_problems = len(ctx.problems)
    axis = ctx.get(prim, "axis", ("token",), "Z")
    if axis not in AXIS_FROM_Z:
        ctx.problem(prim, "axis", f"must be X, Y or Z, got {axis!r}")
        return None
    if not np.all(np.isfinite(world)):
        ctx.problem(prim, "xformOpOrder", "the transform is not finite (a NaN or infinite xformOp value)")
        return None
    if is_singular(world[:3, :3]):
        ctx.problem(prim, "xformOpOrder", "the world transform is singular (a zero or degenerate scale)")
        return None
    placed = np.eye(4)
    placed[:3, :3] = AXIS_FROM_Z[axis]
    fields: dict = {}
    if type_name == "Cube":
        half = ctx.number(prim, "size", 2.0, minimum=0.0, strict=True) / 2
        kind, scale = "cube", (half, half, half)
    elif type_name == "Plane":
        width = ctx.number(prim, "width", 2.0, minimum=0.0, strict=True)
        length = ctx.number(prim, "length", 2.0, minimum=0.0, strict=True)
        # Width along X and length along Y for axis Z; (width z, length y) for X and
        # (width x, length z) for Y (schema doc): object x is the width, y the length, z the normal.
        columns = {
            "Z": ((1, 0, 0), (0, 1, 0), (0, 0, 1)),
            "X": ((0, 0, 1), (0, 1, 0), (1, 0, 0)),
            "Y": ((1, 0, 0), (0, 0, 1), (0, 1, 0)),
        }[axis]
        placed[:3, :3] = np.array(columns, dtype=np.float64).T
        infinite = bool(ctx.get(prim, INFINITE, BOOL_TYPES, False))
        kind, scale = "plane", (1.0, 1.0, 1.0) if infinite else (width / 2, length / 2, 1.0)
        fields["infinite"] = infinite
    elif type_name in ("Capsule", "Capsule_1"):
        height = ctx.number(prim, "height", 1.0, minimum=0.0, strict=False)
        if type_name == "Capsule_1":
            bottom = ctx.number(prim, "radiusBottom", 0.5, minimum=0.0, strict=False)
            top = ctx.number(prim, "radiusTop", 0.5, minimum=0.0, strict=False)
            if len(ctx.problems) == n_problems and bottom == 0 and top == 0:
                ctx.problem(prim, "radiusBottom", "radiusBottom and radiusTop are both 0 (no surface)")
        else:
            bottom = top = ctx.number(prim, "radius", 0.5, minimum=0.0, strict=True)
        kind, scale = "capsule", (1.0, 1.0, 1.0)
        fields.update(radius_bottom=bottom, radius_top=top, half_height=height / 2)
    else:
        height = ctx.number(prim, "height", 2.0, minimum=0.0, strict=True)
        if type_name == "Cylinder_1":
            bottom = ctx.number(prim, "radiusBottom", 1.0, minimum=0.0, strict=False)
            top = ctx.number(prim, "radiusTop", 1.0, minimum=0.0, strict=False)
            if len(ctx.problems) == n_problems and bottom == 0 and top == 0:
                ctx.problem(prim, "radiusBottom", "radiusBottom and radiusTop are both 0 (no surface)")
        else:
            bottom = ctx.number(prim, "radius", 1.0, minimum=0.0, strict=True)
            top = 0.0 if type_name == "Cone" else bottom
        kind, scale = "cylinder", (1.0, 1.0, height / 2)
        fields.update(radius_bottom=bottom, radius_top=top)
    if len(ctx.problems) > n_problems:
        return None
    return Intrinsic(kind, world @ placed @ np.diag([*scale, 1.0]), material, path, **fields)


def primitive(ctx: ReadContext, prim: Usd.Prim, world: np.ndarray, material: PhongMaterial) -> TriangleMesh | None:
    """Cube, Plane, Cylinder, Cone or Capsule → a tessellated world-space ``TriangleMesh``."""
    # Imported here, not at the top: trimesh pulls in scipy (~0.35 s, half of a small render's
    # whole process), and only these prims need it.
    import trimesh

    type_name = prim.GetTypeName()
    path = str(prim.GetPath())
    n_problems = len(ctx.problems)
    axis = ctx.get(prim, "axis", ("token",), "Z")
    normals = None
    if type_name == "Cube":
        size = ctx.number(prim, "size", 2.0, minimum=0.0, strict=True)
        tm = trimesh.creation.box(extents=(size, size, size))
    elif type_name == "Plane":
        width = ctx.number(prim, "width", 2.0, minimum=0.0, strict=True)
        length = ctx.number(prim, "length", 2.0, minimum=0.0, strict=True)
        # In the plane's Z-axis frame width runs along X and length along Y; for axis X the
        # table is (width z, length y), for axis Y (width x, length z) — schema doc.
        w, h = width / 2, length / 2
        quad = np.array([[-w, -h, 0.0], [w, -h, 0.0], [w, h, 0.0], [-w, h, 0.0]])
        if axis == "X":
            quad = quad[:, [2, 1, 0]] * [1, 1, -1]  # normal +X: (0, y, z) with width along z
        elif axis == "Y":
            quad = quad[:, [0, 2, 1]] * [1, 1, -1]  # normal +Y: width along x, length along z
        tm = trimesh.Trimesh(quad, [[0, 1, 2], [0, 2, 3]], process=False)
        axis = "Z"  # already placed
    else:
        radius = ctx.number(prim, "radius", 1.0, minimum=0.0, strict=True)
        height = ctx.number(
            prim, "height", 2.0 if type_name != "Capsule" else 1.0, minimum=0.0, strict=type_name != "Capsule"
        )
        if len(ctx.problems) > n_problems:
            return None
        if type_name == "Cylinder":
            tm = trimesh.creation.cylinder(radius=radius, height=height, sections=SEGMENTS)
            normals = _smooth_corner_normals(tm, lambda p, fn: np.column_stack([_radial(p, fn), np.zeros(len(p))]))
        elif type_name == "Cone":
            tm = trimesh.creation.cone(radius=radius, height=height, sections=SEGMENTS)
            tm.apply_translation((0.0, 0.0, -height / 2))  # trimesh: base at z = 0; USD: centred
            slope = np.hypot(height, radius)
            normals = _smooth_corner_normals(
                tm, lambda p, fn: np.column_stack([_radial(p, fn) * height / slope, np.full(len(p), radius / slope)])
            )
        else:  # Capsule: the normal points away from the nearest point of the spine segment
            tm = trimesh.creation.capsule(height=height, radius=radius, count=[SEGMENTS, SEGMENTS // 2])
            half = height / 2
            normals = _smooth_corner_normals(
                tm, lambda p, fn: p - np.column_stack([np.zeros((len(p), 2)), np.clip(p[:, 2], -half, half)])
            )
    if len(ctx.problems) > n_problems:
        return None
    if axis not in AXIS_FROM_Z:
        ctx.problem(prim, "axis", f"must be X, Y or Z, got {axis!r}")
        return None
    placed = np.eye(4)
    placed[:3, :3] = AXIS_FROM_Z[axis]
    world = world @ placed
    triangles = np.asarray(tm.faces, dtype=np.int64)
    if normals is not None:
        values, normal_indices = normals
        if _winding_flipped(world):
            triangles, normal_indices = triangles[:, [0, 2, 1]], normal_indices[:, [0, 2, 1]]
        world_normals = _normals_to_world(ctx, prim, values, world)
        if world_normals is None:
            return None
        return TriangleMesh(
            _to_world(np.asarray(tm.vertices), world), triangles, world_normals, normal_indices, material, path
        )
    if _winding_flipped(world):
        triangles = triangles[:, [0, 2, 1]]
    return TriangleMesh(_to_world(np.asarray(tm.vertices), world), triangles, material=material, source=path)


# A Points prim without ``widths`` (USD leaves the size to the renderer): spheres of this
# diameter, in the prim's units, with a warning.
DEFAULT_POINT_WIDTH = 1.0
# A prim transform whose linear part A has AᵀA = s²·I to this relative error maps spheres to
# spheres (rotation, mirror, uniform scale): the points stay one compact ``Points`` node. A
# matrix authored in float32 (a DCC's rotation) is orthogonal to ~1e-7; 1e-6 of the radius is
# far below a pixel at any resolution. Other transforms (non-uniform scale, shear) make
# ellipsoids: one ``Sphere`` (with its matrix) per point, exact but 20-50 times the memory.
SIMILARITY_TOLERANCE = 1e-6


def points(
    ctx: ReadContext, prim: Usd.Prim, world: np.ndarray, material: PhongMaterial
) -> Points | list[Sphere] | None:
    """``UsdGeom.Points`` as analytic spheres: one per point, of diameter ``widths`` (constant:
    one value; vertex or varying: one per point), ``world · translate(p) · scale(w/2)``. Under a
    similarity transform (``SIMILARITY_TOLERANCE``) one ``Points`` node of world-space centres
    and radii; else one ``Sphere`` per point (ellipsoids). None: nothing to draw."""
    path = str(prim.GetPath())
    p = ctx.get(prim, "points", ("point3f[]", "point3d[]", "float3[]", "double3[]"))
    if p is None or not len(p):
        return None
    p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
    if not np.isfinite(p).all():
        ctx.problem(prim, "points", f"{int(np.count_nonzero(~np.isfinite(p).all(axis=1)))} points are not finite")
        return None
    if not np.all(np.isfinite(world)) or is_singular(world[:3, :3]):
        ctx.problem(prim, "xformOpOrder", "the transform is not finite or singular")
        return None
    widths = ctx.get(prim, "widths", ("float[]", "double[]", "half[]"))
    if widths is None or not len(widths):
        ctx.unsupported[f"Points without widths (spheres of diameter {DEFAULT_POINT_WIDTH:g})"].append(path)
        w = np.full(len(p), DEFAULT_POINT_WIDTH)
    else:
        w = np.asarray(widths, dtype=np.float64)
        if len(w) == 1:
            w = np.full(len(p), w[0])
        elif len(w) != len(p):
            ctx.problem(prim, "widths", f"has {len(w)} values, expected 1 (constant) or {len(p)} (one per point)")
            return None
        bad = np.flatnonzero(~(w >= 0))  # NaN and negative (inf is caught below, with the positions)
        if len(bad) or not np.isfinite(w).all():
            bad = np.flatnonzero(~(np.isfinite(w) & (w >= 0)))
            ctx.problem(
                prim,
                "widths",
                f"values must be finite and >= 0: {len(bad)} are not, the first widths[{bad[0]}] = {w[bad[0]]:g}",
            )
            return None
    drawn = w > 0  # a zero width draws nothing
    if not drawn.all():
        p, w = p[drawn], w[drawn]
    if not len(w):
        return None
    a, t = world[:3, :3], world[:3, 3]
    scale = float(np.linalg.norm(a[:, 0]))
    if np.abs(a.T @ a - scale**2 * np.eye(3)).max() > SIMILARITY_TOLERANCE * scale**2:
        out = []
        for k in range(len(w)):
            local = np.diag([w[k] / 2, w[k] / 2, w[k] / 2, 1.0])
            local[:3, 3] = p[k]
            out.append(Sphere(world @ local, material, path))
        return out
    # The centres as world · translate(p) places them; a diagonal or identity A without a
    # product, so that a translated prim's spheres are the numbers the per-point matrices held.
    if not np.array_equal(a, np.eye(3)):
        p = p * np.diag(a) if np.count_nonzero(a - np.diag(np.diag(a))) == 0 else p @ a.T
    if np.any(t):
        p = p + t  # not in place: p may be a view of the attribute's array
    return Points(p, w / 2 if scale == 1.0 else w / 2 * scale, material, path)
