# SPDX-License-Identifier: Apache-2.0
"""The comparison report written to a folder: both images (EXR float + sRGB PNG), the
absolute difference (EXR), a heat map of each pixel's error relative to the error the
thresholds allow there with the failing pixels drawn over it (PNG), ``metrics.json`` and a
static ``index.html`` (no external resources) that shows everything side by side; the legend,
the numbers and every failing pixel's values on both sides are HTML text. ``diff --frames``
adds an index of the frames' reports (``write_frames_report``).

Every file is written atomically (temporary file in the folder, then a rename), so an
interrupted run never leaves a half-written report file behind.
"""

from __future__ import annotations

import html
import json
import math
import os
import re
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from OpenImageIO import ImageBuf, ImageBufAlgo

from .comparison import CHANNEL_NAMES, Report, Thresholds, failing_mask, in_space
from .errors import PhongSceneError
from .files import write_text_atomic
from .images import as_image, write_image, write_imagebuf

if TYPE_CHECKING:
    from .dask_runtime import FramesRun

HEAT_MAP = "inferno"  # perceptually uniform, dark at zero
# The heat map shows each pixel's error as a share of the error allowed there (the thresholds'
# max(fail, fail_relative x mean(|a|, |b|)), worst channel), on the dark part of the colour map
# only: a pixel at the allowed error gets inferno(ALLOWED_ERROR_COLOUR), a dark red, so a PASS is
# dark everywhere, and the failing pixels, drawn in colours inferno never takes, stand out.
ALLOWED_ERROR_COLOUR = 0.4
FAILING_COLOUR = (0.0, 1.0, 1.0)  # cyan: a failing pixel that nothing explains
EXPLAINED_COLOUR = (0.25, 1.0, 0.25)  # green: a failing pixel a known cause explains (diff)
LEGEND_STOPS = 9  # colour stops of the HTML legend's gradient (inferno is smooth between them)
# Small images are enlarged (nearest neighbour, integer factor) to at least this width, so that
# a one-pixel difference is a visible block on the heat map and in the browser.
MIN_DISPLAY_WIDTH = 384
# How many failing pixels the page lists with both values (all of them are in metrics.json up to
# this count as well); more would make a page no one reads.
FAILING_PIXELS_LISTED = 100
# Thumbnails in the frames report (CSS pixels wide; the images are the frames' own PNGs).
THUMBNAIL_WIDTH = 160

FILE_NAMES = {
    "heat": "diff_heat.png",
    "diff": "diff.exr",
    "metrics": "metrics.json",
    "html": "index.html",
}


def display_scale(width: int) -> int:
    """Integer nearest-neighbour enlargement for an image ``width`` pixels wide."""
    return max(1, math.ceil(MIN_DISPLAY_WIDTH / max(width, 1)))


def error_ratio(a: np.ndarray, b: np.ndarray, thresholds: Thresholds) -> np.ndarray:
    """Each pixel's error as a multiple of the error ``thresholds`` allow there: (H, W) float64,
    the worst channel of |a − b| / max(fail, fail_relative · mean(|a|, |b|)), in the thresholds'
    space (linear, or the sRGB-encoded values). Above 1 exactly where ``failing_mask`` says a
    pixel fails (for finite values); a non-finite value that does not agree gives inf. 0 where
    both are exactly equal, also when nothing is allowed."""
    a, b = in_space(as_image(a), thresholds.space), in_space(as_image(b), thresholds.space)
    a64, b64 = a.astype(np.float64), b.astype(np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        err = np.abs(a64 - b64)
        allowed = np.maximum(thresholds.fail, thresholds.fail_relative * (np.abs(a64) + np.abs(b64)) / 2)
        ratio = np.where(err == 0, 0.0, err / allowed)
    ratio = np.where(np.isfinite(a64) & np.isfinite(b64), ratio, np.where(a64 == b64, 0.0, np.inf))
    return ratio.max(axis=2)


def write_report(
    outdir: str | os.PathLike,
    a,
    b,
    report: Report,
    *,
    labels: tuple[str, str] = ("a", "b"),
    title: str = "phongscene comparison",
    timings: dict[str, float] | None = None,
    meta: dict | None = None,
    explained: Iterable[tuple[int, int]] | Mapping[tuple[int, int], str] | None = None,
    cause: str = "",
    ok: bool | None = None,
) -> Path:
    """Write the report for images ``a`` and ``b`` and their ``report`` into ``outdir``.

    Args:
        outdir: the folder (created if needed).
        a: the reference image (float (H, W, 3), linear), e.g. POV-Ray's.
        b: the image under test, e.g. the native tracer's.
        report: ``compare(a, b)``; its thresholds scale the heat map.
        labels: names of the two images; they become file stems (``<label>.exr``/``.png``).
        title: the page title.
        timings: seconds per step (e.g. each backend's render time), recorded in the JSON.
        meta: anything else worth recording (scene file, mapping, settings); JSON-serialisable.
        explained: failing pixels (x, y) that ``cause`` explains, or a mapping from each such
            pixel to what explains it; given (diff), every other failing pixel is marked "not
            explained"; None (compare): failing pixels are not classified.
        cause: what explains the ``explained`` pixels when they are not a mapping, e.g.
            "POV-Ray's shadow cache".
        ok: the verdict when it is not the comparison's (diff passes when every failing pixel
            is explained); default ``report.ok``.

    Returns:
        The path of ``index.html``.
    """
    a, b = as_image(a), as_image(b)
    # A label may not name one of the report's own files (``compare old/diff.exr new.exr``).
    stems = [_file_stem(label) for label in labels]
    stems = [f"{s}_image" if {f"{s}.exr", f"{s}.png"} & set(FILE_NAMES.values()) else s for s in stems]
    if stems[0] == stems[1]:
        stems = [stems[0] + "_a", stems[1] + "_b"]
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)

    files: dict[str, str] = {}
    for key, stem, img in (("a", stems[0], a), ("b", stems[1], b)):
        write_image(out / f"{stem}.exr", img)
        write_image(out / f"{stem}.png", img)
        files[f"{key}_exr"], files[f"{key}_png"] = f"{stem}.exr", f"{stem}.png"
    with np.errstate(invalid="ignore"):
        absdiff = np.abs(a - b)
    write_image(out / FILE_NAMES["diff"], absdiff)
    files["diff_exr"] = FILE_NAMES["diff"]
    thresholds = report.thresholds
    failing = failing_mask(a, b, thresholds)
    causes = None if explained is None else _causes(explained, cause)
    # The causes in the order first met; the one ``cause`` even when it explains no pixel.
    names = list(dict.fromkeys((causes or {}).values())) or ([cause] if cause and causes is not None else [])
    explained_mask = np.zeros_like(failing)
    for x, y in causes or ():
        explained_mask[y, x] = True
    ratio = error_ratio(a, b, thresholds)
    write_heat_map(out / FILE_NAMES["heat"], ratio, failing & ~explained_mask, failing & explained_mask)
    files["heat_png"] = FILE_NAMES["heat"]
    files["metrics"] = FILE_NAMES["metrics"]

    space = thresholds.space
    pixels = _failing_pixels(in_space(a, space), in_space(b, space), ratio, failing, thresholds, causes)
    verdict = report.ok if ok is None else bool(ok)
    metrics = {
        "title": title,
        "labels": list(labels),
        "files": files,
        "ok": verdict,
        "report": report.to_dict(),
        "heat_map": {
            "map": HEAT_MAP,
            "shows": "error / allowed error, worst channel",
            "allowed_error_at": ALLOWED_ERROR_COLOUR,
            "failing_colour": FAILING_COLOUR,
            "explained_colour": EXPLAINED_COLOUR,
            "max_ratio": _json_number(float(ratio.max()) if ratio.size else 0.0),
            "scale": display_scale(a.shape[1]),
        },
        "failing_pixels_listed": pixels,
        "timings_seconds": dict(timings or {}),
        **(meta or {}),
    }
    write_text_atomic(out / FILE_NAMES["metrics"], json.dumps(metrics, indent=2, allow_nan=False) + "\n")
    page = _html_page(title, labels, files, report, verdict, metrics, a.shape[1], a.shape[0], causes, names)
    return write_text_atomic(out / FILE_NAMES["html"], page)


def write_heat_map(
    path: str | os.PathLike, ratio: np.ndarray, failing: np.ndarray, explained: np.ndarray | None = None
) -> None:
    """Write the heat map PNG (no legend: the page draws it): ``ratio`` (H, W), each pixel's
    error over the allowed error, on inferno from 0 to ``ALLOWED_ERROR_COLOUR`` (0 .. allowed),
    with the ``failing`` pixels in ``FAILING_COLOUR`` and the ``explained`` ones in
    ``EXPLAINED_COLOUR`` over it. Small images are enlarged by an integer factor (nearest
    neighbour), so that one pixel is a visible block."""
    ratio = np.asarray(ratio, dtype=np.float64)
    height, width = ratio.shape
    level = (ALLOWED_ERROR_COLOUR * np.clip(np.nan_to_num(ratio, nan=0.0, posinf=1.0), 0.0, 1.0)).astype(np.float32)
    heat = ImageBufAlgo.color_map(ImageBuf(np.ascontiguousarray(level[..., None])), 0, HEAT_MAP)
    if heat.has_error:
        raise PhongSceneError(f"{path}: cannot draw the heat map: {heat.geterror()}")
    pixels = np.asarray(heat.get_pixels(), np.float32).reshape(height, width, 3)
    radius = marker_radius(width)
    if explained is not None:
        pixels[_dilate(explained, radius)] = EXPLAINED_COLOUR
    pixels[_dilate(failing, radius)] = FAILING_COLOUR  # on top: the pixels nothing explains matter most
    scale = display_scale(width)
    pixels = np.repeat(np.repeat(pixels, scale, axis=0), scale, axis=1)
    # The colour map is already display-referred (sRGB): write it without conversion.
    write_imagebuf(path, ImageBuf(np.ascontiguousarray(pixels)), "uint8")


def marker_radius(width: int) -> int:
    """Half-width in image pixels of a failing pixel's mark: 0 (the pixel itself) up to
    MIN_DISPLAY_WIDTH pixels wide; a wider map is shown scaled down to about that width on the
    page, so a failing pixel is drawn as a (2r+1)² square that stays at least a screen pixel."""
    return max(0, math.ceil(width / MIN_DISPLAY_WIDTH) - 1)


def _dilate(mask: np.ndarray, radius: int) -> np.ndarray:
    """``mask`` grown by ``radius`` pixels in x and y (a square structuring element)."""
    if radius <= 0:
        return mask
    height, width = mask.shape
    padded = np.pad(mask, radius)
    out = np.zeros_like(mask)
    for dy in range(2 * radius + 1):
        for dx in range(2 * radius + 1):
            out |= padded[dy : dy + height, dx : dx + width]
    return out


def _legend_gradient() -> str:
    """The CSS gradient of the heat map's colours from 0 to the allowed error (OIIO's inferno)."""
    ramp = np.linspace(0.0, ALLOWED_ERROR_COLOUR, LEGEND_STOPS, dtype=np.float32)[None, :, None]
    colours = np.asarray(
        ImageBufAlgo.color_map(ImageBuf(np.ascontiguousarray(ramp)), 0, HEAT_MAP).get_pixels(), np.float32
    )
    stops = [_css_colour(c) for c in colours.reshape(-1, 3)]
    return f"linear-gradient(to right, {', '.join(stops)})"


def _css_colour(rgb) -> str:
    return "#" + "".join(f"{int(round(255 * min(max(float(c), 0.0), 1.0))):02x}" for c in rgb)


def _causes(explained, cause: str) -> dict[tuple[int, int], str]:
    """Each explained pixel (x, y) and what explains it."""
    if isinstance(explained, Mapping):
        return {(int(x), int(y)): str(why) for (x, y), why in explained.items()}
    return {(int(x), int(y)): cause for x, y in explained}


def _failing_pixels(a, b, ratio, failing, thresholds: Thresholds, causes: dict | None) -> list[dict]:
    """Up to FAILING_PIXELS_LISTED failing pixels, worst (largest ratio) first: where, the worst
    channel, both values, the error, the error allowed there, and what explains the pixel."""
    ys, xs = np.nonzero(failing)
    order = np.argsort(-ratio[ys, xs], kind="stable")[:FAILING_PIXELS_LISTED]
    out = []
    for i in order:
        y, x = int(ys[i]), int(xs[i])
        pa, pb = a[y, x].astype(np.float64), b[y, x].astype(np.float64)
        with np.errstate(invalid="ignore", divide="ignore"):
            err = np.abs(pa - pb)
            allowed = np.maximum(thresholds.fail, thresholds.fail_relative * (np.abs(pa) + np.abs(pb)) / 2)
            per_channel = np.where(np.isfinite(err), err / allowed, np.inf)
        c = int(np.nanargmax(np.nan_to_num(per_channel, nan=np.inf)))
        why = None if causes is None else causes.get((x, y), "not explained")
        out.append(
            {
                "x": x,
                "y": y,
                "channel": CHANNEL_NAMES[c],
                "a": [_json_number(float(v)) for v in pa],
                "b": [_json_number(float(v)) for v in pb],
                "error": _json_number(float(err[c])),
                "allowed": _json_number(float(allowed[c])),
                "ratio": _json_number(float(per_channel[c])),
                "cause": why,
            }
        )
    return out


def _json_number(value: float):
    """Strict JSON has no NaN or infinity: those become the strings "nan", "inf", "-inf"."""
    return value if math.isfinite(value) else str(value)


def _file_stem(label: str) -> str:
    """A label as a safe file stem: letters, digits, '-', '_' only."""
    stem = re.sub(r"[^A-Za-z0-9_-]+", "_", label).strip("_")
    return stem or "image"


# ----------------------------------------------------------------------------------------------
# HTML

_CSS = """
body { font: 15px/1.45 system-ui, sans-serif; margin: 1.5em; color: #222; background: #fafafa; }
h1 { font-size: 1.35em; margin: 0 0 .3em; } h2 { font-size: 1.1em; margin: 1.4em 0 .4em; }
.verdict { display: inline-block; padding: .15em .6em; border-radius: .3em; color: #fff; font-weight: bold; }
.pass { background: #2a7a2a; } .fail { background: #b02020; }
.images { display: flex; gap: 1.2em; align-items: flex-start; margin: 1em 0; }
/* Side by side at any window width: each figure takes a third and scales its image down. */
figure { margin: 0; flex: 1 1 0; min-width: 0; } figcaption { font-weight: bold; margin-bottom: .3em; }
img { image-rendering: pixelated; border: 1px solid #ccc; display: block; max-width: 100%; height: auto; }
.legend { margin-top: .5em; font-size: .95em; }
.ramp { height: 14px; border: 1px solid #ccc; }
.ramp-labels { display: flex; justify-content: space-between; }
.swatch { display: inline-block; width: 1em; height: 1em; vertical-align: -.15em; border: 1px solid #888; margin-right: .3em; }
table { border-collapse: collapse; margin: .6em 0 1.2em; }
td, th { border: 1px solid #ddd; padding: .2em .6em; text-align: left; font-variant-numeric: tabular-nums; vertical-align: top; }
th { background: #eee; } code { font-size: .95em; }
td.num { text-align: right; } .note { color: #555; }
"""


def _fmt(value) -> str:
    """A value as a reader wants it: yes/no, ∞, 6 significant digits, lists without brackets."""
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        if math.isnan(value):
            return "NaN"
        if math.isinf(value):
            return "∞" if value > 0 else "−∞"
        return f"{value:.6g}"
    if isinstance(value, str) and value in ("inf", "-inf", "nan"):  # a number JSON could not hold
        return _fmt(float(value))
    if isinstance(value, (list, tuple)):
        if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value) and 0 < len(value) <= 4:
            return "(" + ", ".join(_fmt(v) for v in value) + ")"
        return ", ".join(_fmt(v) for v in value) if value else "none"
    if value is None:
        return "none"
    return str(value)


def _cell(value) -> str:
    """A table cell's content: a dict becomes a nested table, a long list a bulleted one."""
    e = html.escape
    if isinstance(value, dict):
        return "<table>" + _rows(value.items()) + "</table>" if value else "none"
    if isinstance(value, (list, tuple)) and value and not all(isinstance(v, (int, float)) for v in value):
        return "<ul>" + "".join(f"<li>{e(_fmt(v))}</li>" for v in value) + "</ul>"
    return e(_fmt(value))


def _rows(pairs) -> str:
    e = html.escape
    return "\n".join(f"<tr><th>{e(str(k))}</th><td>{_cell(v)}</td></tr>" for k, v in pairs)


def _rgb(values) -> str:
    return "(" + ", ".join(_fmt(float(v)) for v in values) + ")"


def _html_page(
    title,
    labels,
    files,
    report: Report,
    verdict: bool,
    metrics: dict,
    width: int,
    height: int,
    causes: dict | None,
    names: list[str],
) -> str:
    e = html.escape
    scale = display_scale(width)
    w, h = width * scale, height * scale
    t = report.thresholds
    worst = report.worst
    classify = causes is not None
    n_explained = len(causes or ())
    status = '<span class="verdict pass">PASS</span>' if verdict else '<span class="verdict fail">FAIL</span>'
    if verdict and not report.ok:
        status += f" &nbsp; every failing pixel is explained by {e(' or '.join(names))}"
    numbers = [
        ("size", f"{report.width} x {report.height} pixels"),
        (
            "failing pixels",
            f"{report.failing_pixels} of {report.pixels} ({report.failing_percent:.4g} %; "
            f"allowed {t.fail_percent:g} %)",
        ),
    ]
    if classify:
        numbers += [(f"explained by {name}", sum(why == name for why in causes.values())) for name in names]
        numbers += [("not explained", report.failing_pixels - n_explained)]
    numbers += [
        ("max error", report.max_error),
        ("max error at (x, y, channel)", f"({worst.x}, {worst.y}, {CHANNEL_NAMES[worst.channel]})" if worst else "-"),
        (f"{labels[0]} there", _rgb(worst.a) if worst else "-"),
        (f"{labels[1]} there", _rgb(worst.b) if worst else "-"),
        (
            "max relative error (above the absolute floor)",
            f"{_fmt(report.max_relative_error)} = {report.max_relative_error / t.fail_relative:.3g} x allowed"
            if t.fail_relative > 0
            else report.max_relative_error,
        ),
        ("mean error", report.mean_error),
        ("RMS error", report.rms_error),
        (
            "non-finite pixels",
            f"{report.nonfinite_pixels_a} in {labels[0]}, {report.nonfinite_pixels_b} in {labels[1]}",
        ),
        ("hard fail (an error above hard_fail, or non-finite values that differ)", report.hard_fail),
    ]
    thresholds = [
        ("fail: absolute error always accepted", t.fail),
        ("fail_relative: error accepted relative to mean(|a|, |b|)", t.fail_relative),
        ("fail_percent: share of pixels allowed to fail", f"{t.fail_percent:g} %"),
        ("hard_fail: any error above it fails", "none (no limit)" if math.isinf(t.hard_fail) else t.hard_fail),
    ]
    listed = metrics["failing_pixels_listed"]
    space_note = "" if t.space == "linear" else f", {e(t.space)}-encoded"
    pixel_rows = "\n".join(
        f"<tr><td class=num>{p['x']}</td><td class=num>{p['y']}</td><td>{p['channel']}</td>"
        f"<td>{e(_rgb(float(v) for v in p['a']))}</td><td>{e(_rgb(float(v) for v in p['b']))}</td>"
        f"<td class=num>{e(_fmt(float(p['error'])))}</td><td class=num>{e(_fmt(float(p['allowed'])))}</td>"
        f"<td class=num>{e(_fmt(float(p['ratio'])))}</td>" + (f"<td>{e(p['cause'])}</td>" if classify else "") + "</tr>"
        for p in listed
    )
    if listed:
        more = report.failing_pixels - len(listed)
        failing_section = (
            "<p class=note>Worst first (by error / allowed error); the worst channel's error and allowance."
            + (f" {more} more not listed." if more > 0 else "")
            + "</p>\n<table>\n"
            f"<tr><th>x</th><th>y</th><th>channel</th><th>{e(labels[0])} (R, G, B{space_note})</th>"
            f"<th>{e(labels[1])} (R, G, B{space_note})</th>"
            "<th>|a − b|</th><th>allowed</th><th>× allowed</th>" + ("<th>cause</th>" if classify else "") + "</tr>\n"
            f"{pixel_rows}\n</table>"
        )
    else:
        failing_section = "<p>None: every pixel is within the allowed error.</p>"
    timings = metrics.get("timings_seconds", {})
    skip = {
        "title",
        "labels",
        "files",
        "ok",
        "report",
        "heat_map",
        "timings_seconds",
        "failing_pixels_listed",
        "explained_by_povray_shadow_cache",
        "unexplained_failing_pixels",
    }
    extra = [(k.replace("_", " "), v) for k, v in metrics.items() if k not in skip]
    ramp = _legend_gradient()
    legend_items = [
        f'<span class="swatch" style="background:{_css_colour(FAILING_COLOUR)}"></span>failing pixel'
        + (" (not explained)" if classify else "")
    ]
    if classify:
        legend_items.append(
            f'<span class="swatch" style="background:{_css_colour(EXPLAINED_COLOUR)}"></span>'
            f"failing pixel explained{' by ' + e(' or '.join(names)) if names else ''}"
        )
    radius = marker_radius(width)
    if radius:
        legend_items.append(
            f"(a failing pixel is marked {2 * radius + 1} x {2 * radius + 1} pixels wide, so that it "
            "stays visible where the page scales the map down; the table has its exact place)"
        )
    legend = f"""<div class="legend" id="legend" style="max-width: {max(w, 1)}px">
<div class="ramp" style="background: {ramp}"></div>
<div class="ramp-labels"><span>0</span><span>½ allowed</span><span>allowed error</span></div>
<p>Colour: |{e(labels[0])} − {e(labels[1])}| / allowed error, worst channel; allowed error =
max(fail, fail_relative × mean(|a|, |b|)) = max({_fmt(t.fail)}, {_fmt(t.fail_relative)} × mean).<br>
{"<br>".join(legend_items)}</p>
</div>"""

    def figure(caption: str, png: str, exr: str, extra_html: str = "") -> str:
        return (
            f'<figure><figcaption>{e(caption)} (<a href="{e(exr)}">EXR</a>)</figcaption>'
            f'<img src="{e(png)}" alt="{e(caption)}" width="{w}" height="{h}">{extra_html}</figure>'
        )

    timing_rows = _rows((k, f"{v:.3f} s") for k, v in timings.items()) if timings else "<tr><td>not recorded</td></tr>"
    return f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>{e(title)}</title>
<style>{_CSS}</style>
</head>
<body>
<h1>{e(title)}</h1>
<p>{status} &nbsp; {e(labels[0])} vs {e(labels[1])}, {report.width} x {report.height} pixels,
{report.failing_pixels} failing</p>
<div class="images">
{figure(labels[0], files["a_png"], files["a_exr"])}
{figure(labels[1], files["b_png"], files["b_exr"])}
{figure("error / allowed error", files["heat_png"], files["diff_exr"], legend)}
</div>
<h2>Numbers</h2>
<table>
{_rows(numbers)}
</table>
<h2>Failing pixels</h2>
{failing_section}
<h2>Thresholds</h2>
<table>
{_rows(thresholds)}
</table>
<h2>Timings</h2>
<table>
{timing_rows}
</table>
<h2>Run</h2>
<table>
{_rows(extra)}
</table>
<p>All numbers: <a href="{e(files["metrics"])}">{e(files["metrics"])}</a></p>
</body>
</html>
"""


__all__ = ["display_scale", "error_ratio", "write_heat_map", "write_report"]


# The report of `diff --frames`: a row per frame, linking to each frame's own report


def write_frames_report(outdir: str | os.PathLike, scene: str, run: FramesRun, meta: dict) -> Path:
    """``index.html`` and ``metrics.json`` in ``outdir``: one row per frame (verdict, worst error,
    failing pixels, thumbnails of both renders and the heat map, a link to the frame's report)."""
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    frames = sorted(set(run.results) | set(run.failures))
    rows, records = [], []
    for frame in frames:
        m = run.results.get(frame)
        if m is None:
            error = run.failures[frame]
            records.append({"frame": frame, "ok": False, "error": error})
            rows.append(
                f"<tr class='fail'><td>{frame}</td><td>FAILED</td><td colspan='5'>{html.escape(error)}</td></tr>"
            )
            continue
        folder = os.path.relpath(m["outdir"], out)
        records.append({k: v for k, v in m.items() if k != "warnings"} | {"report": folder})
        thumbs = "".join(
            f"<td><a href='{html.escape(folder)}/{FILE_NAMES['html']}'><img src='{html.escape(folder)}/{name}' "
            f"width='{THUMBNAIL_WIDTH}' alt='{label}, frame {frame}'></a></td>"
            for label, name in (("povray", "povray.png"), ("native", "native.png"), ("heat map", FILE_NAMES["heat"]))
        )
        rows.append(
            f"<tr class='{'ok' if m['ok'] else 'fail'}'><td>{frame}</td><td>{'PASS' if m['ok'] else 'FAIL'}</td>"
            f"<td>{m['max_error']:.6g}{' at ({}, {})'.format(*m['worst_pixel']) if m.get('worst_pixel') else ''}</td>"
            f"<td>{m['failing_pixels']} ({m['failing_percent']:.4g}%)</td>{thumbs}</tr>"
        )
    failed = [r["frame"] for r in records if not r["ok"]]
    summary = f"{len(frames)} frames, {len(frames) - len(failed)} pass" + (
        f", fail: {', '.join(map(str, failed))}" if failed else ""
    )
    page = (
        "<!doctype html><html><head><meta charset='utf-8'>"
        f"<title>phongscene diff --frames: {html.escape(Path(scene).name)}</title>"
        "<style>body{font-family:sans-serif}td,th{padding:4px 8px;border-bottom:1px solid #ccc}"
        "tr.fail td:nth-child(2){color:#b00;font-weight:bold}img{image-rendering:pixelated}</style></head><body>"
        f"<h1>phongscene diff --frames: {html.escape(Path(scene).name)}</h1><p>{html.escape(summary)}</p>"
        "<table><tr><th>frame</th><th>verdict</th><th>max error</th><th>failing pixels</th>"
        "<th>POV-Ray</th><th>native</th><th>heat map</th></tr>" + "".join(rows) + "</table></body></html>\n"
    )
    write_text_atomic(
        out / "metrics.json",
        json.dumps({"scene": scene, **meta, "summary": summary, "frames": records}, indent=2, default=str) + "\n",
    )
    return write_text_atomic(out / FILE_NAMES["html"], page)
