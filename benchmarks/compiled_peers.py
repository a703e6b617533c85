# SPDX-License-Identifier: Apache-2.0
"""Compiled peers of the native tracer in benchmarks/run.py, built here at benchmark time (never
at install or test time, never a dependency) and run as child processes on the same rays:

* **Embree** through its C API (``peers/embree_peer.cpp``, Debian's ``libembree-dev``): single
  rays (``rtcIntersect1`` / ``rtcOccluded1``) and 8- and 16-ray packets (``rtcIntersect8/16``
  over 4×2 / 4×4 pixel blocks, then per block and shadow target one ``rtcOccluded8/16`` packet);
  its build timed by ``rtcCommitScene`` alone; threads = Embree's device config ``threads=N``
  (its build) and as many render threads.
* **The naive scalar loop** (``peers/naive_peer.c``): every ray against every primitive in
  double precision, spheres by centre and radius; small scenes only. Compiled twice: for the
  x86-64 baseline (as the native extension is) and with ``-march=native``.

The rays: the native camera's primary rays through the pixel centres, then per primary hit one
shadow ray per shadow target (a point light's position, each point of an area light's full grid:
``peer_rays.py``) from the peer's own hit point, as the Mitsuba peer traces. Each peer's answers
(primary hit distance, and each point light's shadow rays) are checked against the native BVH's
on the same rays before its time is printed (``peer_rays.agreement``).

The binaries go to a cache folder under the system's temporary directory, keyed by a hash of the
sources and flags (``PHONGSCENE_PEER_BUILD`` overrides the folder).
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import shutil
import struct
import subprocess
import tempfile
from pathlib import Path

import numpy as np
from peer_rays import SHADOW_OFFSET, agreement, primary_rays, shadow_targets, sphere_centre_radius

HERE = Path(__file__).resolve().parent / "peers"
MAGIC = 0x52504850  # peer_input.h
# The naive loop tests every ray against every primitive: beyond this many it is not a peer.
NAIVE_MAX_PRIMITIVES = 64
EMBREE_MODES = ("single", "packet8", "packet16")


def _build_dir() -> Path:
    return Path(os.environ.get("PHONGSCENE_PEER_BUILD") or Path(tempfile.gettempdir()) / "phongscene-peers")


def _compile(compiler: str, source: str, flags: tuple[str, ...], libs: tuple[str, ...]) -> Path | str:
    """The binary of ``peers/source`` built with ``flags`` (cached), or why it could not be built."""
    if shutil.which(compiler) is None:
        return f"{compiler} not found"
    text = (HERE / source).read_bytes() + (HERE / "peer_input.h").read_bytes()
    key = hashlib.sha256(text + repr((compiler, flags, libs)).encode()).hexdigest()[:16]
    out = _build_dir() / f"{Path(source).stem}-{key}"
    if out.exists():
        return out
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + f".{os.getpid()}.tmp")
    done = subprocess.run([compiler, *flags, str(HERE / source), "-o", str(tmp), *libs], capture_output=True, text=True)
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or ["failed"])[-1]
        return f"{source} does not build: {last[-200:]}"
    tmp.replace(out)
    return out


COMMON = ("-O3", "-ffp-contract=off", "-Wall")


@functools.cache
def embree_binary() -> Path | str:
    if not Path("/usr/include/embree3/rtcore.h").exists():
        return "libembree-dev not installed (apt-get install libembree-dev)"
    return _compile("c++", "embree_peer.cpp", (*COMMON, "-std=c++17"), ("-lembree3", "-lpthread"))


@functools.cache
def naive_binary(march_native: bool) -> Path | str:
    flags = (*COMMON, "-std=c11", *(("-march=native",) if march_native else ()))
    return _compile("cc", "naive_peer.c", flags, ("-lm", "-lpthread"))


def why_not(scene) -> str | None:
    """None when the compiled peers can stand in for ``scene``, else why not."""
    if any(sphere_centre_radius(s) is None for s in scene.spheres):
        return "a non-uniformly scaled sphere"
    if any(shadow_targets(light) is None for light in scene.lights):
        return "a light other than point and rectangular area lights"
    if scene.camera.projection != "perspective":
        return "an orthographic camera"
    return None


def write_rays(scene, settings, path: Path, only=None) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
    """Write peer_input.h's RAYS.bin for ``scene``; returns (origins, dirs, targets per light).
    ``only`` (a boolean mask over the pixels, row by row): just those pixels' rays, written as an
    image one row high."""
    origins, dirs = primary_rays(scene, settings)
    width, height = settings.width, settings.height
    if only is not None:
        origins, dirs = origins[only], dirs[only]
        width, height = len(origins), 1
    targets = [shadow_targets(light) for light in scene.lights]
    offsets = np.cumsum([0] + [len(m.points) for m in scene.meshes])
    points = np.concatenate([np.asarray(m.points, np.float32) for m in scene.meshes] or [np.zeros((0, 3), np.float32)])
    triangles = np.concatenate(
        [np.asarray(m.triangles, np.int64) + o for m, o in zip(scene.meshes, offsets)] or [np.zeros((0, 3), np.int64)]
    ).astype(np.uint32)
    spheres = np.asarray([[*c, r] for c, r in map(sphere_centre_radius, scene.spheres)], np.float32).reshape(-1, 4)
    head = struct.pack("<7i", MAGIC, width, height, len(points), len(triangles), len(spheres), len(targets))
    with open(path, "wb") as f:
        f.write(head + struct.pack(f"<{len(targets)}i", *(len(t) for t in targets)))
        for array in (points, triangles, spheres, origins, dirs, *targets):
            f.write(np.ascontiguousarray(array).tobytes())
    return origins, dirs, targets


def run_peer(cmd: list[str]) -> dict:
    """A compiled peer's JSON line (its figures), or SystemExit with its error."""
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{cmd[0]} failed ({done.returncode}): {done.stderr.strip()[-500:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def _answers(path: Path, origins, dirs, targets) -> tuple[np.ndarray, np.ndarray, np.ndarray, list]:
    """(valid, t, hit points, per light the shadow answers or None) from HITS.bin."""
    n = len(origins)
    data = path.read_bytes()
    t = np.frombuffer(data, np.float32, n)
    point_lights = [i for i, target in enumerate(targets) if len(target) == 1]
    bytes_ = np.frombuffer(data, np.uint8, n * len(point_lights), offset=4 * n).reshape(len(point_lights), n)
    valid = np.isfinite(t)
    points = (origins[valid] + dirs[valid] * t[valid, None]).astype(np.float64)  # as peer_input.h's hit_point
    occluded = [None] * len(targets)
    for row, i in enumerate(point_lights):
        occluded[i] = bytes_[row][valid] == 1
    return valid, t, points, occluded


# The native tracer's smallest hit distance on the peers' rays: positive, as every ray of a native
# render starts (t_min = 0 would send each ray to the double-precision box test, bvh4.hpp's
# FloatSlabRay::applies), and far below any hit in the benchmark scenes (distances >= ~1e-4).
NATIVE_TRACE_T_MIN = 1e-9


def pixel_blocks(width: int, height: int) -> np.ndarray | None:
    """The row-order pixel indices regrouped into the 8 x 4 blocks a native render traces as
    packets (render.cpp: kPacketWidth x kPacketHeight), or None when the image does not divide."""
    if width % 8 or height % 4:
        return None
    index = np.arange(width * height).reshape(height // 4, 4, width // 8, 8)
    return index.transpose(0, 2, 1, 3).reshape(-1)


def native_trace(scene, settings, native_scene, repeat: int) -> dict:
    """The native tracer on the peers' rays, one thread, tracing only (what the peers do; native's
    render also shades): the primary rays' closest hits as a render traces them, 32 at a time
    in 8 x 4 pixel blocks (``Scene.intersect_packets``; ``Scene.intersect`` one by one when the
    image does not divide into blocks), then from each hit one shadow ray per target with the
    peers' offsets (``Scene.occluded``, the any-hit walk of shadow rays). Best of ``repeat``, also
    of the primary and the shadow rays apart ("primary", "shadow"); the
    time is the C++ calls' (the blocks' order and the shadow rays' origins and directions are made
    in numpy between them, untimed: ~20 arithmetic operations a ray, which the peers do inside
    their loops)."""
    import time

    origins, dirs = (a.astype(np.float64) for a in primary_rays(scene, settings))
    blocks = pixel_blocks(settings.width, settings.height)
    block_dirs = None if blocks is None else np.ascontiguousarray(dirs[blocks])
    targets = [shadow_targets(light) for light in scene.lights]
    best, best_primary, best_shadow, rays = float("inf"), float("inf"), float("inf"), 0
    for _ in range(repeat):
        if block_dirs is None:
            start = time.perf_counter()
            t, _ = native_scene.intersect(origins, dirs, NATIVE_TRACE_T_MIN)
            elapsed = time.perf_counter() - start
        else:
            start = time.perf_counter()
            t_blocks, _, _, _ = native_scene.intersect_packets(origins[0], block_dirs, NATIVE_TRACE_T_MIN)
            elapsed = time.perf_counter() - start
            t = np.empty_like(t_blocks)
            t[blocks] = t_blocks
        primary = elapsed
        valid = np.isfinite(t)
        points = origins[valid] + dirs[valid] * t[valid, None]
        rays = len(origins)
        for grid in targets:
            for target in grid.astype(np.float64):
                to_light = target - points
                dist = np.linalg.norm(to_light, axis=1)
                to_light /= dist[:, None]
                shadow_origins = points + to_light * SHADOW_OFFSET
                start = time.perf_counter()
                native_scene.occluded(shadow_origins, to_light, dist - 2 * SHADOW_OFFSET, NATIVE_TRACE_T_MIN)
                elapsed += time.perf_counter() - start
                rays += len(points)
        best = min(best, elapsed)
        best_primary, best_shadow = min(best_primary, primary), min(best_shadow, elapsed - primary)
    return {"render": best, "primary": best_primary, "shadow": best_shadow, "rays": rays}


def run_peers(scene, settings, native_scene, threads: int, repeat: int) -> dict[str, dict | str]:
    """Each compiled peer's figures on ``scene`` at ``threads`` threads (best of ``repeat``):
    name -> {"build" (Embree only), "render", "rays", "agreement"}, or the reason it was skipped."""
    results: dict[str, dict | str] = {}
    if reason := why_not(scene):
        return {"peers": reason}
    with tempfile.TemporaryDirectory() as tmp:
        rays_path, hits_path = Path(tmp) / "rays.bin", Path(tmp) / "hits.bin"
        origins, dirs, targets = write_rays(scene, settings, rays_path)

        def checked(cmd: list[str]) -> dict:
            figures = run_peer(cmd)
            valid, t, points, occluded = _answers(hits_path, origins, dirs, targets)
            figures["agreement"] = agreement(
                native_scene, origins, dirs, valid, t, points, targets, occluded, who=Path(cmd[0]).name
            )
            return figures

        primitives = len(scene.spheres) + scene.triangle_count
        for march_native in (False, True):
            name = "naive C" + (" -march=native" if march_native else "")
            binary = naive_binary(march_native)
            if isinstance(binary, str):
                results[name] = binary
            elif primitives > NAIVE_MAX_PRIMITIVES:
                results[name] = f"{primitives} primitives (brute force beyond {NAIVE_MAX_PRIMITIVES})"
            else:
                results[name] = checked([str(binary), str(rays_path), str(hits_path), str(threads), str(repeat)])
        binary = embree_binary()
        for mode in EMBREE_MODES:
            name = f"Embree {mode}"
            results[name] = (
                binary
                if isinstance(binary, str)
                else checked([str(binary), str(rays_path), str(hits_path), mode, str(threads), str(repeat)])
            )
    return results
