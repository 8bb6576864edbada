"""Vertex normals of a triangle mesh: what the renderer shades a bag's smooth surface with and
what its BOP model records, one function for both."""

from __future__ import annotations

import numpy as np


def vertex_normals(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Area-weighted unit vertex normals (N, 3) float32 of an outward-oriented mesh."""
    v = vertices.astype(np.float64)
    face = np.cross(v[triangles[:, 1]] - v[triangles[:, 0]], v[triangles[:, 2]] - v[triangles[:, 0]])
    normals = np.zeros_like(v)
    for corner in range(3):
        np.add.at(normals, triangles[:, corner], face)
    return (normals / np.linalg.norm(normals, axis=1, keepdims=True)).astype(np.float32)
