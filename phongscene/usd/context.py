# SPDX-License-Identifier: Apache-2.0
"""State shared while one stage is read: collected problems and warnings, world transforms
(with the Z-up → Y-up correction) and type-checked attribute access."""

from __future__ import annotations

import functools
import re
from collections import defaultdict

import numpy as np
from pxr import Gf, Tf, Usd, UsdGeom

from ..errors import Problem
from ..tolerances import KEEP_UNIT
from .names import COLOR_TYPES, FLOAT_TYPES
from .skinning import Skinning

# A Z-up stage is rotated −90° about X into the model's Y-up frame: (x, y, z) → (x, z, −y).
Z_UP_TO_Y_UP = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, -1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]])


def tf_error_text(error: Exception) -> str:
    """The message of a USD (Tf) error without its C++ source location."""
    try:
        text = str(error)
    except UnicodeDecodeError:
        return "(USD's message could not be decoded)"
    found = re.findall(r" : '(.*)'", text)
    return found[-1] if found else text.strip()


def unit(v: np.ndarray) -> np.ndarray | None:
    """``v / |v|``, or ``v`` itself when already unit to a few ulps; None for a zero vector."""
    length = float(np.linalg.norm(v))
    if length == 0 or not np.isfinite(length):
        return None
    return v if abs(length - 1.0) <= KEEP_UNIT else v / length


def authored_type(attr) -> str:
    """The type the file authored (the strongest spec), which may differ from the schema's:
    ``GetTypeName()`` reports the schema type even when a file writes ``int[] normals``."""
    stack = attr.GetPropertyStack(Usd.TimeCode.Default())
    return str(stack[0].typeName) if stack else str(attr.GetTypeName())


def gf_to_numpy(m: Gf.Matrix4d) -> np.ndarray:
    """A USD (row-vector) matrix as a column-vector numpy matrix."""
    return np.array(m, dtype=np.float64).T


class ReadContext:
    """Problems, warnings and transforms for one stage being read."""

    def __init__(
        self,
        stage: Usd.Stage,
        file: str,
        time: Usd.TimeCode = Usd.TimeCode.Default(),  # noqa: B008 (an immutable value)
        types: dict | None = None,
    ):
        self.stage = stage
        self.file = file
        # Every subdivision surface's refinement level when the reader is told one (the CLI's
        # --subdivision-level); None: each prim's phong:subdivisionLevel or the default.
        self.subdivision_level: int | None = None
        self.problems: list[Problem] = []
        self.warnings: list[str] = []
        # One warning per kind of unsupported thing, listing every prim.
        self.unsupported: dict[str, list[str]] = defaultdict(list)
        self.nodes: list[tuple[str, str]] = []  # (prim path, model node) for `phongscene info`
        # Every value is read at this one time code (the reader chooses it: reader._time_to_read);
        # transforms through one cache at it, so USD's interpolation applies everywhere.
        self.time = time
        self.xforms = UsdGeom.XformCache(self.time)
        self.z_up = UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.z
        # Attribute path -> the type its file authored (the same at every time: kept by a stage
        # read at many times, ``reader.OpenStage``).
        self.types = {} if types is None else types

    @functools.cached_property
    def skinning(self) -> Skinning:
        """The stage's UsdSkel skinning at ``time``, made on first use."""
        return Skinning(self)

    def problem(self, prim, attribute: str, message: str) -> None:
        path = str(prim.GetPath()) if hasattr(prim, "GetPath") else str(prim)
        self.problems.append(Problem(message, prim=path, attribute=attribute, file=self.file))

    def warn(self, message: str) -> None:
        self.warnings.append(message)

    def flush_unsupported(self) -> None:
        for what, paths in self.unsupported.items():
            shown = ", ".join(paths[:10]) + (f" and {len(paths) - 10} more" if len(paths) > 10 else "")
            self.warn(f"{what} ({len(paths)}): {shown}")
        self.unsupported.clear()

    # -- transforms ---------------------------------------------------------------------------

    def to_model(self, m: np.ndarray) -> np.ndarray:
        """A column-vector stage-world matrix → model world (Y-up)."""
        return Z_UP_TO_Y_UP @ m if self.z_up else m

    def world(self, prim: Usd.Prim) -> np.ndarray:
        """The prim's local-to-world matrix in model space (column vectors, Y-up). An xformOp USD
        cannot evaluate (``xformOp:tranlate``) is a problem naming the prim; identity is used."""
        try:
            return self.to_model(gf_to_numpy(self.xforms.GetLocalToWorldTransform(prim)))
        except Tf.ErrorException as e:
            self.problem(prim, "xformOpOrder", f"USD cannot evaluate the transform: {tf_error_text(e)}")
            return np.eye(4)

    # -- attributes -----------------------------------------------------------------------------

    def authored_type(self, attr) -> str:
        """``authored_type(attr)``, looked up once per attribute of the stage."""
        path = attr.GetPath()
        found = self.types.get(path)
        if found is None:
            found = self.types[path] = authored_type(attr)
        return found

    def get(self, prim: Usd.Prim, name: str, types: tuple[str, ...], default=None):
        """The attribute's value (authored or schema fallback) if its type is one of ``types``.

        A wrong type is a problem (and ``default`` is returned); a missing attribute or value
        gives ``default``.
        """
        attr = prim.GetAttribute(name)
        if not attr:
            return default
        type_name = self.authored_type(attr)
        if type_name not in types:
            self.problem(prim, name, f"has type {type_name}, expected {' or '.join(types)}")
            return default
        value = attr.Get(self.time)
        return default if value is None else value

    def number(self, prim, name: str, default: float, *, minimum: float | None = None, strict: bool = False) -> float:
        """A finite float attribute, optionally >= (or > with ``strict``) ``minimum``."""
        value = float(self.get(prim, name, FLOAT_TYPES, default))
        if not np.isfinite(value):
            self.problem(prim, name, f"must be finite, got {value!r}")
            return default
        if minimum is not None and (value <= minimum if strict else value < minimum):
            self.problem(prim, name, f"must be {'>' if strict else '>='} {minimum:g}, got {value!r}")
            return default  # reported once: the model built from it must not report it again
        return value

    def color(self, prim, name: str, default) -> tuple[float, float, float]:
        value = self.get(prim, name, COLOR_TYPES, default)
        out = tuple(float(c) for c in value)
        if not all(np.isfinite(out)):
            self.problem(prim, name, f"must be finite, got {out}")
            return tuple(float(c) for c in default)
        return out
