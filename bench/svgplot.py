"""Time-against-error plots as standalone SVG (no plotting library needed): one polyline per
curve, logarithmic axes, points labelled with their knob value. Shared by the scripts in bench/;
the document frame and the palette are moonbot.pipeline.svgchart's (also `moonbot stats`'s plot)."""

from __future__ import annotations

import math
from html import escape
from pathlib import Path

from moonbot.pipeline.svgchart import COLOURS, svg_close, svg_open

WIDTH, PLOT_HEIGHT, MARGIN = 640, 420, 64


def _log_ticks(lo: float, hi: float) -> list[float]:
    ticks = []
    for e in range(math.floor(math.log10(lo)), math.ceil(math.log10(hi)) + 1):
        for m in (1, 2, 5):
            if lo <= m * 10.0 ** e <= hi:
                ticks.append(m * 10.0 ** e)
    return ticks


def time_error_plot(path: Path, title: str, curves: dict[str, list[tuple[float, float, str]]],
                    x_label: str = "seconds", y_label: str = "error") -> None:
    """Writes an SVG of `curves`: name -> [(time, error, point label)], both axes logarithmic
    (non-positive values are drawn at the axis floor)."""
    height = PLOT_HEIGHT + 14 * len(curves)  # the legend goes under the axis label
    points = [(x, y) for curve in curves.values() for x, y, _ in curve]
    xs = [x for x, _ in points if x > 0]
    ys = [y for _, y in points if y > 0]
    x_lo, x_hi = min(xs) / 1.5, max(xs) * 1.5
    y_lo, y_hi = min(ys) / 1.5, max(ys) * 1.5

    def px(x: float) -> float:
        x = max(x, x_lo)
        return MARGIN + (WIDTH - 2 * MARGIN) * math.log(x / x_lo) / math.log(x_hi / x_lo)

    def py(y: float) -> float:
        y = max(y, y_lo)
        return PLOT_HEIGHT - MARGIN - (PLOT_HEIGHT - 2 * MARGIN) * math.log(y / y_lo) / math.log(y_hi / y_lo)

    out = svg_open(WIDTH, height, title)
    out.append(f'<rect x="{MARGIN}" y="{MARGIN}" width="{WIDTH - 2 * MARGIN}" height="{PLOT_HEIGHT - 2 * MARGIN}" '
               f'fill="none" stroke="black"/>')
    for t in _log_ticks(x_lo, x_hi):
        out.append(f'<line x1="{px(t):.1f}" y1="{MARGIN}" x2="{px(t):.1f}" y2="{PLOT_HEIGHT - MARGIN}" stroke="#ddd"/>')
        out.append(f'<text x="{px(t):.1f}" y="{PLOT_HEIGHT - MARGIN + 14}" text-anchor="middle">{t:g}</text>')
    for t in _log_ticks(y_lo, y_hi):
        out.append(f'<line x1="{MARGIN}" y1="{py(t):.1f}" x2="{WIDTH - MARGIN}" y2="{py(t):.1f}" stroke="#ddd"/>')
        out.append(f'<text x="{MARGIN - 4}" y="{py(t) + 4:.1f}" text-anchor="end">{t:g}</text>')
    out.append(f'<text x="{WIDTH / 2}" y="{PLOT_HEIGHT - 30}" text-anchor="middle">{escape(x_label)}</text>')
    out.append(f'<text transform="translate(16 {PLOT_HEIGHT / 2}) rotate(-90)" text-anchor="middle">{escape(y_label)}</text>')
    for k, (name, curve) in enumerate(curves.items()):
        colour = COLOURS[k % len(COLOURS)]
        coords = " ".join(f"{px(x):.1f},{py(y):.1f}" for x, y, _ in curve)
        out.append(f'<polyline points="{coords}" fill="none" stroke="{colour}" stroke-width="1.5"/>')
        for x, y, label in curve:
            out.append(f'<circle cx="{px(x):.1f}" cy="{py(y):.1f}" r="3" fill="{colour}"/>')
            out.append(f'<text x="{px(x) + 5:.1f}" y="{py(y) - 5:.1f}" fill="{colour}">{escape(label)}</text>')
        out.append(f'<text x="{MARGIN}" y="{PLOT_HEIGHT - 8 + 14 * k}" fill="{colour}">— {escape(name)}</text>')
    path.write_text(svg_close(out))
