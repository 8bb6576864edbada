"""The BOP results CSV (bop_toolkit inout.load_bop_results; docs/dataset-format.md): the header
`scene_id,im_id,obj_id,score,R,t,time`, then one estimate a line — R nine space-separated floats
(row-major, model to camera), t three floats in mm, score a float (higher is better), time the
seconds spent on the whole image (the same for every row of one image, within 1 ms; −1 = unknown)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from moonbot.atomic_io import atomic_write

HEADER = "scene_id,im_id,obj_id,score,R,t,time"
TIME_TOLERANCE_S = 0.001


class ResultsError(ValueError):
    """A results file is malformed; the message names the file and the line."""


@dataclass(frozen=True)
class Estimate:
    """One pose estimate. R (3, 3) float64 model→camera; t (3,) float64 mm. `line`: its line in
    the results file (1-based), 0 when it was not read from one."""

    scene_id: int
    im_id: int
    obj_id: int
    score: float
    R: np.ndarray
    t: np.ndarray
    time_s: float
    line: int = 0


def _numbers(text: str, count: int, what: str, where: str) -> np.ndarray:
    parts = text.split()
    if len(parts) != count:
        raise ResultsError(f"{where}: {what} must be {count} space-separated numbers, got {len(parts)}")
    try:
        values = np.array([float(p) for p in parts])
    except ValueError:
        raise ResultsError(f"{where}: {what} must be numbers, got {text!r}") from None
    if not np.all(np.isfinite(values)):
        raise ResultsError(f"{where}: {what} must be finite, got {text!r}")
    return values


def read_results(path: Path) -> list[Estimate]:
    """Reads and checks a results CSV. Raises ResultsError naming the file and line on a wrong
    header, a line without 7 fields, a non-integer id, a non-numeric or non-finite value, R or t of
    the wrong length, or rows of one image that disagree on its time; OSError if unreadable."""
    path = Path(path)
    lines = path.read_text(encoding="utf-8").splitlines()
    if not lines or lines[0].strip() != HEADER:
        raise ResultsError(f"{path}:1: the header must be {HEADER!r}")
    estimates, times = [], {}
    for number, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        where = f"{path}:{number}"
        fields = line.split(",")
        if len(fields) != 7:
            raise ResultsError(f"{where}: expected 7 comma-separated fields, got {len(fields)}")
        ids = []
        for name, text in zip(("scene_id", "im_id", "obj_id"), fields[:3]):
            try:
                value = int(text)
            except ValueError:
                raise ResultsError(f"{where}: {name} must be an integer, got {text!r}") from None
            if value < 0:
                raise ResultsError(f"{where}: {name} must be >= 0, got {value}")
            ids.append(value)
        score = _numbers(fields[3], 1, "score", where)[0]
        R = _numbers(fields[4], 9, "R", where).reshape(3, 3)
        t = _numbers(fields[5], 3, "t", where)
        time_s = _numbers(fields[6], 1, "time", where)[0]
        key = (ids[0], ids[1])
        if key in times and not math.isclose(times[key], time_s, abs_tol=TIME_TOLERANCE_S):
            raise ResultsError(
                f"{where}: time {time_s} differs from {times[key]} given earlier for scene "
                f"{ids[0]} image {ids[1]} (one time per image)"
            )
        times.setdefault(key, time_s)
        estimates.append(Estimate(ids[0], ids[1], ids[2], float(score), R, t, float(time_s), number))
    return estimates


def format_estimate(e: Estimate) -> str:
    """One CSV line (no newline) for `e`: floats in repr precision, so reading it back gives the
    same numbers."""
    R = " ".join(repr(float(v)) for v in np.asarray(e.R, np.float64).reshape(9))
    t = " ".join(repr(float(v)) for v in np.asarray(e.t, np.float64).reshape(3))
    return f"{e.scene_id},{e.im_id},{e.obj_id},{float(e.score)!r},{R},{t},{float(e.time_s)!r}"


def write_results(path: Path, estimates: list[Estimate]) -> None:
    """Writes `estimates` as a BOP results CSV, atomically (a failed write leaves `path` as it
    was; OSError names it)."""
    path = Path(path)
    lines = [HEADER] + [format_estimate(e) for e in estimates]
    atomic_write(path, "w", lambda f: f.write("\n".join(lines) + "\n"))
