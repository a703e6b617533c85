# SPDX-License-Identifier: Apache-2.0
"""The comparison report written to a folder: both images (EXR float + sRGB PNG), the
absolute difference (EXR) and its heat map with a colour scale (PNG), ``metrics.json`` and a
static ``index.html`` (no external resources) that shows everything side by side.

Every file is written atomically (temporary file in the folder, then a rename), so an
interrupted run never leaves a half-written report file behind.
"""

from __future__ import annotations

import html
import json
import math
import os
import re
from pathlib import Path

import numpy as np
from OpenImageIO import ImageBuf, ImageBufAlgo, ImageSpec

from .comparison import CHANNEL_NAMES, Report, channel_error
from .errors import PhongSceneError
from .files import write_text_atomic
from .images import as_image, write_imagebuf, write_image

HEAT_MAP = "inferno"  # perceptually uniform, dark at zero: any non-zero error stands out
# Small images are enlarged (nearest neighbour, integer factor) to at least this width, so that
# a one-pixel difference is a visible block on the heat map and in the browser.
MIN_DISPLAY_WIDTH = 384
# The heat map PNG is at least this wide (the error image at its top left), so that the
# legend's title and its two end labels fit on one line each.
MIN_HEAT_MAP_WIDTH = 2 * MIN_DISPLAY_WIDTH // 3
# Legend layout in pixels below the heat map (text y positions are baselines): the title line,
# the colour bar, then "0" and the maximum under the bar's two ends.
LEGEND_HEIGHT = 52
LEGEND_TITLE_BASELINE = 15
LEGEND_BAR_TOP = 20
LEGEND_BAR_HEIGHT = 12
LEGEND_LABEL_BASELINE = 47
LEGEND_MARGIN = 10  # left and right
LEGEND_FONT_SIZE = 13
LEGEND_BACKGROUND = (0.12, 0.12, 0.12)
LEGEND_TEXT = (0.95, 0.95, 0.95)

FILE_NAMES = {
    "heat": "diff_heat.png",
    "diff": "diff.exr",
    "metrics": "metrics.json",
    "html": "index.html",
}


def display_scale(width: int) -> int:
    """Integer nearest-neighbour enlargement for an image ``width`` pixels wide."""
    return max(1, math.ceil(MIN_DISPLAY_WIDTH / max(width, 1)))


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
) -> Path:
    """Write the report for images ``a`` and ``b`` and their ``report`` into ``outdir``.

    Args:
        outdir: the folder (created if needed).
        a: the reference image (float (H, W, 3), linear), e.g. POV-Ray's.
        b: the image under test, e.g. the native tracer's.
        report: ``compare(a, b)``.
        labels: names of the two images; they become file stems (``<label>.exr``/``.png``).
        title: the page title.
        timings: seconds per step (e.g. each backend's render time), recorded in the JSON.
        meta: anything else worth recording (scene file, mapping, settings); JSON-serialisable.

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
    err = channel_error(a, b)
    heat_max = write_heat_map(out / FILE_NAMES["heat"], err)
    files["heat_png"] = FILE_NAMES["heat"]
    files["metrics"] = FILE_NAMES["metrics"]

    metrics = {
        "title": title,
        "labels": list(labels),
        "files": files,
        "report": report.to_dict(),
        "heat_map": {"map": HEAT_MAP, "min": 0.0, "max": heat_max, "scale": display_scale(a.shape[1])},
        "timings_seconds": dict(timings or {}),
        **(meta or {}),
    }
    write_text_atomic(out / FILE_NAMES["metrics"], json.dumps(metrics, indent=2, allow_nan=False) + "\n")
    page = _html_page(title, labels, files, report, metrics, a.shape[1], a.shape[0])
    return write_text_atomic(out / FILE_NAMES["html"], page)


def write_heat_map(path: str | os.PathLike, error: np.ndarray) -> float:
    """Write the per-pixel error (H, W) as a colour-mapped PNG with a legend bar below it.

    The scale runs from 0 to the largest finite error, so the worst pixel gets the brightest
    colour and any non-zero pixel differs from the zero colour; small images are enlarged by
    an integer factor (nearest neighbour). Non-finite errors are drawn at the top of the
    scale. Returns the error the top of the scale stands for (0 for identical images).
    """
    error = np.asarray(error, dtype=np.float32)
    height, width = error.shape
    finite = np.isfinite(error)
    top = float(error[finite].max()) if finite.any() else 0.0
    norm = np.where(finite, error / top if top > 0 else 0.0, 1.0).astype(np.float32)
    scale = display_scale(width)
    heat = ImageBufAlgo.color_map(ImageBuf(np.ascontiguousarray(norm[..., None])), 0, HEAT_MAP)
    pixels = np.asarray(heat.get_pixels(), np.float32).reshape(height, width, 3)
    pixels = np.repeat(np.repeat(pixels, scale, axis=0), scale, axis=1)

    canvas_w = max(width * scale, MIN_HEAT_MAP_WIDTH)
    canvas = ImageBuf(ImageSpec(canvas_w, height * scale + LEGEND_HEIGHT, 3, "float"))
    ImageBufAlgo.fill(canvas, LEGEND_BACKGROUND)
    ImageBufAlgo.paste(canvas, 0, 0, 0, 0, ImageBuf(np.ascontiguousarray(pixels)))

    # Legend: a title line, the colour bar, then "0" at the left and the maximum at the right.
    bar_w = canvas_w - 2 * LEGEND_MARGIN
    y0 = height * scale
    ramp = np.tile(np.linspace(0, 1, bar_w, dtype=np.float32), (LEGEND_BAR_HEIGHT, 1))[..., None]
    bar = ImageBufAlgo.color_map(ImageBuf(np.ascontiguousarray(ramp)), 0, HEAT_MAP)
    ImageBufAlgo.paste(canvas, LEGEND_MARGIN, y0 + LEGEND_BAR_TOP, 0, 0, bar)
    label = "|a - b|, max over R,G,B" + ("" if finite.all() else " (non-finite: top colour)")
    ImageBufAlgo.render_text(canvas, LEGEND_MARGIN, y0 + LEGEND_TITLE_BASELINE, label, LEGEND_FONT_SIZE, "", LEGEND_TEXT)
    ImageBufAlgo.render_text(canvas, LEGEND_MARGIN, y0 + LEGEND_LABEL_BASELINE, "0", LEGEND_FONT_SIZE, "", LEGEND_TEXT)
    ImageBufAlgo.render_text(
        canvas, canvas_w - LEGEND_MARGIN, y0 + LEGEND_LABEL_BASELINE, f"{top:.4g}", LEGEND_FONT_SIZE, "", LEGEND_TEXT, "right"
    )
    if canvas.has_error:
        raise PhongSceneError(f"{path}: cannot draw the heat map: {canvas.geterror()}")
    # The colour map is already display-referred (sRGB): write it without conversion.
    write_imagebuf(path, canvas, "uint8")
    return top


def _file_stem(label: str) -> str:
    """A label as a safe file stem: letters, digits, '-', '_' only."""
    stem = re.sub(r"[^A-Za-z0-9_-]+", "_", label).strip("_")
    return stem or "image"


# ----------------------------------------------------------------------------------------------
# HTML

_CSS = """
body { font: 14px/1.4 system-ui, sans-serif; margin: 1.5em; color: #222; background: #fafafa; }
h1 { font-size: 1.3em; margin: 0 0 .3em; }
.verdict { display: inline-block; padding: .15em .6em; border-radius: .3em; color: #fff; font-weight: bold; }
.pass { background: #2a7a2a; } .fail { background: #b02020; }
.images { display: flex; gap: 1.2em; align-items: flex-start; margin: 1em 0; }
/* Side by side at any window width: each figure takes a third and scales its image down. */
figure { margin: 0; flex: 1 1 0; min-width: 0; } figcaption { font-weight: bold; margin-bottom: .3em; }
img { image-rendering: pixelated; border: 1px solid #ccc; display: block; max-width: 100%; height: auto; }
table { border-collapse: collapse; margin: .6em 0 1.2em; }
td, th { border: 1px solid #ddd; padding: .2em .6em; text-align: left; font-variant-numeric: tabular-nums; }
th { background: #eee; } code { font-size: .95em; }
"""


def _fmt(value) -> str:
    if isinstance(value, float):
        return f"{value:.8g}"
    if isinstance(value, (list, tuple)):
        return "(" + ", ".join(_fmt(v) for v in value) + ")"
    if value is None:
        return "none"
    return str(value)


def _rows(pairs) -> str:
    e = html.escape
    return "\n".join(f"<tr><th>{e(str(k))}</th><td>{e(_fmt(v))}</td></tr>" for k, v in pairs)


def _html_page(title, labels, files, report: Report, metrics: dict, width: int, height: int) -> str:
    e = html.escape
    scale = display_scale(width)
    w, h = width * scale, height * scale
    verdict = '<span class="verdict pass">PASS</span>' if report.ok else '<span class="verdict fail">FAIL</span>'
    t = report.thresholds
    worst = report.worst
    numbers = [
        ("size", f"{report.width} x {report.height}"),
        ("mean error", report.mean_error),
        ("RMS error", report.rms_error),
        ("max error", report.max_error),
        ("max error at (x, y, channel)", f"({worst.x}, {worst.y}, {CHANNEL_NAMES[worst.channel]})" if worst else "-"),
        (f"{labels[0]} there", worst.a if worst else "-"),
        (f"{labels[1]} there", worst.b if worst else "-"),
        ("max relative error (above the floor)", report.max_relative_error),
        ("failing pixels", f"{report.failing_pixels} ({report.failing_percent:.4g} %)"),
        ("non-finite pixels", f"{report.nonfinite_pixels_a} / {report.nonfinite_pixels_b}"),
        ("hard fail", report.hard_fail),
    ]
    thresholds = [
        ("fail (absolute floor)", t.fail),
        ("fail_relative (of mean |a|, |b|)", t.fail_relative),
        ("fail_percent", t.fail_percent),
        ("hard_fail", t.hard_fail),
    ]
    worst_rows = "\n".join(
        f"<tr><td>{p.x}</td><td>{p.y}</td><td>{CHANNEL_NAMES[p.channel]}</td><td>{e(_fmt(p.error))}</td>"
        f"<td>{e(_fmt(p.a))}</td><td>{e(_fmt(p.b))}</td></tr>"
        for p in report.worst_pixels
    )
    timings = metrics.get("timings_seconds", {})
    extra = [(k, v) for k, v in metrics.items() if k not in ("title", "labels", "files", "report", "heat_map", "timings_seconds")]
    heat = metrics["heat_map"]

    def figure(caption: str, png: str, exr: str | None, img_w: int, img_h: int | None) -> str:
        size = f' width="{img_w}"' + (f' height="{img_h}"' if img_h else "")
        link = f' (<a href="{e(exr)}">EXR</a>)' if exr else ""
        return (
            f'<figure><figcaption>{e(caption)}{link}</figcaption>'
            f'<img src="{e(png)}" alt="{e(caption)}"{size}></figure>'
        )

    return f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>{e(title)}</title>
<style>{_CSS}</style>
</head>
<body>
<h1>{e(title)}</h1>
<p>{verdict} &nbsp; {e(labels[0])} vs {e(labels[1])}, {report.width} x {report.height} pixels</p>
<div class="images">
{figure(labels[0], files["a_png"], files["a_exr"], w, h)}
{figure(labels[1], files["b_png"], files["b_exr"], w, h)}
{figure(f"|{labels[0]} - {labels[1]}| (0 .. {heat['max']:.4g})", files["heat_png"], files["diff_exr"], max(w, MIN_HEAT_MAP_WIDTH), None)}
</div>
<h2>Numbers</h2>
<table>
{_rows(numbers)}
</table>
<h2>Thresholds</h2>
<table>
{_rows(thresholds)}
</table>
<h2>Worst pixels</h2>
<table>
<tr><th>x</th><th>y</th><th>channel</th><th>error</th><th>{e(labels[0])}</th><th>{e(labels[1])}</th></tr>
{worst_rows}
</table>
<h2>Timings (seconds)</h2>
<table>
{_rows(timings.items())}
</table>
<h2>Run</h2>
<table>
{_rows((k, json.dumps(v) if isinstance(v, (dict, list)) else v) for k, v in extra)}
</table>
<p>All numbers: <a href="{e(files["metrics"])}">{e(files["metrics"])}</a></p>
</body>
</html>
"""


__all__ = ["display_scale", "write_heat_map", "write_report"]
