"""moonbot's charts, on matplotlib's Agg canvas (no pyplot state, no display): the palette, a
figure, horizontal bar panels (plain or stacked; throughput figures), time-against-error curves on
logarithmic axes (bench/ scripts), and a figure's PNG or SVG bytes.

The same data gives the same bytes: the SVG has no date, its element ids come from a fixed hash
salt, and its text stays text (svg.fonttype 'none') in matplotlib's own bundled font (DejaVu Sans),
so neither the installed fonts nor the run change it; the PNG has no software or date record."""

from __future__ import annotations

import io
import math
from collections.abc import Sequence
from contextlib import contextmanager
from pathlib import Path

# Curves, bars and stacked stages take colours in this order.
COLOURS = ("#1b6ca8", "#d1495b", "#2e8b57", "#edae49", "#6a4c93", "#00798c", "#8c564b", "#7f7f7f", "#bcbd22", "#e377c2")

# The settings every chart is drawn and saved under (matplotlib.rc_context: nothing global changes).
_STYLE = {
    "font.family": "DejaVu Sans",  # bundled with matplotlib: the same metrics wherever it runs
    "svg.fonttype": "none",  # text as <text> elements, not glyph paths
    "svg.hashsalt": "moonbot",  # element ids from the content, not a random salt
}


@contextmanager
def _style():
    import matplotlib

    with matplotlib.rc_context(_STYLE):
        yield


def figure(width_in: float, height_in: float):
    """A matplotlib Figure of `width_in` × `height_in` inches on an Agg canvas, constrained layout."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    with _style():
        fig = Figure(figsize=(width_in, height_in), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def png_bytes(fig, dpi: float) -> bytes:
    """The figure as PNG at `dpi`, without metadata that changes run to run."""
    buffer = io.BytesIO()
    with _style():
        fig.savefig(buffer, format="png", dpi=dpi, metadata={"Software": None})
    return buffer.getvalue()


def svg_bytes(fig) -> bytes:
    """The figure as SVG, the same bytes for the same figure (no date, fixed ids, text as text)."""
    buffer = io.BytesIO()
    with _style():
        fig.savefig(buffer, format="svg", metadata={"Date": None})
    return buffer.getvalue()


def bar_panel(
    ax,
    title: str,
    axis_label: str,
    rows: Sequence[tuple[str, Sequence[float], str]],
    series: Sequence[str] | None = None,
    colours: Sequence[str] | None = None,
) -> None:
    """Draws horizontal bars on `ax`, one per row (label, segment values, text after the bar),
    first row at the top; a row's segments are stacked left to right in the colours of `series`
    (a legend under the axis when there is more than one). Values are drawn from 0 on a linear
    axis; negative and non-finite ones as 0."""
    rows = [(label, [v if math.isfinite(v) and v > 0 else 0.0 for v in values], note) for label, values, note in rows]
    series = list(series or [""])
    colours = list(colours or [COLOURS[k % len(COLOURS)] for k in range(len(series))])
    with _style():
        y = list(range(len(rows)))
        left = [0.0] * len(rows)
        for k, (name, colour) in enumerate(zip(series, colours)):
            widths = [values[k] if k < len(values) else 0.0 for _, values, _ in rows]
            ax.barh(y, widths, left=left, height=0.7, color=colour, label=name or None)
            left = [a + b for a, b in zip(left, widths)]
        hi = max(left, default=0.0)
        for k, (_, _, note) in enumerate(rows):
            ax.text(left[k] + 0.01 * (hi or 1.0), k, note, va="center", fontsize=8)
        ax.set_yticks(y, [label for label, _, _ in rows], fontsize=8)
        ax.set_ylim(len(rows) - 0.5, -0.5)
        ax.set_xlim(0.0, 1.25 * hi if hi > 0 else 1.0)  # room for the notes
        ax.set_xlabel(axis_label)
        ax.set_title(title, loc="left", fontweight="bold")
        ax.grid(True, axis="x", color="0.87")
        ax.set_axisbelow(True)
        if len(series) > 1:
            ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.25), ncols=min(len(series), 5), frameon=False)


def bar_panels_svg(title: str, panels: Sequence[dict], width_in: float = 9.0) -> bytes:
    """An SVG of bar panels stacked top to bottom under `title`; each panel is bar_panel's keyword
    arguments (title, axis_label, rows, optional series and colours)."""
    heights = [1.1 + 0.3 * len(p["rows"]) + (0.5 if len(p.get("series") or ()) > 1 else 0.0) for p in panels]
    fig = figure(width_in, sum(heights) + 0.4)
    with _style():
        fig.suptitle(title, fontsize=11)
        axes = fig.subplots(len(panels), 1, gridspec_kw={"height_ratios": heights}, squeeze=False)[:, 0]
    for ax, panel in zip(axes, panels):
        bar_panel(ax, **panel)
    return svg_bytes(fig)


def time_error_plot(
    path: Path,
    title: str,
    curves: dict[str, list[tuple[float, float, str]]],
    x_label: str = "seconds",
    y_label: str = "error",
) -> None:
    """Writes an SVG of `curves`: name → [(time, error, point label)], both axes logarithmic,
    each point labelled (non-positive values are drawn at the axis floor)."""
    points = [(x, y) for curve in curves.values() for x, y, _ in curve]
    xs = [x for x, _ in points if x > 0] or [1.0]
    ys = [y for _, y in points if y > 0] or [1.0]
    x_lo, x_hi = min(xs) / 1.5, max(xs) * 1.5
    y_lo, y_hi = min(ys) / 1.5, max(ys) * 1.5
    fig = figure(7.0, 5.0)
    with _style():
        ax = fig.add_subplot()
        for k, (name, curve) in enumerate(curves.items()):
            colour = COLOURS[k % len(COLOURS)]
            x = [max(p, x_lo) for p, _, _ in curve]
            y = [max(q, y_lo) for _, q, _ in curve]
            ax.plot(x, y, color=colour, marker="o", markersize=4, linewidth=1.5, label=name)
            for px, py, (_, _, label) in zip(x, y, curve):
                ax.annotate(label, (px, py), xytext=(4, 4), textcoords="offset points", color=colour, fontsize=8)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlim(x_lo, x_hi)
        ax.set_ylim(y_lo, y_hi)
        ax.set_xlabel(x_label)
        ax.set_ylabel(y_label)
        ax.set_title(title, fontsize=11)
        ax.grid(True, which="major", color="0.87")
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.12), ncols=min(len(curves), 3) or 1, frameon=False)
    Path(path).write_bytes(svg_bytes(fig))
