"""What building a location costs, what the cache saves, and what the grid's growth buys.

Measures, on this machine:
  1. per location (flat, hilly, crater, dem; default config): triangles, rocks (instances and the
     triangles they instance), small craters drawn, the cold build
     (seconds; the Python heights and mesh), the same call again from the per-process cache,
     the Embree BVH build, one view's render, and memory: the mesh arrays (MB) and the growth
     of the process's resident set over building terrain + BVH (MB). The `dem` row reads a
     6 km square LocalDem at 5 m spacing made here from the hilly location's relief (what it
     costs depends on the DEM's size, not its content); with `--dem FILE.npz --site E N
     --extent M` a real imported DEM is measured as well (docs/physics.md "Terrain": Kepler crater, LOLA);
  2. the grid's `growth` knob on the flat location, camera 0.2 m above the target so the horizon
     is in view: triangles and build + BVH + render time against the error of the depth image
     (median and 99th percentile of |Δz|/z over pixels, and the share of pixels off by > 1 %)
     relative to a fine reference (growth 1.01, 7.4 M triangles).

Writes bench/results/terrain-<machine>.json and .svg (time against depth error) and prints
tables. Run: .venv/bin/python bench/bench_terrain.py [--dem FILE.npz --site E N --extent M]
"""

from __future__ import annotations

import argparse
import gc
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from moonbot.config import load_config
from moonbot.render import build_scene, render_view
from moonbot.scene import compose_scene, intrinsics, orbit_pose
from moonbot.terrain import clear_cache, get_terrain
from moonbot.terrain.dem import LocalDem
from moonbot.terrain.location import Location, location_axis

from fingerprint import machine  # bench/ is on sys.path when run as a script
from result_file import write_result_and_chart

SCHEMA_VERSION = 2  # 2: dem rows
GROWTHS = [1.01, 1.02, 1.03, 1.05, 1.1]  # the first is the reference (7.4 M triangles)


def rss_mb() -> float:
    """This process's resident set size now, MB."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    return float("nan")


def view(config, spec, scene):
    pose = orbit_pose(spec.target, config.orbit.radius_m, config.orbit.height_m, config.orbit.start_azimuth_deg)
    start = time.perf_counter()
    out = render_view(scene, config, intrinsics(config.camera), pose, seed=0)
    return out, time.perf_counter() - start


def synthetic_dem(path: Path) -> Path:
    """A 6 km square LocalDem at 5 m spacing (1201² nodes, flat-earth): the hilly location's
    relief band-limited to the DEM's pixel, as a DEM of known content and typical size."""
    config = load_config(None, {"terrain.location": "hilly"}).terrain
    location = Location(config, location_axis(config))
    e = (np.arange(1201) - 600) * 5.0
    E, N = np.meshgrid(e, e)
    heights = location.surface(E, N, np.full(E.shape, 5.0))
    return LocalDem(
        heights=heights,
        spacing_m=5.0,
        lat_deg=0.0,
        lon_deg=0.0,
        h0_m=0.0,
        curvature=False,
        source={"made_by": "bench_terrain.synthetic_dem (hilly relief, 5 m)"},
    ).save(path)


def location_row(location: str, overrides: dict | None = None, label: str | None = None) -> dict:
    clear_cache()
    gc.collect()
    config = load_config(None, {"terrain.location": location, **(overrides or {})})
    before = rss_mb()
    start = time.perf_counter()
    terrain, _ = get_terrain(config.terrain)
    build_s = time.perf_counter() - start
    start = time.perf_counter()
    _, cached = get_terrain(config.terrain)
    cached_s = time.perf_counter() - start
    assert cached
    spec = compose_scene(config)
    start = time.perf_counter()
    scene = build_scene(spec)
    bvh_s = time.perf_counter() - start
    grown = rss_mb() - before
    _, render_s = view(config, spec, scene)
    v, t = terrain.mesh
    rock_triangles = sum(len(spec.meshes[key][1]) for key, _ in spec.rocks)
    craters = (
        len(Location(config.terrain, location_axis(config.terrain)).craters.diameters) if location != "dem" else None
    )
    return {
        "location": label or location,
        "triangles": int(len(t)),
        "vertices": int(len(v)),
        "rocks": len(spec.rocks),
        "rock_triangles": rock_triangles,
        "craters": craters,
        "build_s": build_s,
        "cached_s": cached_s,
        "bvh_s": bvh_s,
        "render_view_s": render_s,
        "mesh_mb": (v.nbytes + t.nbytes) / 2**20,
        "rss_growth_mb": grown,
    }


def growth_rows() -> list[dict]:
    rows, reference = [], None
    for growth in GROWTHS:
        clear_cache()
        gc.collect()
        config = load_config(None, {"terrain.location": "flat", "terrain.growth": growth, "orbit.height_m": 0.2})
        start = time.perf_counter()
        terrain, _ = get_terrain(config.terrain)
        spec = compose_scene(config)
        scene = build_scene(spec)
        out, render_s = view(config, spec, scene)
        total = time.perf_counter() - start
        depth = out.depth.astype(np.float64)
        row = {
            "growth": growth,
            "triangles": int(len(terrain.mesh[1])),
            "build_s": terrain.build_seconds,
            "build_bvh_render_s": total,
            "render_view_s": render_s,
        }
        if reference is None:
            reference = depth
        else:
            both = (depth > 0) & (reference > 0)
            rel = np.abs(depth[both] - reference[both]) / reference[both]
            row.update(
                {
                    "depth_rel_err_median": float(np.median(rel)),
                    "depth_rel_err_p99": float(np.percentile(rel, 99)),
                    "pixels_off_1pct": float(np.mean(rel > 0.01)),
                    "hit_mismatch": float(np.mean((depth > 0) != (reference > 0))),
                }
            )
        rows.append(row)
        del scene, spec, terrain
    return rows


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dem", type=Path, help="also measure this LocalDem (moonbot terrain import)")
    parser.add_argument(
        "--site",
        type=float,
        nargs=2,
        default=(0.0, 0.0),
        metavar=("E", "N"),
        help="its work site, metres east and north of its origin",
    )
    parser.add_argument("--extent", type=float, default=2000.0, help="terrain.extent_m for it, metres")
    args = parser.parse_args()
    result = {"schema_version": SCHEMA_VERSION, "machine": machine(), "locations": [], "growth": []}
    print(
        f"{'location':<12} {'triangles':>10} {'rocks':>6} {'build':>7} {'cached':>8} {'bvh':>6} {'render':>7} "
        f"{'mesh':>7} {'rss+':>7}"
    )
    with tempfile.TemporaryDirectory() as tmp:
        runs = [(name, {}, None) for name in ("flat", "hilly", "crater")]
        runs.append(("dem", {"terrain.dem_file": str(synthetic_dem(Path(tmp) / "hilly5m.npz"))}, "dem 5 m"))
        if args.dem is not None:
            runs.append(
                (
                    "dem",
                    {
                        "terrain.dem_file": str(args.dem),
                        "terrain.dem_site_m": list(args.site),
                        "terrain.extent_m": args.extent,
                    },
                    f"dem {args.dem.stem}",
                )
            )
        for location, overrides, label in runs:
            r = location_row(location, overrides, label)
            if location == "dem":
                dem = LocalDem.load(overrides["terrain.dem_file"])
                r.update(
                    {
                        "dem_nodes": list(dem.shape),
                        "dem_spacing_m": dem.spacing_m,
                        "dem_source": dem.source,
                        "extent_m": overrides.get("terrain.extent_m", 2000.0),
                        "site_m": overrides.get("terrain.dem_site_m", [0.0, 0.0]),
                    }
                )
            result["locations"].append(r)
            print(
                f"{r['location']:<12} {r['triangles']:>10} {r['rocks']:>6} {r['build_s']:>6.2f}s {1e6 * r['cached_s']:>6.1f}µs "
                f"{r['bvh_s']:>5.2f}s {1e3 * r['render_view_s']:>5.0f}ms {r['mesh_mb']:>5.0f}MB {r['rss_growth_mb']:>5.0f}MB"
            )
    print(f"\n{'growth':>6} {'triangles':>10} {'build+bvh+render':>17} {'|Δz|/z med':>11} {'p99':>8} {'>1 %':>7}")
    result["growth"] = growth_rows()
    for r in result["growth"]:
        err = (
            f"{r['depth_rel_err_median']:>11.2e} {r['depth_rel_err_p99']:>8.2e} {100 * r['pixels_off_1pct']:>6.2f}%"
            if "depth_rel_err_median" in r
            else f"{'reference':>11}"
        )
        print(f"{r['growth']:>6} {r['triangles']:>10} {r['build_bvh_render_s']:>16.2f}s {err}")
    curve = [(r["build_bvh_render_s"], r["depth_rel_err_p99"], f"{r['growth']}") for r in result["growth"][1:]]
    write_result_and_chart(
        result,
        "terrain",
        "Terrain grid growth: time against depth error",
        "",
        {"flat, growth": curve},
        "build + BVH + one view, s",
        "p99 |Δz|/z vs growth 1.01",
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
