# SPDX-License-Identifier: Apache-2.0
"""``phongscene preview``: render a scene natively in this process, serve the image on a local
web page and render again whenever the scene, a layer or a texture of it changes
(``phongscene.preview``). Runs until Ctrl-C (exit 130, one line) or SIGTERM."""

from __future__ import annotations

from .options import add_override_options, add_scene_argument, add_single_time_option, int_in, overrides_from_args


def add_preview_command(sub) -> None:
    p = sub.add_parser(
        "preview",
        help="render a scene on a local web page and render again on every edit",
        description="Render SCENE natively and serve it on http://127.0.0.1:PORT/. The page shows the latest "
        "image (a coarse pass first, then the full image) and the scene's errors and warnings; SCENE, every "
        "layer it uses and every texture it reads are watched, and each change is rendered in this process "
        "(stage and tracer stay loaded). Ctrl-C ends it.",
        epilog="Exit codes: 130 ended with Ctrl-C, 2 bad usage (a port in use).",
    )
    add_scene_argument(p)
    p.add_argument(
        "--port",
        type=int_in(0, 65535),
        default=8000,
        metavar="N",
        help="the local port to serve on (default 8000; 0: any free port)",
    )
    add_single_time_option(p)
    add_override_options(
        p,
        mapping_help="specular convention: exact or classic (as render --mapping); default: the scene's",
        shadow_cells=True,
        threads_help="worker threads (0 = all cores)",
    )
    p.set_defaults(func=run_preview)


def run_preview(args) -> int:
    from ..preview import Preview, make_server, serve_in_thread
    from .options import UsageError

    preview = Preview(args.scene, overrides_from_args(args))
    try:
        server = make_server(preview, args.port)
    except OSError as e:
        raise UsageError(f"--port {args.port}: cannot serve on 127.0.0.1: {e.strerror or e}") from None
    try:
        serve_in_thread(server)
        host, port = server.server_address[:2]
        print(f"previewing {args.scene} on http://{host}:{port}/ (Ctrl-C to stop)", flush=True)
        preview.run()  # until Ctrl-C: KeyboardInterrupt, which main prints as one line, exit 130
    finally:
        server.shutdown()
        server.server_close()
        preview.close()
    return 0
