"""Bag meshes in their model frame: origin at the body's centre, x along the length, y across,
z up, metres (BOP models are the same meshes in millimetres)."""

from __future__ import annotations

import numpy as np


def cuboid(size_m: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    """A closed box of the given (length, width, height) centred on the origin, outward-facing
    counter-clockwise triangles. Returns (vertices (8, 3) float32, triangles (12, 3) int32)."""
    sx, sy, sz = (s / 2.0 for s in size_m)
    corners = np.array([[x, y, z] for z in (-sz, sz) for y in (-sy, sy) for x in (-sx, sx)],
                       dtype=np.float32)
    # Corner index = 4·(z>0) + 2·(y>0) + (x>0); each face listed counter-clockwise from outside.
    faces = [(0, 2, 3, 1), (4, 5, 7, 6),  # bottom (−z), top (+z)
             (0, 1, 5, 4), (2, 6, 7, 3),  # −y, +y
             (0, 4, 6, 2), (1, 3, 7, 5)]  # −x, +x
    triangles = np.array([t for a, b, c, d in faces for t in ((a, b, c), (a, c, d))], dtype=np.int32)
    return corners, triangles
