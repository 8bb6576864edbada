"""Test oracle for mask outlines: a ring filled back into pixels, independently of moonbot.yolo."""

from __future__ import annotations

import numpy as np


def raster(ring: np.ndarray, height: int, width: int) -> np.ndarray:
    """Even-odd fill of a closed ring (N, 2) of pixel coordinates, sampled at pixel centres."""
    yc, xc = np.mgrid[0:height, 0:width] + 0.5
    inside = np.zeros((height, width), dtype=bool)
    for (x1, y1), (x2, y2) in zip(ring, np.roll(ring, -1, axis=0)):
        if y1 != y2:
            crosses = (yc >= min(y1, y2)) & (yc < max(y1, y2))
            inside ^= crosses & (xc < x1 + (yc - y1) * (x2 - x1) / (y2 - y1))
    return inside
