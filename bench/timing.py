"""The benchmarks' timer."""

from __future__ import annotations

import statistics
import time


def timed(fn, repeats: int):
    """(fn's last result, the median wall seconds of `repeats` calls)."""
    seconds, out = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        out = fn()
        seconds.append(time.perf_counter() - start)
    return out, statistics.median(seconds)
