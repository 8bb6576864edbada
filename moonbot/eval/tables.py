"""The tables of `moonbot eval` (moonbot.eval.report), aggregated from the per-instance results
(moonbot.eval.matching): a Summary of errors and recalls per group, by condition as the paper's
Table 3 (mesh, location, stain, dust) and by visible-pixel bin as its Table 4. Errors in mm;
percentages 0–100."""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from moonbot.eval.matching import Evaluation, InstanceResult
from moonbot.eval.metrics import auc

DEFAULT_PX_BINS = (0, 500, 1000, 2000, 5000, 10000)
"""Lower edges of Table 4's visible-pixel bins; the last bin is open ([10000, inf))."""
AUC_MAX_MM = 100.0


@dataclass(frozen=True)
class Summary:
    """One table row's numbers (module docstring): counts; means over matched instances (nan when
    none); recalls and AUC in percent over all instances (nan when there are none)."""

    instances: int
    matched: int
    missed: int
    add_mm: float
    add_pct: float
    adds_mm: float
    adds_pct: float
    adds_pct_median: float
    te_mm: float
    add_recall_10: float
    add_recall_20: float
    adds_recall_10: float
    adds_recall_20: float
    adds_auc: float


def _mean(values: np.ndarray) -> float:
    return float(np.mean(values)) if values.size else math.nan


def summarize(instances: Sequence[InstanceResult]) -> Summary:
    """Summary of evaluated instances (module docstring): means over the matched ones, recalls
    (the toolkit's correct flags) and the AUC (misses +inf) over all, in percent."""
    diam = np.array([r.diameter_mm for r in instances], np.float64)
    matched = np.array([r.matched for r in instances], bool)
    add_mm = np.array([r.add_mm for r in instances], np.float64)[matched]
    adds_mm = np.array([r.adds_mm if r.matched else math.inf for r in instances], np.float64)
    te_mm = np.array([r.te_mm for r in instances], np.float64)[matched]
    adds_pct = 100 * adds_mm[matched] / diam[matched]

    def share(flag: str) -> float:
        return 100 * float(np.mean([getattr(r, flag) for r in instances])) if instances else math.nan

    return Summary(
        instances=len(instances),
        matched=int(matched.sum()),
        missed=int((~matched).sum()),
        add_mm=_mean(add_mm),
        add_pct=_mean(100 * add_mm / diam[matched]),
        adds_mm=_mean(adds_mm[matched]),
        adds_pct=_mean(adds_pct),
        adds_pct_median=float(np.median(adds_pct)) if adds_pct.size else math.nan,
        te_mm=_mean(te_mm),
        add_recall_10=share("add_correct_10"),
        add_recall_20=share("add_correct_20"),
        adds_recall_10=share("adds_correct_10"),
        adds_recall_20=share("adds_correct_20"),
        adds_auc=100 * auc(adds_mm, AUC_MAX_MM),
    )


@dataclass(frozen=True)
class ConditionRow:
    """A Table 3 row: `level` 'condition' (one mesh, location, stain and dust), 'mesh',
    'location', 'stain', 'dust' (one value of that factor, the others 'all'), or 'all'."""

    level: str
    mesh: str
    location: str
    stain: str
    dust: str
    summary: Summary


FACTORS = ("mesh", "location", "stain", "dust")


def table3(evaluation: Evaluation) -> list[ConditionRow]:
    """Table 3: one row per (mesh, location, stain, dust) group present among the evaluated
    instances, in sorted order; then one per value of each factor alone; then 'all'. The
    instances of the condition rows, and of each factor's rows, add up to those of 'all'."""
    rows = evaluation.evaluated
    out = []
    groups: dict[tuple[str, ...], list[InstanceResult]] = defaultdict(list)
    for r in rows:
        groups[tuple(getattr(r, f) for f in FACTORS)].append(r)
    for key in sorted(groups):
        out.append(ConditionRow("condition", *key, summarize(groups[key])))
    for k, factor in enumerate(FACTORS):
        for value in sorted({getattr(r, factor) for r in rows}):
            labels = ["all"] * 4
            labels[k] = value
            out.append(ConditionRow(factor, *labels, summarize([r for r in rows if getattr(r, factor) == value])))
    out.append(ConditionRow("all", "all", "all", "all", "all", summarize(rows)))
    return out


@dataclass(frozen=True)
class PixelRow:
    """A Table 4 row: instances of `mesh` ('all' for every mesh) with lo ≤ px_visib < hi."""

    mesh: str
    lo: float
    hi: float
    summary: Summary

    @property
    def label(self) -> str:
        return f"[{self.lo:g}, {self.hi:g})" if math.isfinite(self.hi) else f">= {self.lo:g}"


def check_bins(edges: Sequence[float]) -> tuple[float, ...]:
    """`edges` as a tuple if they are finite, ≥ 0 and strictly increasing; ValueError otherwise."""
    edges = tuple(float(e) for e in edges)
    if not edges or any(not math.isfinite(e) or e < 0 for e in edges) or any(b <= a for a, b in zip(edges, edges[1:])):
        raise ValueError(f"visible-pixel bin edges must be finite, >= 0 and increasing, got {list(edges)}")
    return edges


def table4(evaluation: Evaluation, edges: Sequence[float] = DEFAULT_PX_BINS) -> list[PixelRow]:
    """Table 4: evaluated instances by visible pixels in the bins [edges[k], edges[k+1]) and
    [edges[-1], inf) — every bin, empty ones too — first over all meshes, then per mesh. An
    instance below edges[0] is in no bin."""
    edges = check_bins(edges)
    bounds = list(zip(edges, [*edges[1:], math.inf]))
    rows = evaluation.evaluated
    out = []
    for mesh in ["all", *sorted({r.mesh for r in rows})]:
        chosen = [r for r in rows if mesh == "all" or r.mesh == mesh]
        for lo, hi in bounds:
            out.append(PixelRow(mesh, lo, hi, summarize([r for r in chosen if lo <= r.px_visib < hi])))
    return out
