# SPDX-License-Identifier: Apache-2.0
"""Warnings that read: the same message about many prims is one line (a count and the first
few prims), and a command prints at most ``MAX_WARNING_LINES`` lines, saying how many more
there are and where to see them all (`phongscene info` lists every warning).

One missing layer referenced by 500 instanced assets used to print 500 lines; USD caps its own
diagnostics at 10 of a kind, and so do we, by grouping messages that differ only in the prim
path they start with. A command that caps its lines also merges messages that differ in the prim
paths they name besides: one missing layer referenced by 548 teapot prims, each through one of 24
``</_teapot_animCycle_offset_N>`` prims, was 24 lines and over the cap (usd-wg's
teapotScene_animCycle.usd), and is one. `info` keeps those apart."""

from __future__ import annotations

import re
from collections import defaultdict

# Lines a command prints before "… and N more": a screenful, enough for every distinct cause a
# scene of the public sweep has (benchmarks/warning_sweep.py over usd-wg/assets, pablode/usd-assets
# and ft-lab/sample_usd, 338 files, 2026-12-04: the most render or compile printed was 14).
MAX_WARNING_LINES = 20
# Prims named in a grouped line; the count says the rest.
PRIMS_SHOWN = 3
# Lines a command keeps free after the reader's warnings, for the image check's warning (at most
# one line, phongscene.diagnostics.ImageChecks) printed when the render is done.
IMAGE_CHECK_LINES = 1
# A warning about one prim: "/Path/To/Prim[.attribute]: message".
_ABOUT_A_PRIM = re.compile(r"^(?P<prim>/[^\s:.]*)(?P<attribute>\.[\w:]+)?: (?P<message>.+)$", re.DOTALL)
# A prim path named inside a message ("targets /World/Looks/M", "@a.usd@</Prim>"): after a
# space, '<' or '(', never inside an @asset path@ or a file name, ending where the path does.
_NAMED_PATH = re.compile(r"(?<=[\s<(])/[A-Za-z_]\w*(?:/[A-Za-z_]\w*)*(?:\.[A-Za-z_][\w:]*)?(?=$|[\s>,;:)]|\.(?:\s|$))")


def grouped(warnings, *, merge_named_paths: bool = False) -> list[str]:
    """``warnings`` in their order, those that differ only in their leading prim path merged into
    one line at the place of the first; with ``merge_named_paths``, also those that differ in
    the prim paths their message names (the line shows the first message's paths, each followed
    by how many there are where they differ)."""
    order: list[tuple] = []
    prims: dict[tuple, list[str]] = defaultdict(list)
    messages: dict[tuple, list[str]] = defaultdict(list)
    for warning in warnings:
        match = _ABOUT_A_PRIM.match(warning)
        if match:
            message = match["message"]
            key = ("prim", match["attribute"] or "", _NAMED_PATH.sub("/", message) if merge_named_paths else message)
        else:
            key = ("text", warning)
        if key not in prims:
            order.append(key)
        prims[key].append(match["prim"] if match else warning)
        messages[key].append(match["message"] if match else warning)
    lines = []
    for key in order:
        if key[0] == "text":
            lines.extend(prims[key])
            continue
        _, attribute, _ = key
        paths, message = prims[key], _with_path_counts(messages[key])
        if len(paths) == 1:
            lines.append(f"{paths[0]}{attribute}: {message}")
            continue
        shown = ", ".join(f"{p}{attribute}" for p in paths[:PRIMS_SHOWN])
        more = f" and {len(paths) - PRIMS_SHOWN} more" if len(paths) > PRIMS_SHOWN else ""
        lines.append(f"{len(paths)} prims: {message} ({shown}{more})")
    return lines


def _with_path_counts(messages: list[str]) -> str:
    """The first of ``messages`` (which differ at most in the prim paths they name), each path
    that differs among them followed by "(or another of N paths)"."""
    first = messages[0]
    if len(set(messages)) == 1:
        return first
    named = [[m.group() for m in _NAMED_PATH.finditer(message)] for message in messages]
    distinct = [len(set(paths)) for paths in zip(*named)]
    parts, end = [], 0
    for m, count in zip(_NAMED_PATH.finditer(first), distinct):
        stop = m.end() + first.startswith(">", m.end())  # after a reference's </Prim>, not inside it
        parts.append(first[end:stop] + (f" (or another of {count} paths)" if count > 1 else ""))
        end = stop
    return "".join(parts) + first[end:]


def capped(lines: list[str], limit: int = MAX_WARNING_LINES) -> list[str]:
    """At most ``limit`` lines, the last saying how many were left out."""
    if len(lines) <= limit:
        return lines
    return lines[: limit - 1] + [
        f"... and {len(lines) - limit + 1} more warnings (`phongscene info SCENE` lists them all)"
    ]
