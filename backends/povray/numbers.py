# SPDX-License-Identifier: Apache-2.0
"""Numbers as SDL text: exact scalars, and vectorised bulk formatting for mesh2 arrays.

Scalars are printed with ``repr`` (the shortest decimal that reads back as the same float64,
at most 17 significant digits); never ``%g``, whose 6 digits once cost an 11x error in the
camera (ref §13, e01). Numbers POV-Ray stores as float32 (colours and finish coefficients, ref §2)
are printed as the shortest decimal that reads back as that float32 (``sdl_float32``): ``rgb
<0.2, ...>``, not ``rgb <0.20000000298023224, ...>``, and POV-Ray stores the same value.

``mesh2`` stores vertices and normals as float32 (ref §7), so a mesh array is first
rounded to float32 and printed with 9 significant digits. That reads back to the identical
float32 POV-Ray would have stored from the 17-digit float64: 9 digits are within 1.5e-8
relative of the float32 value even if the last digit is off by one (below), while the
nearest rounding boundary of float32 is at least 2**-25 ~ 2.98e-8 relative away.
Formatting is done in numpy on byte matrices (one row per number) with digit lookup tables, so
a 1M-triangle mesh compiles in a fraction of a second; Python never formats a mesh number.

POV-Ray facts cite ``docs/povray-3.7-semantics.md`` as "ref §n".
"""

from __future__ import annotations

import functools
import math

import numpy as np

# Significant digits for float32 data (FLT_DECIMAL_DIG = 9 round-trips every float32).
FLOAT32_DIGITS = 9
_PAD = 0  # byte that marks "no character" in a formatted row; removed when joining


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


# Below and above these magnitudes a float32 prints in scientific notation (as numpy's str does),
# so that no number needs dozens of zeros.
_POSITIONAL_RANGE = (1e-4, 1e7)


def sdl_float32(x: float) -> str:
    """A number POV-Ray stores as float32 (a colour channel, a finish coefficient; ref §2): the
    shortest decimal (numpy's unique float32 formatting) that POV-Ray, reading it to a double and
    storing it as float32, turns into the same float32 as it does ``sdl_float(x)``. Where the two
    roundings (decimal -> double -> float32) could disagree, or the value overflows float32, the
    exact ``sdl_float`` text is kept."""
    exact = sdl_float(x)  # also rejects NaN and infinities
    with np.errstate(over="ignore"):
        stored = np.float32(float(exact))
    if not np.isfinite(stored):
        return exact
    if stored == 0 or _POSITIONAL_RANGE[0] <= abs(stored) < _POSITIONAL_RANGE[1]:
        short = np.format_float_positional(stored, unique=True, trim="0")
    else:
        short = np.format_float_scientific(stored, unique=True, trim="-").replace("+", "")
    return short if np.float32(float(short)) == stored else exact


def sdl_color(v) -> str:
    """A colour (three float32 channels in POV-Ray) as ``<r, g, b>``, each ``sdl_float32``."""
    return "<" + ", ".join(sdl_float32(c) for c in v) + ">"


def _digits(values: np.ndarray, count: int) -> np.ndarray:
    """The ``count`` decimal digits of non-negative integers, most significant first, (N, count)."""
    out = np.empty((values.shape[0], count), dtype=np.uint8)
    rest = values.astype(np.int64)
    for k in range(count - 1, -1, -1):
        rest, out[:, k] = np.divmod(rest, 10)
    return out


def _trim_trailing_zeros(chars: np.ndarray) -> np.ndarray:
    """Digit characters (N, k) with trailing '0's replaced by padding."""
    significant = np.logical_or.accumulate(chars[:, ::-1] != ord("0"), axis=1)[:, ::-1]
    return np.where(significant, chars, _PAD).astype(np.uint8)


def _words(rows: np.ndarray, dtype: str) -> np.ndarray:
    """Byte rows (N, k·size) as (N, k) little-endian words, so a lookup moves a whole row."""
    return np.ascontiguousarray(rows).view(dtype)


@functools.cache
def _mantissa_tables() -> tuple[np.ndarray, np.ndarray]:
    """Lookup tables for a signed 9-digit mantissa m = hi·10⁴ + lo, hi in [10⁴, 10⁵), as 8-byte words:

    * ``head[(2·negative + trimmed)·9·10⁴ + hi − 10⁴]`` = ``-d0.d1d2d3d4`` (sign and point as
      needed; "trimmed", used when lo = 0, turns trailing zeros and a bare point into padding);
    * ``tail[lo]`` = ``d5d6d7d8`` with trailing zeros as padding (all padding for lo = 0).
    """
    hi = _digits(np.arange(10**4, 10**5), 5) + ord("0")
    n = hi.shape[0]
    pad = np.full((n, 1), _PAD, np.uint8)
    point = np.full((n, 1), ord("."), np.uint8)
    fraction = _trim_trailing_zeros(hi[:, 1:])
    point_if_any = np.where(fraction[:, :1] != _PAD, ord("."), _PAD).astype(np.uint8)
    heads = []
    for sign in (pad, np.full((n, 1), ord("-"), np.uint8)):
        heads.append(np.concatenate([sign, hi[:, :1], point, hi[:, 1:], pad], axis=1))
        heads.append(np.concatenate([sign, hi[:, :1], point_if_any, fraction, pad], axis=1))
    head = _words(np.concatenate(heads), "<u8")[:, 0]
    tail = _words(_trim_trailing_zeros(_digits(np.arange(10**4), 4) + ord("0")), "<u4")[:, 0]
    return head, tail


@functools.cache
def _exponent_table() -> np.ndarray:
    """``e-XX`` (4 bytes, padded, as a word) for decimal exponents -50..49 at index E + 50; none for 0."""
    rows = []
    for e in range(-50, 50):
        text = f"e{e}" if e else ""
        rows.append(list(text.encode("ascii")) + [_PAD] * (4 - len(text)))
    return _words(np.array(rows, dtype=np.uint8), "<u4")[:, 0]


def _float32_words(values: np.ndarray) -> np.ndarray:
    """Format float32-rounded ``values`` (1-D float64) as (N, 2) 8-byte words of text.

    Layout: ``-d.dddddddde-XX`` with 9 significant digits, trailing zeros (and a bare decimal
    point) as padding, no exponent when it is 0; zero prints as ``0``. The digits come from
    lookup tables of whole words, so each step is one whole-array numpy operation.
    """
    top = FLOAT32_DIGITS - 1
    mag = np.abs(values)
    zero = mag == 0
    safe = np.where(zero, 1.0, mag)
    # Decimal exponent and the 9-digit integer mantissa m in [1e8, 1e9). log10 and the power
    # of ten may each be off by an ulp, so the exponent is corrected where m left the range.
    exp10 = np.floor(np.log10(safe)).astype(np.int64)
    m = np.rint(safe * np.power(10.0, top - exp10, dtype=np.float64))
    off = np.flatnonzero((m >= 10.0**FLOAT32_DIGITS) | (m < 10.0**top))
    if off.size:
        exp10[off] += np.where(m[off] >= 10.0**FLOAT32_DIGITS, 1, -1)
        m[off] = np.rint(safe[off] * np.power(10.0, top - exp10[off], dtype=np.float64))
    # Zero is formatted as "1" (m = 10^8, exponent 0) and its digit patched below.
    m[zero] = 10.0**top
    exp10[zero] = 0

    hi, lo = np.divmod(m.astype(np.int64), 10**4)
    head, tail = _mantissa_tables()
    variant = 2 * (values < 0) + (lo == 0)
    words = np.empty((values.shape[0], 2), dtype="<u8")
    words[:, 0] = head[variant * (9 * 10**4) + (hi - 10**4)]
    words[:, 1] = tail[lo].astype("<u8") | (_exponent_table()[exp10 + 50].astype("<u8") << np.uint64(32))
    # "1" -> "0": the digit of a zero is byte 1 (after the sign slot).
    as_bytes = words.view(np.uint8).reshape(-1, 16)
    as_bytes[zero, 1] = ord("0")
    return words


@functools.cache
def _int_table() -> np.ndarray:
    """Four-digit groups as 4-byte words at index kind·10⁴ + g: kind 0 = nothing (before the
    first non-zero group), 1 = leading group (no leading zeros), 2 = inner group (zero-padded)."""
    full = _digits(np.arange(10**4), 4) + ord("0")
    significant = np.logical_or.accumulate(full != ord("0"), axis=1)
    significant[0, -1] = True  # the value 0 prints as "0"
    leading = np.where(significant, full, _PAD).astype(np.uint8)
    return _words(np.concatenate([np.full_like(full, _PAD), leading, full]), "<u4")[:, 0]


def _int_words(values: np.ndarray) -> np.ndarray:
    """Format non-negative integers (1-D, < 2**31) as (N, groups) 4-byte words of text."""
    v = values.astype(np.int64)
    groups = max(1, -(-len(str(int(v.max()))) // 4)) if v.size else 1
    table = _int_table()
    words = np.empty((v.shape[0], groups), dtype="<u4")
    started = np.zeros(v.shape[0], dtype=bool)
    for j in range(groups):
        g = (v // 10 ** (4 * (groups - 1 - j))) % 10**4
        # The units group always prints (so 0 -> "0"); before the first non-zero group, nothing.
        lead = ~started & ((g != 0) | (j == groups - 1))
        kind = np.where(started, 2, lead.astype(np.int64))
        words[:, j] = table[kind * 10**4 + g]
        started |= lead
    return words


def _vector_lines(words: np.ndarray, per_line: int = 1) -> str:
    """Join (3N, k) words of formatted numbers (x, y, z of each vector in turn) into
    ``<x,y,z>`` entries separated by ``,`` with a newline after every ``per_line`` entries."""
    k = words.shape[1]
    n = words.shape[0] // 3
    if n == 0:
        return ""
    dtype = words.dtype
    xyz = words.reshape(n, 3 * k)

    def word(text: bytes) -> np.ndarray:
        return np.frombuffer(text.ljust(dtype.itemsize, bytes([_PAD])), dtype=dtype)[0]

    out = np.empty((n, 3 * k + 4), dtype=dtype)
    out[:, 0] = word(b"<")
    out[:, 1 : 1 + k] = xyz[:, :k]
    out[:, 1 + k] = word(b",")
    out[:, 2 + k : 2 + 2 * k] = xyz[:, k : 2 * k]
    out[:, 2 + 2 * k] = word(b",")
    out[:, 3 + 2 * k : 3 + 3 * k] = xyz[:, 2 * k :]
    out[:, 3 + 3 * k] = word(b">,")
    out[per_line - 1 :: per_line, 3 + 3 * k] = word(b">,\n")
    out[-1, 3 + 3 * k] = word(b">")
    # bytes.translate drops the padding about twice as fast as a numpy boolean mask.
    return out.tobytes().translate(None, bytes([_PAD])).decode("ascii")


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
    return _vector_lines(_float32_words(as32.astype(np.float64)))


def int_vectors(indices: np.ndarray, per_line: int = 4) -> str:
    """(M, 3) non-negative integers as mesh2 text ``<a,b,c>,``, ``per_line`` per line."""
    flat = np.asarray(indices).reshape(-1)
    return _vector_lines(_int_words(flat), per_line)
