"""Terrain meshes. For now a flat square patch; the terrain stage (procedural locations, DEM
import, horizon rings) will grow here."""

from __future__ import annotations

import numpy as np


def flat_patch(size_m: float) -> tuple[np.ndarray, np.ndarray]:
    """A square in the z = 0 plane centred on the origin, normal +z.

    Returns (vertices (4, 3) float32 metres, triangles (2, 3) int32). Two triangles are exact for
    a plane: the renderer resolves hits in double precision, so no tessellation is needed.
    """
    h = size_m / 2.0
    vertices = np.array([[-h, -h, 0.0], [h, -h, 0.0], [h, h, 0.0], [-h, h, 0.0]], dtype=np.float32)
    triangles = np.array([[0, 1, 2], [0, 2, 3]], dtype=np.int32)
    return vertices, triangles
