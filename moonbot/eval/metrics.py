"""Pose errors and their summaries (bop_toolkit's pose_error.py; docs/evaluation.md). Poses map model points
to the camera: x_cam = R·x + t, R (3, 3) float64, t (3,) in the model's units (mm in BOP);
`points` (N, 3) are the model's evaluation points (models_eval/ vertices), same units.

- ADD (bop_toolkit `add`): the mean distance between each point under the estimated and under the
  true pose.
- ADD-S (`adi`): the mean distance from each point under the true pose to the nearest point under
  the estimated pose (the toolkit's direction: ground truth queried into the estimate), so a pose
  that differs by a symmetry of the point set scores 0.
- Recall at a fraction of the diameter: the share of ground-truth instances whose matched error is
  strictly below fraction × diameter (unmatched instances count as misses), matching estimates to
  instances greedily in decreasing score, each at most once (pose_matching.match_poses).
- ADD-S AUC (YCB-Video, FoundationPose's `compute_auc_sklearn`): the area under accuracy(θ), the
  share of errors ≤ θ, for θ from 0 to 100 mm in 1 mm steps, by the trapezoid rule, divided by
  100 mm: 1 for perfect poses, 0 when every error is 100 mm or more. An absolute threshold, not a
  fraction of the diameter."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree


def _posed(R: np.ndarray, t: np.ndarray, points: np.ndarray) -> np.ndarray:
    return np.asarray(points, np.float64) @ np.asarray(R, np.float64).T + np.asarray(t, np.float64).reshape(1, 3)


def add(R_est: np.ndarray, t_est: np.ndarray, R_gt: np.ndarray, t_gt: np.ndarray, points: np.ndarray) -> float:
    """ADD: mean ‖(R_est x + t_est) − (R_gt x + t_gt)‖ over the points, in their units."""
    return float(np.linalg.norm(_posed(R_est, t_est, points) - _posed(R_gt, t_gt, points), axis=1).mean())


def adds(R_est: np.ndarray, t_est: np.ndarray, R_gt: np.ndarray, t_gt: np.ndarray, points: np.ndarray) -> float:
    """ADD-S: mean over the truly posed points of the distance to the nearest estimated point."""
    distances, _ = cKDTree(_posed(R_est, t_est, points)).query(_posed(R_gt, t_gt, points), k=1)
    return float(np.mean(distances))


def translation_error(t_est: np.ndarray, t_gt: np.ndarray) -> float:
    """‖t_est − t_gt‖, in the poses' units."""
    return float(np.linalg.norm(np.asarray(t_est, np.float64) - np.asarray(t_gt, np.float64)))


def match_greedy(errors: np.ndarray, scores: np.ndarray, threshold: float) -> np.ndarray:
    """Matches estimates to ground-truth instances of one object in one image as the BOP toolkit
    does: estimates in decreasing score (ties: lower index first) each take the not yet matched
    instance of lowest error, if that error is strictly below `threshold`. `errors` (n_est,
    n_gt), `scores` (n_est,). Returns (n_gt,) float64: each instance's matched error, +inf where
    none matched."""
    errors = np.asarray(errors, np.float64)
    if errors.ndim != 2:  # a (n_est,) row for one instance; a (0, n_gt) matrix stays as it is
        errors = errors.reshape(len(scores), -1)
    matched = np.full(errors.shape[1], np.inf)
    taken = np.zeros(errors.shape[1], bool)
    for e in sorted(range(len(scores)), key=lambda i: (-float(scores[i]), i)):
        candidates = np.where(~taken & (errors[e] < threshold))[0]
        if len(candidates):
            g = candidates[np.argmin(errors[e, candidates])]
            taken[g] = True
            matched[g] = errors[e, g]
    return matched


def recall(errors: np.ndarray, diameters: np.ndarray, fraction: float) -> float:
    """Share of instances whose error is strictly below `fraction` × its object's diameter
    (inf = unmatched, a miss). `errors` and `diameters` (n,), same units. 0 instances: nan."""
    errors = np.asarray(errors, np.float64)
    if errors.size == 0:
        return float("nan")
    return float(np.mean(errors < fraction * np.asarray(diameters, np.float64)))


def auc(errors_mm: np.ndarray, max_mm: float = 100.0, step_mm: float = 1.0) -> float:
    """Area under the accuracy–threshold curve of `errors_mm` (n,) for thresholds 0 … max_mm in
    step_mm steps (accuracy = share ≤ threshold), trapezoid rule, divided by max_mm; in [0, 1]."""
    errors = np.asarray(errors_mm, np.float64)
    if errors.size == 0:
        return float("nan")
    thresholds = np.arange(0.0, max_mm + step_mm / 2, step_mm)
    accuracy = (errors[None, :] <= thresholds[:, None]).mean(axis=1)
    return float(np.sum((accuracy[1:] + accuracy[:-1]) / 2 * np.diff(thresholds)) / max_mm)
