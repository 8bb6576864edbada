"""`moonbot eval`'s figures as PNG bytes (moonbot.charts: matplotlib's Agg canvas, no pyplot
state): ADD-S against visible pixels per instance (the paper's Figure 11) and recall per condition
group (Table 3). No timestamps or version in the PNG metadata, so the same evaluation gives the
same bytes."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from moonbot.charts import COLOURS, figure, png_bytes
from moonbot.eval.matching import RECALL_FRACTIONS, Evaluation
from moonbot.eval.tables import ConditionRow, check_bins

DPI = 110


def adds_vs_visible_pixels(evaluation: Evaluation, edges: Sequence[float], title: str) -> bytes:
    """Scatter of each evaluated, matched instance's ADD-S (% of its diameter) against its visible
    pixels (log x), one colour per mesh; the recall thresholds (10 %, 20 %) as dashed lines, the
    visible-pixel bin edges as dotted ones and the median per bin (all meshes) as a black line.
    Missed instances are crosses on the top edge, errors above the plotted range triangles there."""
    from matplotlib.ticker import FuncFormatter, NullFormatter

    edges = check_bins(edges)
    rows = evaluation.evaluated
    fig = figure(11, 5.5)
    ax = fig.add_subplot()
    matched = [r for r in rows if r.matched]
    y_all = np.array([100 * r.adds_mm / r.diameter_mm for r in matched])
    top = max(25.0, 1.08 * float(y_all.max())) if y_all.size else 25.0
    if top > 60.0:  # a few far-off estimates would squash the rest: clip them to the top edge
        top = max(60.0, 1.08 * float(np.percentile(y_all, 95)))
    px_all = np.array([r.px_visib for r in rows], np.float64)
    x_lo = float(px_all.min()) / 1.6 if px_all.size else 1.0
    x_hi = float(px_all.max()) * 1.6 if px_all.size else 1e5
    for k, mesh in enumerate(sorted({r.mesh for r in rows})):
        colour = COLOURS[k % len(COLOURS)]
        mine = [r for r in matched if r.mesh == mesh]
        x = np.array([r.px_visib for r in mine], np.float64)
        y = np.array([100 * r.adds_mm / r.diameter_mm for r in mine])
        n_missed = sum(1 for r in rows if r.mesh == mesh and not r.matched)
        inside = y <= top
        ax.scatter(
            x[inside],
            y[inside],
            s=14,
            alpha=0.6,
            color=colour,
            edgecolors="none",
            label=f"{mesh} ({len(mine)} matched" + (f", {n_missed} missed)" if n_missed else ")"),
        )
        if (~inside).any():
            ax.scatter(x[~inside], np.full((~inside).sum(), top * 0.985), marker="^", s=30, color=colour, clip_on=False)
        missed = np.array([r.px_visib for r in rows if r.mesh == mesh and not r.matched], np.float64)
        if missed.size:
            ax.scatter(missed, np.full(missed.size, top), marker="x", s=30, color=colour, clip_on=False)
    for fraction, style in zip(RECALL_FRACTIONS, ("--", "-.")):
        ax.axhline(
            100 * fraction, color="0.25", linestyle=style, linewidth=1.0, label=f"{100 * fraction:g} % of the diameter"
        )
    for edge in edges:
        if edge > 0:
            ax.axvline(edge, color="0.8", linestyle=":", linewidth=0.9, zorder=0)
    bounds = list(zip(edges, [*edges[1:], math.inf]))
    centres, medians = [], []
    px_matched = np.array([r.px_visib for r in matched], np.float64)
    for lo, hi in bounds:
        inside = (px_matched >= lo) & (px_matched < hi)
        if inside.any():
            centres.append(float(np.exp(np.mean(np.log(px_matched[inside])))))
            medians.append(float(np.median(y_all[inside])))
    if centres:
        ax.plot(
            centres,
            np.minimum(medians, top),
            color="black",
            marker="o",
            markersize=4,
            linewidth=1.2,
            label="median per pixel bin",
        )
    if any(not r.matched for r in rows):
        ax.scatter([], [], marker="x", color="0.3", label="missed (no estimate), at the top")
    if y_all.size and (y_all > top).any():
        ax.scatter([], [], marker="^", color="0.3", label=f"above {top:.0f} %, at the top")
    ax.set_xscale("log")
    ax.set_xlim(x_lo, x_hi)
    plain = FuncFormatter(lambda v, _: f"{v:,.0f}")
    ax.xaxis.set_major_formatter(plain)
    # Within two decades also label the minor ticks at 2 and 5 × a power of ten.
    some = FuncFormatter(lambda v, _: f"{v:,.0f}" if round(v / 10 ** math.floor(math.log10(v))) in (2, 5) else "")
    ax.xaxis.set_minor_formatter(some if x_hi / x_lo < 100 else NullFormatter())
    ax.set_ylim(0.0, top)
    ax.set_xlabel("visible pixels of the instance (scene_gt_info px_count_visib, log scale)")
    ax.set_ylabel("ADD-S error (% of the object diameter)")
    ax.set_title(f"ADD-S against visibility: {title}", fontsize=11)
    ax.grid(True, which="major", color="0.92")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    if not rows:
        ax.text(0.5, 0.5, "no evaluated instances", transform=ax.transAxes, ha="center")
    return png_bytes(fig, DPI)


def _label(row: ConditionRow) -> str:
    if row.level == "condition":
        return f"{row.mesh} · {row.location} · {row.stain} · {row.dust}"
    if row.level == "all":
        return "all"
    return f"{row.level}: {getattr(row, row.level)}"


def recall_by_condition(rows: Sequence[ConditionRow], title: str) -> bytes:
    """Horizontal bars of each Table 3 row's ADD-S recall at 20 % of the diameter (the recall at
    10 % as a darker inner bar), condition groups first, then each factor's rows and 'all'; each
    bar annotated with both recalls and the instance count."""
    height = 1.6 + 0.3 * max(len(rows), 1)
    fig = figure(9, height)
    ax = fig.add_subplot()
    levels = ["condition", "mesh", "location", "stain", "dust", "all"]
    palette = {level: COLOURS[k % len(COLOURS)] for k, level in enumerate(levels)}
    palette["all"] = "#444444"
    y = np.arange(len(rows))
    r20 = np.array([r.summary.adds_recall_20 for r in rows], np.float64)
    r10 = np.array([r.summary.adds_recall_10 for r in rows], np.float64)
    colours = [palette.get(r.level, COLOURS[0]) for r in rows]
    ax.barh(y, np.nan_to_num(r20), height=0.75, color=colours, alpha=0.45)
    ax.barh(y, np.nan_to_num(r10), height=0.4, color=colours)
    for k, r in enumerate(rows):
        s = r.summary
        note = (
            (
                f"20 %: {s.adds_recall_20:5.1f}   10 %: {s.adds_recall_10:5.1f}   n={s.instances}"
                + (f", {s.missed} missed" if s.missed else "")
            )
            if s.instances
            else "no instances"
        )
        ax.text(101, k, note, va="center", fontsize=8)
    ax.set_yticks(y, [_label(r) for r in rows], fontsize=8)
    ax.set_ylim(len(rows) - 0.5, -0.5)  # first row at the top
    ax.set_xlim(0, 100)
    ax.set_xlabel("ADD-S recall (%): light bar at 20 % of the diameter, dark bar at 10 %")
    ax.set_title(f"Recall by condition: {title}", fontsize=11)
    ax.grid(True, axis="x", color="0.9")
    ax.set_axisbelow(True)
    return png_bytes(fig, DPI)
