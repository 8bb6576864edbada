"""`moonbot baseline`: the zero-shot estimator (estimator.py) over every instance of one split of a
merged dataset, written as a BOP results CSV (moonbot/eval/results.py) for `moonbot eval`.

The estimator is told what FoundationPose is told in the paper's unseen-object mode: each
instance's object model (models/, mm), its visible mask (mask_visib/), the depth (depth_npy/) and
cam_K. It never reads the ground-truth poses. Instances whose mask has fewer than MIN_POINTS
pixels with depth get no estimate (eval counts them as misses).

Images are independent: they are spread over `workers` processes and collected in (scene_id,
im_id) order, so the poses and scores are the same whatever the number of workers; only the
`time` column (each image's seconds) varies between runs."""

from __future__ import annotations

import os
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from moonbot.baseline.estimator import ModelCloud, Settings, estimate_pose
from moonbot.bop.reader import Scene, read_models, scenes
from moonbot.eval.results import Estimate, write_results


@dataclass
class BaselineReport:
    """What a run did: instances seen, estimated, skipped (too few pixels), CPU seconds of the
    estimator summed over images, and the CSV written."""

    instances: int = 0
    estimated: int = 0
    skipped: int = 0
    seconds: float = 0.0
    out: Path | None = None


_clouds: dict[int, ModelCloud] = {}


def _load_clouds(dataset: str) -> None:
    """Worker start-up: each model's surface samples and KD-tree, built once per process."""
    global _clouds
    _clouds = {obj: ModelCloud.from_model(model) for obj, model in read_models(Path(dataset), "models").items()}


def estimate_image(scene: Scene, im_id: int, settings: Settings) -> tuple[list[Estimate], int, float]:
    """Every instance of one image: (its estimates in scene_gt order, instances skipped, seconds
    spent estimating). Uses the process's model clouds (_load_clouds)."""
    depth_mm = scene.depth_m(im_id).astype(np.float64) * 1000.0
    K = scene.cameras[im_id]
    estimates, skipped, seconds = [], 0, 0.0
    poses = []
    for instance in scene.images[im_id]:
        mask = scene.mask_visib(im_id, instance.index, depth_mm.shape)
        start = time.perf_counter()
        found = estimate_pose(depth_mm, mask, K, _clouds[instance.obj_id], settings)
        seconds += time.perf_counter() - start
        if found is None:
            skipped += 1
        else:
            poses.append((instance.obj_id, found))
    for obj_id, found in poses:
        estimates.append(Estimate(scene.scene_id, im_id, obj_id, found.score, found.R, found.t, seconds))
    return estimates, skipped, seconds


def run_baseline(
    dataset: Path,
    split: str = "test",
    out: Path | None = None,
    workers: int = 1,
    settings: Settings = Settings(),
    progress=None,
) -> BaselineReport:
    """Estimates every instance of `split` and writes the CSV to `out` (default
    DATASET/eval/baseline_<split>.csv). `progress(done, total)` is called after each image.
    Raises DatasetError naming a missing or malformed file."""
    dataset = Path(dataset)
    out = Path(out) if out else dataset / "eval" / f"baseline_{split}.csv"
    # The scenes' JSON is read once, here; each job carries its scene (no re-read per image).
    jobs = [(scene, im_id) for scene in scenes(dataset, split) for im_id in sorted(scene.images)]
    report = BaselineReport(out=out)
    results = []
    if workers <= 1:
        _load_clouds(str(dataset))
        for k, (scene, im_id) in enumerate(jobs):
            results.append(estimate_image(scene, im_id, settings))
            if progress:
                progress(k + 1, len(jobs))
    else:
        with ProcessPoolExecutor(workers, initializer=_load_clouds, initargs=(str(dataset),)) as pool:
            futures = [pool.submit(estimate_image, scene, im_id, settings) for scene, im_id in jobs]
            for k, future in enumerate(futures):
                results.append(future.result())
                if progress:
                    progress(k + 1, len(jobs))
    estimates = []
    for found, skipped, seconds in results:
        estimates.extend(found)
        report.estimated += len(found)
        report.skipped += skipped
        report.seconds += seconds
    report.instances = report.estimated + report.skipped
    out.parent.mkdir(parents=True, exist_ok=True)
    write_results(out, estimates)
    return report


def default_workers() -> int:
    """One process per core the scheduler gives this process."""
    return max(1, len(os.sched_getaffinity(0)))
