"""Placing bags on the ground. Poses are exact rigid transforms (world-from-model,
(4, 4) float64, metres), deterministic from the scene seed. World frame: East-North-Up; a bag's
model frame has x along its length, z up.

Two stages, then a check:
1. **Geometric rest** (`place_bags`): each bag is yawed, tilted to the mean slope under its
   footprint and lowered until it is `clearance_m` above the ground or the bags below it.
   - `single`: one bag at the origin.
   - `scattered`: the target at the origin, the others at random positions within `radius_m`
     with random yaw; their footprints (the plan outline of the tilted bag) stay `gap_m` apart.
   - `stacked`: a construction wall in running bond along the target's yawed x axis: courses of
     bags end to end (`gap_m` apart), each holding one bag fewer than the course below and
     centred on it, so every upper bag's centre of mass lies over its supports and nothing
     overhangs to tip (11 = 5 + 4 + 2; the issue's 4 + 4 + 3 would overhang an end).
2. **Settling** (`moonbot.scene.settle`, when `bags.settle.enabled`): the bags are dropped from
   `drop_m` above their rest under lunar gravity and stepped until still.
3. **Check** (`check_placement`): exact mesh tests prove that no two bags share volume and no
   bag cuts into the ground; a failure is an error, never an overlapping scene.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import ConvexHull

from moonbot.config.schema import BagsConfig
from moonbot.scene.collision import solids_intersect, surfaces_cross, transform, vertical_extent
from moonbot.terrain.ground import FlatGround, Ground

LAYOUTS = ("single", "scattered", "stacked")


def yaw_tilt_rotation(yaw: float, gradient: tuple[float, float]) -> np.ndarray:
    """Rotation (3, 3): yaw `yaw` radians about +z, then the shortest rotation taking +z to the
    ground normal of a surface with slope `gradient` (dh/dx, dh/dy)."""
    c, s = math.cos(yaw), math.sin(yaw)
    Rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    gx, gy = gradient
    n = np.array([-gx, -gy, 1.0]) / math.sqrt(gx * gx + gy * gy + 1.0)
    axis = np.array([-n[1], n[0], 0.0])  # z × n
    sin_a = float(np.linalg.norm(axis))
    if sin_a < 1e-15:
        return Rz
    k = axis / sin_a
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    tilt = np.eye(3) + sin_a * K + (1.0 - n[2]) * (K @ K)  # Rodrigues, cos a = n_z
    return tilt @ Rz


def _mean_gradient(ground: Ground, x: float, y: float, yaw: float, half: np.ndarray) -> tuple[float, float]:
    """Ground slope averaged over a 5 × 5 grid spanning the bag's footprint rectangle."""
    u, v = np.meshgrid(np.linspace(-half[0], half[0], 5), np.linspace(-half[1], half[1], 5))
    c, s = math.cos(yaw), math.sin(yaw)
    gx, gy = ground.gradient(x + c * u - s * v, y + s * u + c * v)
    return float(gx.mean()), float(gy.mean())


def _pose(R: np.ndarray, t: tuple[float, float, float]) -> np.ndarray:
    pose = np.eye(4)
    pose[:3, :3], pose[:3, 3] = R, t
    return pose


def _on_ground(vertices: np.ndarray, R: np.ndarray, x: float, y: float, ground: Ground, clearance: float) -> np.ndarray:
    """The pose with rotation R over (x, y) lowered until its lowest point relative to the
    ground is `clearance` above it (a vertical shift moves no vertex in plan, so this is exact
    at the vertices)."""
    world = vertices @ R.T + [x, y, 0.0]
    z = clearance - float((world[:, 2] - ground.height(world[:, 0], world[:, 1])).min())
    return _pose(R, (x, y, z))


def _on_bags(
    vertices: np.ndarray, triangles: np.ndarray, pose: np.ndarray, below: list[np.ndarray], clearance: float
) -> np.ndarray:
    """`pose` raised (never lowered) until the bag is `clearance` above the bags `below` (their
    world vertices) along every vertical line through a vertex of either: exact at vertices."""
    world = transform(vertices, pose)

    def on_faces(w: np.ndarray, sign: int) -> np.ndarray:
        """Mask of the vertices of triangles facing up (sign +1) or down (-1) in the world."""
        tri = w[triangles]
        up = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])[:, 2]
        mask = np.zeros(len(w), dtype=bool)
        mask[triangles[sign * up > 0].ravel()] = True
        return mask

    lift = -np.inf
    underside = on_faces(world, -1)
    for lower in below:
        # Only this bag's underside over the lower bag's plan box, and the lower bag's top under
        # this bag's plan box, can meet.
        over = underside & np.all(
            (world[:, :2] >= lower[:, :2].min(axis=0)) & (world[:, :2] <= lower[:, :2].max(axis=0)), axis=1
        )
        under = on_faces(lower, +1) & np.all(
            (lower[:, :2] >= world[:, :2].min(axis=0)) & (lower[:, :2] <= world[:, :2].max(axis=0)), axis=1
        )
        _, top_below = vertical_extent(world[over, :2], lower, triangles, facing=+1)
        bottom_above, _ = vertical_extent(lower[under, :2], world, triangles, facing=-1)
        lift = np.nanmax(
            [
                lift,
                np.nanmax(top_below - world[over, 2], initial=-np.inf),
                np.nanmax(lower[under, 2] - bottom_above, initial=-np.inf),
            ]
        )
    raised = pose.copy()
    if np.isfinite(lift):
        raised[2, 3] += max(lift + clearance, 0.0)
    return raised


def _plan_outline(vertices: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """The bag's outline in plan: the convex hull (K, 2) of its vertices' x, y, counter-clockwise."""
    xy = transform(vertices, pose)[:, :2]
    return xy[ConvexHull(xy).vertices]


def polygons_apart(a: np.ndarray, b: np.ndarray, gap: float) -> bool:
    """Separating-axis test for two convex polygons ((K, 2) counter-clockwise) with a required
    clearance `gap` along the separating axis."""
    for poly in (a, b):
        edges = np.roll(poly, -1, axis=0) - poly
        axes = np.column_stack([edges[:, 1], -edges[:, 0]])
        axes /= np.linalg.norm(axes, axis=1, keepdims=True)
        pa, pb = a @ axes.T, b @ axes.T
        if np.any((pa.max(axis=0) + gap <= pb.min(axis=0)) | (pb.max(axis=0) + gap <= pa.min(axis=0))):
            return True
    return False


def _wall_slots(count: int, pitch: float) -> list[tuple[float, int]]:
    """(position along the wall, course) of each bag, target first: the bottom course is the
    shortest that holds `count` with each course one shorter, centred on the one below; the
    target is the bottom course's middle bag, at position 0."""
    bottom = 1
    while bottom * (bottom + 1) // 2 < count:
        bottom += 1
    slots = []
    course = 0
    while len(slots) < count:
        n = min(bottom - course, count - len(slots))
        slots += [((i - 0.5 * (n - 1)) * pitch, course) for i in range(n)]
        course += 1
    target = (bottom - 1) // 2
    along0 = slots[target][0]
    order = [target] + [i for i in range(count) if i != target]
    return [(slots[i][0] - along0, slots[i][1]) for i in order]


def place_bags(
    vertices: np.ndarray,
    triangles: np.ndarray,
    count: int,
    layout: str,
    seed: int,
    ground: Ground | None = None,
    yaw_deg: float = 0.0,
    gap_m: float = 0.02,
    radius_m: float = 1.0,
    clearance_m: float = 0.001,
    max_tries: int = 10000,
) -> list[np.ndarray]:
    """Geometric resting poses of `count` bags of the mesh (`vertices` (N, 3) model frame,
    metres; `triangles` (M, 3)) on `ground` (flat if None): the first is the orbit target at the origin, yawed by
    `yaw_deg`. Raises ValueError naming the field when the layout cannot hold them."""
    if layout not in LAYOUTS:
        raise ValueError(f"layout: must be one of {', '.join(LAYOUTS)}, got {layout!r}")
    if count < 1:
        raise ValueError(f"count: must be >= 1, got {count}")
    if layout == "single" and count != 1:
        raise ValueError(f"count: the single layout holds one bag, got {count}")
    ground = ground or FlatGround()
    vertices = np.asarray(vertices, dtype=np.float64)
    half = (vertices.max(axis=0) - vertices.min(axis=0)) / 2.0
    yaw = math.radians(yaw_deg)

    def resting(x: float, y: float, yaw: float) -> np.ndarray:
        R = yaw_tilt_rotation(yaw, _mean_gradient(ground, x, y, yaw, half))
        return _on_ground(vertices, R, x, y, ground, clearance_m)

    if layout in ("single", "scattered"):
        poses = [resting(0.0, 0.0, yaw)]
        outlines = [_plan_outline(vertices, poses[0])]
        rng = np.random.default_rng(seed)
        tries = 0
        while len(poses) < count:
            tries += 1
            if tries > max_tries:
                raise ValueError(
                    f"count: {count} bags do not fit within scatter_radius_m = {radius_m} "
                    f"with gap_m = {gap_m} (placed {len(poses)})"
                )
            r = radius_m * math.sqrt(rng.random())
            phi = 2 * math.pi * rng.random()
            candidate = resting(r * math.cos(phi), r * math.sin(phi), 2 * math.pi * rng.random())
            outline = _plan_outline(vertices, candidate)
            if all(polygons_apart(outline, other, gap_m) for other in outlines):
                poses.append(candidate)
                outlines.append(outline)
        return poses

    c, s = math.cos(yaw), math.sin(yaw)
    slots = _wall_slots(count, 2 * half[0] + gap_m)
    world: dict[int, np.ndarray] = {}
    poses: list[np.ndarray | None] = [None] * count
    for k in sorted(range(count), key=lambda k: slots[k][1]):  # course by course, bottom first
        along, course = slots[k]
        pose = resting(along * c, along * s, yaw)
        if course > 0:
            below = [
                world[j] for j in world if slots[j][1] == course - 1 and abs(slots[j][0] - along) < 2 * half[0] + gap_m
            ]
            pose = _on_bags(vertices, triangles, pose, below, clearance_m)
        poses[k] = pose
        world[k] = transform(vertices, pose)
    return poses


@dataclass(frozen=True)
class Placement:
    """Bag poses (world-from-model (4, 4) float64, target first) and, when settled, the
    simulated seconds, steps and wall-clock seconds settling took."""

    poses: list[np.ndarray]
    settle_simulated_s: float | None = None
    settle_steps: int | None = None
    settle_seconds: float | None = None


def arrange_bags(
    vertices: np.ndarray,
    triangles: np.ndarray,
    bags: BagsConfig,
    ground: Ground,
    seed: int,
    collision: np.ndarray | list[np.ndarray] | None = None,
) -> Placement:
    """Places the configured bags on `ground`, settles them when `bags.settle.enabled`, and
    checks the result against the ground's mesh (the triangles the renderer draws).
    `collision` (K, 3), model frame, metres: points whose convex hull holds the mesh, the shape
    settling collides (bag_mesh.collision_points), or a list of such point sets whose hulls hold
    it together (convex parts: bag_mesh.bag_collision); None: the mesh's vertices."""
    settle_cfg = bags.settle
    clearance = settle_cfg.margin_m + (settle_cfg.drop_m if settle_cfg.enabled else 0.0)
    poses = place_bags(
        vertices,
        triangles,
        bags.count,
        bags.layout,
        seed=seed,
        ground=ground,
        yaw_deg=bags.yaw_deg,
        gap_m=bags.gap_m,
        radius_m=bags.scatter_radius_m,
        clearance_m=clearance,
    )
    placement = Placement(poses=poses)
    if settle_cfg.enabled:
        from moonbot.scene.settle import settle

        result = settle(vertices if collision is None else collision, poses, ground, settle_cfg)
        placement = Placement(
            poses=result.poses,
            settle_simulated_s=result.simulated_s,
            settle_steps=result.steps,
            settle_seconds=result.seconds,
        )
    check_placement(vertices, triangles, placement.poses, ground)
    return placement


def check_placement(vertices: np.ndarray, triangles: np.ndarray, poses: list[np.ndarray], ground: Ground) -> None:
    """Raises ValueError when a bag cuts into the ground's mesh, lies below the ground, or
    shares volume with another bag (exact triangle tests, moonbot.scene.collision)."""
    world = [transform(vertices, p) for p in poses]
    lo = np.min([w.min(axis=0) for w in world], axis=0)
    hi = np.max([w.max(axis=0) for w in world], axis=0)
    gv, gt = ground.patch(lo[:2], hi[:2])
    for k, (pose, w) in enumerate(zip(poses, world)):
        if pose[2, 3] < ground.height(pose[0, 3], pose[1, 3]) or surfaces_cross(w, triangles, gv, gt):
            raise ValueError(f"bags: bag {k + 1} cuts into the ground")
        for j in range(k):
            if solids_intersect(w, triangles, world[j], triangles):
                raise ValueError(f"bags: bags {j + 1} and {k + 1} overlap")
