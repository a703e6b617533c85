# SPDX-License-Identifier: Apache-2.0
"""Mitsuba 3 (LLVM variant) as a peer of the native tracer in benchmarks/run.py: the same scene
(spheres as Mitsuba's analytic ``sphere``, meshes as ``mi.Mesh`` from the model's arrays), the
same camera's primary rays, and per primary hit the same shadow rays as the native tracer: one
per point light, the full samples × samples grid per rectangular area light (S3's 9×9). Never a
project dependency; set up by hand (benchmarks/README.md).

What is timed: *build* = the model's arrays to Mitsuba shapes and the scene with its
acceleration structure; *render* = closest hits of the primary rays (``ray_intersect_preliminary``:
distance only, as Embree's peer asks for), the hit points compacted, then one occlusion test
(``ray_test``) per hit and shadow target, evaluated target by target. Dr.Jit compiles each kernel
the first time (and caches it): the best of several runs is a run with compiled kernels.

What it checks: the primary rays' hits against the native tracer's on the same rays, and the
point lights' shadow rays from Mitsuba's hit points against the native BVH's answer for the same
rays; each must agree on at least ``MIN_AGREEMENT`` of the rays, or the run stops.
"""

from __future__ import annotations

import functools
import importlib.util
import os
import subprocess
import sys

import numpy as np
from peer_rays import primary_rays, shadow_targets
from timing import best_time

VARIANT = "llvm_ad_rgb"  # the CPU JIT variant the PyPI wheel ships
# Shadow rays start this far from the hit point toward the light and stop as far before it (as
# the Embree peer's): a timing needs no more than a plausible offset.
SHADOW_OFFSET = 1e-4
# Mitsuba traces in float32, the native tracer in double: rays grazing a silhouette or a shadow
# edge may go either way (at 1280×720 a sphere's outline is a few thousand of 0.9M rays). More
# disagreement than this fraction means the peer is not tracing the same scene.
MIN_AGREEMENT = 0.995
# Mitsuba's float32 hit distances against native's double ones, relative (or absolute below 1):
# float32 carries ~6e-8 relative; its ray set-up and intersection tests lose a few hundred ulps.
HIT_DISTANCE_TOLERANCE = 1e-4
# Spheres are passed to Mitsuba as centre and radius: a world_from_object whose linear part is
# a rotation times r, to this relative precision, is one.
SIMILARITY_TOLERANCE = 1e-9


# Started in a child process first: with an LLVM it cannot use (Debian's 14/15), Dr.Jit's LLVM
# backend aborts the whole process (issue 15) instead of raising.
PROBE = f"""
import mitsuba as mi
mi.set_variant({VARIANT!r})
scene = mi.load_dict({{"type": "scene", "s": {{"type": "sphere"}}}})
ray = mi.Ray3f(mi.Point3f(0, 0, -5), mi.Vector3f(0, 0, 1))
assert bool(scene.ray_test(ray)[0])
"""


@functools.cache
def unavailable() -> str | None:
    """None when Mitsuba's LLVM variant starts and traces a ray here, else why not (printed by
    run.py)."""
    if importlib.util.find_spec("mitsuba") is None:
        return "mitsuba not installed"
    done = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True)
    if done.returncode != 0:
        hint = (
            ""
            if os.environ.get("DRJIT_LIBLLVM_PATH")
            else "; DRJIT_LIBLLVM_PATH not set (point it at libLLVM.so.19.1: benchmarks/README.md)"
        )
        last = (done.stderr.strip().splitlines() or [f"exit status {done.returncode}"])[-1]
        return f"mitsuba {VARIANT} does not start: {last[-200:]}{hint}"
    return None


def _sphere(sphere) -> dict | None:
    m = np.asarray(sphere.world_from_object)
    s = np.linalg.svd(m[:3, :3], compute_uv=False)
    if s.max() - s.min() > SIMILARITY_TOLERANCE * s.max():
        return None  # an ellipsoid: Mitsuba's sphere cannot stand in for it
    return {"type": "sphere", "center": m[:3, 3].tolist(), "radius": float(s[0])}


def _mesh(mi, mesh, name: str):
    shape = mi.Mesh(name, len(mesh.points), len(mesh.triangles))
    params = mi.traverse(shape)
    params["vertex_positions"] = mi.Float(np.ascontiguousarray(mesh.points, np.float32).ravel())
    params["faces"] = mi.UInt32(np.ascontiguousarray(mesh.triangles, np.uint32).ravel())
    params.update()
    return shape


def _targets(scene) -> list[np.ndarray] | None:
    targets = [shadow_targets(light) for light in scene.lights]
    return None if any(t is None for t in targets) else targets


def why_not(scene) -> str | None:
    """None when the peer can stand in for ``scene``, else why not."""
    if any(_sphere(s) is None for s in scene.spheres):
        return "a non-uniformly scaled sphere"
    if _targets(scene) is None:
        return "a light other than point and rectangular area lights"
    if scene.camera.projection != "perspective":
        return "an orthographic camera"
    return None


def times(scene, settings, native_scene, repeat: int, threads: int) -> dict:
    """Mitsuba's build and render times (best of ``repeat``) at ``threads`` threads, the rays
    counted and the agreement with the native tracer (``native_scene``: its built scene)."""
    import drjit as dr
    import mitsuba as mi

    mi.set_variant(VARIANT)
    dr.set_thread_count(threads)
    targets = _targets(scene)

    def build():
        shapes = {f"sphere{i}": _sphere(s) for i, s in enumerate(scene.spheres)}
        shapes.update({f"mesh{i}": _mesh(mi, m, f"mesh{i}") for i, m in enumerate(scene.meshes)})
        built = mi.load_dict({"type": "scene", **shapes})
        dr.sync_thread()
        return built

    t_build, mi_scene = best_time(build, repeat)
    origins, dirs = primary_rays(scene, settings)
    rays = mi.Ray3f(mi.Point3f(*origins.T), mi.Vector3f(*dirs.T))
    light_points = [[mi.Point3f(*(dr.opaque(mi.Float, float(x)) for x in p)) for p in t] for t in targets]
    dr.eval(rays)

    def render():
        hit = mi_scene.ray_intersect_preliminary(rays)
        valid = hit.is_valid()
        index = dr.compress(valid)
        p = rays.o + rays.d * hit.t
        points = mi.Point3f(*(dr.gather(mi.Float, c, index) for c in (p.x, p.y, p.z)))
        dr.eval(hit.t, points)
        count, first_occluded = len(origins), []
        for light in light_points:
            for target in light:
                to_light = target - points
                dist = dr.norm(to_light)
                to_light /= dist
                occluded = mi_scene.ray_test(
                    mi.Ray3f(points + to_light * SHADOW_OFFSET, to_light, dist - 2 * SHADOW_OFFSET)
                )
                dr.eval(occluded)
                count += dr.width(points)
            first_occluded.append(occluded if len(light) == 1 else None)
        dr.sync_thread()
        return count, hit.t, valid, points, first_occluded

    t_render, (count, t_hit, valid, points, occluded) = best_time(render, repeat)
    agreement = _agreement(
        native_scene,
        origins,
        dirs,
        np.asarray(valid),
        np.asarray(t_hit),
        np.asarray(points).T.astype(np.float64),
        targets,
        occluded,
    )
    return {"build": t_build, "render": t_render, "rays": count, "agreement": agreement}


def _agreement(native_scene, origins, dirs, valid, t_hit, points, targets, occluded) -> float:
    """The smallest fraction of rays on which Mitsuba and the native tracer agree: primary rays
    (hit or miss, and where both hit, the distance to float precision), then each point light's
    shadow rays from Mitsuba's hit points (occluded or not)."""
    t_native, _ = native_scene.intersect(origins.astype(np.float64), dirs.astype(np.float64))
    hit_native = np.isfinite(t_native)
    both = valid & hit_native
    same_t = np.ones_like(both)
    same_t[both] = np.abs(t_hit[both] - t_native[both]) <= HIT_DISTANCE_TOLERANCE * np.maximum(1.0, t_native[both])
    fractions = [float(np.mean((valid == hit_native) & same_t))]
    for target, mi_occluded in zip(targets, occluded):
        if mi_occluded is None:
            continue
        to_light = target[0].astype(np.float64) - points
        dist = np.linalg.norm(to_light, axis=1)
        to_light /= dist[:, None]
        t, _ = native_scene.intersect(points + to_light * SHADOW_OFFSET, to_light)
        fractions.append(float(np.mean((t < dist - 2 * SHADOW_OFFSET) == np.asarray(mi_occluded))))
    worst = min(fractions)
    if worst < MIN_AGREEMENT:
        raise SystemExit(
            f"Mitsuba and the native tracer agree on only {worst:.4f} of the rays "
            f"(fractions {fractions}; at least {MIN_AGREEMENT} expected): not the same scene"
        )
    return worst
