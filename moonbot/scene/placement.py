"""Placing bags on flat ground (issue 3, first piece; slopes, crater rims and physics settling
come next). Poses are exact rigid transforms, deterministic from the scene seed. World frame:
ENU metres, ground at z = 0; a bag's model frame has x along its length, z up.

Layouts:
- `single`: one bag at the origin.
- `scattered`: the target at the origin, the others at random positions within `radius_m`
  with random yaw, kept apart by `gap_m` (separating-axis test on their footprints).
- `stacked`: a construction wall in running bond along x: courses of bags end to end (`gap_m`
  apart), each resting on the highest points of the one below and holding at most one bag
  fewer, centred on it, so nothing overhangs and tips (11 = 5 + 4 + 2).
"""

from __future__ import annotations

import math

import numpy as np

LAYOUTS = ("single", "scattered", "stacked")


def _pose(x: float, y: float, z: float, yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0, x], [s, c, 0.0, y], [0.0, 0.0, 1.0, z], [0.0, 0.0, 0.0, 1.0]])


def _footprint(pose: np.ndarray, half: np.ndarray) -> np.ndarray:
    """Corners (4, 2) of a bag's footprint rectangle in the ground plane."""
    corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * half[:2]
    return corners @ pose[:2, :2].T + pose[:2, 3]


def _rectangles_apart(a: np.ndarray, b: np.ndarray, gap: float) -> bool:
    """Separating-axis test for two convex quadrilaterals, with a required clearance `gap`."""
    for poly in (a, b):
        for k in range(4):
            edge = poly[(k + 1) % 4] - poly[k]
            axis = np.array([-edge[1], edge[0]]) / np.linalg.norm(edge)
            pa, pb = a @ axis, b @ axis
            if pa.max() + gap <= pb.min() or pb.max() + gap <= pa.min():
                return True
    return False


def place_bags(vertices: np.ndarray, count: int, layout: str, seed: int, yaw_deg: float = 0.0,
               gap_m: float = 0.02, radius_m: float = 1.0, max_tries: int = 10000) -> list[np.ndarray]:
    """World-from-model poses (4, 4) float64 for `count` bags of the mesh `vertices` (model
    frame, metres), the first being the orbit target at the origin, yawed by `yaw_deg`.
    Raises ValueError naming the field when the layout cannot hold them."""
    if layout not in LAYOUTS:
        raise ValueError(f"layout: must be one of {', '.join(LAYOUTS)}, got {layout!r}")
    if count < 1:
        raise ValueError(f"count: must be >= 1, got {count}")
    if layout == "single" and count != 1:
        raise ValueError(f"count: the single layout holds one bag, got {count}")
    lo, hi = vertices.min(axis=0).astype(np.float64), vertices.max(axis=0).astype(np.float64)
    half = (hi - lo) / 2.0
    rest = -lo[2]  # lifts the lowest point onto the ground
    yaw = math.radians(yaw_deg)
    if layout in ("single", "scattered"):
        poses = [_pose(0.0, 0.0, rest, yaw)]
        rng = np.random.default_rng(seed)
        tries = 0
        while len(poses) < count:
            tries += 1
            if tries > max_tries:
                raise ValueError(f"count: {count} bags do not fit within radius_m = {radius_m} "
                                 f"with gap_m = {gap_m} (placed {len(poses)})")
            r = radius_m * math.sqrt(rng.random())
            phi = 2 * math.pi * rng.random()
            candidate = _pose(r * math.cos(phi), r * math.sin(phi), rest, 2 * math.pi * rng.random())
            rect = _footprint(candidate, half)
            if all(_rectangles_apart(rect, _footprint(p, half), gap_m) for p in poses):
                poses.append(candidate)
        return poses
    # stacked: a running-bond wall along the (yawed) x axis. Each course is centred on the one
    # below and holds at most one bag fewer, so every upper bag sits over a joint or a bag with
    # its centre of mass inside its support; a course as long as the one below, shifted by half
    # a bag, would overhang an end by half a bag and tip. The bottom course is the shortest that
    # holds `count` this way (5 + 4 + 2 for 11); the target is its middle bag, at the origin.
    pitch = 2 * half[0] + gap_m
    height = 2 * half[2]
    bottom = 1
    while bottom * (bottom + 1) // 2 < count:
        bottom += 1
    slots = []  # (position along the wall, course)
    course = 0
    while len(slots) < count:
        n = min(bottom - course, count - len(slots))
        slots += [((i - 0.5 * (n - 1)) * pitch, course) for i in range(n)]
        course += 1
    target = (bottom - 1) // 2
    along0 = slots[target][0]
    order = [target] + [i for i in range(count) if i != target]
    return [_pose((slots[i][0] - along0) * math.cos(yaw), (slots[i][0] - along0) * math.sin(yaw),
                  rest + slots[i][1] * height, yaw) for i in order]
