# SPDX-License-Identifier: Apache-2.0
"""The ``info``, ``validate`` and ``import`` subcommands. ``pxr`` is imported only when one of
them runs, so the rest of the CLI starts fast."""

from __future__ import annotations

import sys


def add_usd_commands(sub) -> None:
    """Register ``phongscene info``, ``validate`` and ``import`` on the CLI's subparsers."""
    p = sub.add_parser(
        "info",
        help="show what phongscene reads from a USD scene",
        description="Read SCENE and print which prims became which model nodes, the counts of meshes, "
        "triangles, spheres, lights and materials, the camera, the render settings and every warning "
        "(unsupported prims, defaults used).",
        epilog="Exit codes: 0 ok, 2 the scene is invalid (one problem per line on stderr).",
    )
    p.add_argument("scene", metavar="SCENE", help="USD file (.usda, .usdc, .usd, .usdz)")
    p.set_defaults(func=_run_info)

    p = sub.add_parser(
        "validate",
        help="check a USD scene; list every problem",
        description="Read and validate SCENE. Prints 'ok' and exits 0 when it is valid; otherwise prints "
        "one problem per line on stderr (file: prim.attribute: what is wrong) and exits 2.",
        epilog="Exit codes: 0 valid, 2 invalid.",
    )
    p.add_argument("scene", metavar="SCENE", help="USD file (.usda, .usdc, .usd, .usdz)")
    p.add_argument("-q", "--quiet", action="store_true", help="do not print warnings")
    p.set_defaults(func=_run_validate)

    p = sub.add_parser(
        "import",
        help="convert a mesh file (OBJ, PLY, STL, GLB, ...) to a USD scene",
        description="Read MESHFILE with trimesh and write a USD file with one Mesh (vertex normals, "
        "subdivisionScheme none) bound to a default Phong material. The scene has no camera or "
        "lights, so renderers use the framing camera and the head light.",
        epilog="Exit codes: 0 ok, 2 unreadable input or bad output path.",
    )
    p.add_argument("mesh", metavar="MESHFILE", help="any format trimesh.load reads")
    p.add_argument("-o", "--output", required=True, metavar="OUT", help="USD file to write (.usda, .usdc, .usd)")
    p.set_defaults(func=_run_import)


def _run_info(args) -> int:
    from .usd import read_usd

    result = read_usd(args.scene)
    scene = result.scene
    out = sys.stdout
    print(f"file: {scene.source_file}", file=out)
    print("prims -> model nodes:", file=out)
    for prim, node in result.nodes:
        print(f"  {prim} -> {node}", file=out)
    materials = {id(m.material): m.material for m in (*scene.spheres, *scene.meshes)}
    kinds: dict[str, int] = {}
    for light in scene.lights:
        kinds[type(light).__name__] = kinds.get(type(light).__name__, 0) + 1
    print(
        f"counts: {len(scene.meshes)} meshes, {scene.triangle_count} triangles, {len(scene.spheres)} spheres, "
        f"{len(scene.lights)} lights ({', '.join(f'{n} {k}' for k, n in sorted(kinds.items())) or 'none'}), "
        f"{len(materials)} materials",
        file=out,
    )
    print(f"ambient: {_fmt(scene.ambient.color)}", file=out)
    cam = scene.camera
    extent = f"hfov {cam.horizontal_fov_deg:.6g} deg" if cam.projection == "perspective" else f"width {cam.ortho_width:.6g}"
    print(
        f"camera: {cam.source or '(model default)'}: {cam.projection}, {extent}, position {_fmt(cam.position)}, "
        f"forward {_fmt(cam.forward)}, up {_fmt(cam.up)}",
        file=out,
    )
    s = scene.settings
    print(
        f"settings: {s.source or '(defaults)'}: {s.width}x{s.height}, samples {s.samples} ({s.sample_pattern}), "
        f"specular {s.specular}, background {_fmt(s.background)}",
        file=out,
    )
    for warning in result.warnings:
        print(f"warning: {warning}", file=out)
    return 0


def _run_validate(args) -> int:
    from .usd import read_usd

    result = read_usd(args.scene)
    if not args.quiet:
        for warning in result.warnings:
            print(f"warning: {warning}", file=sys.stderr)
    print(f"ok: {args.scene}")
    return 0


def _run_import(args) -> int:
    from .usd import import_mesh

    path = import_mesh(args.mesh, args.output)
    print(f"wrote {path}")
    return 0


def _fmt(v) -> str:
    return "(" + ", ".join(f"{float(c):.6g}" for c in v) + ")"
