# SPDX-License-Identifier: Apache-2.0
"""Independent per-pixel reference renderer (test-only): numpy, float64, vectorised over rays.

Written from the shading model in docs/concepts/phong-model.md and ``docs/povray-3.7-semantics.md`` (cited as "ref §n"), never
from either backend. Both backends are tested against it. The derivation, formula by formula:

Camera (ref §3). A continuous image position (sx, sy), pixel (i, j) covering [i, i+1)×[j, j+1),
row 0 at the top, maps to u = sx/W − ½, v = ½ − sy/H. The model camera becomes POV-Ray's vectors
(common scale k = 1)::

    R = right·(W/H),  U = up,  D = forward·(W/H)/(2·tan(hfov/2)),   right = forward × up
    perspective:   origin = position,              dir = normalise(D + u·R + v·U)
    orthographic:  origin = position + u·R + v·U,  dir = normalise(forward),
                   with |R| = ortho_width, |U| = ortho_width·H/W

``right = forward × up`` is right-handed: a camera looking down −Z with +Y up sees +X on the
right of the image (ref §3, recipe (b)).

Anti-aliasing (ref §8). samples n = 1: the pixel centre (i+½, j+½). "grid": the n×n
cell-centred grid (i + (a+½)/n, j + (b+½)/n), plain mean. "povray-am1" (``+AM1 +A0.0 +R n -J``):
(centre + Σ grid)/(n²+1), so for odd n the centre counts twice.

Geometry (ref §7). ``Sphere``: the unit sphere under the affine ``world_from_object`` M. The ray
(o, d) is mapped to object space (M⁻¹o, M⁻¹d); the object-space direction is normalised for the
quadratic (half-chord² = 1 − |oc|² + (oc·d̂)² must exceed EPSILON, as POV's sphere requires), and
the roots are divided by |M⁻¹d| so that t is the world distance along the unit world ray. Normal:
(M⁻¹)ᵀ·p_object, normalised. Triangles: Möller–Trumbore in float64, edges inclusive
(u ≥ 0, v ≥ 0, u + v ≤ 1, each with a 1e-12 slack so shared edges are watertight), rejected as parallel when |n̂·d| < EPSILON (ref §6). Flat normal
normalise(e1 × e2); smooth normal = barycentric interpolation of the corner normals (through
``normal_indices``), normalised. The shading normal is flipped to face the viewer: n·d > 0 → −n
(ref §4, §7), so every surface is two-sided.

Tolerances (ref §6), absolute as in POV-Ray: a primary hit needs MIN_ISECT_DEPTH ≤ t < MAX_DISTANCE;
a shadow ray starts exactly at P and an occluder counts for SHADOW_TOLERANCE < t < dist −
SHADOW_TOLERANCE (and t < MAX_DISTANCE); a light with n·l < EPSILON is skipped (no shadow ray).

Lights (ref §5). Point: l = normalise(p − P), dist = |p − P|, colour Lc (no falloff), or with
fade_power > 0: Lc·2/(1 + (dist/fade_distance)^fade_power); falloff "inverse-square" (UsdLux):
Lc/dist², for a rect light × max(0, cos θ) from its emitting side −(A1 × A2). Directional: l = −direction, shadow
ray up to MAX_DISTANCE (the model has no light position, so nothing lies "behind" it). Area lights:
shading exactly like a point light at the centre (including the n·l gate on the centre direction),
times a shadow fraction = Σ w_u·w_v·visible(sample_uv), samples at
centre + ju·A1 + jv·A2 with ju = u/(n−1) − ½, and w the weights of POV's full recursive 4-corner
subdivision (trapezoid (½,1,…,1,½)/(n−1) for n = 2^k + 1; see ``subdivision_weights``).
``RectAreaLight``: A1 = axis_u, A2 = axis_v. ``SphereAreaLight`` = POV's
``area_light <2r,0,0>, <0,2r,0>, n, n circular orient``: ``circular`` uses
ju = u/(n−1) − ½ + 0.001 (same for jv), both scaled by max(|ju|,|jv|)/√(ju² + jv²); ``orient``
per shaded point, with l the unit direction to the centre and t = (0,0,1), or (0,1,0) when
||l_z| − 1| < ORIENT_VERTICAL_TOLERANCE: A1 := normalise(l × t)·|A1|, A2 := normalise(l × A1)·|A1|.
The ambient light is never occluded. A miss returns the background colour (ref §9).

Shading (docs/concepts/phong-model.md; ref §4 and §12), wo = −d, n the viewer-facing normal, for each light with
n·l ≥ EPSILON, scaled by its shadow fraction (0/1 for point and directional lights):

* ``seed`` (Suffern)::

      L = ka·cd·La + Σ_j [kd·cd/π + ks·cs·S_j]·Lj·(n·l_j),   r_j = −l_j + 2(n·l_j)n,
      S_j = (r_j·wo)^e where r_j·wo > 0, else 0 (also for e = 0).

* ``povray-classic`` (= ``finish { ambient ka diffuse kd/π phong ks phong_size e }``, pigment cd,
  light colour Lj)::

      L = ka·cd·La + Σ_j [kd/π·cd·(n·l_j)·Lj + ks·P_j·Lj],   r = d − 2(d·n)n,  k_j = r·l_j,
      P_j = k_j^e where k_j > 0 and ks > 0, except 0 when e ≥ 60 and k_j ≤ 0.0008 (POV's cut-off).

  r·l equals Suffern's r_j·wo (ref §4); the differences are the missing n·l on the highlight and
  the missing cs.

Emission (Suffern's Emissive, ch. 14): L += Le wherever the surface is seen, lit or not. Linking
(UsdLux, model ``Linking``): light j contributes to a hit only when the object hit is in its
light link; with shadows off its fraction is 1 (no shadow ray); otherwise only the objects of its
shadow link occlude it.
Mirror reflection (Suffern ch. 24, PerfectSpecular; ref §18, where POV-Ray's ``reflection`` was
measured to add the same way): at a hit of depth k (camera rays: 0) on a material with kr > 0 and
k < max_depth, L += kr·cr·L(P, r) with r = d − 2(d·n)n, traced from exactly P with the primary
ray's tolerances (MIN_ISECT_DEPTH ≤ t < MAX_DISTANCE; a miss gives the background). Deeper rays
are not traced: they return black (ref §18: ``max_trace_level`` = max_depth + 1).

Transparency (Suffern ch. 27, Transparent::shade; ref §18), at a hit of depth k < max_depth on a
material with kt > 0: the unflipped normal points out of the interior, so the ray is leaving when
it meets the normal from behind (settings.transmission "book"), η = ior entering, 1/ior leaving;
"povray": each ray keeps the list of the interiors it is in (POV-Ray's; objects, not materials),
and η is the ratio of the indices on the two sides by POV-Ray's rules (_reflected; ref §18:
nested and overlapping interiors); with n facing the ray and
cos_i = −d·n, Snell gives cos²θt = 1 − (1 − cos_i²)/η². cos²θt < 0 (total internal reflection):
L += L(P, r) at full weight (no kr term). Otherwise L += kr·cr·L(P, r) + w·L(P, t) with
t = d/η − (cos θt − cos_i/η)·n and w = kt/η² (settings.transmission "book") or kt ("povray").
In the "povray" convention a crossing with |η − 1| < 1e-10 sends t = d at depth k, not k + 1 (POV-Ray's
continued ray uses no trace level); the book counts it.
A ``fresnel`` material (the dielectric, Suffern ch. 28) replaces kr by F·kr and kt by (1 − F)·kt
with F = ½(r_s² + r_p²), r_s = (cos_i − η cos θt)/(cos_i + η cos θt), r_p = (η cos_i − cos θt)/(η
cos_i + cos θt) (cos θt = 0 where Snell has no solution, so F = 1 there).
Beer-Lambert: in the "book" convention a ray travels in one medium, the interior of a transmissive
object or none (the camera's), and its radiance is multiplied by interior_filter^t over the
distance t to its hit (a miss: t = ∞); a refracted ray enters the interior of the surface it
crosses or leaves it for none, a reflected ray keeps its side. In the "povray" one only the
refracted or internally reflected term of a transparent surface is, by that surface's
interior_filter^t when the incoming ray is in its interior (ref §18); a reflected ray keeps its
list. A shadow ray starts with the shaded ray's interiors and, at every transmissive surface it
crosses, is filtered by the surface's interior over the stretch since the last crossing when it
is in it, then leaves that interior or enters it.
Shadow rays in a scene with a transmissive material, in the "povray" transmission convention,
are traced segment by segment (each with the shadow window, from the last crossing): an opaque
hit blocks the light, a transmissive one multiplies it by kt (no refraction). In the "book"
convention every object blocks them (Suffern's Whitted tracer).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from phongscene.scene import (
    CHECKER_SHIFT,
    Camera,
    DirectionalLight,
    PointLight,
    RectAreaLight,
    RenderSettings,
    Scene,
)

# --- POV-Ray 3.7's absolute tolerances (ref §6, configbackend.h / trace.cpp) -----------------
MIN_ISECT_DEPTH = 1e-4  # a primary hit needs t >= this (POV's near clip for every ray)
MAX_DISTANCE = 1e7  # every hit needs t < this
SHADOW_TOLERANCE = 1e-3  # a shadow hit counts only for SHADOW_TOLERANCE < t < dist - SHADOW_TOLERANCE
EPSILON = 1e-10  # n·l gate; sphere half-chord² must exceed it; |n̂·d| below it = ray parallel to a triangle
POVRAY_SAME_IOR = 1e-10  # |η − 1| below it: POV-Ray continues the ray unrefracted, using no trace level (ref §18)

# --- POV-Ray's phong cut-off (ref §4: I = 0 if phong_size >= 60 and k <= 0.0008) ---------------
PHONG_CUTOFF_SIZE = 60.0
PHONG_CUTOFF_K = 0.0008

# --- area_light circular/orient (ref §5; the 0.01 is POV's "too close to vertical" test in trace.cpp)
CIRCULAR_OFFSET = 0.001  # added to ju, jv before the square-to-disc scaling (avoids 0/0 at the centre)
ORIENT_VERTICAL_TOLERANCE = 0.01  # ||l_z| − 1| below this: cross with (0,1,0) instead of (0,0,1)

# --- Implementation limits of this oracle (not POV semantics) ------------------------------------
RAY_TRIANGLE_PAIRS_PER_CHUNK = 200_000  # bounds memory of the rays × triangles Möller–Trumbore arrays
BARYCENTRIC_SLACK = 1e-12  # triangles accept u, v >= −slack and u + v <= 1 + slack: a ray exactly on a
#                            shared edge then hits at least one side despite double rounding (watertight
#                            enough for an oracle); it grows a triangle by 1e-12 of its size, far below
#                            anything a pixel can see
AABB_PAD_RELATIVE = 1e-9  # mesh bounding boxes are padded by this × their scale, so culling never
#                           rejects a hit Möller–Trumbore accepts (its rounding is ~1e-16 relative)


# =============================================================================================
# Camera and sample patterns


def camera_vectors(camera: Camera, width: int, height: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """POV-Ray's (R, U, D) for the model camera (ref §3), scale k = 1."""
    aspect = width / height
    forward = np.asarray(camera.forward, dtype=np.float64)
    up = np.asarray(camera.up, dtype=np.float64)
    right = np.asarray(camera.right, dtype=np.float64)
    if camera.projection == "orthographic":
        return right * camera.ortho_width, up * camera.ortho_width * height / width, forward
    direction = forward * aspect / (2.0 * math.tan(math.radians(camera.horizontal_fov_deg) / 2.0))
    return right * aspect, up, direction


def camera_rays(camera: Camera, width: int, height: int, sx, sy) -> tuple[np.ndarray, np.ndarray]:
    """Rays through continuous image positions (ref §3).

    Args:
        camera: the model camera.
        width, height: image size in pixels.
        sx, sy: arrays of the same shape; pixel (i, j) covers [i, i+1)×[j, j+1), row 0 at the top.

    Returns:
        (origins, directions), each (N, 3) float64 with N = sx.size; directions are unit.
    """
    sx = np.asarray(sx, dtype=np.float64).reshape(-1)
    sy = np.asarray(sy, dtype=np.float64).reshape(-1)
    u = (sx / width - 0.5)[:, None]
    v = (0.5 - sy / height)[:, None]
    r, up, d = camera_vectors(camera, width, height)
    position = np.asarray(camera.position, dtype=np.float64)
    if camera.projection == "orthographic":
        origins = position + u * r + v * up
        directions = np.broadcast_to(d / np.linalg.norm(d), origins.shape).copy()
    else:
        directions = d + u * r + v * up
        directions /= np.linalg.norm(directions, axis=1, keepdims=True)
        origins = np.broadcast_to(position, directions.shape).copy()
    return origins, directions


def pixel_samples(samples: int, pattern: str) -> tuple[np.ndarray, np.ndarray]:
    """Sample offsets inside a pixel and their weights (ref §8).

    Returns:
        (offsets (K, 2) as (dx, dy) from the pixel's top-left corner, weights (K,) summing to 1).
    """
    centre = np.array([[0.5, 0.5]])
    if samples == 1:
        return centre, np.ones(1)
    cells = (np.arange(samples) + 0.5) / samples
    dx, dy = np.meshgrid(cells, cells, indexing="xy")
    grid = np.stack([dx.ravel(), dy.ravel()], axis=1)
    if pattern == "grid":
        return grid, np.full(len(grid), 1.0 / len(grid))
    if pattern == "povray-am1":
        offsets = np.concatenate([centre, grid])
        return offsets, np.full(len(offsets), 1.0 / len(offsets))
    raise ValueError(f"unknown sample pattern {pattern!r}")


def subdivision_weights(n: int) -> np.ndarray:
    """Per-axis weights of POV-Ray's full recursive 4-corner area-light subdivision (ref §5).

    A region [lo, hi] of more than one step splits into [lo, ⌊mid⌋] and [⌈mid⌉, hi], each worth
    half; a region of at most one step is the mean of its two end samples. In 2-D the split is
    simultaneous on both axes and a one-step axis splitting again gives the same (½, ½), so the
    2-D weights are the outer product of these. For n = 2^k + 1 this is the trapezoid rule
    (½, 1, …, 1, ½)/(n − 1).
    """
    weights = np.zeros(n)

    def split(lo: int, hi: int, share: float) -> None:
        if hi - lo <= 1:
            weights[lo] += share / 2
            weights[hi] += share / 2
            return
        mid = (lo + hi) / 2
        split(lo, math.floor(mid), share / 2)
        split(math.ceil(mid), hi, share / 2)

    split(0, n - 1, 1.0)
    return weights


def _area_grid(n: int, circular: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(ju, jv, weight) for every sample of an n×n area-light grid (ref §5)."""
    steps = np.arange(n, dtype=np.float64)
    j = steps / (n - 1) - 0.5 if n > 1 else np.zeros(1)
    ju, jv = np.meshgrid(j, j, indexing="ij")
    ju, jv = ju.ravel(), jv.ravel()
    if circular and n > 1:
        ju = ju + CIRCULAR_OFFSET
        jv = jv + CIRCULAR_OFFSET
        scale = np.maximum(np.abs(ju), np.abs(jv)) / np.sqrt(ju * ju + jv * jv)
        ju, jv = ju * scale, jv * scale
    w = subdivision_weights(n)
    return ju, jv, np.outer(w, w).ravel()


def area_light_offsets(light, to_light: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sample offsets from the light's centre, per shaded point, and their weights (ref §5).

    Args:
        light: a RectAreaLight or SphereAreaLight.
        to_light: (N, 3) unit directions from the shaded points to the light's centre (``orient``).

    Returns:
        (offsets (N, K, 3), weights (K,)).
    """
    n_points = len(to_light)
    if isinstance(light, RectAreaLight):
        ju, jv, w = _area_grid(light.samples, circular=False)
        a1 = np.asarray(light.axis_u, dtype=np.float64)
        a2 = np.asarray(light.axis_v, dtype=np.float64)
        offsets = ju[:, None] * a1 + jv[:, None] * a2
        return np.broadcast_to(offsets, (n_points, *offsets.shape)), w
    # SphereAreaLight: area_light <2r,0,0>, <0,2r,0>, n, n circular orient.
    ju, jv, w = _area_grid(light.samples, circular=True)
    length = 2.0 * light.radius  # |A1|; orient gives both axes this length
    near_vertical = np.abs(np.abs(to_light[:, 2]) - 1.0) < ORIENT_VERTICAL_TOLERANCE
    helper = np.where(near_vertical[:, None], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0])
    a1 = np.cross(to_light, helper)
    a1 /= np.linalg.norm(a1, axis=1, keepdims=True)
    a2 = np.cross(to_light, a1)
    a2 /= np.linalg.norm(a2, axis=1, keepdims=True)
    a1, a2 = a1 * length, a2 * length
    offsets = ju[None, :, None] * a1[:, None, :] + jv[None, :, None] * a2[:, None, :]
    return offsets, w


# =============================================================================================
# Geometry


@dataclass
class _Mesh:
    p0: np.ndarray  # (T, 3)
    e1: np.ndarray  # (T, 3) p1 − p0
    e2: np.ndarray  # (T, 3) p2 − p0
    cross_len: np.ndarray  # (T,) |e1 × e2| (twice the area)
    flat_normal: np.ndarray  # (T, 3) unit
    corner_normals: np.ndarray | None  # (T, 3, 3) unit, or None for flat shading
    material: int
    lo: np.ndarray  # padded bounds
    hi: np.ndarray
    corner_uv: np.ndarray | None = None  # (T, 3, 2) when the material is textured
    texture: object = None  # the material's diffuse Texture
    specular_texture: object = None  # ... and specular Texture
    source: str = ""  # the mesh's prim (light and shadow linking)
    normal_texture: object = None  # the material's tangent-space normal map
    opacity_texture: object = None  # the material's cut-out mask (its first channel) ...
    opacity_threshold: float = 0.0  # ... below which the surface is not there


def normal_mapped(n: np.ndarray, e1: np.ndarray, e2: np.ndarray, uv: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The unit normals ``n`` (K, 3) perturbed by tangent-space texels ``t`` (K, 3), written from
    the definition: the triangle's (dP/du, dP/dv) solve [e1 e2] = [dP/du dP/dv] · J for the uv
    Jacobian J = [[u1 − u0, u2 − u0], [v1 − v0, v2 − v0]] (uv (K, 3, 2) per corner), then T, B by
    Gram-Schmidt against n, and the normal is normalize(t.x T + t.y B + t.z n)."""
    jacobian = np.stack([uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]], axis=2)  # (K, 2 rows u/v, 2 cols e1/e2)
    edges = np.stack([e1, e2], axis=2)  # (K, 3, 2)
    partials = edges @ np.linalg.inv(jacobian)  # (K, 3, 2): columns dP/du, dP/dv
    dpdu, dpdv = partials[:, :, 0], partials[:, :, 1]

    def unit(x):
        return x / np.linalg.norm(x, axis=1, keepdims=True)

    dot = lambda a, b: np.einsum("ij,ij->i", a, b)[:, None]  # noqa: E731
    tangent = unit(dpdu - dot(n, dpdu) * n)
    bitangent = unit(dpdv - dot(n, dpdv) * n - dot(tangent, dpdv) * tangent)
    return unit(t[:, :1] * tangent + t[:, 1:2] * bitangent + t[:, 2:] * n)


# numpy's pad mode for each wrap rule: the image extended beyond its edges is exactly what the
# rule samples there (np.pad "symmetric" repeats the edge texel: mirror about the image edge).
_PAD_MODES = {"repeat": "wrap", "clamp": "edge", "mirror": "symmetric", "black": "constant"}


def sample_texture(texture, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The texture at (u, v), written independently of both backends: the image is padded
    (numpy's pad, by each axis's wrap rule) far enough to cover every (u, v), then bilinearly
    interpolated between texel centres (texel (i, j) at u = (i + ½)/W, v = 1 − (j + ½)/H)."""
    image = np.asarray(texture.image, dtype=np.float64)
    h, w = image.shape[:2]
    x = np.asarray(u, dtype=np.float64) * w - 0.5
    y = (1.0 - np.asarray(v, dtype=np.float64)) * h - 0.5
    if x.size == 0:
        return np.zeros((0, 3))
    x0, y0 = np.floor(x).astype(np.int64), np.floor(y).astype(np.int64)
    px = (max(0, -int(x0.min())), max(0, int(x0.max()) + 2 - w))
    py = (max(0, -int(y0.min())), max(0, int(y0.max()) + 2 - h))
    padded = image
    for axis, pads, wrap in ((1, px, texture.wrap_s), (0, py, texture.wrap_t)):
        widths = [(0, 0)] * 3
        widths[axis] = pads
        padded = np.pad(padded, widths, mode=_PAD_MODES[wrap])
    xi, yi = x0 + px[0], y0 + py[0]
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    return (padded[yi, xi] * (1 - fx) + padded[yi, xi + 1] * fx) * (1 - fy) + (
        padded[yi + 1, xi] * (1 - fx) + padded[yi + 1, xi + 1] * fx
    ) * fy


@dataclass
class _Geometry:
    sphere_object_from_world: list[np.ndarray]
    sphere_normal_matrix: list[np.ndarray]  # (M⁻¹)ᵀ, 3×3
    sphere_material: list[int]
    meshes: list[_Mesh]
    ka: np.ndarray
    kd: np.ndarray
    ks: np.ndarray
    exponent: np.ndarray
    cd: np.ndarray
    cs: np.ndarray
    emission: np.ndarray  # (materials, 3) Le
    sphere_source: list[str]  # each sphere's prim (light and shadow linking)
    intrinsics: list  # the model's Intrinsic nodes
    intrinsic_material: list[int]
    kr: np.ndarray  # mirror reflection, per material
    cr: np.ndarray
    kt: np.ndarray  # transparency, per material
    ior: np.ndarray
    fresnel: np.ndarray  # bool
    interior_filter: np.ndarray  # (M, 3)
    checker_size: np.ndarray  # (M,) the book's Checker3D cell size; 0: none
    checker_color: np.ndarray  # (M, 3) its second colour
    checker_plane: np.ndarray  # (M,) bool: the book's PlaneChecker instead
    checker_outline_width: np.ndarray  # (M,)
    checker_outline_color: np.ndarray  # (M, 3)

    def medium_transmittance(self, medium: np.ndarray, distance: np.ndarray) -> np.ndarray:
        """interior_filter[medium]^distance per ray, 1 where medium < 0 (none). (N, 3)."""
        out = np.ones((len(medium), 3))
        inside = medium >= 0
        if inside.any():
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                out[inside] = np.power(self.interior_filter[medium[inside]], distance[inside, None])
        return out

    @property
    def transmissive(self) -> bool:
        return bool(np.any(self.kt > 0.0))

    @property
    def cut_outs(self) -> bool:
        return any(m.opacity_texture is not None for m in self.meshes)


def _prepare(scene: Scene) -> _Geometry:
    materials: list = []

    def material_index(m) -> int:
        materials.append(m)
        return len(materials) - 1

    inverses, normal_matrices, sphere_materials = [], [], []
    for sphere in scene.spheres:
        inverse = np.linalg.inv(sphere.world_from_object)
        inverses.append(inverse)
        normal_matrices.append(inverse[:3, :3].T)
        sphere_materials.append(material_index(sphere.material))
    meshes = []
    for mesh in scene.meshes:
        if len(mesh.triangles) == 0:
            continue
        corners = mesh.points[mesh.triangles]
        p0 = corners[:, 0]
        e1 = corners[:, 1] - p0
        e2 = corners[:, 2] - p0
        cross = np.cross(e1, e2)
        cross_len = np.linalg.norm(cross, axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):  # zero-area triangles never hit (below)
            flat = cross / cross_len[:, None]
        corner_normals = None if mesh.normals is None else mesh.normals[mesh.normal_indices]
        lo, hi = mesh.points.min(axis=0), mesh.points.max(axis=0)
        pad = AABB_PAD_RELATIVE * (1.0 + float(np.abs(mesh.points).max()))
        texture, specular = mesh.material.diffuse_texture, mesh.material.specular_texture
        normal_map = mesh.material.normal_texture
        corner_uv = None if not mesh.material.textures else mesh.uvs[mesh.uv_indices]
        meshes.append(
            _Mesh(
                p0,
                e1,
                e2,
                cross_len,
                flat,
                corner_normals,
                material_index(mesh.material),
                lo - pad,
                hi + pad,
                corner_uv,
                texture,
                specular,
                mesh.source,
                normal_map,
                mesh.material.opacity_texture,
                float(mesh.material.opacity_threshold),
            )
        )
    intrinsic_materials = [material_index(i.material) for i in scene.intrinsics]
    return _Geometry(
        inverses,
        normal_matrices,
        sphere_materials,
        meshes,
        ka=np.array([m.ka for m in materials], dtype=np.float64),
        kd=np.array([m.kd for m in materials], dtype=np.float64),
        ks=np.array([m.ks for m in materials], dtype=np.float64),
        exponent=np.array([m.exponent for m in materials], dtype=np.float64),
        cd=np.array([m.diffuse_color for m in materials], dtype=np.float64).reshape(-1, 3),
        cs=np.array([m.specular_color for m in materials], dtype=np.float64).reshape(-1, 3),
        emission=np.array([m.emission for m in materials], dtype=np.float64).reshape(-1, 3),
        sphere_source=[sphere.source for sphere in scene.spheres],
        intrinsics=list(scene.intrinsics),
        intrinsic_material=intrinsic_materials,
        kr=np.array([m.kr for m in materials], dtype=np.float64),
        cr=np.array([m.reflective_color for m in materials], dtype=np.float64).reshape(-1, 3),
        kt=np.array([m.kt for m in materials], dtype=np.float64),
        ior=np.array([m.ior for m in materials], dtype=np.float64),
        fresnel=np.array([bool(m.fresnel) for m in materials], dtype=bool),
        interior_filter=np.array([m.interior_filter for m in materials], dtype=np.float64).reshape(-1, 3),
        checker_size=np.array([m.checker_size for m in materials], dtype=np.float64),
        checker_color=np.array([m.checker_color for m in materials], dtype=np.float64).reshape(-1, 3),
        checker_plane=np.array([bool(m.checker_plane) for m in materials], dtype=bool),
        checker_outline_width=np.array([m.checker_outline_width for m in materials], dtype=np.float64),
        checker_outline_color=np.array([m.checker_outline_color for m in materials], dtype=np.float64).reshape(-1, 3),
    )


def _sphere_roots(inverse: np.ndarray, o: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World-distance roots (near, far) of unit rays against a transformed unit sphere, and a hit mask."""
    oo = o @ inverse[:3, :3].T + inverse[:3, 3]
    do = d @ inverse[:3, :3].T
    length = np.linalg.norm(do, axis=1)
    dn = do / length[:, None]
    # Closest approach to the centre along the normalised object ray; half-chord² > EPSILON (ref §7).
    oc = -oo
    closest = np.einsum("ij,ij->i", oc, dn)
    half_chord_sq = 1.0 - (np.einsum("ij,ij->i", oc, oc) - closest * closest)
    hit = half_chord_sq > EPSILON
    half_chord = np.sqrt(np.where(hit, half_chord_sq, 0.0))
    return (closest - half_chord) / length, (closest + half_chord) / length, hit


def _ray_aabb(o: np.ndarray, d: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Rays whose line meets the box at some t >= 0 (a conservative cull)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / d
        t0 = (lo - o) * inv
        t1 = (hi - o) * inv
    near = np.minimum(t0, t1)
    far = np.maximum(t0, t1)
    # An axis the ray is parallel to: either always inside the slab or never.
    parallel = d == 0.0
    inside = (o >= lo) & (o <= hi)
    near = np.where(parallel, np.where(inside, -np.inf, np.inf), near)
    far = np.where(parallel, np.where(inside, np.inf, -np.inf), far)
    t_near, t_far = near.max(axis=1), far.min(axis=1)
    return (t_near <= t_far) & (t_far >= 0.0)


def _mesh_hits(
    mesh: _Mesh, o: np.ndarray, d: np.ndarray, accept
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Nearest accepted triangle hit per ray: (t, triangle, u, v); t = inf where none."""
    n = len(o)
    best_t = np.full(n, np.inf)
    best_tri = np.zeros(n, dtype=np.int64)
    best_u = np.zeros(n)
    best_v = np.zeros(n)
    candidates = np.nonzero(_ray_aabb(o, d, mesh.lo, mesh.hi))[0]
    tris = len(mesh.p0)
    chunk = max(1, RAY_TRIANGLE_PAIRS_PER_CHUNK // tris)
    for start in range(0, len(candidates), chunk):
        rows = candidates[start : start + chunk]
        ro, rd = o[rows][:, None, :], d[rows][:, None, :]
        # Möller–Trumbore: P = p0 + u·e1 + v·e2.
        pvec = np.cross(rd, mesh.e2)
        det = np.einsum("rtk,tk->rt", pvec, mesh.e1)
        # |det| = |d·(e1×e2)| = |n̂·d|·|e1×e2|: parallel when |n̂·d| < EPSILON (ref §6).
        usable = np.abs(det) >= EPSILON * mesh.cross_len
        usable &= mesh.cross_len > 0.0
        inv_det = 1.0 / np.where(usable, det, 1.0)
        tvec = ro - mesh.p0
        u = np.einsum("rtk,rtk->rt", tvec, pvec) * inv_det
        qvec = np.cross(tvec, mesh.e1)
        v = np.einsum("rtk,rtk->rt", np.broadcast_to(rd, qvec.shape), qvec) * inv_det
        t = np.einsum("rtk,tk->rt", qvec, mesh.e2) * inv_det
        inside = (u >= -BARYCENTRIC_SLACK) & (v >= -BARYCENTRIC_SLACK) & (u + v <= 1.0 + BARYCENTRIC_SLACK)
        ok = usable & inside & accept(t, rows[:, None])
        t = np.where(ok, t, np.inf)
        nearest = np.argmin(t, axis=1)
        pick = np.arange(len(rows))
        best_t[rows] = t[pick, nearest]
        best_tri[rows] = nearest
        best_u[rows] = u[pick, nearest]
        best_v[rows] = v[pick, nearest]
    return best_t, best_tri, best_u, best_v


def _first_accepted(candidates, accept) -> tuple[np.ndarray, np.ndarray]:
    """The nearest accepted (t, object-space normal) over a list of candidate (t, normal) pairs."""
    n = len(candidates[0][0]) if candidates else 0
    best = np.full(n, np.inf)
    normal = np.zeros((n, 3))
    for t, nrm in candidates:
        t = np.where(np.isfinite(t), t, np.inf)
        ok = accept(t, None) & (t < best)
        best[ok] = t[ok]
        normal[ok] = nrm[ok]
    return best, normal


def _intrinsic_candidates(intrinsic, o: np.ndarray, d: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """Every root of the intrinsic prim's surfaces along object-space rays (o, d), d not unit so
    that t is the world distance: (t or nan, the object-space normal there). Written from the
    model's definitions (``Intrinsic``), with the textbook formulas."""
    kind = intrinsic.kind
    out = []
    with np.errstate(divide="ignore", invalid="ignore"):
        if kind == "cube":
            for axis in range(3):
                for side in (-1.0, 1.0):
                    t = (side - o[:, axis]) / d[:, axis]
                    p = o + t[:, None] * d
                    others = [k for k in range(3) if k != axis]
                    inside = np.all(np.abs(p[:, others]) <= 1.0, axis=1)
                    normal = np.zeros_like(o)
                    normal[:, axis] = side
                    out.append((np.where(inside, t, np.nan), normal))
            return out
        if kind == "plane":
            t = -o[:, 2] / d[:, 2]
            p = o + t[:, None] * d
            inside = np.ones(len(o), bool) if intrinsic.infinite else (np.abs(p[:, 0]) <= 1) & (np.abs(p[:, 1]) <= 1)
            return [(np.where(inside, t, np.nan), np.tile([0.0, 0.0, 1.0], (len(o), 1)))]

        def side(r0, r1, z_lo, z_hi):
            # x² + y² = (a + b z)², the radius r0 at z_lo and r1 at z_hi.
            b = (r1 - r0) / (z_hi - z_lo)
            a = r0 - b * z_lo
            qa = d[:, 0] ** 2 + d[:, 1] ** 2 - (b * d[:, 2]) ** 2
            qb = 2 * (o[:, 0] * d[:, 0] + o[:, 1] * d[:, 1] - b * d[:, 2] * (a + b * o[:, 2]))
            qc = o[:, 0] ** 2 + o[:, 1] ** 2 - (a + b * o[:, 2]) ** 2
            root = np.sqrt(qb * qb - 4 * qa * qc)
            for t in ((-qb - root) / (2 * qa), (-qb + root) / (2 * qa)):
                p = o + t[:, None] * d
                ok = (p[:, 2] >= z_lo) & (p[:, 2] <= z_hi) & (a + b * p[:, 2] >= 0)
                normal = np.stack([p[:, 0], p[:, 1], -b * (a + b * p[:, 2])], axis=1)
                out.append((np.where(ok, t, np.nan), normal))

        def disc(r, z):
            t = (z - o[:, 2]) / d[:, 2]
            p = o + t[:, None] * d
            ok = p[:, 0] ** 2 + p[:, 1] ** 2 <= r * r
            out.append((np.where(ok, t, np.nan), np.tile([0.0, 0.0, 1.0], (len(o), 1))))

        def ball(centre_z, r):
            c = o - np.array([0.0, 0.0, centre_z])
            qa = np.einsum("ij,ij->i", d, d)
            qb = 2 * np.einsum("ij,ij->i", c, d)
            qc = np.einsum("ij,ij->i", c, c) - r * r
            root = np.sqrt(qb * qb - 4 * qa * qc)
            for t in ((-qb - root) / (2 * qa), (-qb + root) / (2 * qa)):
                out.append((t, c + t[:, None] * d))

        if kind == "cylinder":
            side(intrinsic.radius_bottom, intrinsic.radius_top, -1.0, 1.0)
            disc(intrinsic.radius_bottom, -1.0)
            disc(intrinsic.radius_top, 1.0)
        else:  # capsule: the side, and the spheres tangent to it at its ends
            rb, rt, h = intrinsic.radius_bottom, intrinsic.radius_top, intrinsic.half_height
            if h > 0:
                side(rb, rt, -h, h)
                # The side leans by α from the axis: a sphere touching it along the circle of
                # radius r at z sits r·tan α further from the narrow end, radius r / cos α.
                lean = math.atan2(rb - rt, 2 * h)
                for r, z in ((rb, -h), (rt, h)):
                    if r > 0:
                        ball(z - r * math.tan(lean), r / math.cos(lean))
            else:
                ball(0.0, max(rb, rt))
    return out


def _intrinsic_hits(intrinsic, o: np.ndarray, d: np.ndarray, accept) -> tuple[np.ndarray, np.ndarray]:
    """(nearest accepted world t, unit world normal) of world rays (o, unit d) against an intrinsic."""
    inverse = np.linalg.inv(intrinsic.world_from_object)
    oo = o @ inverse[:3, :3].T + inverse[:3, 3]
    do = d @ inverse[:3, :3].T
    t, normal = _first_accepted(_intrinsic_candidates(intrinsic, oo, do), accept)
    nw = normal @ inverse[:3, :3]  # (M⁻¹)ᵀ n, row-wise
    with np.errstate(invalid="ignore", divide="ignore"):
        nw = nw / np.linalg.norm(nw, axis=1, keepdims=True)
    return t, nw


def _closest_hit(geo: _Geometry, o: np.ndarray, d: np.ndarray, accept=None):
    """Nearest hit with MIN_ISECT_DEPTH <= t < MAX_DISTANCE (or as ``accept(t, rows)`` says):
    (t, material, unflipped normal, cd and cs at the hit: the material's, or its textures' at the
    hit's uv, the prim of the object hit, and the object: _object_id); t = inf on a miss."""
    n = len(o)
    source = np.full(n, "", dtype=object)
    obj = np.full(n, -1, dtype=np.int64)
    cut = np.zeros(n, dtype=bool)  # the hit is on a cut-out texel (the surface is not there)
    best_t = np.full(n, np.inf)
    material = np.full(n, -1, dtype=np.int64)
    normal = np.zeros((n, 3))
    colour = np.zeros((n, 3))
    specular = np.zeros((n, 3))

    if accept is None:

        def accept(t, _rows):
            return (t >= MIN_ISECT_DEPTH) & (t < MAX_DISTANCE)

    for k, (inverse, normal_matrix, mat, sphere_source) in enumerate(
        zip(geo.sphere_object_from_world, geo.sphere_normal_matrix, geo.sphere_material, geo.sphere_source)
    ):
        near, far, hit = _sphere_roots(inverse, o, d)
        t = np.where(hit & accept(near, None), near, np.where(hit & accept(far, None), far, np.inf))
        closer = t < best_t
        if not closer.any():
            continue
        best_t[closer] = t[closer]
        material[closer] = mat
        source[closer] = sphere_source
        obj[closer] = _object_id("sphere", k)
        cut[closer] = False
        colour[closer] = geo.cd[mat]
        specular[closer] = geo.cs[mat]
        p_object = (o[closer] + t[closer, None] * d[closer]) @ inverse[:3, :3].T + inverse[:3, 3]
        nw = p_object @ normal_matrix.T
        normal[closer] = nw / np.linalg.norm(nw, axis=1, keepdims=True)
    for k, mesh in enumerate(geo.meshes):
        t, tri, u, v = _mesh_hits(mesh, o, d, accept)
        closer = t < best_t
        if not closer.any():
            continue
        best_t[closer] = t[closer]
        material[closer] = mesh.material
        source[closer] = mesh.source
        obj[closer] = _object_id("mesh", k)
        tri, u, v = tri[closer], u[closer], v[closer]
        cut[closer] = False
        colour[closer] = geo.cd[mesh.material]
        specular[closer] = geo.cs[mesh.material]
        if mesh.corner_uv is not None:
            uv = mesh.corner_uv[tri]
            st = (1.0 - u - v)[:, None] * uv[:, 0] + u[:, None] * uv[:, 1] + v[:, None] * uv[:, 2]
            if mesh.texture is not None:
                colour[closer] = sample_texture(mesh.texture, st[:, 0], st[:, 1])
            if mesh.specular_texture is not None:
                specular[closer] = sample_texture(mesh.specular_texture, st[:, 0], st[:, 1])
            if mesh.opacity_texture is not None:
                opacity = sample_texture(mesh.opacity_texture, st[:, 0], st[:, 1])[:, 0]
                cut[closer] = opacity < mesh.opacity_threshold
        if mesh.corner_normals is None:
            nw = mesh.flat_normal[tri]
        else:
            c = mesh.corner_normals[tri]
            nw = (1.0 - u - v)[:, None] * c[:, 0] + u[:, None] * c[:, 1] + v[:, None] * c[:, 2]
            nw = nw / np.linalg.norm(nw, axis=1, keepdims=True)
        if mesh.normal_texture is not None:
            # (The side a ray meets is then the perturbed normal's: scenes here tilt it less than
            # the view, so it is the surface's too, as the native tracer decides it.)
            texel = sample_texture(mesh.normal_texture, st[:, 0], st[:, 1])
            nw = normal_mapped(nw, mesh.e1[tri], mesh.e2[tri], mesh.corner_uv[tri], texel)
        normal[closer] = nw
    for k, (intrinsic, mat) in enumerate(zip(geo.intrinsics, geo.intrinsic_material)):
        t, nw = _intrinsic_hits(intrinsic, o, d, accept)
        closer = t < best_t
        best_t[closer] = t[closer]
        material[closer] = mat
        colour[closer] = geo.cd[mat]
        specular[closer] = geo.cs[mat]
        source[closer] = intrinsic.source
        obj[closer] = _object_id("intrinsic", k)
        cut[closer] = False
        normal[closer] = nw[closer]
    _checker_colours(geo, o, d, best_t, material, colour)
    return best_t, material, normal, colour, specular, source, obj, cut


_OBJECT_KINDS = ("sphere", "mesh", "intrinsic")
_OBJECTS_PER_KIND = 1 << 32


def _object_id(kind: str, k: int) -> int:
    """An object's identity (its interior's, POV-Ray's interior list): the k-th of its kind."""
    return _OBJECT_KINDS.index(kind) * _OBJECTS_PER_KIND + k


# --- A ray's interiors (POV-Ray's interior list; ref §18) ---------------------------------------
# Per ray, up to MAX_INTERIORS (object, material) pairs, innermost last, -1 in the free slots: the
# objects it has entered and not left. The "book" convention keeps at most one.
MAX_INTERIORS = 16  # the native tracer's bound (interiors.hpp); no scene here nests deeper


def no_interiors(n: int) -> np.ndarray:
    return np.full((n, MAX_INTERIORS, 2), -1, dtype=np.int64)


def _interior_count(inside: np.ndarray) -> np.ndarray:
    return (inside[:, :, 0] >= 0).sum(axis=1)


def _innermost(inside: np.ndarray) -> np.ndarray:
    """The innermost (object, material) per ray, (-1, -1) outside every object. (N, 2)."""
    last = np.maximum(_interior_count(inside) - 1, 0)
    out = inside[np.arange(len(inside)), last].copy()
    out[_interior_count(inside) == 0] = -1
    return out


def _contains(inside: np.ndarray, obj: np.ndarray) -> np.ndarray:
    return np.any(inside[:, :, 0] == obj[:, None], axis=1)


def _removed(inside: np.ndarray, obj: np.ndarray) -> np.ndarray:
    """``inside`` without ``obj`` per ray (order kept)."""
    out = no_interiors(len(inside))
    for r in range(len(inside)):
        kept = [e for e in inside[r] if e[0] >= 0 and e[0] != obj[r]]
        if kept:
            out[r, : len(kept)] = kept
    return out


def _appended(inside: np.ndarray, obj: np.ndarray, material: np.ndarray) -> np.ndarray:
    out = inside.copy()
    count = _interior_count(inside)
    room = count < MAX_INTERIORS
    rows = np.nonzero(room)[0]
    out[rows, count[rows], 0] = obj[rows]
    out[rows, count[rows], 1] = material[rows]
    return out


def _checker_colours(geo: _Geometry, o, d, t, material, colour) -> None:
    """Where a hit's material is the book's Checker3D, its cd in ``colour``: diffuse_color or
    checker_color by the parity of the summed cells floor((p + ε)/s) of the world point, a sum
    beyond 32 bits counting as even (POV-Ray's int cast; the native tracer's rule)."""
    hit = np.flatnonzero(np.isfinite(t))
    hit = hit[geo.checker_size[material[hit]] > 0]
    if not len(hit):
        return
    m = material[hit]
    p = o[hit] + t[hit, None] * d[hit]
    cells = np.floor((p + CHECKER_SHIFT) / geo.checker_size[m][:, None]).sum(axis=1)
    odd = (np.abs(cells) < 2.0**31) & (np.mod(cells, 2.0) == 1.0)
    colour[hit] = np.where(odd[:, None], geo.checker_color[m], geo.cd[m])
    # The book's PlaneChecker, in its float arithmetic (Textures/PlaneChecker.cpp: x, z, x/s, the
    # fractions and the half width stored as float; 1 − w a double).
    plane = geo.checker_plane[m]
    if plane.any():
        rows, mp = hit[plane], m[plane]
        s = geo.checker_size[mp].astype(np.float32)
        x, z = p[plane, 0].astype(np.float32), p[plane, 2].astype(np.float32)
        ix, iz = np.floor(x / s), np.floor(z / s)
        fx, fz = x / s - ix, z / s - iz
        w = (0.5 * geo.checker_outline_width[mp].astype(np.float32).astype(np.float64) / s).astype(np.float32)
        outline = (fx < w) | (fx > 1.0 - w.astype(np.float64)) | (fz < w) | (fz > 1.0 - w.astype(np.float64))
        odd_cell = np.mod(ix.astype(np.float64) + iz.astype(np.float64), 2.0) != 0.0
        cd = np.where(odd_cell[:, None], geo.checker_color[mp], geo.cd[mp])
        colour[rows] = np.where(outline[:, None], geo.checker_outline_color[mp], cd)


def _occluded(geo: _Geometry, p: np.ndarray, l: np.ndarray, dist: np.ndarray, casts=None) -> np.ndarray:
    """Shadow test from exactly P along unit l: any hit with SHADOW_TOLERANCE < t < dist − SHADOW_TOLERANCE (ref §6),
    by the objects whose prim ``casts(source)`` accepts (a light's shadow link; None: all)."""
    upper = np.minimum(dist - SHADOW_TOLERANCE, MAX_DISTANCE)
    blocked = np.zeros(len(p), dtype=bool)

    def accept(t, rows):
        hi = upper if rows is None else upper[rows]
        return (t > SHADOW_TOLERANCE) & (t < hi)

    for inverse, source in zip(geo.sphere_object_from_world, geo.sphere_source):
        if casts is not None and not casts(source):
            continue
        near, far, hit = _sphere_roots(inverse, p, l)
        blocked |= hit & (accept(near, None) | accept(far, None))
    for intrinsic in geo.intrinsics:
        if casts is not None and not casts(intrinsic.source):
            continue
        t, _ = _intrinsic_hits(intrinsic, p, l, accept)
        blocked |= np.isfinite(t)
    for mesh in geo.meshes:
        if casts is not None and not casts(mesh.source):
            continue
        todo = np.nonzero(~blocked)[0]
        if len(todo) == 0:
            break
        upper_todo = upper[todo]

        def accept_todo(t, rows, upper_todo=upper_todo):
            return (t > SHADOW_TOLERANCE) & (t < upper_todo[rows])

        t, _, _, _ = _mesh_hits(mesh, p[todo], l[todo], accept_todo)
        blocked[todo] |= np.isfinite(t)
    return blocked


# =============================================================================================
# Lights and shading


def classic_phong_factor(k: np.ndarray, exponent: np.ndarray) -> np.ndarray:
    """POV-Ray's phong factor k^phong_size for k > 0, with its ``phong_size >= 60 and k <= 0.0008`` cut-off (ref §4)."""
    k = np.asarray(k, dtype=np.float64)
    exponent = np.broadcast_to(np.asarray(exponent, dtype=np.float64), k.shape)
    value = np.power(np.where(k > 0.0, k, 1.0), exponent)
    cut = (exponent >= PHONG_CUTOFF_SIZE) & (k <= PHONG_CUTOFF_K)
    return np.where((k > 0.0) & ~cut, value, 0.0)


def _light_at_centre(light, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(unit l, distance, colour Lc per point) for shading (ref §5); area lights act from their centre."""
    colour = np.asarray(light.color, dtype=np.float64)
    if isinstance(light, DirectionalLight):
        direction = np.asarray(light.direction, dtype=np.float64)
        l = np.broadcast_to(-direction / np.linalg.norm(direction), p.shape)
        return l, np.full(len(p), MAX_DISTANCE), np.broadcast_to(colour, p.shape)
    position = np.asarray(light.position if isinstance(light, PointLight) else light.center, dtype=np.float64)
    to_light = position - p
    dist = np.linalg.norm(to_light, axis=1)
    l = to_light / dist[:, None]
    lc = np.broadcast_to(colour, p.shape)
    if isinstance(light, PointLight) and light.fade_power > 0.0 and light.fade_distance != 0.0:
        fade = 2.0 / (1.0 + (dist / light.fade_distance) ** light.fade_power)
        lc = lc * fade[:, None]
    if light.falloff == "inverse-square":
        # UsdLux: colour is the radiant intensity; a rect light is a one-sided Lambertian panel
        # emitting along −(axis_u × axis_v), seen from afar: I·cos θ / d².
        factor = 1.0 / dist**2
        if isinstance(light, RectAreaLight):
            emit = -np.cross(light.axis_u, light.axis_v)
            cos_light = (-l) @ (emit / np.linalg.norm(emit))
            factor = factor * np.maximum(cos_light, 0.0)
        lc = lc * factor[:, None]
    if isinstance(light, PointLight) and light.cone is not None:
        cone = light.cone
        c = (-l) @ np.asarray(cone.axis, dtype=np.float64)
        span = cone.cos_inner - cone.cos_outer
        t = np.clip((c - cone.cos_outer) / span, 0.0, 1.0) if span > 0 else (c > cone.cos_outer).astype(np.float64)
        focus = np.power(np.maximum(c, 0.0), cone.focus) if cone.focus > 0 else 1.0  # cos θ^focus
        lc = lc * (t * t * (3.0 - 2.0 * t) * focus)[:, None]
    return l, dist, lc


def _visible_fraction(geo: _Geometry, light, p: np.ndarray, l: np.ndarray, dist: np.ndarray) -> np.ndarray:
    """Shadow factor in [0, 1]: 0/1 for point and directional lights, the weighted grid for area lights;
    1 where the light casts no shadows (UsdLux shadow:enable off), and only the objects of its
    shadow link occlude."""
    linking = light.linking
    if not linking.shadows:
        return np.ones(len(p))
    casts = None if linking.shadowed_by is None else linking.shadowed_by.__contains__
    if isinstance(light, (PointLight, DirectionalLight)):
        return (~_occluded(geo, p, l, dist, casts)).astype(np.float64)
    offsets, weights = area_light_offsets(light, l)
    centre = np.asarray(light.center, dtype=np.float64)
    targets = centre + offsets  # (N, K, 3)
    to_sample = targets - p[:, None, :]
    sample_dist = np.linalg.norm(to_sample, axis=2)
    directions = to_sample / sample_dist[..., None]
    n, k = sample_dist.shape
    points = np.broadcast_to(p[:, None, :], (n, k, 3)).reshape(-1, 3)
    blocked = _occluded(geo, points, directions.reshape(-1, 3), sample_dist.reshape(-1), casts).reshape(n, k)
    return (~blocked).astype(np.float64) @ weights


def _shade(
    geo: _Geometry,
    scene: Scene,
    settings: RenderSettings,
    p,
    d,
    normal,
    material,
    cd,
    cs,
    source,
    inside: np.ndarray | None = None,
) -> np.ndarray:
    n = np.where((np.einsum("ij,ij->i", normal, d) > 0.0)[:, None], -normal, normal)  # face the viewer
    if settings.transmission == "book":
        # The book lights a transparent surface with its unflipped (outward) normal, also seen
        # from inside (Suffern's Sphere::hit, Phong::shade): a light outside can reach it there.
        n = np.where((geo.kt[material] > 0.0)[:, None], normal, n)
    wo = -d
    ka, kd, ks, e = geo.ka[material], geo.kd[material], geo.ks[material], geo.exponent[material]
    radiance = ka[:, None] * cd * np.asarray(scene.ambient.color, dtype=np.float64) + geo.emission[material]
    for light in scene.lights:
        l, dist, lc = _light_at_centre(light, p)
        n_dot_l = np.einsum("ij,ij->i", n, l)
        # Light linking: a light reaches only the objects of its collection:lightLink.
        linked = np.array([light.linking.lights(s) for s in source], dtype=bool).reshape(len(p))
        lit = np.nonzero((n_dot_l >= EPSILON) & linked)[0]  # below the gate: no shadow ray, no contribution
        if len(lit) == 0:
            continue
        nl = n_dot_l[lit]
        glass_filters = settings.transmission == "povray"
        if ((geo.transmissive and glass_filters) or geo.cut_outs) and light.linking.shadows:
            # The shadow ray starts in the shaded ray's interiors (POV-Ray's light source ray is
            # a copy of the eye ray); one that casts no shadow is never crossed, so never fades.
            start = no_interiors(len(lit)) if inside is None else inside[lit].copy()
            shadowed_by = light.linking.shadowed_by
            casts = None if shadowed_by is None else shadowed_by.__contains__
            if isinstance(light, (PointLight, DirectionalLight)):
                light_colour = lc[lit] * _shadow_filter(geo, p[lit], l[lit], dist[lit], start, casts, glass_filters)
            else:
                # An area light: each grid sample's shadow ray filtered, the colours weighted.
                offsets, weights = area_light_offsets(light, l[lit])
                filtered = np.zeros((len(lit), 3))
                for k, weight in enumerate(weights):
                    to_sample = np.asarray(light.center, dtype=np.float64) + offsets[:, k] - p[lit]
                    sample_dist = np.linalg.norm(to_sample, axis=1)
                    sample_dir = to_sample / sample_dist[:, None]
                    filtered += weight * _shadow_filter(
                        geo, p[lit], sample_dir, sample_dist, start.copy(), casts, glass_filters
                    )
                light_colour = lc[lit] * filtered
        else:
            fraction = _visible_fraction(geo, light, p[lit], l[lit], dist[lit])
            light_colour = lc[lit] * fraction[:, None]
        dm, sm = light.diffuse, light.specular  # the light's multipliers of the two terms
        if settings.specular == "seed":
            mirror = -l[lit] + 2.0 * nl[:, None] * n[lit]
            s = np.einsum("ij,ij->i", mirror, wo[lit])
            spec = np.where(s > 0.0, np.power(np.where(s > 0.0, s, 1.0), e[lit]), 0.0)
            brdf = dm * kd[lit, None] * cd[lit] / math.pi + sm * ks[lit, None] * cs[lit] * spec[:, None]
            radiance[lit] += brdf * light_colour * nl[:, None]
        elif settings.specular == "povray-classic":
            dl = d[lit]
            reflected = dl - 2.0 * np.einsum("ij,ij->i", dl, n[lit])[:, None] * n[lit]
            k = np.einsum("ij,ij->i", reflected, l[lit])
            phong = np.where(ks[lit] > 0.0, ks[lit] * classic_phong_factor(k, e[lit]), 0.0)
            radiance[lit] += (dm * kd[lit, None] / math.pi * cd[lit] * nl[:, None] + sm * phong[:, None]) * light_colour
        else:
            raise ValueError(f"unknown specular convention {settings.specular!r}")
    return radiance


# =============================================================================================
# Public API


def _trace(
    geo: _Geometry,
    scene: Scene,
    settings: RenderSettings,
    origins,
    directions,
    depth: int = 0,
    inside: np.ndarray | None = None,
) -> np.ndarray:
    o = np.asarray(origins, dtype=np.float64).reshape(-1, 3)
    d = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    inside = no_interiors(len(o)) if inside is None else inside
    t, material, normal, colour, specular, source, obj, cut = _closest_hit(geo, o, d)
    radiance = np.empty((len(o), 3))
    radiance[:] = np.asarray(settings.background, dtype=np.float64)
    hit = np.isfinite(t) & ~cut
    if cut.any():
        # A cut-out texel: the ray goes on from the hit, unchanged, at its depth (POV-Ray's
        # continued ray through a texel that transmits all).
        rows = np.nonzero(cut)[0]
        radiance[rows] = _trace(geo, scene, settings, o[rows] + t[rows, None] * d[rows], d[rows], depth, inside[rows])
    if hit.any():
        p = o[hit] + t[hit, None] * d[hit]
        radiance[hit] = _shade(
            geo,
            scene,
            settings,
            p,
            d[hit],
            normal[hit],
            material[hit],
            colour[hit],
            specular[hit],
            source[hit],
            inside[hit],
        )
        if depth < settings.max_depth:
            radiance[hit] += _reflected(
                geo, scene, settings, p, d[hit], normal[hit], material[hit], obj[hit], depth, inside[hit], t[hit]
            )
    if settings.transmission != "book":
        return radiance
    return radiance * geo.medium_transmittance(_innermost(inside)[:, 1], t)


def _reflected(
    geo: _Geometry,
    scene: Scene,
    settings: RenderSettings,
    p,
    d,
    normal,
    material,
    obj,
    depth: int,
    inside: np.ndarray,
    t_hit: np.ndarray,
) -> np.ndarray:
    """The secondary rays' radiance at each hit (zero where none is traced): kr·cr·L(P, r) with r
    the mirror of d, plus the refracted ray's, or L(P, r) alone under total internal reflection."""
    out = np.zeros((len(p), 3))
    kr, cr, kt, ior = geo.kr[material], geo.cr[material], geo.kt[material], geo.ior[material]
    along = np.einsum("ij,ij->i", normal, d)
    transmits = kt > 0.0
    n = np.where((along > 0.0)[:, None], -normal, normal)  # facing the ray
    # The book (and any opaque surface): leaving where the ray meets the normal from behind,
    # η = ior entering, 1/ior leaving; a refracted ray enters this object's interior or leaves it
    # for none; a reflected one keeps its side.
    leaving = along > 0.0
    eta = np.where(leaving, 1.0 / ior, ior)
    fresnel_eta = eta.copy()
    entered = _appended(no_interiors(len(p)), obj, material)
    refracted_inside = np.where((transmits & ~leaving)[:, None, None], entered, no_interiors(len(p)))
    reflected_inside = inside.copy()
    if settings.transmission == "book":
        back = transmits & leaving
        reflected_inside[back] = _appended(no_interiors(int(back.sum())), obj[back], material[back])
    else:
        # POV-Ray's interior list (trace.cpp ComputeRefraction; ComputeRelativeIOR for Fresnel):
        # outside every object the ray enters (ior); leaving the innermost it goes into the next
        # one out (n_next/ior, or 1/ior), where Fresnel sees a ratio of 1 when there is a next one;
        # leaving an object that is not the innermost, the ray continues unrefracted (ratio 1)
        # and Fresnel sees n_innermost/ior; entering while inside: ior/n_innermost.
        rows = np.nonzero(transmits)[0]
        inner = _innermost(inside[rows])
        count = _interior_count(inside[rows])
        contains = _contains(inside[rows], obj[rows])
        removed = _removed(inside[rows], obj[rows])
        appended = _appended(inside[rows], obj[rows], material[rows])
        outer = _innermost(removed)
        own = ior[rows]
        empty = count == 0
        last = ~empty & (inner[:, 0] == obj[rows])
        overlap = contains & ~last
        entering = ~empty & ~contains
        with np.errstate(divide="ignore", invalid="ignore"):
            inner_ior = np.where(inner[:, 1] >= 0, geo.ior[np.maximum(inner[:, 1], 0)], 1.0)
            outer_ior = np.where(outer[:, 1] >= 0, geo.ior[np.maximum(outer[:, 1], 0)], 1.0)
            e = np.select([empty, last, overlap], [own, outer_ior / own, np.ones_like(own)], own / inner_ior)
            f = np.select(
                [empty, last & (count == 1), last, overlap],
                [own, 1.0 / own, np.ones_like(own), inner_ior / own],
                own / inner_ior,
            )
        eta[rows], fresnel_eta[rows] = e, f
        refracted_inside[rows] = np.where((empty | entering)[:, None, None], appended, removed)
    cos_i = np.abs(along)
    cos_t2 = 1.0 - (1.0 - cos_i**2) / eta**2
    tir = transmits & (cos_t2 < 0.0)
    cos_tf = np.sqrt(np.maximum(1.0 - (1.0 - cos_i**2) / fresnel_eta**2, 0.0))
    rs = (cos_i - fresnel_eta * cos_tf) / (cos_i + fresnel_eta * cos_tf)
    rp = (fresnel_eta * cos_i - cos_tf) / (fresnel_eta * cos_i + cos_tf)
    reflectance = np.where(geo.fresnel[material], 0.5 * (rs**2 + rp**2), 1.0)
    kt = np.where(geo.fresnel[material], kt * (1.0 - reflectance), kt)
    # "povray": Beer-Lambert only on what a transparent surface transmits (refracted or internally
    # reflected), over the incoming ray's path inside this surface's interior; "book": every
    # ray's path (in _trace).
    carried = np.ones((len(p), 3))
    if settings.transmission != "book":
        faded = transmits & _contains(inside, obj)
        carried[faded] = geo.medium_transmittance(material[faded], t_hit[faded])
    weight = np.where(tir[:, None], carried, (kr * reflectance)[:, None] * cr)
    mirror_rows = np.nonzero(tir | ((kr > 0.0) & np.any(cr > 0.0, axis=1)))[0]
    if len(mirror_rows):
        dr, nr = d[mirror_rows], n[mirror_rows]
        r = dr - 2.0 * np.einsum("ij,ij->i", dr, nr)[:, None] * nr
        out[mirror_rows] += weight[mirror_rows] * _trace(
            geo, scene, settings, p[mirror_rows], r, depth + 1, reflected_inside[mirror_rows]
        )
    rows = np.nonzero(transmits & ~tir)[0]
    if len(rows):
        e, c = eta[rows, None], cos_i[rows, None]
        t = d[rows] / e - (np.sqrt(cos_t2[rows, None]) - c / e) * n[rows]
        w = kt[rows] / eta[rows] ** 2 if settings.transmission == "book" else kt[rows]
        # "povray": between equal indices (|η − 1| < POVRAY_SAME_IOR) the ray goes straight on at
        # this depth (POV-Ray's continued ray, ref §18); the book counts every crossing.
        same = np.abs(eta[rows] - 1.0) < POVRAY_SAME_IOR
        if settings.transmission == "book":
            same[:] = False
        t[same] = d[rows][same]
        for part, level in ((~same, depth + 1), (same, depth)):
            if part.any():
                out[rows[part]] += (
                    w[part, None]
                    * carried[rows[part]]
                    * _trace(geo, scene, settings, p[rows[part]], t[part], level, refracted_inside[rows[part]])
                )
    return out


def _shadow_filter(
    geo: _Geometry,
    p: np.ndarray,
    l: np.ndarray,
    dist: np.ndarray,
    inside: np.ndarray,
    casts=None,
    glass_filters: bool = True,
) -> np.ndarray:
    """The light reaching each P along unit l from distance dist through transmissive objects:
    segment by segment, each hit in the shadow window (ref §6) from the last crossing; an opaque
    one blocks, a transmissive one multiplies by kt (ref §18) and, when the ray is in its
    interior, by the fade over the stretch since the last crossing; the ray then leaves that
    interior, or enters it. An object outside the light's shadow link (``casts(prim)`` false) is
    crossed as if it were not there, as is a cut-out texel; with ``glass_filters`` false (the
    book's convention) a transmissive object blocks as an opaque one does. (N, 3)."""
    filt = np.ones((len(p), 3))
    origin, remaining = p.copy(), dist.astype(np.float64).copy()
    inside = inside.copy()
    segment = np.zeros(len(p))
    active = np.arange(len(p))
    while len(active):
        upper = np.minimum(remaining[active] - SHADOW_TOLERANCE, MAX_DISTANCE)

        def accept(t, rows, upper=upper):
            hi = upper if rows is None else upper[rows]
            return (t > SHADOW_TOLERANCE) & (t < hi)

        t, material, _, _, _, source, obj, cut = _closest_hit(geo, origin[active], l[active], accept)
        hit = np.isfinite(t)
        segment[active[hit]] += t[hit]
        casting = hit if casts is None else hit & np.array([bool(casts(s)) for s in source], dtype=bool)
        casting &= ~cut
        opaque = casting & ~((geo.kt[material] > 0.0) & glass_filters)
        filt[active[opaque]] = 0.0
        filtering = casting & ~opaque
        rows = active[filtering]
        crossed, crossed_material = obj[filtering], material[filtering]
        faded = _contains(inside[rows], crossed)
        filt[rows[faded]] *= geo.medium_transmittance(crossed_material[faded], segment[rows[faded]])
        filt[rows] *= geo.kt[crossed_material, None]
        inside[rows] = np.where(
            faded[:, None, None],
            _removed(inside[rows], crossed),
            _appended(inside[rows], crossed, crossed_material),
        )
        segment[rows] = 0.0
        through = hit & ~opaque
        origin[active[through]] += t[through, None] * l[active[through]]
        remaining[active[through]] -= t[through]
        active = active[through]
    return filt


def trace_rays(scene: Scene, origins, directions, settings: RenderSettings | None = None) -> np.ndarray:
    """Radiance along each ray (directions are normalised here), (N, 3) float64.

    ``settings`` (default ``scene.settings``) supplies the background and the specular convention.
    """
    settings = scene.settings if settings is None else settings
    return _trace(_prepare(scene), scene, settings, origins, directions)


def render(scene: Scene, settings: RenderSettings | None = None) -> np.ndarray:
    """Render the scene: float64 (H, W, 3), row 0 at the top (ref §3, §8)."""
    settings = scene.settings if settings is None else settings
    width, height = settings.width, settings.height
    offsets, weights = pixel_samples(settings.samples, settings.sample_pattern)
    cols, rows = np.meshgrid(np.arange(width, dtype=np.float64), np.arange(height, dtype=np.float64), indexing="xy")
    sx = cols[..., None] + offsets[:, 0]  # (H, W, K)
    sy = rows[..., None] + offsets[:, 1]
    origins, directions = camera_rays(scene.camera, width, height, sx, sy)
    geo = _prepare(scene)
    inside = np.repeat(_camera_interiors(geo, scene, settings)[None], len(origins.reshape(-1, 3)), axis=0)
    radiance = _trace(geo, scene, settings, origins, directions, inside=inside)
    return np.einsum("hwkc,k->hwc", radiance.reshape(height, width, len(weights), 3), weights)


def _camera_interiors(geo: _Geometry, scene: Scene, settings: RenderSettings) -> np.ndarray:
    """The interiors camera rays start in: in the "povray" convention those of the transparent
    spheres and meshes containing the camera (POV-Ray's interior list), found here by the sphere's
    equation and a closed mesh's winding number (the triangles' solid angles seen from the camera,
    Van Oosterom-Strackee, summed over 4π: ±1 inside, 0 outside; not the backend's ray parity),
    outermost first: by the volume they enclose (a sphere's 4π/3·|det|, a mesh's by the
    divergence theorem), larger first, ties spheres then meshes; else none. (MAX_INTERIORS, 2)."""
    out = no_interiors(1)
    if settings.transmission != "povray":
        return out[0]
    eye = np.asarray(scene.camera.position, dtype=np.float64)
    found = []
    for k, (inverse, material) in enumerate(zip(geo.sphere_object_from_world, geo.sphere_material)):
        q = inverse[:3, :3] @ eye + inverse[:3, 3]
        if geo.kt[material] > 0 and float(q @ q) < 1.0:
            found.append((4.0 * math.pi / 3.0 / abs(np.linalg.det(inverse[:3, :3])), _object_id("sphere", k), material))
    meshes = [m for m in scene.meshes if len(m.triangles)]
    for k, (model, mesh) in enumerate(zip(meshes, geo.meshes)):
        if geo.kt[mesh.material] > 0 and abs(_winding_number(model, eye)) > 0.5:
            corners = model.points[model.triangles]
            volume = abs(np.sum(np.cross(corners[:, 0], corners[:, 1]) * corners[:, 2])) / 6.0
            found.append((volume, _object_id("mesh", k), mesh.material))
    for _, obj, material in sorted(found, key=lambda entry: (-entry[0], entry[1])):
        out = _appended(out, np.array([obj]), np.array([material]))
    return out[0]


def _winding_number(mesh, eye: np.ndarray) -> float:
    a, b, c = (mesh.points[mesh.triangles[:, k]] - eye for k in range(3))
    la, lb, lc = (np.linalg.norm(x, axis=1) for x in (a, b, c))
    numerator = np.einsum("ij,ij->i", a, np.cross(b, c))
    denominator = (
        la * lb * lc
        + np.einsum("ij,ij->i", a, b) * lc
        + np.einsum("ij,ij->i", b, c) * la
        + np.einsum("ij,ij->i", c, a) * lb
    )
    return float(np.sum(2.0 * np.arctan2(numerator, denominator)) / (4.0 * math.pi))


def with_half_texels(scene: Scene) -> Scene:
    """``scene`` with every texture's texels rounded to half floats: what POV-Ray samples, as it
    holds an EXR image map as half floats (docs/povray-3.7-semantics.md §16). Compare POV-Ray
    images with the oracle of this scene."""
    import dataclasses

    def half_texture(t):
        if t is None:
            return None
        return dataclasses.replace(t, image=np.asarray(t.image, dtype=np.float16).astype(np.float32))

    def half(material):
        return dataclasses.replace(
            material,
            diffuse_texture=half_texture(material.diffuse_texture),
            specular_texture=half_texture(material.specular_texture),
        )

    return dataclasses.replace(
        scene,
        spheres=tuple(dataclasses.replace(s, material=half(s.material)) for s in scene.spheres),
        meshes=tuple(dataclasses.replace(m, material=half(m.material)) for m in scene.meshes),
    )
