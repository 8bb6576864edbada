"""Collision shapes for settling a mesh whose convex hull is a poor fit (a U, an L, a bag with a
deep fold): a few convex hulls that hold the solid between them, found by splitting its bounding
box with axis-aligned planes, deterministically.

MuJoCo collides convex shapes only; a concave bag settled as its hull rests on air across its
hollows. Here the box around the solid is split, one cut at a time, into boxes; each box's
part is the convex hull of the solid inside it — exactly: the hull of the solid ∩ box is the
hull of the surface's triangles clipped to the box (their corners within it, the points where
their edges cross its faces and where its edges cross them) and of the box's own corners inside
the solid. So the parts hold the whole solid, and no part reaches beyond its box, so parts never
overlap. Each cut is the one, among planes at 1/12 … 11/12 of a box's extent along each axis, that
shrinks the sum of hull volumes most (where no single cut gains, as in a ring whose halves keep
its hull, the one whose halves' best cuts then gain most); cutting stops when that sum is within
`target_fit` of the mesh's volume, at `max_parts`, or when no cut gains `min_gain` of the volume. (MuJoCo decomposes
nothing itself, and trimesh's `convex_decomposition` needs the VHACD binaries.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from moonbot.scene.collision import winding_number

_FRACTIONS = np.arange(1, 12) / 12.0  # thirds, quarters and halves among them


@dataclass(frozen=True)
class ConvexParts:
    """`parts`: per part, points (K, 3) float64 in the mesh's frame and unit whose convex hull
    is that part; `hull_fit` is the whole mesh's hull volume over its volume, `parts_fit` the
    parts' hull volumes summed over it (1 = exact)."""

    parts: tuple[np.ndarray, ...]
    hull_fit: float
    parts_fit: float


@dataclass(eq=False)
class _Part:
    lo: np.ndarray
    hi: np.ndarray
    vertices: np.ndarray  # the surface's triangles clipped to the box
    faces: np.ndarray
    points: np.ndarray
    hull_volume: float
    best: tuple[float, _Part, _Part] | None = None  # its best cut: (gain, lower, upper)
    ahead: tuple[float, _Part, _Part] | None = None  # its best cut looking two deep


def hull_volume(points: np.ndarray) -> float:
    """Volume of the convex hull of points (K, 3); 0 for fewer than four or coplanar points."""
    if len(points) < 4:
        return 0.0
    try:
        return float(ConvexHull(points).volume)
    except QhullError:
        return 0.0


def convex_parts(
    vertices: np.ndarray,
    triangles: np.ndarray,
    volume: float,
    target_fit: float = 1.1,
    max_parts: int = 16,
    min_gain: float = 0.01,
) -> ConvexParts:
    """Splits the closed, outward-wound mesh (vertices (N, 3) float, triangles (M, 3) int) of
    enclosed `volume` into convex parts (module docstring)."""
    from trimesh.intersections import slice_faces_plane  # the triangle clipper; user meshes only

    v = np.asarray(vertices, dtype=np.float64)
    t = np.asarray(triangles, dtype=np.int64)

    known: dict[tuple[float, float, float], bool] = {}  # box corners recur across candidate cuts

    def inside(points: np.ndarray) -> np.ndarray:
        keys = [tuple(p) for p in points.tolist()]
        new = [k for k in dict.fromkeys(keys) if k not in known]
        if new:
            known.update(zip(new, (winding_number(np.array(new), v, t) > 0.5).tolist()))
        return np.array([known[k] for k in keys], dtype=bool)

    def make(lo: np.ndarray, hi: np.ndarray, pv: np.ndarray, pf: np.ndarray) -> _Part:
        corners = np.array(np.meshgrid(*zip(lo, hi), indexing="ij")).reshape(3, -1).T
        used = pv[np.unique(pf)] if len(pf) else np.empty((0, 3))
        points = np.concatenate([used, corners[inside(corners)]])
        points = np.unique(points, axis=0) if len(points) else points
        return _Part(lo, hi, pv, pf, points, hull_volume(points))

    def clip(pv: np.ndarray, pf: np.ndarray, normal: np.ndarray, origin: np.ndarray):
        if len(pf) == 0:
            return pv, pf
        out = slice_faces_plane(pv, pf, normal, origin)
        return out[0], out[1]

    def candidate_cuts(part: _Part) -> list[tuple[float, _Part, _Part]]:
        """(gain, lower, upper) of every cut of `part` that leaves no sliver."""
        cuts = []
        for axis in range(3):
            normal = np.eye(3)[axis]
            for f in _FRACTIONS:
                cut = part.lo[axis] + f * (part.hi[axis] - part.lo[axis])
                origin = normal * cut
                lower_hi, upper_lo = part.hi.copy(), part.lo.copy()
                lower_hi[axis] = upper_lo[axis] = cut
                lower = make(part.lo, lower_hi, *clip(part.vertices, part.faces, -normal, origin))
                upper = make(upper_lo, part.hi, *clip(part.vertices, part.faces, normal, origin))
                if min(lower.hull_volume, upper.hull_volume) < min_gain * volume:
                    continue  # a sliver: too thin to matter, and a degenerate body for MuJoCo
                cuts.append((part.hull_volume - lower.hull_volume - upper.hull_volume, lower, upper))
        return cuts

    def best_cut(part: _Part) -> tuple[float, _Part, _Part]:
        """The cut of `part` that shrinks its hull volume most (the first of equals); a zero
        gain and the part itself where none is possible."""
        if part.best is None:
            part.best = max(candidate_cuts(part), key=lambda c: c[0], default=(0.0, part, part))
        return part.best

    def best_two_cuts(part: _Part) -> tuple[float, _Part, _Part]:
        """The cut of `part` whose halves' own best cuts then shrink the hull volume most, with
        that total gain: for a ring, whose halves (two C's) have the hulls it had."""
        if part.ahead is None:
            part.ahead = max(
                (
                    (gain + best_cut(lower)[0] + best_cut(upper)[0], lower, upper)
                    for gain, lower, upper in candidate_cuts(part)
                ),
                key=lambda c: c[0],
                default=(0.0, part, part),
            )
        return part.ahead

    root = make(v.min(axis=0), v.max(axis=0), v, t)
    hull_fit = root.hull_volume / volume
    parts = [root]
    while len(parts) < max_parts and sum(p.hull_volume for p in parts) > target_fit * volume:
        k, (gain, lower, upper) = max(enumerate(best_cut(p) for p in parts), key=lambda c: c[1][0])
        if gain < min_gain * volume:  # no single cut pays: look two cuts deep
            k, (gain, lower, upper) = max(enumerate(best_two_cuts(p) for p in parts), key=lambda c: c[1][0])
            if gain < min_gain * volume:
                break
        parts[k : k + 1] = [lower, upper]
    return ConvexParts(
        parts=tuple(p.points for p in parts), hull_fit=hull_fit, parts_fit=sum(p.hull_volume for p in parts) / volume
    )
