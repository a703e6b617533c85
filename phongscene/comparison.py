# SPDX-License-Identifier: Apache-2.0
"""Comparing two linear float images: the thresholds (the only place they live) and the
verdict, computed by OpenImageIO's ``ImageBufAlgo.compare`` in idiff's vocabulary.

Why these thresholds: POV-Ray 3.7 writes half-float EXR (ref §2), so the best agreement
the two backends can reach is half precision. Half floats have an 11-bit significand: rounding
to nearest moves a normal value v by at most 2⁻¹¹·|v|; below 2⁻¹⁴ (subnormal halves) the step is
a fixed 2⁻²⁴. A pixel therefore *agrees* when, in every channel,

    |a − b| ≤ fail   or   |a − b| ≤ fail_relative · (|a| + |b|) / 2

which is exactly OpenImageIO's rule (``compare(A, B, fail, warn, failrelative, ...)`` counts a
failure only when the absolute error exceeds ``fail`` *and* the error relative to the mean of
|a| and |b| exceeds ``failrelative``; verified on OIIO 3.2.2, see tests/test_comparison.py).
PSNR is not used: its peak is the image maximum, meaningless for HDR.

The comparison fails (``ok`` False) when more than ``fail_percent`` % of the pixels fail, when
any channel error exceeds ``hard_fail``, or when non-finite values differ: a NaN never agrees
(it is a renderer bug, never a tolerance matter) and an infinity agrees only with the same
infinity. OpenImageIO ignores NaN and infinity silently (neither fails), so those pixels are
judged here and left out of the mean/RMS statistics. Images of different sizes cannot be
compared: ``ImageMismatchError``.

POV-Ray facts cite ``docs/povray-3.7-semantics.md`` as "ref §n".
"""

from __future__ import annotations

import math
import os
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from .errors import PhongSceneError
from .images import as_image, read_image

# Half-float rounding: round-to-nearest with an 11-bit significand moves a normal value by at
# most half a unit in the last place, 2⁻¹¹ relative to the value.
HALF_ROUNDING_RELATIVE = 2.0**-11
# One step of the subnormal half range (values below 2⁻¹⁴): the finest absolute resolution a
# half-float EXR has, so the smallest absolute difference that can mean anything.
HALF_SUBNORMAL_STEP = 2.0**-24

CHANNEL_NAMES = ("R", "G", "B")
SPACES = ("linear", "sRGB")
# How many of the worst pixels a Report lists (for the HTML page and test messages).
WORST_PIXELS_LISTED = 10


class ImageMismatchError(PhongSceneError):
    """The two images cannot be compared pixel by pixel (different sizes)."""


@dataclass(frozen=True, slots=True)
class Thresholds:
    """When two images agree, in idiff's vocabulary. The one place thresholds live.

    A channel value fails when ``|a − b| > fail`` and ``|a − b| > fail_relative·mean(|a|, |b|)``.
    The comparison fails when more than ``fail_percent`` % of the pixels fail, or when any
    channel error exceeds ``hard_fail``.
    """

    fail: float = HALF_SUBNORMAL_STEP  # absolute floor: differences at or below it always agree
    # k·2⁻¹¹ with k = 2: one half-float rounding (2⁻¹¹) on POV-Ray's side, doubled to cover what
    # else separates the backends, all far smaller: OIIO divides by the mean of |a| and |b|, not
    # the exact value (≤ 2⁻¹² relative); float32 colour arithmetic in both renderers (~1e-6);
    # the exact mapping's slope colour_map (≤ 2e-5 relative, ref §12) and its per-light
    # passes, each rounded to half before they are summed.
    fail_relative: float = 2 * HALF_ROUNDING_RELATIVE
    fail_percent: float = 0.0  # % of pixels allowed to fail; 0: every pixel must agree
    hard_fail: float = math.inf  # any channel error above it fails the comparison
    # What the errors are measured on: "linear" values, or "sRGB": the values an 8-bit sRGB file
    # holds (clipped to [0, 1], sRGB-encoded), for comparing such files one code step apart.
    space: str = "linear"

    def __post_init__(self) -> None:
        for name in ("fail", "fail_relative", "fail_percent", "hard_fail"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and value >= 0 and not math.isnan(value)):
                raise ValueError(f"Thresholds.{name} must be a number >= 0, got {value!r}")
        if self.fail_percent > 100:
            raise ValueError(f"Thresholds.fail_percent must be <= 100, got {self.fail_percent!r}")
        if self.space not in SPACES:
            raise ValueError(f"Thresholds.space must be one of {', '.join(SPACES)}, got {self.space!r}")

    def to_dict(self) -> dict:
        """JSON-ready: an infinite ``hard_fail`` becomes None (no hard limit)."""
        return {k: (None if isinstance(v, float) and math.isinf(v) else v) for k, v in asdict(self).items()}


# The backends must agree at half-float precision at every pixel (POV-Ray's EXR output).
HALF_FLOAT = Thresholds()


def for_povray_passes(passes: int, thresholds: Thresholds = HALF_FLOAT) -> Thresholds:
    """``thresholds`` for a POV-Ray image summed from ``passes`` half-float frames (the exact
    mapping renders one per light). Below 2⁻¹⁴ half floats are subnormal: each frame rounds to
    within half a step (2⁻²⁵) absolutely, so the sum is within passes·2⁻²⁵, which exceeds the
    one-step floor from three passes on (a fuzzed scene with three lights failed one pixel by
    6.04e-8 > 2⁻²⁴). Above the subnormal range the relative bound already holds for the sum."""
    return replace(thresholds, fail=max(thresholds.fail, passes * HALF_SUBNORMAL_STEP / 2))


# POV-Ray's per-thread shadow cache (ref §6): each thread retests the last opaque occluder
# of a light first, with a looser window (t ≥ 1e-4 instead of t > 1e-3). A shadow ray that meets
# an occluder at 1e-4 ≤ t ≤ 1e-3 is then lit or shadowed depending on the previously rendered
# pixel. That happens for area-light samples just below a sphere's horizon (the reference
# measured 1–7 of 6912 pixels, ≤ 0.10 %) and on the terminator of smooth-normal meshes, where
# the interpolated normal passes the n·l gate but the ray leaves the facet through a neighbour
# (measured: orthographic calibration scene, pixel (10, 32), neighbour facet at t = 1.95e-4).
# Such a pixel gains or loses a whole light's (or sample's) contribution, so no error bound
# holds for it (hard_fail stays infinite); what is bounded is how many there are: 0.2 % of the
# pixels, twice the reference's share, since small test images put a larger share of their
# pixels on terminators.
POVRAY_SHADOW_CACHE = replace(HALF_FLOAT, fail_percent=0.2)

# POV-Ray stores mesh2 vertices and normals as float32 (ref §2, §7). Near the terminator
# of a smooth-normal mesh (n·l → 0) the shading is proportional to a small n·l whose absolute error from that
# storage (~1e-7..1e-6) becomes a large relative one, so a pixel there can leave half-float
# precision while the native tracer (float64 geometry) matches the float64 oracle. Measured: the
# teapot (shared assets) at 96×72, classic, pixel (38, 29): n·l ≈ 7.9e-4, POV-Ray 2.09·2⁻¹¹ off
# the oracle, native 3e-5·2⁻¹¹. Bounded by count like the shadow cache (a terminator is a line).
POVRAY_MESH_FLOAT32 = replace(HALF_FLOAT, fail_percent=0.2)

# Integer image files (8-bit PNG, JPEG, 16-bit PNG/TIFF) quantise: two renders that agree at half
# precision land on the same code or on neighbouring codes (one value rounds up, the other down),
# never two codes apart. So such files agree when their stored values differ by at most one code
# step: an absolute threshold of 1.5 steps (exactly one step passes whatever the float32 rounding
# of k/255; two steps fail), no relative one. Measured on the values the file stores: sRGB-encoded
# for sRGB files (one code is up to 10 % of a dark linear value, 0.9 % of a bright one, so no
# linear threshold fits), linear otherwise.
INTEGER_CODE_STEPS = 1.5


def integer_thresholds(bits: int, space: str = "sRGB") -> Thresholds:
    """Thresholds for ``bits``-bit integer images whose values are ``space``-encoded."""
    return Thresholds(fail=INTEGER_CODE_STEPS / (2**bits - 1), fail_relative=0.0, space=space)


@dataclass(frozen=True, slots=True)
class ImageFormat:
    """How an image file stores its values: ``bits`` of an integer code (None: floating point)
    and whether they are sRGB-encoded."""

    bits: int | None
    srgb: bool

    def __str__(self) -> str:
        if self.bits is None:
            return "floating point"
        return f"{self.bits}-bit {'sRGB' if self.srgb else 'linear'}"


def image_format(path: str | os.PathLike) -> ImageFormat:
    """The storage format of an image file, from its header (OpenImageIO)."""
    from OpenImageIO import DOUBLE, FLOAT, HALF, ImageInput

    path = os.fspath(path)
    inp = ImageInput.open(path)
    if inp is None:
        import OpenImageIO

        raise PhongSceneError(f"{path}: cannot read image: {OpenImageIO.geterror()}")
    try:
        spec = inp.spec()
    finally:
        inp.close()
    srgb = "srgb" in spec.get_string_attribute("oiio:ColorSpace").lower()
    if spec.format.basetype in (HALF, FLOAT, DOUBLE):
        return ImageFormat(None, srgb)
    return ImageFormat(spec.format.size() * 8, srgb)


def thresholds_for_files(a: str | os.PathLike, b: str | os.PathLike) -> tuple[Thresholds, str]:
    """The thresholds two image files are compared with, and why: floating-point files (EXR, as
    both backends write) at half-float precision (``HALF_FLOAT``, POV-Ray's output precision);
    when either file stores integer codes, one code step of the coarser one
    (``integer_thresholds``), on its encoding."""
    formats = [(image_format(a), os.fspath(a)), (image_format(b), os.fspath(b))]
    integer = [(f, p) for f, p in formats if f.bits is not None]
    if not integer:
        return HALF_FLOAT, "floating-point images: half-float precision (POV-Ray's EXR output)"
    coarsest, path = min(integer, key=lambda fp: fp[0].bits)
    space = "sRGB" if coarsest.srgb else "linear"
    reason = (
        f"{coarsest} input ({path}): values one code step apart agree "
        f"(|a-b| <= {INTEGER_CODE_STEPS:g}/{2**coarsest.bits - 1} of the {space}-encoded values)"
    )
    return integer_thresholds(coarsest.bits, space), reason


@dataclass(frozen=True, slots=True)
class PixelError:
    """One pixel's error: where, which channel is worst, and both pixels' values."""

    x: int  # column, 0 = left
    y: int  # row, 0 = top
    channel: int  # 0, 1, 2 = R, G, B
    error: float  # |a − b| in that channel (inf or nan for non-finite values)
    a: tuple[float, float, float]  # pixel of image a (RGB)
    b: tuple[float, float, float]  # pixel of image b (RGB)

    def __str__(self) -> str:
        fa = ", ".join(f"{v:.8g}" for v in self.a)
        fb = ", ".join(f"{v:.8g}" for v in self.b)
        return f"{self.error:.6g} @ ({self.x}, {self.y}, {CHANNEL_NAMES[self.channel]})  values are {fa} vs {fb}"


@dataclass(frozen=True, slots=True)
class Report:
    """The outcome of ``compare``. Errors are absolute, in linear image units; ``mean_error``
    and ``rms_error`` average over pixels × channels (OIIO's convention)."""

    width: int
    height: int
    mean_error: float
    rms_error: float
    max_error: float
    max_relative_error: float  # worst |a − b| / mean(|a|, |b|) among channel values above ``fail``
    worst: PixelError | None  # the pixel with the largest error (None for identical images)
    failing_pixels: int  # pixels with at least one failing channel (NaN pixels included)
    failing_percent: float
    nonfinite_pixels_a: int  # pixels of a with a NaN or infinite channel
    nonfinite_pixels_b: int
    hard_fail: bool  # some channel error exceeds thresholds.hard_fail, or non-finite values differ
    ok: bool  # the verdict
    thresholds: Thresholds
    worst_pixels: tuple[PixelError, ...] = field(default=())  # up to WORST_PIXELS_LISTED, worst first

    @property
    def pixels(self) -> int:
        return self.width * self.height

    def _repr_html_(self) -> str:
        """Jupyter's display: the verdict, coloured, over the summary's facts."""
        import html

        colour = "#1a7f37" if self.ok else "#cf222e"
        verdict = "PASS" if self.ok else "FAIL"
        rows = "".join(
            f"<tr><td style='text-align:left'>{html.escape(line.strip())}</td></tr>"
            for line in self.summary().splitlines()
            if line.strip() not in ("PASS", "FAILURE")
        )
        return (
            f"<div class='phongscene-report'><b style='color:{colour}'>{verdict}</b>: {self.failing_pixels} of "
            f"{self.pixels} pixels fail, max error {self.max_error:.3g}<table>{rows}</table></div>"
        )

    def summary(self) -> str:
        """idiff-style text block, one fact per line."""
        t = self.thresholds
        lines = [
            f"  size        {self.width} x {self.height}"
            + ("" if t.space == "linear" else f"  (errors of the {t.space}-encoded values)"),
            f"  mean error  {self.mean_error:.6g}",
            f"  RMS error   {self.rms_error:.6g}",
            f"  max error   {self.worst if self.worst else 0}",
            f"  max relative error (above the floor) {self.max_relative_error:.6g}"
            f" = {self.max_relative_error / HALF_ROUNDING_RELATIVE:.3g} x 2^-11",
            f"  {self.failing_pixels} pixels ({self.failing_percent:.4g}%) fail"
            f" (|a-b| > {t.fail:.3g} and > {t.fail_relative:.3g} relative; allowed {t.fail_percent:g}%)",
        ]
        if self.nonfinite_pixels_a or self.nonfinite_pixels_b:
            lines.append(f"  non-finite pixels {self.nonfinite_pixels_a} in a, {self.nonfinite_pixels_b} in b")
        if self.hard_fail:
            lines.append(f"  hard fail   (an error above {t.hard_fail:.6g}, or non-finite values that differ)")
        lines.append("  PASS" if self.ok else "  FAILURE")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """JSON-ready dictionary of every number (non-finite floats become strings)."""
        d = {
            "width": self.width,
            "height": self.height,
            "pixels": self.pixels,
            "mean_error": self.mean_error,
            "rms_error": self.rms_error,
            "max_error": self.max_error,
            "max_relative_error": self.max_relative_error,
            "worst": _pixel_dict(self.worst),
            "failing_pixels": self.failing_pixels,
            "failing_percent": self.failing_percent,
            "nonfinite_pixels_a": self.nonfinite_pixels_a,
            "nonfinite_pixels_b": self.nonfinite_pixels_b,
            "hard_fail": self.hard_fail,
            "ok": self.ok,
            "thresholds": self.thresholds.to_dict(),
            "worst_pixels": [_pixel_dict(p) for p in self.worst_pixels],
        }
        return _json_safe(d)


def _pixel_dict(p: PixelError | None) -> dict | None:
    if p is None:
        return None
    return {"x": p.x, "y": p.y, "channel": CHANNEL_NAMES[p.channel], "error": p.error, "a": list(p.a), "b": list(p.b)}


def _json_safe(value):
    """Strict JSON has no NaN/Infinity: write them as the strings "nan", "inf", "-inf"."""
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    if isinstance(value, dict):
        return {k: _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    return value


def load(image) -> np.ndarray:
    """An image argument as linear float32 (H, W, 3): an array, or a path read by OpenImageIO."""
    if isinstance(image, (str, os.PathLike)):
        return read_image(image)
    return as_image(image)


def compare(a, b, thresholds: Thresholds | None = None) -> Report:
    """Compare two linear images pixel by pixel.

    Two images only: how they were rendered is not known here, so ``compare`` applies none of
    what ``phongscene.diff`` does for a POV-Ray mapping (diff renders the native image in
    POV-Ray's numerics, ``numerics="povray"``; widens the floor for the exact mapping's one
    half-float pass per light, ``for_povray_passes``; and explains the pixels POV-Ray's shadow
    cache decides, which needs the scene). ``compare(povray_image, ps.render(scene))`` therefore
    fails pixels that ``diff`` passes: compare the backends with ``diff(scene)``, or pass
    ``thresholds=for_povray_passes(n)`` and render the native image with ``numerics="povray"``.

    Args:
        a: the reference image: a float array (H, W, 3) or a path OpenImageIO can read.
        b: the image under test, same kind.
        thresholds: when the images agree. Default: for two files, by their formats
            (``thresholds_for_files``: half-float precision, or one code step of an 8-bit file);
            for arrays, half-float precision everywhere (``HALF_FLOAT``). With ``space="sRGB"``
            the errors in the report are of the sRGB-encoded values.

    Returns:
        A ``Report`` with the error statistics, the worst pixels and the verdict ``ok``.

    Raises:
        ImageMismatchError: the images differ in size.
    """
    from OpenImageIO import ImageBuf, ImageBufAlgo  # here: building the CLI's parser needs no OIIO

    if thresholds is None:
        paths = isinstance(a, (str, os.PathLike)) and isinstance(b, (str, os.PathLike))
        thresholds = thresholds_for_files(a, b)[0] if paths else HALF_FLOAT
    a_img, b_img = (in_space(img, thresholds.space) for img in _load_pair(a, b))
    height, width = a_img.shape[:2]
    nonfinite_a = ~np.isfinite(a_img).all(axis=2)
    nonfinite_b = ~np.isfinite(b_img).all(axis=2)
    special = nonfinite_a | nonfinite_b
    # OIIO mishandles non-finite values (a NaN, or inf against a finite value, neither fails
    # nor enters the statistics), so they are judged here: a pixel with a non-finite value
    # agrees only if both images hold bit-equal values there (the same infinity); NaN never
    # agrees. OIIO then compares copies with those pixels zeroed in both.
    with np.errstate(invalid="ignore"):
        special_fail = special & ~(a_img == b_img).all(axis=2)
    if special.any():
        a_clean = np.where(special[..., None], np.float32(0), a_img)
        b_clean = np.where(special[..., None], np.float32(0), b_img)
    else:
        a_clean, b_clean = a_img, b_img
    result = ImageBufAlgo.compare(
        ImageBuf(a_clean),
        ImageBuf(b_clean),
        thresholds.fail,
        thresholds.fail,
        thresholds.fail_relative,
        thresholds.fail_relative,
    )
    failing = int(result.nfail) + int(special_fail.sum())
    npixels = width * height
    failing_percent = 100.0 * failing / npixels if npixels else 0.0

    worst = _worst_pixels(a_img, b_img, WORST_PIXELS_LISTED)
    max_error = float(result.maxerror)
    if special_fail.any():
        max_error = worst[0].error  # inf, or nan when a NaN is involved
    hard = bool(special_fail.any()) or max_error > thresholds.hard_fail
    ok = not hard and failing <= thresholds.fail_percent / 100.0 * npixels
    return Report(
        width=width,
        height=height,
        mean_error=float(result.meanerror),
        rms_error=float(result.rms_error),
        max_error=max_error,
        max_relative_error=_max_relative_error(a_clean, b_clean, thresholds.fail),
        worst=worst[0] if worst else None,
        failing_pixels=failing,
        failing_percent=failing_percent,
        nonfinite_pixels_a=int(nonfinite_a.sum()),
        nonfinite_pixels_b=int(nonfinite_b.sum()),
        hard_fail=hard,
        ok=bool(ok),
        thresholds=thresholds,
        worst_pixels=tuple(worst),
    )


def failing_mask(a, b, thresholds: Thresholds = HALF_FLOAT) -> np.ndarray:
    """Which pixels fail: (H, W) bool, by the same rule ``compare`` counts with OIIO (a channel
    fails when its error exceeds ``fail`` and ``fail_relative`` of mean(|a|, |b|); a NaN never
    agrees; an infinity agrees only with the same infinity). For locating failures, e.g. to
    explain each one; ``compare`` stays the verdict."""
    a, b = (in_space(img, thresholds.space) for img in _load_pair(a, b))
    a64, b64 = a.astype(np.float64), b.astype(np.float64)
    with np.errstate(invalid="ignore"):
        err = np.abs(a64 - b64)
        bad = (err > thresholds.fail) & (err > thresholds.fail_relative * (np.abs(a64) + np.abs(b64)) / 2)
        special = ~np.isfinite(a64) | ~np.isfinite(b64)
        bad = np.where(special, ~(a64 == b64), bad)
    return bad.any(axis=2)


def in_space(image: np.ndarray, space: str) -> np.ndarray:
    """A linear image as the values ``space`` measures: itself ("linear"), or clipped to [0, 1]
    and sRGB-encoded by OpenImageIO ("sRGB", what an 8-bit sRGB file holds, unquantised).
    Non-finite values stay as they are, so that ``compare`` still judges them."""
    if space == "linear":
        return image
    from OpenImageIO import FLOAT, ImageBuf, ImageBufAlgo

    finite = np.isfinite(image)
    clipped = np.clip(np.where(finite, image, np.float32(0)), 0.0, 1.0).astype(np.float32)
    encoded = ImageBufAlgo.colorconvert(ImageBuf(clipped), "linear", "sRGB")
    out = np.asarray(encoded.get_pixels(FLOAT), dtype=np.float32).reshape(image.shape)
    return np.where(finite, out, image)


def channel_error(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """|a − b| per pixel, maximum over channels: (H, W) float32, computed by OIIO
    (``absdiff`` + ``maxchan``). NaN where either image has a NaN."""
    from OpenImageIO import ImageBuf, ImageBufAlgo

    diff = ImageBufAlgo.maxchan(ImageBufAlgo.absdiff(ImageBuf(as_image(a)), ImageBuf(as_image(b))))
    out = np.asarray(diff.get_pixels(), dtype=np.float32).reshape(a.shape[0], a.shape[1])
    nan_any = np.isnan(a).any(axis=2) | np.isnan(b).any(axis=2)
    out[nan_any] = np.nan
    return out


def _worst_pixels(a: np.ndarray, b: np.ndarray, count: int) -> list[PixelError]:
    """The ``count`` pixels with the largest channel error (NaN pixels first), zero errors omitted."""
    with np.errstate(invalid="ignore"):
        err = np.abs(a.astype(np.float64) - b.astype(np.float64))
    both_inf_equal = np.isinf(a) & (a == b)  # inf − inf is NaN, but equal infinities agree
    err[both_inf_equal] = 0.0
    per_pixel = np.where(np.isnan(err).any(axis=2), np.inf, np.nanmax(np.nan_to_num(err, nan=0.0), axis=2))
    flat = per_pixel.ravel()
    n = min(count, flat.size)
    order = np.argsort(-flat, kind="stable")[:n]
    out = []
    for idx in order:
        if not flat[idx] > 0:
            break
        y, x = divmod(int(idx), a.shape[1])
        chan_err = err[y, x]
        if np.isnan(chan_err).any():
            c = int(np.argmax(np.isnan(chan_err)))
            e = math.nan
        else:
            c = int(np.argmax(chan_err))
            e = float(chan_err[c])
        out.append(PixelError(x, y, c, e, tuple(map(float, a[y, x])), tuple(map(float, b[y, x]))))
    return out


def _max_relative_error(a: np.ndarray, b: np.ndarray, floor: float) -> float:
    """Worst |a − b| / mean(|a|, |b|) over channel values whose error exceeds ``floor``
    (OIIO's relative measure), 0 if there are none."""
    with np.errstate(invalid="ignore", divide="ignore"):
        err = np.abs(a.astype(np.float64) - b.astype(np.float64))
        err[np.isinf(a) & (a == b)] = 0.0
        scale = (np.abs(a.astype(np.float64)) + np.abs(b.astype(np.float64))) / 2
        mask = err > floor
        if not mask.any():
            return 0.0
        rel = err[mask] / scale[mask]
    rel = rel[~np.isnan(rel)]
    return float(rel.max()) if rel.size else 0.0


def _load_pair(a, b) -> tuple[np.ndarray, np.ndarray]:
    """Both images (``load``), or ImageMismatchError naming both when their sizes differ."""
    a_img, b_img = load(a), load(b)
    if a_img.shape != b_img.shape:
        raise ImageMismatchError(
            f"cannot compare images of different sizes: {_size(a_img)} ({_name(a)}) vs {_size(b_img)} ({_name(b)})"
        )
    return a_img, b_img


def _size(img: np.ndarray) -> str:
    return f"{img.shape[1]}x{img.shape[0]}"


def _name(image) -> str:
    return os.fspath(image) if isinstance(image, (str, os.PathLike)) else "array"
