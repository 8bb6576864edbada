"""What placing and settling bags costs, and what its knobs buy.

Measures, on this machine:
  1. per scene (ground × layout × mesh, the sweep's bag counts 1, 5, 8, 11): the geometric
     placement, the MuJoCo settling (wall-clock, simulated seconds, steps) and the exact overlap
     check, median over repeats;
  2. what settling changes: the largest displacement of any bag vertex between the geometric
     rest and the settled pose (mm);
  3. the knobs against a reference: integration step `timestep_s` (reference 0.25 ms) and,
     on the crater, the height-field spacing `ground_step_m` (reference 5 mm): settle time
     against the largest vertex displacement from the reference's settled poses (mm).

Writes bench/results/settle-<machine>.json and .svg (settle time against error, one curve per
knob and scene) and prints tables.
Run: .venv/bin/python bench/bench_settle.py [--repeats N] [--plot-only]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from moonbot.charts import time_error_plot
from moonbot.config.schema import BagsConfig, MeshesConfig, SettleConfig
from moonbot.scene.bag_mesh import variant_mesh
from moonbot.scene.collision import transform
from moonbot.scene.placement import check_placement, place_bags
from moonbot.scene.settle import settle
from moonbot.terrain.ground import CraterGround, FlatGround, SlopedGround

from fingerprint import machine, machine_slug  # bench/ is on sys.path when run as a script
from result_file import RESULTS, write_result

SCHEMA_VERSION = 1

GROUNDS = {
    "flat": FlatGround(),
    "slope 30°": SlopedGround(slope_deg=30.0, downhill_azimuth_deg=90.0),
    "crater rim": CraterGround(),
}
SCENES = [  # (ground, layout, count, obj_id)
    ("flat", "single", 1, 1),
    ("flat", "scattered", 5, 1),
    ("flat", "scattered", 8, 1),
    ("flat", "stacked", 11, 1),
    ("flat", "stacked", 11, 3),
    ("slope 30°", "single", 1, 1),
    ("slope 30°", "scattered", 5, 1),
    ("slope 30°", "stacked", 5, 1),
    ("crater rim", "single", 1, 1),
    ("crater rim", "scattered", 5, 1),
    ("crater rim", "scattered", 5, 3),
]
KNOB_SCENES = [("flat", "stacked", 11, 1), ("slope 30°", "scattered", 5, 1), ("crater rim", "scattered", 5, 1)]


def geometric(scene, config: SettleConfig):
    ground_name, layout, count, obj_id = scene
    v, t = variant_mesh(MeshesConfig(), obj_id)
    bags = BagsConfig(count=count, layout=layout, settle=config)
    start = time.perf_counter()
    poses = place_bags(
        v,
        t,
        count,
        layout,
        seed=0,
        ground=GROUNDS[ground_name],
        yaw_deg=bags.yaw_deg,
        gap_m=bags.gap_m,
        radius_m=bags.scatter_radius_m,
        clearance_m=config.margin_m + config.drop_m,
    )
    return v, t, poses, time.perf_counter() - start


def displacement_mm(vertices, a, b) -> float:
    """Largest distance (mm) any vertex moves between two lists of poses."""
    return 1e3 * max(
        float(np.linalg.norm(transform(vertices, p) - transform(vertices, q), axis=1).max()) for p, q in zip(a, b)
    )


def scene_costs(repeats: int) -> list[dict]:
    rows = []
    config = SettleConfig()
    for scene in SCENES:
        ground = GROUNDS[scene[0]]
        place_s, settle_s, check_s = [], [], []
        for _ in range(repeats):
            v, t, poses, seconds = geometric(scene, config)
            place_s.append(seconds)
            result = settle(v, poses, ground, config)
            settle_s.append(result.seconds)
            start = time.perf_counter()
            check_placement(v, t, result.poses, ground)
            check_s.append(time.perf_counter() - start)
        rest = place_bags(v, t, scene[2], scene[1], seed=0, ground=ground, yaw_deg=20.0, clearance_m=config.margin_m)
        rows.append(
            {
                "ground": scene[0],
                "layout": scene[1],
                "count": scene[2],
                "obj_id": scene[3],
                "place_s": statistics.median(place_s),
                "settle_s": statistics.median(settle_s),
                "check_s": statistics.median(check_s),
                "simulated_s": result.simulated_s,
                "steps": result.steps,
                "settling_moves_mm": displacement_mm(v, rest, result.poses),
            }
        )
        r = rows[-1]
        print(
            f"{r['ground']:>10} {r['layout']:>9} {r['count']:>2} × obj {r['obj_id']}: place {r['place_s']:.3f} s, "
            f"settle {r['settle_s']:.3f} s ({r['simulated_s']:.2f} s simulated, {r['steps']} steps), "
            f"check {r['check_s']:.3f} s; settling moves a vertex up to {r['settling_moves_mm']:.1f} mm"
        )
    return rows


def knob_curve(knob: str, values: list[float], reference: float, scenes, extra: dict) -> list[dict]:
    rows = []
    for scene in scenes:
        ground = GROUNDS[scene[0]]
        base = dataclasses.replace(SettleConfig(), **extra)
        v, _, poses, _ = geometric(scene, base)
        ref = settle(v, poses, ground, dataclasses.replace(base, **{knob: reference}))
        for value in values:
            config = dataclasses.replace(base, **{knob: value})
            result = settle(v, poses, ground, config)
            rows.append(
                {
                    "ground": scene[0],
                    "layout": scene[1],
                    "count": scene[2],
                    knob: value,
                    "settle_s": result.seconds,
                    "steps": result.steps,
                    "error_mm": displacement_mm(v, ref.poses, result.poses),
                }
            )
            r = rows[-1]
            print(
                f"{r['ground']:>10} {r['layout']:>9} {r['count']:>2}  {knob} = {value:<7g} "
                f"settle {r['settle_s']:.3f} s, {r['steps']:>5} steps, error {r['error_mm']:.2f} mm"
            )
    return rows


def plot(result: dict, path: Path) -> None:
    curves = {}
    for knob, key in (("timestep_s", "timestep"), ("ground_step_m", "ground_step")):
        for row in result[key]:
            name = f"{knob}, {row['ground']} {row['layout']} {row['count']}"
            curves.setdefault(name, []).append((row["settle_s"], row["error_mm"], f"{row[knob]:g}"))
    time_error_plot(
        path,
        f"Settling: time against error ({result['machine']['git_commit'][:7]})",
        curves,
        x_label="settle wall-clock, s",
        y_label="largest vertex displacement from the reference, mm",
    )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--plot-only", action="store_true", help="redraw the SVG from this machine's JSON")
    args = parser.parse_args()
    if args.plot_only:
        out = RESULTS / f"settle-{machine_slug(machine())}.json"
        plot(json.loads(out.read_text()), out.with_suffix(".svg"))
        return 0
    result = {"schema_version": SCHEMA_VERSION, "machine": machine(), "defaults": dataclasses.asdict(SettleConfig())}
    print("Per scene (medians):")
    result["scenes"] = scene_costs(args.repeats)
    print("\ntimestep_s against a 0.25 ms reference (contact_time_s 0.02 s):")
    result["timestep"] = knob_curve("timestep_s", [0.0005, 0.001, 0.002, 0.004, 0.008], 0.00025, KNOB_SCENES, {})
    print("\nground_step_m on the crater rim against a 5 mm reference:")
    result["ground_step"] = knob_curve(
        "ground_step_m", [0.01, 0.02, 0.05], 0.005, [s for s in KNOB_SCENES if s[0] == "crater rim"], {}
    )
    out = write_result(result, "settle")
    plot(result, out.with_suffix(".svg"))
    print(f"\nwrote {out} and {out.with_suffix('.svg').name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
