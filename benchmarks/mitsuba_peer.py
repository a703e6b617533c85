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
from peer_rays import SHADOW_OFFSET, agreement, primary_rays, shadow_targets, sphere_centre_radius
from timing import best_time

VARIANT = "llvm_ad_rgb"  # the CPU JIT variant the PyPI wheel ships
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
    if any(sphere_centre_radius(s) is None for s in scene.spheres):
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
        shapes = {
            f"sphere{i}": {"type": "sphere", "center": list(c), "radius": r}
            for i, (c, r) in enumerate(map(sphere_centre_radius, scene.spheres))
        }
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
    agreement_ = agreement(
        native_scene,
        origins,
        dirs,
        np.asarray(valid),
        np.asarray(t_hit),
        np.asarray(points).T.astype(np.float64),
        targets,
        occluded,
        who="Mitsuba",
    )
    return {"build": t_build, "render": t_render, "rays": count, "agreement": agreement_}
