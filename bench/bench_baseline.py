"""What the zero-shot baseline's knobs cost: its ICP settings (points and
iterations of the coarse pass over every hypothesis and of the fine pass over the best few)
against the pose error they leave, on the instances of a generated dataset's test split.

Each instance with at least one visible pixel is estimated from its own visible mask (no
matching: the mask names the instance), single-threaded; the error is ADD-S against the ground
truth in mm and as recall at 10 % and 20 % of the diameter (strict <, as bop_toolkit), over
every image of the split or `--images` of them spread evenly. Seconds are the estimator's wall
time per instance (mean), without loading or the error's computation; the 1-minute load average
before and after is recorded, since other work on the machine inflates them.

Writes bench/results/baseline-<machine>.json and .svg. Run, on a dataset from
configs/synbag-test-12.yaml (`moonbot generate configs/synbag-test-12.yaml --out D`):
  .venv/bin/python bench/bench_baseline.py D/dataset [--images 48]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

from moonbot.baseline import ModelCloud, Settings, estimate_pose
from moonbot.bop.reader import read_models, scenes
from moonbot.eval.matching import ModelPoints

from fingerprint import machine  # bench/ is on sys.path when run as a script
from result_file import write_result_and_chart

LEVELS = {
    "draft": Settings(coarse_points=80, coarse_iterations=5, fine_points=300, fine_iterations=10, fine_hypotheses=1),
    "default": Settings(),
    "high": Settings(coarse_points=300, coarse_iterations=12, fine_points=2000, fine_iterations=40, fine_hypotheses=5),
}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("dataset", type=Path)
    parser.add_argument("--split", default="test")
    parser.add_argument("--images", type=int, default=48, help="images of the split, spread evenly (0: all)")
    args = parser.parse_args()

    models = read_models(args.dataset, "models")
    evaluation = {
        obj: ModelPoints(model, workers=-1) for obj, model in read_models(args.dataset, "models_eval").items()
    }
    clouds = {obj: ModelCloud.from_model(model) for obj, model in models.items()}
    images = [(scene, im) for scene in scenes(args.dataset, args.split) for im in sorted(scene.images)]
    if args.images and args.images < len(images):
        images = [images[i] for i in np.linspace(0, len(images) - 1, args.images).round().astype(int)]
    cases = []
    for scene, im in images:
        depth_mm = scene.depth_m(im).astype(np.float64) * 1000.0
        for inst in scene.images[im]:
            if inst.px_visib > 0:
                cases.append((scene, im, inst, depth_mm))
    print(f"{len(images)} images, {len(cases)} instances with visible pixels")

    result = {
        "machine": machine(),
        "dataset": str(args.dataset),
        "split": args.split,
        "images": len(images),
        "instances": len(cases),
        "levels": [],
    }
    load_before = os.getloadavg()
    print(f"{'level':>8} {'ms/inst':>8} {'median':>8} {'p90':>8} {'R@10%':>6} {'R@20%':>6} {'none':>5}")
    for name, settings in LEVELS.items():
        errors, seconds, none = [], 0.0, 0
        for scene, im, inst, depth_mm in cases:
            mask = scene.mask_visib(im, inst.index, depth_mm.shape)
            start = time.perf_counter()
            found = estimate_pose(depth_mm, mask, scene.cameras[im], clouds[inst.obj_id], settings)
            seconds += time.perf_counter() - start
            if found is None:
                none += 1
                errors.append(np.inf)
            else:
                errors.append(evaluation[inst.obj_id].adds(found.R, found.t, inst.R, inst.t))
        errors = np.array(errors)
        diameters = np.array([evaluation[inst.obj_id].diameter for _, _, inst, _ in cases])
        row = {
            "level": name,
            "settings": vars(settings),
            "seconds_per_instance": seconds / len(cases),
            "median_adds_mm": float(np.median(errors)),
            "p90_adds_mm": float(np.percentile(errors, 90)),
            "recall_10": float(np.mean(errors < 0.1 * diameters)),
            "recall_20": float(np.mean(errors < 0.2 * diameters)),
            "no_estimate": none,
        }
        result["levels"].append(row)
        print(
            f"{name:>8} {1e3 * row['seconds_per_instance']:>8.0f} {row['median_adds_mm']:>8.2f} "
            f"{row['p90_adds_mm']:>8.1f} {row['recall_10']:>6.3f} {row['recall_20']:>6.3f} {none:>5}"
        )
    result["load_average_before_after"] = [load_before[0], os.getloadavg()[0]]
    curve = [(r["seconds_per_instance"], max(1.0 - r["recall_20"], 1e-4), r["level"]) for r in result["levels"]]
    write_result_and_chart(
        result,
        "baseline",
        "Baseline ICP settings against pose error",
        f"{len(cases)} instances",
        {"ICP": curve},
        "estimator seconds per instance",
        "1 - recall at 20 % ADD-S",
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
