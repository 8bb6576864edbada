"""Exact intersection tests between triangle meshes, for validating placements: two bags must
never interpenetrate, and no bag may cut into the ground.

Two closed surfaces intersect when an edge of one crosses a triangle of the other (checked in
float64 with the Möller–Trumbore segment test, touching counts as crossing), or when one lies
entirely inside the other (checked with the generalised winding number of one vertex). A
bounding-sphere broad phase (scipy cKDTree over triangle centroids) keeps the work proportional
to the triangles that come close, not to the product of the mesh sizes.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

_PAIR_CHUNK = 100_000  # candidate triangle pairs per vectorised batch (~100 MB of temporaries)


def transform(vertices: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """Vertices (N, 3) moved by the rigid transform `pose` (4, 4): (N, 3) float64."""
    return np.asarray(vertices, dtype=np.float64) @ pose[:3, :3].T + pose[:3, 3]


def segments_cross_triangles(p0: np.ndarray, p1: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """For matching rows of segments p0→p1 and triangles abc (all (K, 3) float64): whether the
    closed segment meets the closed triangle (bool (K,)). A segment parallel to its triangle's
    plane never counts; a coplanar touch is left to the neighbouring edges' tests."""
    e1, e2, d = b - a, c - a, p1 - p0
    h = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, h)
    scale = np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1) * np.linalg.norm(d, axis=1)
    ok = np.abs(det) > 1e-12 * scale
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = p0 - a
    u = inv * np.einsum("ij,ij->i", s, h)
    q = np.cross(s, e1)
    v = inv * np.einsum("ij,ij->i", d, q)
    t = inv * np.einsum("ij,ij->i", e2, q)
    return ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t >= 0) & (t <= 1)


def _bounding_spheres(v: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    centroid = v[t].mean(axis=1)
    radius = np.linalg.norm(v[t] - centroid[:, None, :], axis=2).max(axis=1)
    return centroid, radius


def _near(v: np.ndarray, t: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Indices of triangles whose bounding box meets the box [lo, hi]."""
    corners = v[t]
    return np.flatnonzero(np.all(corners.max(axis=1) >= lo, axis=1) & np.all(corners.min(axis=1) <= hi, axis=1))


def surfaces_cross(va: np.ndarray, ta: np.ndarray, vb: np.ndarray, tb: np.ndarray) -> bool:
    """Whether any triangle of surface A (vertices (N, 3) float64, triangles (M, 3) int) meets
    any triangle of surface B. Surfaces need not be closed."""
    va, vb = np.asarray(va, dtype=np.float64), np.asarray(vb, dtype=np.float64)
    lo = np.maximum(va.min(axis=0), vb.min(axis=0))
    hi = np.minimum(va.max(axis=0), vb.max(axis=0))
    if np.any(lo > hi):
        return False
    ia, ib = _near(va, ta, lo, hi), _near(vb, tb, lo, hi)
    if len(ia) == 0 or len(ib) == 0:
        return False
    ta, tb = np.asarray(ta)[ia], np.asarray(tb)[ib]
    ca, ra = _bounding_spheres(va, ta)
    cb, rb = _bounding_spheres(vb, tb)
    hits = cKDTree(ca).query_ball_point(cb, r=rb + ra.max())
    counts = np.fromiter((len(h) for h in hits), dtype=np.int64, count=len(hits))
    if counts.sum() == 0:
        return False
    j = np.repeat(np.arange(len(tb)), counts)
    i = np.concatenate([np.asarray(h, dtype=np.int64) for h in hits if h])
    close = np.linalg.norm(ca[i] - cb[j], axis=1) <= ra[i] + rb[j]
    i, j = i[close], j[close]
    for start in range(0, len(i), _PAIR_CHUNK):
        A, B = va[ta[i[start : start + _PAIR_CHUNK]]], vb[tb[j[start : start + _PAIR_CHUNK]]]
        for edges, tri in ((A, B), (B, A)):
            for k in range(3):
                if segments_cross_triangles(edges[:, k], edges[:, (k + 1) % 3], tri[:, 0], tri[:, 1], tri[:, 2]).any():
                    return True
    return False


def vertical_extent(xy: np.ndarray, v: np.ndarray, t: np.ndarray, facing: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Lowest and highest z (float64 (P,) each, NaN where the vertical line misses the mesh) at
    which vertical lines through the points `xy` (P, 2) meet the mesh (v (N, 3), t (M, 3)):
    exact plane heights of the triangles whose plan projection holds each point. `facing` +1
    (or -1) counts only triangles facing up (or down): of a closed mesh, its top (or bottom)."""
    xy = np.asarray(xy, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    tri = v[t]
    if facing:
        up = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])[:, 2]
        tri = tri[facing * up > 0]
    centroid = tri[:, :, :2].mean(axis=1)
    radius = np.linalg.norm(tri[:, :, :2] - centroid[:, None, :], axis=2).max(axis=1)
    hits = cKDTree(centroid).query_ball_point(xy, r=radius.max())
    counts = np.fromiter((len(h) for h in hits), dtype=np.int64, count=len(hits))
    lo, hi = np.full(len(xy), np.nan), np.full(len(xy), np.nan)
    if counts.sum() == 0:
        return lo, hi
    p = np.repeat(np.arange(len(xy)), counts)
    f = np.concatenate([np.asarray(h, dtype=np.int64) for h in hits if h])
    a, b, c = tri[f, 0], tri[f, 1], tri[f, 2]
    q = xy[p]
    # Barycentric coordinates in plan; triangles seen edge-on from above are skipped.
    det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
    ok = np.abs(det) > 1e-18
    det = np.where(ok, det, 1.0)
    w1 = ((q[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (q[:, 1] - a[:, 1])) / det
    w2 = ((b[:, 0] - a[:, 0]) * (q[:, 1] - a[:, 1]) - (q[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])) / det
    inside = ok & (w1 >= 0) & (w2 >= 0) & (w1 + w2 <= 1)
    z = a[:, 2] + w1 * (b[:, 2] - a[:, 2]) + w2 * (c[:, 2] - a[:, 2])
    p, z = p[inside], z[inside]
    np.fmin.at(lo, p, z)
    np.fmax.at(hi, p, z)
    return lo, hi


def winding_number(points: np.ndarray, v: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Generalised winding number (Jacobson et al. 2013) of points (P, 3) with respect to the
    closed, outward-wound mesh (v, t): ~1 inside, ~0 outside (float64 (P,)). Each triangle
    contributes its signed solid angle (Van Oosterom & Strackee 1983) over 4π."""
    v = np.asarray(v, dtype=np.float64)
    out = np.empty(len(points))
    for n, p in enumerate(np.asarray(points, dtype=np.float64)):
        a, b, c = v[t[:, 0]] - p, v[t[:, 1]] - p, v[t[:, 2]] - p
        la, lb, lc = (np.linalg.norm(x, axis=1) for x in (a, b, c))
        num = np.einsum("ij,ij->i", a, np.cross(b, c))
        den = (
            la * lb * lc
            + np.einsum("ij,ij->i", a, b) * lc
            + np.einsum("ij,ij->i", b, c) * la
            + np.einsum("ij,ij->i", c, a) * lb
        )
        out[n] = 2.0 * np.arctan2(num, den).sum() / (4.0 * np.pi)
    return out


def solids_intersect(va: np.ndarray, ta: np.ndarray, vb: np.ndarray, tb: np.ndarray) -> bool:
    """Whether two closed, outward-wound meshes share any volume: their surfaces cross, or one
    holds a vertex of the other inside it."""
    va, vb = np.asarray(va, dtype=np.float64), np.asarray(vb, dtype=np.float64)
    if np.any(va.min(axis=0) > vb.max(axis=0)) or np.any(vb.min(axis=0) > va.max(axis=0)):
        return False
    if surfaces_cross(va, ta, vb, tb):
        return True
    return bool(winding_number(va[:1], vb, tb)[0] > 0.5 or winding_number(vb[:1], va, ta)[0] > 0.5)
