"""A zero-shot pose estimator from the mesh, the depth, one instance mask and K, with no training:
the paper verifies its data with FoundationPose in unseen-object mode; this is the
classical counterpart that runs anywhere and shows the annotations are consistent.

1. The instance's visible pixels are back-projected with their depth (camera frame, mm; pixel
   centres at u + 0.5, v + 0.5, as the renderer and the BOP toolkit place them).
2. Hypotheses: the model's axes are laid along the point cloud's principal axes in each of the
   24 ways a box can be (moonbot.bop.models.axis_rotations), less those the model's discrete
   symmetries make equal, and placed so the centroid of the model's surface facing the camera,
   weighted by projected area as pixels sample it, lies on the cloud's centroid — the cloud is
   the near side only.
3. Each is refined by point-to-plane ICP of the observed points onto the model's surface samples,
   coarse (few points, few iterations) for all, fine for the best few. A correspondence counts
   only when the model's normal there faces the camera: the observed points are all front-facing,
   so a back-face match is always wrong.
4. A hypothesis's score is the share of observed points within INLIER_MM of the posed model minus
   the share of the model's camera-facing samples that would stand in front of the observed depth
   by more than FREE_SPACE_MM (the model may hide behind what is seen, never in front of it). The
   best score wins; it is the CSV's score.

Units: millimetres and radians throughout; poses map model points to the camera (BOP)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from moonbot.bop.models import axis_rotations, sample_surface_faces
from moonbot.bop.reader import Model

FINE_SPACING_MM, COARSE_SPACING_MM = 3.0, 8.0  # the model's surface samples (ModelCloud)
MIN_POINTS = 20  # fewer visible pixels with depth than this: no estimate
INLIER_MM = 5.0
FREE_SPACE_MM = 10.0
# Correspondences farther than this multiple of the median distance are dropped (after the
# first iterations), so that occluders wrongly inside the mask or a poor start do not drag.
TRIM_FACTOR = 3.0
MIN_TRIM_MM = 10.0
MAX_STEP_RAD, MAX_STEP_MM = 0.2, 30.0  # largest ICP update per iteration


@dataclass(frozen=True)
class Settings:
    """The estimator's quality knobs (bench/bench_baseline.py measures their time against the
    pose error): every hypothesis gets `coarse_iterations` of ICP on `coarse_points` observed
    points, the best `fine_hypotheses` then `fine_iterations` on `fine_points`."""

    coarse_points: int = 150
    coarse_iterations: int = 8
    fine_points: int = 600
    fine_iterations: int = 20
    fine_hypotheses: int = 3

    def __post_init__(self):
        for name in ("coarse_points", "coarse_iterations", "fine_points", "fine_iterations", "fine_hypotheses"):
            if not isinstance(getattr(self, name), int) or getattr(self, name) < 1:
                raise ValueError(f"baseline settings: {name} must be an integer >= 1, got {getattr(self, name)!r}")


@dataclass(frozen=True)
class Surface:
    """Samples of a model's surface: points (N, 3) and outward unit normals (N, 3), float64,
    model frame mm, and the points' KD-tree."""

    points: np.ndarray
    normals: np.ndarray
    tree: cKDTree

    @classmethod
    def sample(cls, model: Model, spacing_mm: float) -> Surface:
        v, tri = model.vertices.astype(np.float64), model.triangles
        points, faces = sample_surface_faces(v, tri, spacing_mm, seed=model.obj_id)
        normals = np.cross(v[tri[:, 1]] - v[tri[:, 0]], v[tri[:, 2]] - v[tri[:, 0]])
        normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-300)
        return cls(points, normals[faces], cKDTree(points))


@dataclass(frozen=True)
class ModelCloud:
    """What the estimator knows of one object: its surface sampled finely (the fine ICP pass and
    the final score) and coarsely (hypotheses, the coarse pass, the free-space check — a far-off
    point costs a KD-tree query in proportion to the samples near its sphere, so the passes that
    start far use few); and its symmetries as (3, 3) rotations (model frame), identity excluded."""

    obj_id: int
    fine: Surface
    coarse: Surface
    symmetries: tuple[np.ndarray, ...]

    @classmethod
    def from_model(cls, model: Model) -> ModelCloud:
        return cls(
            model.obj_id,
            Surface.sample(model, FINE_SPACING_MM),
            Surface.sample(model, COARSE_SPACING_MM),
            tuple(S[:3, :3] for S in model.symmetries),
        )


@dataclass(frozen=True)
class Estimate:
    """The estimator's answer: R (3, 3) float64 model→camera, t (3,) float64 mm, its score, and
    the share of observed points within INLIER_MM and of camera-facing model samples in front of
    the observed depth."""

    R: np.ndarray
    t: np.ndarray
    score: float
    inliers: float
    free_space_violations: float


def back_project(depth_mm: np.ndarray, mask: np.ndarray, K: np.ndarray) -> np.ndarray:
    """The masked pixels with depth as camera-frame points (n, 3) float64 mm, in row-major pixel
    order. depth_mm (H, W) z-depth, 0 = none; mask (H, W) bool; K (3, 3)."""
    v, u = np.nonzero(mask & (depth_mm > 0))
    z = depth_mm[v, u].astype(np.float64)
    x = (u + 0.5 - K[0, 2]) * z / K[0, 0]
    y = (v + 0.5 - K[1, 2]) * z / K[1, 1]
    return np.stack([x, y, z], axis=1)


def _spread(points: np.ndarray, count: int) -> np.ndarray:
    """At most `count` of `points`, evenly strided (deterministic)."""
    if len(points) <= count:
        return points
    return points[np.linspace(0, len(points) - 1, count).round().astype(int)]


def _rotation(omega: np.ndarray) -> np.ndarray:
    """exp([ω]×), the rotation by |ω| radians about ω."""
    angle = float(np.linalg.norm(omega))
    if angle < 1e-12:
        return np.eye(3)
    k = omega / angle
    Kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * Kx + (1 - np.cos(angle)) * Kx @ Kx


def hypotheses(points: np.ndarray, cloud: ModelCloud) -> list[tuple[np.ndarray, np.ndarray]]:
    """Starting poses (R, t) for the observed points (n, 3) camera mm: the model axes along the
    points' principal axes in every box orientation that the model's symmetries do not repeat."""
    centroid = points.mean(axis=0)
    _, _, Vt = np.linalg.svd(points - centroid, full_matrices=False)
    principal = Vt.T  # columns: the principal axes, by decreasing spread
    if np.linalg.det(principal) < 0:
        principal[:, 2] *= -1
    sight = centroid / np.linalg.norm(centroid)
    starts: list[tuple[np.ndarray, np.ndarray]] = []
    for A in axis_rotations():
        R = principal @ A
        if any(np.allclose(R0.T @ R, S, atol=1e-6) for R0, _ in starts for S in cloud.symmetries):
            continue
        # The cloud is the model's near side, one point a pixel: put the centroid of the model's
        # samples that face the camera, each weighted by its projected area as pixels weight
        # them, on the cloud's centroid.
        weight = np.maximum(-(cloud.coarse.normals @ (R.T @ sight)), 0.0)
        t = centroid - R @ (weight @ cloud.coarse.points / max(float(weight.sum()), 1e-300))
        starts.append((R, t))
    return starts


def icp(
    points: np.ndarray, surface: Surface, R: np.ndarray, t: np.ndarray, iterations: int
) -> tuple[np.ndarray, np.ndarray]:
    """Point-to-plane ICP of the observed points (n, 3) camera mm onto the model's `surface` from
    the pose (R, t) model→camera; returns the refined (R, t). Solves in the model frame for the
    small motion of the observed points (Gauss–Newton on the linearised rotation)."""
    Rg, tg = R.T.copy(), -R.T @ t  # camera → model
    for it in range(iterations):
        y = points @ Rg.T + tg
        distance, index = surface.tree.query(y, k=1)
        m, n = surface.points[index], surface.normals[index]
        # The observed points face the camera; so must the model's surface where they land.
        camera_in_model = tg  # the camera centre in the model frame is Rg·0 + tg
        facing = np.einsum("ij,ij->i", n, camera_in_model - m) > 0
        keep = facing
        if it >= 2 and keep.any():
            keep &= distance <= max(TRIM_FACTOR * float(np.median(distance[keep])), MIN_TRIM_MM)
        if keep.sum() < 6:
            break
        y, m, n = y[keep], m[keep], n[keep]
        residual = np.einsum("ij,ij->i", y - m, n)
        J = np.concatenate([np.cross(y, n), n], axis=1)
        try:
            step = np.linalg.solve(J.T @ J + 1e-6 * np.eye(6), -J.T @ residual)
        except np.linalg.LinAlgError:
            break
        # A sliver of a bag (a few hundred pixels along an edge) leaves the system nearly
        # singular; a bounded step keeps such a fit near the evidence instead of flying off.
        step[:3] *= min(1.0, MAX_STEP_RAD / max(float(np.linalg.norm(step[:3])), 1e-300))
        step[3:] *= min(1.0, MAX_STEP_MM / max(float(np.linalg.norm(step[3:])), 1e-300))
        dR = _rotation(step[:3])
        Rg, tg = dR @ Rg, dR @ tg + step[3:]
        if np.linalg.norm(step[:3]) < 1e-5 and np.linalg.norm(step[3:]) < 1e-3:
            break
    R_new = Rg.T
    return R_new, -R_new @ tg


def score(
    points: np.ndarray,
    surface: Surface,
    cloud: ModelCloud,
    R: np.ndarray,
    t: np.ndarray,
    depth_mm: np.ndarray,
    K: np.ndarray,
) -> tuple[float, float, float]:
    """(score, inlier share, free-space violation share) of the pose (R, t) model→camera against
    the observed points (n, 3), their distances taken to `surface`, and the image's depth (H, W)
    mm (0 = none), which the model's coarse samples must not stand in front of."""
    y = (points - t) @ R  # into the model frame
    inliers = float(np.mean(surface.tree.query(y, k=1)[0] < INLIER_MM))
    p = cloud.coarse.points @ R.T + t
    n = cloud.coarse.normals @ R.T
    front = (np.einsum("ij,ij->i", n, p) < 0) & (p[:, 2] > 1e-3)
    p = p[front]
    u = np.floor(K[0, 0] * p[:, 0] / p[:, 2] + K[0, 2]).astype(np.int64)
    v = np.floor(K[1, 1] * p[:, 1] / p[:, 2] + K[1, 2]).astype(np.int64)
    inside = (u >= 0) & (u < depth_mm.shape[1]) & (v >= 0) & (v < depth_mm.shape[0])
    if not inside.any():
        return inliers - 1.0, inliers, 1.0
    seen = depth_mm[v[inside], u[inside]].astype(np.float64)
    # In front of the observed surface, or where the camera saw nothing at all.
    violations = float(np.mean((seen <= 0) | (p[inside, 2] < seen - FREE_SPACE_MM)))
    return inliers - violations, inliers, violations


def estimate_pose(
    depth_mm: np.ndarray, mask: np.ndarray, K: np.ndarray, cloud: ModelCloud, settings: Settings = Settings()
) -> Estimate | None:
    """The best pose of `cloud`'s object for one instance: depth_mm (H, W) z-depth mm (0 = none),
    mask (H, W) bool its visible pixels, K (3, 3). None when fewer than MIN_POINTS pixels have
    depth."""
    observed = back_project(depth_mm, mask, K)
    if len(observed) < MIN_POINTS:
        return None
    coarse_points = _spread(observed, settings.coarse_points)
    fine_points = _spread(observed, settings.fine_points)
    coarse = []
    for R, t in hypotheses(observed, cloud):
        R, t = icp(coarse_points, cloud.coarse, R, t, settings.coarse_iterations)
        coarse.append((score(coarse_points, cloud.coarse, cloud, R, t, depth_mm, K)[0], R, t))
    coarse.sort(key=lambda c: -c[0])  # stable: ties keep the hypotheses' order
    best = None
    for _, R, t in coarse[: settings.fine_hypotheses]:
        R, t = icp(fine_points, cloud.fine, R, t, settings.fine_iterations)
        s, inliers, violations = score(fine_points, cloud.fine, cloud, R, t, depth_mm, K)
        if best is None or s > best.score:
            best = Estimate(R, t, s, inliers, violations)
    return best
