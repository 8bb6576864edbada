"""The text and CSV of `moonbot eval`'s tables (moonbot.eval.tables) and of its per-instance
results (moonbot.eval.matching): fixed-width text for the terminal, CSV (full precision, empty
for NaN) for other tools."""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Iterable, Sequence

from moonbot.eval.matching import Evaluation
from moonbot.eval.tables import FACTORS, ConditionRow, PixelRow, Summary


def _fmt(value: float, digits: int = 1) -> str:
    return "-" if value is None or not math.isfinite(value) else f"{value:.{digits}f}"


def _csv_value(value) -> str:
    if isinstance(value, bool):
        return str(int(value))
    if isinstance(value, float):
        return "" if math.isnan(value) else repr(value)
    return str(value)


def _csv(header: Sequence[str], rows: Iterable[Sequence]) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(header)
    for row in rows:
        writer.writerow([_csv_value(v) for v in row])
    return buffer.getvalue()


SUMMARY_COLUMNS = (
    "instances",
    "matched",
    "missed",
    "add_mm",
    "add_pct",
    "adds_mm",
    "adds_pct",
    "adds_pct_median",
    "te_mm",
    "add_recall_10",
    "add_recall_20",
    "adds_recall_10",
    "adds_recall_20",
    "adds_auc",
)


def _summary_values(s: Summary) -> list:
    return [getattr(s, c) for c in SUMMARY_COLUMNS]


def table3_csv(rows: Sequence[ConditionRow]) -> str:
    """table3.csv: level, mesh, location, stain, dust, then SUMMARY_COLUMNS (errors in mm, *_pct
    in % of the diameter, recalls at 10/20 % of the diameter and the 0–100 mm AUC in %)."""
    return _csv(
        ("level", *FACTORS, *SUMMARY_COLUMNS),
        ([r.level, r.mesh, r.location, r.stain, r.dust, *_summary_values(r.summary)] for r in rows),
    )


def table4_csv(rows: Sequence[PixelRow]) -> str:
    """table4.csv: mesh, px_lo, px_hi (empty = no upper edge), then SUMMARY_COLUMNS."""
    return _csv(
        ("mesh", "px_lo", "px_hi", *SUMMARY_COLUMNS),
        ([r.mesh, r.lo, r.hi if math.isfinite(r.hi) else math.nan, *_summary_values(r.summary)] for r in rows),
    )


INSTANCE_COLUMNS = (
    "split",
    "scene_id",
    "im_id",
    "obj_id",
    "instance",
    "mesh",
    "location",
    "stain",
    "dust",
    "px_visib",
    "visib_fract",
    "evaluated",
    "matched",
    "add_mm",
    "adds_mm",
    "te_mm",
    "diameter_mm",
    "score",
    "results_line",
    "add_correct_10",
    "add_correct_20",
    "adds_correct_10",
    "adds_correct_20",
)


def per_instance_csv(evaluation: Evaluation) -> str:
    """per_instance.csv: one line per ground-truth instance of the split; errors in mm, empty when
    unmatched or not evaluated; `instance` is its index in scene_gt.json (the K of its masks),
    `results_line` the matched estimate's line in the results CSV (0: none); `*_correct_10/20`
    1 where the toolkit's matching counts the instance correct (the tables' recalls are their
    shares)."""
    return _csv(
        INSTANCE_COLUMNS,
        (
            [
                r.split,
                r.scene_id,
                r.im_id,
                r.obj_id,
                r.index,
                r.mesh,
                r.location,
                r.stain,
                r.dust,
                r.px_visib,
                r.visib_fract,
                r.evaluated,
                r.matched,
                r.add_mm,
                r.adds_mm,
                r.te_mm,
                r.diameter_mm,
                r.score,
                r.line,
                r.add_correct_10,
                r.add_correct_20,
                r.adds_correct_10,
                r.adds_correct_20,
            ]
            for r in evaluation.instances
        ),
    )


def _text_table(header: Sequence[str], rows: Sequence[Sequence[str]], left: int) -> list[str]:
    """Columns padded to their widest cell; the first `left` columns flush left, the rest right."""
    widths = [max(len(str(c)) for c in col) for col in zip(header, *rows)]

    def line(cells):
        return "  ".join(
            str(c).ljust(w) if k < left else str(c).rjust(w) for k, (c, w) in enumerate(zip(cells, widths))
        ).rstrip()

    return [line(header), "  ".join("-" * w for w in widths), *[line(r) for r in rows]]


def _summary_cells(s: Summary) -> list[str]:
    return [
        str(s.instances),
        str(s.missed),
        _fmt(s.add_mm),
        _fmt(s.add_pct),
        _fmt(s.adds_mm),
        _fmt(s.adds_pct),
        _fmt(s.te_mm),
        _fmt(s.add_recall_10),
        _fmt(s.add_recall_20),
        _fmt(s.adds_recall_10),
        _fmt(s.adds_recall_20),
        _fmt(s.adds_auc),
    ]


SUMMARY_HEADER = [
    "inst",
    "missed",
    "ADD mm",
    "ADD %d",
    "ADD-S mm",
    "ADD-S %d",
    "TE mm",
    "ADD<10%",
    "ADD<20%",
    "ADD-S<10%",
    "ADD-S<20%",
    "AUC",
]
LEGEND = (
    "means over matched instances; %d = % of the object diameter; ADD<10% etc. = recall (%): share of the "
    "instances the BOP toolkit's matching counts correct at 10/20 % of the diameter, misses included; "
    "AUC = ADD-S AUC 0-100 mm (%), misses included"
)


def _header_lines(title: str, evaluation: Evaluation) -> list[str]:
    ev = evaluation.evaluated
    left_out = len(evaluation.instances) - len(ev)
    return [
        f"{title} — split {evaluation.split!r}: {len(ev)} instances evaluated "
        f"(px_visib > 0, visib_fract >= {evaluation.min_visib_fract:g}; {left_out} left out), "
        f"{evaluation.estimates} estimates ({evaluation.matched_estimates} matched, "
        f"{evaluation.unmatched_estimates} unmatched, {len(evaluation.unknown)} unknown)",
        LEGEND,
        "",
    ]


def format_table3(rows: Sequence[ConditionRow], evaluation: Evaluation) -> str:
    """table3.txt: the rows as a fixed-width text table with a header naming the split and counts."""
    body = []
    for k, r in enumerate(rows):
        if k and r.level != rows[k - 1].level and r.level != "condition":
            body.append([""] * (4 + len(SUMMARY_HEADER)))
        body.append([r.mesh, r.location, r.stain, r.dust, *_summary_cells(r.summary)])
    lines = _header_lines("Table 3: pose error by condition", evaluation)
    lines += _text_table(["mesh", "location", "stain", "dust", *SUMMARY_HEADER], body, 4)
    return "\n".join(lines) + "\n"


def format_table4(rows: Sequence[PixelRow], evaluation: Evaluation) -> str:
    """table4.txt: instances, missed, mean and median ADD-S % diameter and the ADD-S recalls per
    visible-pixel bin, all meshes first, then per mesh."""
    header = ["mesh", "visible px", "inst", "missed", "ADD-S %d mean", "ADD-S %d median", "ADD-S<10%", "ADD-S<20%"]
    body = []
    for k, r in enumerate(rows):
        if k and r.mesh != rows[k - 1].mesh:
            body.append([""] * len(header))
        s = r.summary
        body.append(
            [
                r.mesh,
                r.label,
                str(s.instances),
                str(s.missed),
                _fmt(s.adds_pct),
                _fmt(s.adds_pct_median),
                _fmt(s.adds_recall_10),
                _fmt(s.adds_recall_20),
            ]
        )
    lines = _header_lines("Table 4: pose error by visible pixels (scene_gt_info px_count_visib)", evaluation)
    lines += _text_table(header, body, 2)
    return "\n".join(lines) + "\n"
