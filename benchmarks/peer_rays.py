# SPDX-License-Identifier: Apache-2.0
"""The rays a peer renderer traces to stand in for a native render of the same scene: the native
camera's primary rays through the pixel centres, and the points each light sends shadow rays to
(benchmarks/run.py's Embree and Mitsuba peers)."""

from __future__ import annotations

import numpy as np


def primary_rays(scene, settings) -> tuple[np.ndarray, np.ndarray]:
    """(origins, unit directions), float32, one per pixel in row order: the native camera's rays
    through the pixel centres (camera.hpp), perspective only."""
    cam = scene.camera
    w, h = settings.width, settings.height
    forward, up = np.asarray(cam.forward, float), np.asarray(cam.up, float)
    aspect = w / h
    right = np.cross(forward, up) * aspect
    direction = forward * (aspect / (2.0 * np.tan(np.radians(cam.horizontal_fov_deg) / 2.0)))
    j, i = np.mgrid[0:h, 0:w]
    u = ((i + 0.5) / w - 0.5).reshape(-1, 1)
    v = (0.5 - (j + 0.5) / h).reshape(-1, 1)
    d = direction + right * u + up * v
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.broadcast_to(np.asarray(cam.position, float), d.shape).astype(np.float32), d.astype(np.float32)


def shadow_targets(light) -> np.ndarray | None:
    """The points one hit sends shadow rays to for ``light``, (n, 3) float32: a point light's
    position (n = 1); a rectangular area light's full samples × samples grid, edges included (what
    the native tracer traces without ``adaptive``; S3's 9×9 = 81). None for lights a peer does not
    stand in for (directional and spherical area lights: no benchmark scene has them)."""
    from phongscene.scene import PointLight, RectAreaLight

    if isinstance(light, PointLight):
        return np.asarray([light.position], np.float32)
    if isinstance(light, RectAreaLight):
        s = np.linspace(-0.5, 0.5, light.samples)
        a, b = np.meshgrid(s, s, indexing="ij")
        grid = (
            np.asarray(light.center)
            + a.reshape(-1, 1) * np.asarray(light.axis_u)
            + b.reshape(-1, 1) * np.asarray(light.axis_v)
        )
        return grid.astype(np.float32)
    return None


# A shadow ray of a peer starts this far from its hit point toward the target and stops as far
# before it (every peer's: mitsuba_peer.py, peers/peer_input.h): a timing needs a plausible offset.
SHADOW_OFFSET = 1e-4
# A peer traces in float32 (the naive loop: float32 rays and hit points), the native tracer in
# double: rays grazing a silhouette or a shadow edge may go either way (at 1280×720 a sphere's
# outline is a few thousand of 0.9M rays). More disagreement than this fraction means the peer
# is not tracing the same scene.
MIN_AGREEMENT = 0.995
# A peer's float32 hit distances against native's double ones, relative (or absolute below 1):
# float32 carries ~6e-8 relative; ray set-up and intersection tests lose a few hundred ulps.
HIT_DISTANCE_TOLERANCE = 1e-4
# Spheres are passed to peers as centre and radius: a world_from_object whose linear part is
# a rotation times r, to this relative precision, is one.
SIMILARITY_TOLERANCE = 1e-9


def sphere_centre_radius(sphere) -> tuple[tuple[float, float, float], float] | None:
    """(centre, radius) of a model sphere, or None for an ellipsoid (no peer's sphere stands in)."""
    m = np.asarray(sphere.world_from_object)
    s = np.linalg.svd(m[:3, :3], compute_uv=False)
    if s.max() - s.min() > SIMILARITY_TOLERANCE * s.max():
        return None
    return tuple(float(x) for x in m[:3, 3]), float(s[0])


def agreement(native_scene, origins, dirs, valid, t_hit, points, targets, occluded, who: str) -> float:
    """The smallest fraction of rays on which peer ``who`` and the native tracer (its built scene)
    agree: primary rays (hit or miss, and where both hit, the distance to float precision), then
    each point light's shadow rays from the peer's hit points (occluded or not; ``occluded`` has
    per light the peer's answers for its hits, None for lights with more than one target)."""
    t_native, _ = native_scene.intersect(origins.astype(np.float64), dirs.astype(np.float64))
    hit_native = np.isfinite(t_native)
    both = valid & hit_native
    same_t = np.ones_like(both)
    same_t[both] = np.abs(t_hit[both] - t_native[both]) <= HIT_DISTANCE_TOLERANCE * np.maximum(1.0, t_native[both])
    fractions = [float(np.mean((valid == hit_native) & same_t))]
    for target, peer_occluded in zip(targets, occluded):
        if peer_occluded is None:
            continue
        to_light = target[0].astype(np.float64) - points
        dist = np.linalg.norm(to_light, axis=1)
        to_light /= dist[:, None]
        t, _ = native_scene.intersect(points + to_light * SHADOW_OFFSET, to_light)
        fractions.append(float(np.mean((t < dist - 2 * SHADOW_OFFSET) == np.asarray(peer_occluded))))
    worst = min(fractions)
    if worst < MIN_AGREEMENT:
        raise SystemExit(
            f"{who} and the native tracer agree on only {worst:.4f} of the rays "
            f"(fractions {fractions}; at least {MIN_AGREEMENT} expected): not the same scene"
        )
    return worst
