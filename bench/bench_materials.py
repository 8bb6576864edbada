"""What the Moon's materials cost per frame: regolith's grain (terrain.photometry.grain), the
cloth's sheen (bags.fabric.sheen) and the dust stain mode (bags.stain.mode dust, 90 seeds),
each against the look without it, in one process on one built terrain.

Two views of the default scene: the default orbit view (1 m out, 0.5 m up: the bag covers ~4 %
of the frame, the textured ground most of the rest) and a close view of the bag (0.25 m out,
0.1 m up, from the Sun's side: the bag fills ~75 %). Each variant's scene is built once; the
renders then alternate A B A B … (`--rounds`, default 3) so that drift of a shared machine falls
on both alike, and the median of the core's render seconds is printed with the ray counts
(deterministic) and the ratio to the all-off variant. Provisional on a shared machine: quote the
ratios. Run: .venv/bin/python bench/bench_materials.py [--rounds N] [--spp N] [--out FILE.json]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
from pathlib import Path

from moonbot.config import load_config
from moonbot.render import build_scene, render_view
from moonbot.scene import compose_scene, intrinsics, orbit_pose

OFF = {
    "terrain.roughness.subgrid_shading": False,
    "terrain.craters.subgrid_shading": False,
    "terrain.photometry.grain.albedo_rms": 0.0,
    "terrain.photometry.grain.slope_rms_deg": 0.0,
    "bags.fabric.sheen": 0.0,
}
VARIANTS = {
    "off": OFF,
    "grain": {**OFF, "terrain.photometry.grain.albedo_rms": 0.08, "terrain.photometry.grain.slope_rms_deg": 12.5},
    "sheen": {**OFF, "bags.fabric.sheen": 0.1},
    "stamp90": {**OFF, "bags.stain.seeds": 90},
    "dust90": {**OFF, "bags.stain.seeds": 90, "bags.stain.mode": "dust"},
    "all": {"bags.stain.seeds": 90, "bags.stain.mode": "dust"},
}
VIEWS = {"default": {}, "close": {"orbit.radius_m": 0.25, "orbit.height_m": 0.1}}
CLOSE_AZIMUTH_DEG = 120.0  # the Sun's azimuth: the lit side


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--spp", type=int, default=4)
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()
    results = {}
    for view_name, view in VIEWS.items():
        built = {}
        for name, overrides in VARIANTS.items():
            config = load_config(None, {**overrides, **view, "render.spp": args.spp})
            spec = compose_scene(config)
            azimuth = CLOSE_AZIMUTH_DEG if view_name == "close" else config.orbit.start_azimuth_deg
            pose = orbit_pose(spec.target, config.orbit.radius_m, config.orbit.height_m, azimuth)
            built[name] = (config, build_scene(spec), pose)
        seconds = {name: [] for name in VARIANTS}
        stats = {}
        for _ in range(args.rounds):
            for name, (config, scene, pose) in built.items():
                out = render_view(scene, config, intrinsics(config.camera), pose, seed=0)
                seconds[name].append(out.stats["core_seconds"])
                stats[name] = {k: out.stats[k] for k in ("camera_rays", "shadow_rays", "bounce_rays")}
        base = statistics.median(seconds["off"])
        for name in VARIANTS:
            median = statistics.median(seconds[name])
            results[f"{view_name}/{name}"] = {
                "median_s": median,
                "ratio_to_off": median / base,
                "seconds": seconds[name],
                **stats[name],
            }
            print(f"{view_name:8s} {name:8s} {median:7.3f} s  x{median / base:5.3f}  {stats[name]}")
    results["load_average"] = os.getloadavg()
    print("load average", results["load_average"])
    if args.out:
        args.out.write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
