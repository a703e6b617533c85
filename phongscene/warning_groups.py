# SPDX-License-Identifier: Apache-2.0
"""Warnings that read: the same message about many prims is one line (a count and the first
few prims), and a command prints at most ``MAX_WARNING_LINES`` lines, saying how many more
there are and where to see them all (`phongscene info` lists every warning).

One missing layer referenced by 500 instanced assets used to print 500 lines; USD caps its own
diagnostics at 10 of a kind, and so do we, by grouping messages that differ only in the prim
path they start with."""

from __future__ import annotations

import re
from collections import defaultdict

# Lines a command prints before "… and N more": a screenful, enough for every distinct cause a
# scene of the public sweep has (the most seen was 14).
MAX_WARNING_LINES = 20
# Prims named in a grouped line; the count says the rest.
PRIMS_SHOWN = 3
# A warning about one prim: "/Path/To/Prim[.attribute]: message".
_ABOUT_A_PRIM = re.compile(r"^(?P<prim>/[^\s:.]*)(?P<attribute>\.[\w:]+)?: (?P<message>.+)$", re.DOTALL)


def grouped(warnings) -> list[str]:
    """``warnings`` in their order, those that differ only in their leading prim path merged into
    one line at the place of the first."""
    order: list[tuple] = []
    prims: dict[tuple, list[str]] = defaultdict(list)
    for warning in warnings:
        match = _ABOUT_A_PRIM.match(warning)
        key = ("prim", match["attribute"] or "", match["message"]) if match else ("text", warning)
        if key not in prims:
            order.append(key)
        prims[key].append(match["prim"] if match else warning)
    lines = []
    for key in order:
        if key[0] == "text":
            lines.extend(prims[key])
            continue
        _, attribute, message = key
        paths = prims[key]
        if len(paths) == 1:
            lines.append(f"{paths[0]}{attribute}: {message}")
            continue
        shown = ", ".join(f"{p}{attribute}" for p in paths[:PRIMS_SHOWN])
        more = f" and {len(paths) - PRIMS_SHOWN} more" if len(paths) > PRIMS_SHOWN else ""
        lines.append(f"{len(paths)} prims: {message} ({shown}{more})")
    return lines


def capped(lines: list[str], limit: int = MAX_WARNING_LINES) -> list[str]:
    """At most ``limit`` lines, the last saying how many were left out."""
    if len(lines) <= limit:
        return lines
    return lines[: limit - 1] + [
        f"... and {len(lines) - limit + 1} more warnings (`phongscene info SCENE` lists them all)"
    ]
