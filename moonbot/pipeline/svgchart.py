"""Charts as standalone SVG text, without a plotting library: the document frame and palette
(shared with bench/svgplot.py's time-against-error plots) and horizontal bar panels, plain or
stacked, for throughput figures. Every number is printed at a fixed precision, so the same data
gives the same bytes."""

from __future__ import annotations

import math
from html import escape

# The first six are bench/svgplot.py's curve colours; the rest extend it for stacked stages.
COLOURS = ("#1b6ca8", "#d1495b", "#2e8b57", "#edae49", "#6a4c93", "#00798c",
           "#8c564b", "#7f7f7f", "#bcbd22", "#e377c2")


def svg_open(width: float, height: float, title: str) -> list[str]:
    """The first lines of an SVG document of `width` × `height` pixels: the root element, a white
    background and `title` centred at the top."""
    return [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
            f'font-family="sans-serif" font-size="11">',
            f'<rect width="{width}" height="{height}" fill="white"/>',
            f'<text x="{width / 2}" y="20" text-anchor="middle" font-size="14">{escape(title)}</text>']


def svg_close(lines: list[str]) -> str:
    """The document's text: `lines` and the closing tag, one element a line."""
    return "\n".join([*lines, "</svg>"]) + "\n"


def linear_ticks(hi: float) -> list[float]:
    """Ticks 0, s, 2s, ... covering [0, hi] with s a 1-2-5 multiple of a power of ten, 4-10 of them."""
    if not hi > 0 or not math.isfinite(hi):
        return [0.0, 1.0]
    step = 10.0 ** math.floor(math.log10(hi / 4))
    for m in (1, 2, 5, 10):
        if hi / (m * step) <= 8:
            step *= m
            break
    count = math.ceil(hi / step - 1e-9)
    return [k * step for k in range(count + 1)]


def bar_panel(top: float, width: float, title: str, axis_label: str,
              rows: list[tuple[str, list[float], str]], series: list[str] | None = None,
              colours: list[str] | None = None, label_width: float = 150) -> tuple[list[str], float]:
    """A panel of horizontal bars starting `top` pixels down a document `width` wide: one bar per
    row (label, segment values, text after the bar); a row's segments are stacked left to right in
    the colours of `series` (a legend under the axis when there is more than one). Returns the
    panel's SVG lines and its height in pixels. Values are drawn from 0 on a linear axis; negative
    and non-finite ones as 0."""
    bar_h, gap, right = 18, 8, 110
    rows = [(label, [v if math.isfinite(v) and v > 0 else 0.0 for v in values], note)
            for label, values, note in rows]
    series = series or [""]
    colours = colours or [COLOURS[k % len(COLOURS)] for k in range(len(series))]
    x0, x1 = label_width, width - right
    plot_top = top + 24
    plot_h = len(rows) * (bar_h + gap) + gap
    ticks = linear_ticks(max((sum(v) for _, v, _ in rows), default=0.0))
    scale = (x1 - x0) / ticks[-1]
    out = [f'<text x="{x0}" y="{top + 14}" font-size="12" font-weight="bold">{escape(title)}</text>']
    for t in ticks:
        x = x0 + t * scale
        out.append(f'<line x1="{x:.1f}" y1="{plot_top}" x2="{x:.1f}" y2="{plot_top + plot_h}" stroke="#ddd"/>')
        out.append(f'<text x="{x:.1f}" y="{plot_top + plot_h + 14}" text-anchor="middle">{t:g}</text>')
    for k, (label, values, note) in enumerate(rows):
        y = plot_top + gap + k * (bar_h + gap)
        out.append(f'<text x="{x0 - 6}" y="{y + 13}" text-anchor="end">{escape(label)}</text>')
        x = x0
        for value, colour in zip(values, colours):
            w = value * scale
            if w > 0:
                out.append(f'<rect x="{x:.1f}" y="{y}" width="{w:.1f}" height="{bar_h}" fill="{colour}"/>')
            x += w
        out.append(f'<text x="{x + 4:.1f}" y="{y + 13}">{escape(note)}</text>')
    out.append(f'<line x1="{x0}" y1="{plot_top}" x2="{x0}" y2="{plot_top + plot_h}" stroke="black"/>')
    out.append(f'<text x="{(x0 + x1) / 2:.1f}" y="{plot_top + plot_h + 30}" text-anchor="middle">'
               f'{escape(axis_label)}</text>')
    height = plot_top + plot_h + 36 - top
    if len(series) > 1:
        x, y = x0, top + height + 4
        for name, colour in zip(series, colours):
            if x + 12 + 7 * len(name) > width:  # wrap the legend
                x, y = x0, y + 16
            out.append(f'<rect x="{x:.1f}" y="{y}" width="10" height="10" fill="{colour}"/>')
            out.append(f'<text x="{x + 14:.1f}" y="{y + 9}">{escape(name)}</text>')
            x += 24 + 7 * len(name)
        height = y + 16 - top
    return out, height
