# SPDX-License-Identifier: Apache-2.0
"""``phongscene info`` (what phongscene reads from a USD scene) and ``phongscene validate``
(every problem of one)."""

from __future__ import annotations

import sys

from ..limits import MAX_SUBDIVISION_LEVEL
from .options import SCENE_HELP, UsageError, add_sandbox_option, add_scene_argument, int_in, print_warnings
from .process import EXIT_OK, EXIT_SCENE


def add_info_command(sub) -> None:
    p = sub.add_parser(
        "info",
        help="show what phongscene reads from a USD scene",
        description="Read SCENE and print which prims became which model nodes, the counts of meshes, "
        "triangles, spheres, lights and materials, the textures each material samples, the camera, the render settings and every warning "
        "(unsupported prims, defaults used).",
        epilog="Exit codes: 0 ok, 2 the scene is invalid (one problem per line on stderr).",
    )
    p.add_argument("scene", metavar="SCENE", nargs="?", help=SCENE_HELP)
    p.add_argument("--camera", metavar="PATH", help="show the scene as seen through this Camera prim")
    p.add_argument(
        "--subdivision-level",
        type=int_in(0, MAX_SUBDIVISION_LEVEL),
        metavar="N",
        help="refine every subdivision surface N times (0: its control cage; default: each Mesh's "
        "phong:subdivisionLevel, else 2)",
    )
    p.add_argument(
        "--usd-plugin-path",
        action="store_true",
        help="print the folder of the Phong shader's Sdr definition and exit: other USD tools know the "
        "shader with PXR_SDR_FS_PLUGIN_SEARCH_PATHS=<it> PXR_SDR_FS_PLUGIN_ALLOWED_EXTS=usda",
    )
    add_sandbox_option(p)
    p.set_defaults(func=run_info)


def run_info(args) -> int:
    if args.usd_plugin_path:
        from ..schemas import folder

        print(folder())
        return EXIT_OK
    if args.scene is None:
        raise UsageError("info needs SCENE (or --usd-plugin-path)")
    from ..scene_files import read_scene_file

    result = read_scene_file(
        args.scene, sandbox=args.sandbox, camera=args.camera, subdivision_level=args.subdivision_level
    )
    scene = result.scene
    print(f"file: {scene.source_file}")
    print("prims -> model nodes:")
    for prim, node in result.nodes:
        print(f"  {prim} -> {node}")
    prototype_meshes = tuple(m for p in scene.prototypes for m in p.meshes)
    # equal materials count once
    materials = {m.material for m in (*scene.spheres, *scene.meshes, *scene.points, *prototype_meshes)}
    kinds: dict[str, int] = {}
    for light in scene.lights:
        kinds[type(light).__name__] = kinds.get(type(light).__name__, 0) + 1
    print(
        f"counts: {len(scene.meshes)} meshes, {scene.triangle_count} triangles, {len(scene.spheres)} spheres, "
        + (f"{sum(map(len, scene.points))} points in {len(scene.points)} sets, " if scene.points else "")
        + f"{len(scene.lights)} lights ({', '.join(f'{n} {k}' for k, n in sorted(kinds.items())) or 'none'}), "
        f"{len(materials)} materials"
    )
    if scene.instances:
        # Triangles above are stored ones (each prototype once); a flattened copy would hold these.
        print(
            f"instancing: {len(scene.prototypes)} prototypes, {scene.instance_count} instances, "
            f"{scene.instanced_triangle_count} triangles drawn"
        )
    textured = [m for m in materials if m.textures]
    if textured:
        print("textures:")
        for m in sorted(textured, key=lambda m: m.source):
            for role, t in (
                ("diffuseColor", m.diffuse_texture),
                ("specularColor", m.specular_texture),
                ("normal", m.normal_texture),
                (f"opacity (cut out below {m.opacity_threshold:g})", m.opacity_texture),
            ):
                if t is not None:
                    # The file, not t.source: equal textures are shared, and source is the first prim read.
                    print(
                        f"  {m.source or '(material)'} {role} <- {t.file or '(no file)'}, "
                        f"{t.width}x{t.height}, wrap {t.wrap_s}/{t.wrap_t}"
                    )
    secondary = [m for m in materials if m.reflects or m.transmits]
    if secondary:
        print("reflect or refract (secondary rays, up to max_depth):")
        for m in sorted(secondary, key=lambda m: m.source):
            terms = []
            if m.reflects:
                terms.append(f"reflects kr {m.kr:g} cr {_vector(m.reflective_color)}")
            if m.transmits:
                terms.append(f"refracts kt {m.kt:g} ior {m.ior:g}")
            if m.fresnel:
                terms.append("fresnel")
            print(f"  {m.source or '(material)'}: {', '.join(terms)}")
    print(f"ambient: {_vector(scene.ambient.color)}")
    if scene.environment is not None:
        e = scene.environment
        print(
            f"environment: {e.source or '(built in Python)'}: {e.texture.width}x{e.texture.height} lat-long, "
            f"scale {_vector(e.scale)} (seen by rays that miss, in place of the background)"
        )
    cam = scene.camera
    extent = (
        f"hfov {cam.horizontal_fov_deg:.6g} deg" if cam.projection == "perspective" else f"width {cam.ortho_width:.6g}"
    )
    print(
        f"camera: {cam.source or '(model default)'}: {cam.projection}, {extent}, position {_vector(cam.position)}, "
        f"forward {_vector(cam.forward)}, up {_vector(cam.up)}"
    )
    print(f"cameras ({len(result.cameras)}; --camera PATH chooses one):" if result.cameras else "cameras: none")
    for path in result.cameras:
        print(f"  {path}{'  (used)' if path == cam.source else ''}")
    s = scene.settings
    print(
        f"settings: {s.source or '(defaults)'}: {s.width}x{s.height}, samples {s.samples} ({s.sample_pattern}"
        f"{f', threshold {s.aa_threshold:g}' if s.aa_threshold else ''}), "
        f"specular {s.specular}, background {_vector(s.background)}"
        + (f", max_depth {s.max_depth}, transmission {s.transmission}" if secondary else "")
    )
    print_warnings(result.warnings, sys.stdout, every=True)
    return EXIT_OK


def _vector(v) -> str:
    return "(" + ", ".join(f"{float(c):.6g}" for c in v) + ")"


def add_validate_command(sub) -> None:
    p = sub.add_parser(
        "validate",
        help="check a USD scene; list every problem",
        description="Read and validate SCENE. Prints 'ok' and exits 0 when it is valid; otherwise prints "
        "one problem per line on stderr (file: prim.attribute: what is wrong) and exits 2.",
        epilog="Exit codes: 0 valid, 2 invalid (with --strict: also when there is a warning).",
    )
    add_scene_argument(p)
    p.add_argument("-q", "--quiet", action="store_true", help="do not print warnings")
    p.add_argument(
        "--strict",
        action="store_true",
        help="treat every warning (a typo'd name, an ignored feature, a default camera or light) as an error",
    )
    add_sandbox_option(p)
    p.set_defaults(func=run_validate)


def run_validate(args) -> int:
    from ..scene_files import read_scene_file

    result = read_scene_file(args.scene, sandbox=args.sandbox)
    if args.strict and result.warnings:
        for warning in result.warnings:
            print(f"error: {args.scene}: {warning}", file=sys.stderr)
        return EXIT_SCENE
    if not args.quiet:
        print_warnings(result.warnings)
    print(f"ok: {args.scene}")
    return EXIT_OK
