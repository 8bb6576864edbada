"""What the ejecta simulation's knobs cost: the time step against the
error it leaves, and the fragment count against time.

Free flight is exact at any step (closed-form parabolas), so the step only decides how finely
contacts are found: a chord cuts the parabola's corner by up to g·dt²/8, which moves each bounce
and so every later position. On the default flat location (its 1 cm regolith grid around the
bags), 200 fragments of the paper's emitter are flown to capture times across one 2 s burst with
each step and compared with a 0.25 ms reference: median and 95th percentile of the position
error, and the simulation seconds per capture (median of `--repeats`). Then the count: seconds
for 50 to 5000 fragments at the default step.

Writes bench/results/dust-<machine>.json and .svg (time against error per step). Run:
  .venv/bin/python bench/bench_dust.py [--repeats 3]
"""

from __future__ import annotations

import argparse
import statistics
import sys

import numpy as np

from moonbot import _core
from moonbot.config import load_config
from moonbot.render import build_scene
from moonbot.scene import compose_scene

from fingerprint import machine  # bench/ is on sys.path when run as a script
from result_file import write_result_and_chart
from timing import timed

SCHEMA_VERSION = 1
STEPS = [0.1, 0.05, 0.02, 0.01, 0.005, 0.002, 0.001]
REFERENCE_STEP = 0.00025
COUNTS = [50, 200, 1000, 5000]
CAPTURES = np.linspace(0.1, 1.9, 10)  # capture times within one burst, seconds


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    config = load_config(None, {"terrain.location": "flat"})
    spec = compose_scene(config)
    scene = build_scene(spec)
    origin = spec.target + np.array([0.6, 0.0, 0.0])  # beside the target, as a wheel would be
    origin[2] = float(spec.ground.height(origin[0], origin[1]))

    def run(dt, count=200, t=1.0):
        return _core.simulate_ejecta(
            scene, _core.EjectaParams(origin=origin, count=count), seed=1, time_s=float(t), dt_s=dt
        )

    result = {
        "schema_version": SCHEMA_VERSION,
        "machine": machine(),
        "reference_step_s": REFERENCE_STEP,
        "captures_s": CAPTURES.tolist(),
        "steps": [],
        "counts": [],
    }
    reference = [run(REFERENCE_STEP, t=t)["position"] for t in CAPTURES]
    print(f"{'dt s':>7} {'ms/capture':>11} {'median err mm':>14} {'p95 err mm':>11} {'bounces':>8}")
    for dt in STEPS:
        errors, seconds, bounces = [], [], []
        for t, ref in zip(CAPTURES, reference):
            out, s = timed(lambda: run(dt, t=t), args.repeats)
            errors.append(np.linalg.norm(out["position"] - ref, axis=1))
            seconds.append(s)
            bounces.append(out["bounces"].mean())
        err = np.concatenate(errors)
        row = {
            "dt_s": dt,
            "seconds_per_capture": statistics.median(seconds),
            "median_error_m": float(np.median(err)),
            "p95_error_m": float(np.percentile(err, 95)),
            "mean_bounces": float(np.mean(bounces)),
        }
        result["steps"].append(row)
        print(
            f"{dt:>7} {1e3 * row['seconds_per_capture']:>11.2f} {1e3 * row['median_error_m']:>14.3f} "
            f"{1e3 * row['p95_error_m']:>11.3f} {row['mean_bounces']:>8.2f}"
        )
    print(f"\n{'count':>6} {'ms/capture':>11}")
    for count in COUNTS:
        _, s = timed(lambda: run(0.01, count=count), args.repeats)
        result["counts"].append({"count": count, "dt_s": 0.01, "seconds_per_capture": s})
        print(f"{count:>6} {1e3 * s:>11.2f}")
    curve = [(r["seconds_per_capture"], r["p95_error_m"], f"{r['dt_s']:g}") for r in result["steps"]]
    write_result_and_chart(
        result,
        "dust",
        "Ejecta: time step against position error",
        "200 fragments",
        {"dt, s": curve},
        "simulation seconds per capture",
        "p95 position error vs 0.25 ms, m",
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
