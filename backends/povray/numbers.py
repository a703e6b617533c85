# SPDX-License-Identifier: Apache-2.0
"""Numbers as SDL text: exact scalars, and vectorised bulk formatting for mesh2 arrays.

Scalars are printed with ``repr`` (the shortest decimal that reads back as the same float64,
at most 17 significant digits); never ``%g``, whose 6 digits once cost an 11x error in the
camera (reference §13, e01).

``mesh2`` stores vertices and normals as float32 (reference §7), so a mesh array is first
rounded to float32 and printed with 9 significant digits. That reads back to the identical
float32 POV-Ray would have stored from the 17-digit float64: 9 digits are within 1.5e-8
relative of the float32 value even if the last digit is off by one (below), while the
nearest rounding boundary of float32 is at least 2**-25 ~ 2.98e-8 relative away.
Formatting is done in numpy on a byte matrix (one row per number), so a 1M-triangle mesh
compiles in a fraction of a second; Python never formats a mesh number by itself.
"""

from __future__ import annotations

import math

import numpy as np

# Significant digits for float32 data (FLT_DECIMAL_DIG = 9 round-trips every float32).
FLOAT32_DIGITS = 9
_PAD = 0  # byte that marks "no character" in a format matrix; removed when joining
_WIDTH = 15  # "-d.dddddddde-XX"


class NonFiniteNumber(ValueError):
    """A number that SDL cannot hold (NaN, ±inf, or beyond float32 in mesh data)."""


def sdl_float(x: float) -> str:
    """One float64 as SDL text: the shortest exact decimal (``repr``); -0.0 prints as 0.0."""
    x = float(x)
    if not math.isfinite(x):
        raise NonFiniteNumber(repr(x))
    return repr(x + 0.0)


def sdl_vector(v) -> str:
    """A 3-vector as ``<x, y, z>`` with exact floats."""
    return "<" + ", ".join(sdl_float(c) for c in v) + ">"


def _float32_matrix(values: np.ndarray) -> np.ndarray:
    """Format float32-rounded ``values`` (1-D float64) into a (_WIDTH, N) uint8 matrix.

    Layout: ``-d.dddddddde-XX`` with 9 significant digits, trailing zeros (and a bare decimal
    point) trimmed, and no exponent when it is 0; zero prints as ``0``. One fixed layout keeps
    every step a whole-row numpy operation (the matrix is column-major: one row per column
    of text), which is what makes a million vertices take tens of milliseconds.
    """
    top = FLOAT32_DIGITS - 1
    mag = np.abs(values)
    zero = mag == 0
    safe = np.where(zero, 1.0, mag)
    # Decimal exponent and the 9-digit integer mantissa m in [1e8, 1e9). log10 and the power
    # of ten may each be off by an ulp, so the exponent is corrected where m left the range.
    exp10 = np.floor(np.log10(safe)).astype(np.int32)
    m = np.rint(safe * np.power(10.0, top - exp10, dtype=np.float64))
    off = np.flatnonzero((m >= 10.0**FLOAT32_DIGITS) | (m < 10.0**top))
    if off.size:
        exp10[off] += np.where(m[off] >= 10.0**FLOAT32_DIGITS, 1, -1).astype(np.int32)
        m[off] = np.rint(safe[off] * np.power(10.0, top - exp10[off], dtype=np.float64))
    m[zero] = 0
    exp10[zero] = 0

    out = np.zeros((_WIDTH, values.shape[0]), dtype=np.uint8)
    out[0] = (values < 0) * ord("-")
    rest = m.astype(np.uint32)  # < 1e9 < 2**32
    significant = np.zeros(values.shape[0], dtype=bool)  # a non-zero digit at or after k
    for k in range(top, -1, -1):
        q = rest // 10
        digit = (rest - q * 10).astype(np.uint8)
        significant |= digit != 0
        # Digit k goes to column 1 (k = 0) or 2 + k (after the point); trailing zeros are padding.
        out[1 if k == 0 else 2 + k] = (digit + ord("0")) * (significant | (k == 0))
        rest = q
    out[2] = (out[3] != _PAD) * ord(".")
    out[1, zero] = ord("0")
    e_abs = np.abs(exp10)
    scientific = exp10 != 0
    out[11] = scientific * ord("e")
    out[12] = (exp10 < 0) * ord("-")
    out[13] = (e_abs >= 10) * (e_abs // 10 + ord("0")).astype(np.uint8)
    out[14] = scientific * (e_abs % 10 + ord("0")).astype(np.uint8)
    return out


def _int_matrix(values: np.ndarray) -> np.ndarray:
    """Format non-negative integers (1-D, < 2**32) into a (width, N) uint8 matrix, where
    width is the digit count of the largest value."""
    rest = values.astype(np.uint32)
    width = len(str(int(rest.max()))) if rest.size else 1
    digits = np.empty((width, rest.shape[0]), dtype=np.uint8)
    for k in range(width - 1, -1, -1):
        q = rest // 10
        digits[k] = rest - q * 10
        rest = q
    # Leading zeros are padding, except the last digit (so 0 prints as "0").
    significant = np.logical_or.accumulate(digits != 0, axis=0)
    significant[-1] = True
    digits += ord("0")
    digits *= significant
    return digits


def _vector_lines(cells: np.ndarray, per_line: int = 1) -> str:
    """Join a (W, 3N) column-major byte matrix (x, y, z of each vector in turn) into
    ``<x,y,z>`` entries separated by ``,`` and a newline after every ``per_line``."""
    width = cells.shape[0]
    n = cells.shape[1] // 3
    if n == 0:
        return ""
    xyz = cells.reshape(width, n, 3)

    def byte(ch: str | int) -> np.ndarray:
        return np.full((1, n), ord(ch) if isinstance(ch, str) else ch, dtype=np.uint8)

    comma = byte(",")
    comma[0, -1] = _PAD
    newline = byte(_PAD)
    newline[0, per_line - 1 :: per_line] = ord("\n")
    newline[0, -1] = _PAD
    parts = [byte("<"), xyz[:, :, 0], byte(","), xyz[:, :, 1], byte(","), xyz[:, :, 2], byte(">"), comma, newline]
    line = np.concatenate(parts, axis=0).T.ravel()
    return line[line != _PAD].tobytes().decode("ascii")


def float32_vectors(points: np.ndarray) -> str:
    """(N, 3) floats as mesh2 text ``<x,y,z>,`` one per line, at float32 precision.

    Raises:
        NonFiniteNumber: a value is NaN/inf or overflows float32 (|x| > 3.4e38).
    """
    values = np.asarray(points, dtype=np.float64).reshape(-1)
    with np.errstate(over="ignore"):
        as32 = values.astype(np.float32)
    if not np.all(np.isfinite(as32)):
        bad = values[~np.isfinite(as32)][0]
        raise NonFiniteNumber(f"{bad!r} (mesh2 stores float32: |x| must be <= 3.4e38)")
    return _vector_lines(_float32_matrix(as32.astype(np.float64)))


def int_vectors(indices: np.ndarray, per_line: int = 4) -> str:
    """(M, 3) non-negative integers as mesh2 text ``<a,b,c>,``, ``per_line`` per line."""
    flat = np.asarray(indices).reshape(-1)
    return _vector_lines(_int_matrix(flat), per_line)
