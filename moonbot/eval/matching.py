"""The matching of `moonbot eval` (moonbot.eval.report): pose estimates (a BOP results CSV)
against a merged dataset's ground-truth instances, and each instance's errors.

Units: poses map model points to the camera, x_cam = R·x + t, R (3, 3), t (3,) in mm; model
points are the models_eval/ vertices (N, 3) mm. Errors are in mm; "% diameter" is 100 × error /
the object's models_info diameter; recalls and the AUC are percentages (0–100).

Conditions (scene_meta.json, moonbot/bop/reader.py): mesh, location, stain ('clean': no stain
seeds, else 'stained') and dust ('clear' or 'dusty').

Which instances are evaluated: every ground-truth instance of the split with at least one visible
pixel (scene_gt_info px_count_visib > 0) and visib_fract ≥ `min_visib_fract` (default 0, so all
instances with a visible pixel). The others are left out of every table and cannot be matched,
as the BOP toolkit treats ground truth outside its `gt_valid_mask`; per_instance.csv lists them
with evaluated = 0.

Matching, per image and obj_id, estimates against that image's evaluated instances of the
object, by the BOP toolkit's greedy rule (pose_matching.match_poses; metrics.match_greedy): the
estimates in decreasing score (ties: the earlier line first) each take the not yet matched
instance of lowest error, if that error is strictly below the threshold.
- The recalls are the toolkit's exactly: for each error (ADD, ADD-S) and each threshold (10 %,
  20 % of the diameter) its own matching on that error at that threshold; an instance is correct
  if it is matched there (per_instance.csv: add_correct_10 ... adds_correct_20).
- The errors reported per instance (ADD, ADD-S, translation; the means, median and AUC) are those
  of the one estimate an ADD-S matching gives it, run at 10 % of the diameter, then among what is
  left at 20 %, then with no threshold, so every estimate is matched while an instance of its
  object is left, but an estimate never takes an instance another one fits within 10 % (or 20 %)
  of the diameter — a duplicate or a stray estimate with a higher score does not displace the
  estimate of the instance it lands near. The first pass is the toolkit's matching at 10 %, so
  adds_mm < 10 % of the diameter exactly when adds_correct_10; at 20 % the two can differ only in
  contrived cases of several estimates fitting several instances within 20 %.
Estimates beyond the number of instances stay unmatched (the toolkit's n_top = instance count
gives the same).

Speed: ADD-S(est, gt) = mean over model points x of the distance from R_gt x + t_gt to the
nearest R_est y + t_est, and rigid motions keep distances, so it equals the mean distance from
R_estᵀ(R_gt x + t_gt − t_est) to the nearest model point y itself: one KD-tree per model, built
once (ModelPoints). Most of the time goes into the queries, not the tree (on the development
machine 0.03 s to build, 0.1 s to 3 s to query 110 000 points, more the farther the estimate is
off; `workers` spreads each query over threads), so the matching computes
ADD-S lazily: a cheap lower bound (distance to the model's bounding box and sphere) decides which
instances can still be the nearest, and only those are queried, which gives the same matching as
the full error matrix (tested against metrics.match_greedy)."""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from moonbot.bop.reader import DatasetError, Instance, Model, Scene
from moonbot.eval.metrics import match_greedy
from moonbot.eval.results import Estimate

# The recalls' thresholds, fractions of the object diameter.
RECALL_FRACTIONS = (0.1, 0.2)
DUST_LABELS = {False: "clear", True: "dusty"}


class EvalError(ValueError):
    """The results do not fit the dataset (estimates of images or objects it does not have)."""


# --------------------------------------------------------------------------------------------
# Errors of one estimate against one instance


class ModelPoints:
    """One model's evaluation points (N, 3) float64 mm, with a KD-tree of them, their bounding
    box and bounding sphere about the model origin, and the model's diameter (mm)."""

    def __init__(self, model: Model, workers: int = 1):
        self.obj_id = model.obj_id
        self.points = np.ascontiguousarray(model.vertices, np.float64)
        if self.points.ndim != 2 or self.points.shape[1] != 3 or len(self.points) == 0:
            raise DatasetError(f"models_eval obj_{model.obj_id:06d}.ply: no points")
        self.diameter = float(model.diameter)
        # Leaves of 64 points: a third faster than the default 16 for estimates ~20 mm off (queries
        # far from the surface visit many leaves), the same for near ones.
        self.tree = cKDTree(self.points, leafsize=64)
        self.lo, self.hi = self.points.min(axis=0), self.points.max(axis=0)
        self.radius = float(np.linalg.norm(self.points, axis=1).max())
        self.workers = workers

    def relative(self, R_est: np.ndarray, t_est: np.ndarray, R_gt: np.ndarray, t_gt: np.ndarray) -> np.ndarray:
        """The truly posed points in the estimate's model frame, R_estᵀ(R_gt x + t_gt − t_est), (N, 3)."""
        R_est, R_gt = np.asarray(R_est, np.float64), np.asarray(R_gt, np.float64)
        shift = np.asarray(t_gt, np.float64).reshape(3) - np.asarray(t_est, np.float64).reshape(3)
        return _transform(self.points, R_est.T @ R_gt, R_est.T @ shift)

    def adds(self, R_est: np.ndarray, t_est: np.ndarray, R_gt: np.ndarray, t_gt: np.ndarray) -> float:
        """ADD-S (mm), equal to metrics.adds on these points up to float rounding."""
        distances, _ = self.tree.query(self.relative(R_est, t_est, R_gt, t_gt), k=1, workers=self.workers)
        return float(np.mean(distances))

    def adds_lower_bound(self, R_est: np.ndarray, t_est: np.ndarray, R_gt: np.ndarray, t_gt: np.ndarray) -> float:
        """A lower bound of ADD-S (mm), no query: each relative point is at least as far from the
        nearest model point as from the model's bounding box, and as from its bounding sphere."""
        q = self.relative(R_est, t_est, R_gt, t_gt)
        box = _norms(np.maximum(np.maximum(self.lo - q, q - self.hi), 0.0))
        return float(np.mean(np.maximum(box, _norms(q) - self.radius)))

    def add(self, R_est: np.ndarray, t_est: np.ndarray, R_gt: np.ndarray, t_gt: np.ndarray) -> float:
        """ADD (mm): mean ‖(R_est − R_gt) x + t_est − t_gt‖, as metrics.add."""
        dR = np.asarray(R_est, np.float64) - np.asarray(R_gt, np.float64)
        dt = np.asarray(t_est, np.float64).reshape(3) - np.asarray(t_gt, np.float64).reshape(3)
        return float(np.mean(_norms(_transform(self.points, dR, dt))))


# (N, 3) @ (3, 3) through BLAS is slow for so skinny a matrix (about 30 ms for 110 000 points on the
# development machine, einsum 5 times less).
def _transform(points: np.ndarray, A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """A x + b for each row x of points (N, 3)."""
    return np.einsum("ij,kj->ik", points, A) + b


def _norms(v: np.ndarray) -> np.ndarray:
    """Euclidean norm of each row of v (N, 3)."""
    return np.sqrt(np.einsum("ij,ij->i", v, v))


def assign_greedy(
    scores: Sequence[float],
    n_gt: int,
    error: Callable[[int, int], float],
    lower_bound: Callable[[int, int], float],
    threshold: float = math.inf,
    estimate_of: np.ndarray | None = None,
) -> np.ndarray:
    """metrics.match_greedy computing errors only where needed: the estimates in decreasing score
    (ties: lower index first) each take the not yet matched instance of lowest error(e, g) (ties:
    lower index) if that error is strictly below `threshold`. `lower_bound(e, g)` ≤ error(e, g)
    must hold: instances are tried in increasing bound, skipped once the bound reaches the
    threshold or exceeds the best error found. `estimate_of` (n_gt,) int: a previous assignment
    to continue (its estimates and instances stay as they are). Returns (n_gt,) int64, the
    estimate matched to each instance, −1 for none."""
    estimate_of = np.full(n_gt, -1, np.int64) if estimate_of is None else np.array(estimate_of, np.int64)
    used = set(int(e) for e in estimate_of if e >= 0)
    for e in sorted(range(len(scores)), key=lambda i: (-float(scores[i]), i)):
        free = [g for g in range(n_gt) if estimate_of[g] < 0]
        if not free:
            break
        if e in used:
            continue
        bounds = sorted((lower_bound(e, g), g) for g in free) if len(free) > 1 else [(0.0, free[0])]
        best, best_g = math.inf, -1
        for bound, g in bounds:
            if bound > best or bound >= threshold:
                break
            err = error(e, g)
            if err < threshold and (err < best or (err == best and g < best_g)):
                best, best_g = err, g
        if best_g >= 0:
            estimate_of[best_g] = e
    return estimate_of


class _Pairs:
    """The errors of one image's estimates of one object against its evaluated instances, each
    computed at most once: ADD-S (KD-tree query), its lower bound, ADD and its lower bound
    ‖(R_est − R_gt) x̄ + t_est − t_gt‖ ≤ ADD (x̄ the points' centroid; the mean of norms is at
    least the norm of the mean)."""

    def __init__(self, mp: ModelPoints, ests: Sequence[Estimate], gts: Sequence):
        self.mp, self.ests, self.gts = mp, ests, gts
        self.centroid = mp.points.mean(axis=0)
        self._cache: dict[tuple[str, int, int], float] = {}

    def _get(self, kind: str, e: int, g: int, compute: Callable) -> float:
        key = (kind, e, g)
        if key not in self._cache:
            est, gt = self.ests[e], self.gts[g]
            self._cache[key] = compute(est.R, est.t, gt.R, gt.t)
        return self._cache[key]

    def adds(self, e: int, g: int) -> float:
        return self._get("adds", e, g, self.mp.adds)

    def adds_bound(self, e: int, g: int) -> float:
        return self._get("adds_bound", e, g, self.mp.adds_lower_bound)

    def add(self, e: int, g: int) -> float:
        return self._get("add", e, g, self.mp.add)

    def add_bound(self, e: int, g: int) -> float:
        return self._get(
            "add_bound",
            e,
            g,
            lambda Re, te, Rg, tg: float(
                np.linalg.norm((np.asarray(Re) - np.asarray(Rg)) @ self.centroid + np.asarray(te) - np.asarray(tg))
            ),
        )

    def toolkit_correct(self, kind: str, threshold: float) -> np.ndarray:
        """(n_gt,) bool: the instances the BOP toolkit counts correct for error `kind` ('add' or
        'adds') at `threshold` mm — metrics.match_greedy on the error matrix at that threshold,
        with +inf where the lower bound already reaches it (such a pair cannot match there)."""
        error, bound = (self.add, self.add_bound) if kind == "add" else (self.adds, self.adds_bound)
        matrix = np.full((len(self.ests), len(self.gts)), np.inf)
        for e in range(len(self.ests)):
            for g in range(len(self.gts)):
                if bound(e, g) < threshold:
                    matrix[e, g] = error(e, g)
        return np.isfinite(match_greedy(matrix, np.array([x.score for x in self.ests]), threshold))


# --------------------------------------------------------------------------------------------
# Evaluation: one result per ground-truth instance


@dataclass(frozen=True)
class InstanceResult:
    """One ground-truth instance and the errors of the estimate matched to it. Errors in mm, nan
    when unmatched (`matched` False) or not evaluated; `score` and `line` (results CSV line) of the
    matched estimate, nan and 0 when none. `add_correct_10` etc.: counted correct by the toolkit's
    matching for that error at 10 or 20 % of the diameter."""

    split: str
    scene_id: int
    im_id: int
    obj_id: int
    index: int
    mesh: str
    location: str
    stain: str
    dust: str
    px_visib: int
    visib_fract: float
    diameter_mm: float
    evaluated: bool
    matched: bool
    add_mm: float = math.nan
    adds_mm: float = math.nan
    te_mm: float = math.nan
    score: float = math.nan
    line: int = 0
    add_correct_10: bool = False
    add_correct_20: bool = False
    adds_correct_10: bool = False
    adds_correct_20: bool = False


def _instance_result(inst: Instance, common: dict, evaluated: bool, matched: bool, **errors) -> InstanceResult:
    """The row of ground-truth instance `inst`: its image's and object's fields (`common`), its own,
    and the `errors` of the estimate matched to it (InstanceResult's defaults where none)."""
    return InstanceResult(
        index=inst.index,
        px_visib=inst.px_visib,
        visib_fract=inst.visib_fract,
        evaluated=evaluated,
        matched=matched,
        **common,
        **errors,
    )


@dataclass
class Evaluation:
    """Every ground-truth instance of the split (InstanceResult) and what became of the estimates:
    `estimates` read, `matched_estimates`, `unmatched_estimates` (no instance of their object left
    in their image, or their object is not there), and `unknown` (line, reason) for estimates of
    images not in the split or of objects without a model."""

    split: str
    instances: list[InstanceResult]
    estimates: int
    matched_estimates: int
    unmatched_estimates: int
    unknown: list[tuple[int, str]] = field(default_factory=list)
    min_visib_fract: float = 0.0

    @property
    def evaluated(self) -> list[InstanceResult]:
        return [r for r in self.instances if r.evaluated]


def evaluate(
    scenes: Iterable[Scene],
    models: dict[int, Model],
    estimates: Iterable[Estimate],
    min_visib_fract: float = 0.0,
    workers: int = 1,
    progress: Callable[[int, int], None] | None = None,
) -> Evaluation:
    """Matches `estimates` to the ground truth of `scenes` (one split) and computes each evaluated
    instance's errors (module docstring). `models`: models_eval by obj_id. `workers`: threads of
    each KD-tree query (−1: all cores). `progress(done, total)` is called after each image.
    Raises DatasetError when a ground-truth object has no model."""
    scenes = list(scenes)
    split = scenes[0].split if scenes else ""
    images: dict[tuple[int, int], tuple[Scene, int]] = {}
    for scene in scenes:
        for im_id in scene.images:
            images[(scene.scene_id, im_id)] = (scene, im_id)
    by_image: dict[tuple[int, int], dict[int, list[Estimate]]] = defaultdict(lambda: defaultdict(list))
    unknown: list[tuple[int, str]] = []
    estimates = list(estimates)
    for est in estimates:
        if (est.scene_id, est.im_id) not in images:
            unknown.append((est.line, f"scene {est.scene_id} image {est.im_id} is not in split {split!r}"))
        elif est.obj_id not in models:
            unknown.append((est.line, f"obj_id {est.obj_id} has no model in models_eval"))
        else:
            by_image[(est.scene_id, est.im_id)][est.obj_id].append(est)
    points: dict[int, ModelPoints] = {}

    def model_points(obj_id: int, scene: Scene) -> ModelPoints:
        if obj_id not in points:
            if obj_id not in models:
                raise DatasetError(f"{scene.path / 'scene_gt.json'}: obj_id {obj_id} has no model in models_eval")
            points[obj_id] = ModelPoints(models[obj_id], workers)
        return points[obj_id]

    results: list[InstanceResult] = []
    matched_estimates = 0
    for done, ((scene_id, im_id), (scene, _)) in enumerate(sorted(images.items()), start=1):
        instances = scene.images[im_id]
        per_obj = by_image.get((scene_id, im_id), {})
        rows: dict[int, InstanceResult] = {}
        for obj_id in sorted({i.obj_id for i in instances}):
            mp = model_points(obj_id, scene)
            gts = [i for i in instances if i.obj_id == obj_id]
            valid = [i for i in gts if i.px_visib > 0 and i.visib_fract >= min_visib_fract]
            ests = per_obj.get(obj_id, [])
            pairs = _Pairs(mp, ests, valid)
            scores = [e.score for e in ests]
            estimate_of = None
            for gate in (*(f * mp.diameter for f in RECALL_FRACTIONS), math.inf):
                estimate_of = assign_greedy(scores, len(valid), pairs.adds, pairs.adds_bound, gate, estimate_of)
            correct = (
                {
                    (kind, f): pairs.toolkit_correct(kind, f * mp.diameter)
                    for kind in ("add", "adds")
                    for f in RECALL_FRACTIONS
                }
                if ests and valid
                else {}
            )
            common = dict(
                split=scene.split,
                scene_id=scene_id,
                im_id=im_id,
                obj_id=obj_id,
                mesh=scene.mesh,
                location=scene.location,
                stain=scene.stain,
                dust=DUST_LABELS[scene.dust],
                diameter_mm=mp.diameter,
            )
            for inst in gts:
                rows[inst.index] = _instance_result(inst, common, evaluated=False, matched=False)
            for g, inst in enumerate(valid):
                e = int(estimate_of[g])
                flags = {f"{kind}_correct_{round(100 * f)}": bool(c[g]) for (kind, f), c in correct.items()}
                if e < 0:
                    rows[inst.index] = _instance_result(inst, common, evaluated=True, matched=False, **flags)
                    continue
                est = ests[e]
                matched_estimates += 1
                rows[inst.index] = _instance_result(
                    inst,
                    common,
                    evaluated=True,
                    matched=True,
                    add_mm=pairs.add(e, g),
                    adds_mm=pairs.adds(e, g),
                    te_mm=float(np.linalg.norm(est.t - inst.t)),
                    score=est.score,
                    line=est.line,
                    **flags,
                )
        results.extend(rows[k] for k in sorted(rows))
        if progress is not None:
            progress(done, len(images))
    known = sum(len(v) for per_obj in by_image.values() for v in per_obj.values())
    return Evaluation(
        split, results, len(estimates), matched_estimates, known - matched_estimates, unknown, min_visib_fract
    )


def unknown_message(evaluation: Evaluation, results_path: Path, limit: int = 5) -> str:
    """One line per unknown estimate (the first `limit`), each naming results_path:line, and a
    count of the rest."""
    lines = [f"{results_path}:{line}: {reason}" for line, reason in evaluation.unknown[:limit]]
    if len(evaluation.unknown) > limit:
        lines.append(f"... and {len(evaluation.unknown) - limit} more")
    return "\n".join(lines)
