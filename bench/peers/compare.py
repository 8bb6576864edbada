"""moonbot against Mitsuba 3 and Blender Cycles on the same scene, at equal image error.

One command:

  DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 \\
  .venv/bin/python bench/peers/compare.py [--width 640 --height 480] [--work /tmp/peers]

1. Exports moonbot's default scene with the parity settings (export_scene.py: Lambertian,
   flat shading, a point Sun of 1361 W/m², black sky, direct + 1 diffuse bounce).
2. The shared reference: Mitsuba (llvm_ad_rgb) at 2 × --reference-spp spp, two independent
   halves (distinct seeds). Their difference estimates the reference's own noise: each half's
   MSE about the mean is mean((h1 - h2)²)/2, the average's half that. Every image's squared
   error against the reference is its own squared error plus that variance (the two are
   independent), so the error reported is corrected: sqrt(max(0, MSE - var_ref)) / RMS(ref),
   "relative RMSE" of linear radiance over all pixels and channels (the raw figure is kept too).
3. moonbot (its core, `_core.render` with rgb + depth + instance passes, like render-one), Mitsuba
   (mitsuba_render.py) and Cycles (cycles_render.py, in its own venv) render the ladder of spp
   on --threads threads, one after the other on this machine; each renderer's time per frame is
   its render time alone (scene load and BVH build reported apart).
4. Each renderer's own reference too (--own-reference-spp, two halves each; Mitsuba's is the
   shared one), the references' differences from one another (noise removed), and every
   image's error against its own renderer's reference: its noise alone, whatever systematic
   difference separates the renderers' images (on the default scene Mitsuba's bounce light came
   out brighter than moonbot's and Cycles', which agree; bench/peers/README.md).
5. For each error target, the spp each renderer needs and the seconds that costs, by log-log
   interpolation between the ladder's points (none where the ladder does not bracket it); then
   seconds per sample at that error and the ratio to moonbot's seconds (> 1: moonbot faster).
   Mitsuba's frame with depth and object index adds its 1-spp `aov` pass; Cycles' passes are
   enabled in every render (its frame time includes them).
6. moonbot's quality levels (draft, default, high: adaptive refinement and the per-task light
   cache) on the same scene with the same light transport (render_moonbot_levels), their errors
   against both references, and the spp and seconds every ladder needs to reach each level's
   error: the new method against uniform sampling at equal error.

Writes bench/results/peers-<machine>.json, .svg (time against error, shared reference) and
-own-reference.svg (against each renderer's own reference), and tone-mapped PNG
previews of the reference, every renderer's highest-spp image and moonbot's default level to --work
(check them by eye).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))
from moonbot.charts import time_error_plot  # noqa: E402

from export_scene import PARITY_OVERRIDES, export_scene, parity_config, parity_spec  # noqa: E402
from fingerprint import machine, machine_slug  # noqa: E402
from ladder_errors import at_error, rel_errors  # noqa: E402

ROOT = HERE.parents[1]
RESULTS = HERE.parent / "results"
SCHEMA_VERSION = 1
LLVM19 = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"


def loadavg() -> float:
    return os.getloadavg()[0]


def render_moonbot(
    config,
    spec,
    ladder: list[int],
    threads: int,
    repeats: int,
    repeat_max_spp: int,
    out: Path,
    seed: int = 0,
    prefix: str = "",
) -> dict:
    """moonbot's core on the parity scene: build once, then the ladder (median of repeats up to
    repeat_max_spp after a warm-up; one render above)."""
    from moonbot import _core
    from moonbot.render import build_scene
    from moonbot.render.view import view_inputs

    start = time.perf_counter()
    scene = build_scene(spec, smooth_bags=False)
    build_s = time.perf_counter() - start
    view = view_inputs(config, spec, 0)
    camera, sun = view.camera, view.sun
    r = config.render

    def render(spp: int, seed: int):
        return _core.render(
            scene,
            camera,
            sun,
            _core.RenderSettings(
                spp=spp,
                seed=seed,
                threads=threads,
                exact_depth=r.exact_depth,
                light_samples=r.light_samples,
                bounces=r.bounces,
            ),
        )

    rows = []
    for spp in ladder:
        n = repeats if spp <= repeat_max_spp else 1
        if spp <= repeat_max_spp:
            render(spp, seed)
        times = []
        for k in range(n):
            result = render(spp, seed + 1 + k)
            times.append(result["seconds"])
        np.save(out / f"{prefix}rgb_spp{spp}.npy", result["rgb"])
        rows.append({"spp": spp, "render_s": statistics.median(times), "render_s_all": times})
        print(f"moonbot spp {spp:>5}: {rows[-1]['render_s']:.3f} s", flush=True)
    np.save(out / f"{prefix}depth.npy", result["depth"])
    np.save(out / f"{prefix}index.npy", result["instance"])
    from moonbot import __version__

    return {
        "renderer": "moonbot",
        "version": __version__,
        "threads": threads,
        "build_bvh_s": build_s,
        "passes": "rgb + depth + instance in every render (depth and instance from the pixel-centre ray)",
        "rows": rows,
    }


COMPARED_LEVELS = ("draft", "default", "high")  # moonbot's levels rendered beside the ladders


def render_moonbot_levels(width: int, height: int, spec, threads: int, repeats: int, out: Path) -> list[dict]:
    """moonbot's quality levels (moonbot/benchmark/levels.py: adaptive refinement and the
    per-task light cache) on the parity scene, the parity's light transport kept (one bounce, a
    point Sun: the level's render.bounces and light_samples give way to PARITY_OVERRIDES). Per
    level: one render with an empty light cache, which fills the nodes this view touches (what
    the view costs alone; `first_render_s`, wall seconds; `cache_fill_s`, the fill's
    thread-seconds summed over the render's threads), then `repeats` renders
    reading the filled cache (the view's cost inside a task whose cache is filled; `render_s`,
    the median). The cache's values do not depend on when they are filled, so every render of a
    level is the same image, saved as level_<name>_rgb.npy."""
    from moonbot.benchmark.levels import LEVELS
    from moonbot.render import build_scene
    from moonbot.render.view import build_light_cache, render_view, view_inputs

    scene = build_scene(spec, smooth_bags=False)
    rows = []
    for name in COMPARED_LEVELS:
        level = {k: v for k, v in LEVELS[name].overrides.items() if k not in PARITY_OVERRIDES}
        config = parity_config(width, height, {**level, "render.threads": threads})
        view = view_inputs(config, spec, 0)
        cache = build_light_cache(scene, config)
        first = render_view(scene, config, view.K, view.pose, config.seed, light_cache=cache)
        fill_s = cache.stats()["fill_seconds"] if cache is not None else 0.0
        times = []
        for _ in range(repeats):
            again = render_view(scene, config, view.K, view.pose, config.seed, light_cache=cache)
            times.append(again.stats["seconds"])
        if not np.array_equal(again.rgb, first.rgb):
            raise RuntimeError(f"level {name}: a render reading the filled cache differs from the first")
        np.save(out / f"level_{name}_rgb.npy", first.rgb)
        s = first.stats
        rows.append(
            {
                "level": name,
                "settings": level,
                "render_s": statistics.median(times),
                "render_s_all": times,
                "first_render_s": s["seconds"],
                "cache_fill_s": fill_s,
                "rays": s["camera_rays"] + s["shadow_rays"] + s["bounce_rays"],
                "refined_pixels": s["refined_pixels"],
            }
        )
        print(
            f"moonbot {name:>7}: {rows[-1]['render_s']:.3f} s (first {s['seconds']:.3f} s, fill {fill_s:.3f} s)",
            flush=True,
        )
    return rows


def run(cmd: list[str], env: dict | None = None) -> None:
    print("$ " + " ".join(cmd), flush=True)
    subprocess.run(cmd, check=True, env={**os.environ, **(env or {})})


def render_peer(
    python: str, script: str, work: Path, out: str, spp: str, *options: str, env: dict | None = None
) -> None:
    """Runs the peer renderer `script` (mitsuba_render.py or cycles_render.py, beside this file)
    under `python` on the scene exported to work/scene, writing into work/<out> at `spp` (sample
    counts, comma-separated), with its further command-line `options`."""
    run([python, str(HERE / script), str(work / "scene"), str(work / out), "--spp", spp, *options], env)


def half_options(threads: int, seed: int, prefix: str) -> tuple[str, ...]:
    """A peer renderer's options for one of the two independent halves of a reference: its
    threads, its seed and the prefix of its output files."""
    return ("--threads", str(threads), "--seed", str(seed), "--prefix", prefix)


def time_fit(rows: list[dict]) -> dict:
    """seconds = overhead + per_sample · spp, least squares on relative residuals over the
    ladder: on a shared, loaded machine one render can be slowed by others' work, and the fit's
    slope is steadier than any single point."""
    n = np.array([r["spp"] for r in rows], float)
    t = np.array([r["render_s"] for r in rows], float)
    A = np.column_stack([np.ones_like(n), n]) / t[:, None]
    (a, b), *_ = np.linalg.lstsq(A, np.ones_like(t), rcond=None)
    return {
        "overhead_s": float(a),
        "seconds_per_sample": float(b),
        "max_rel_residual": float(np.max(np.abs((a + b * n) / t - 1))),
    }


def tonemap_png(path: Path, images: list[np.ndarray], scale: float) -> None:
    from PIL import Image

    row = np.concatenate(images, axis=1).astype(np.float64) * scale
    Image.fromarray((np.clip(row / (1 + row), 0, 1) ** (1 / 2.2) * 255).astype(np.uint8)).save(path)


def equal_error_table(renderers: dict, targets: list[float], key: str) -> list[dict]:
    """Per error target, each renderer's spp and seconds at that error (its `key`: "at_error"
    against the shared reference, "at_error_own_reference" against its own) with the ratios of
    measured and fitted seconds to moonbot's; Mitsuba's also with its depth + index pass added."""
    table = []
    for t in targets:
        base = renderers["moonbot"].get(key, {}).get(str(t))
        entry = {"target_rel_rmse": t}
        for name, r in renderers.items():
            a = r.get(key, {}).get(str(t))
            entry[name] = a and {
                **a,
                "ratio_to_moonbot": (a["seconds_per_frame"] / base["seconds_per_frame"]) if base else None,
                "fit_ratio_to_moonbot": (a["fit_seconds_per_frame"] / base["fit_seconds_per_frame"]) if base else None,
            }
            if a and name == "mitsuba" and "aov_pass" in r:
                extra = r["aov_pass"]["render_s"]
                entry[name]["seconds_per_frame_with_depth_index"] = a["seconds_per_frame"] + extra
                entry[name]["ratio_to_moonbot_with_depth_index"] = (
                    ((a["seconds_per_frame"] + extra) / base["seconds_per_frame"]) if base else None
                )
        table.append(entry)
    return table


def print_equal_error(table: list[dict], renderers: dict) -> None:
    """One line per error target and renderer: spp, seconds per frame and per sample at that
    error, the ratio to moonbot, and the same from the time-against-spp fit."""
    for e in table:
        for n in renderers:
            a = e[n]
            if a:
                print(
                    f"{e['target_rel_rmse']:>7} {n:>8} {a['spp']:>7.1f} {a['seconds_per_frame']:>8.2f} {a['seconds_per_sample']:>9.4f} "
                    f"{a['ratio_to_moonbot'] or 0:>9.2f} {a['fit_seconds_per_frame']:>11.2f} {a['fit_ratio_to_moonbot'] or 0:>6.2f}"
                )
            else:
                print(f"{e['target_rel_rmse']:>7} {n:>8} {'not bracketed by the ladder':>40}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=480)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--ladder", default="1,2,4,8,16,32,64,128,256", help="spp of moonbot and Mitsuba")
    parser.add_argument("--cycles-ladder", default="1,2,4,8,16,32,64,128", help="spp of Cycles")
    parser.add_argument("--targets", default="0.1,0.05,0.03,0.02", help="relative RMSE targets")
    parser.add_argument("--reference-spp", type=int, default=512, help="spp of each of the reference's two halves")
    parser.add_argument(
        "--own-reference-spp",
        default="moonbot:256,cycles:128",
        help="each renderer's own reference too (two halves of this many spp; Mitsuba's is the shared one)",
    )
    parser.add_argument("--repeats", type=int, default=3, help="timed renders per spp up to --repeat-max-spp")
    parser.add_argument("--repeat-max-spp", type=int, default=16)
    parser.add_argument("--work", type=Path, default=Path("/tmp/peers"), help="scratch folder (export, images)")
    parser.add_argument(
        "--bpy-python", default=str(ROOT / ".venv-peers-bpy/bin/python"), help="the Python of the venv with bpy"
    )
    parser.add_argument("--skip", default="", help="comma-separated renderers to leave out: mitsuba, cycles")
    parser.add_argument(
        "--analyse-only",
        action="store_true",
        help="render nothing: analyse the images and timings.json files already in --work",
    )
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    skip = set(filter(None, args.skip.split(",")))
    ladder = [int(s) for s in args.ladder.split(",")]
    cycles_ladder = [int(s) for s in args.cycles_ladder.split(",")]
    targets = [float(s) for s in args.targets.split(",")]
    work = args.work
    for sub in ("scene", "moonbot", "mitsuba", "cycles", "reference"):
        (work / sub).mkdir(parents=True, exist_ok=True)
    env = {"DRJIT_LIBLLVM_PATH": os.environ.get("DRJIT_LIBLLVM_PATH", LLVM19)}
    common = [
        "--threads",
        str(args.threads),
        "--repeats",
        str(args.repeats),
        "--repeat-max-spp",
        str(args.repeat_max_spp),
    ]

    m = machine()
    result = {
        "schema_version": SCHEMA_VERSION,
        "benchmark": "peers",
        "machine": m,
        "load_average_1min": {"start": loadavg()},
    }
    config = parity_config(args.width, args.height)
    if args.analyse_only:
        spec, compose_s, export_s = None, None, None
        scene_json = json.loads((work / "scene" / "scene.json").read_text())
    else:
        start = time.perf_counter()
        spec = parity_spec(config)
        compose_s = time.perf_counter() - start
        start = time.perf_counter()
        scene_json = export_scene(work / "scene", config, spec)
        export_s = time.perf_counter() - start
    result["scene"] = {
        "width": args.width,
        "height": args.height,
        "triangles": scene_json["triangles_total"],
        "meshes": [{k: mm[k] for k in ("file", "kind", "triangles")} for mm in scene_json["meshes"]],
        "compose_s": compose_s,
        "export_s": export_s,
        "parity": scene_json["parity"],
        "config_overrides": scene_json["config_overrides"],
    }

    renderers = {}
    names = ["moonbot"] + [n for n in ("mitsuba", "cycles") if n not in skip]
    if args.analyse_only:
        renderers = {n: json.loads((work / n / "timings.json").read_text()) for n in names}
    else:
        py = sys.executable
        for name in names:
            before = loadavg()
            if name == "moonbot":
                r = render_moonbot(config, spec, ladder, args.threads, args.repeats, args.repeat_max_spp, work / name)
                r["levels"] = render_moonbot_levels(
                    args.width, args.height, spec, args.threads, args.repeats, work / name
                )
                (work / name / "timings.json").write_text(json.dumps(r, indent=2) + "\n")
            elif name == "mitsuba":
                render_peer(py, "mitsuba_render.py", work, name, ",".join(map(str, ladder)), *common, env=env)
            else:
                render_peer(args.bpy_python, "cycles_render.py", work, name, ",".join(map(str, cycles_ladder)), *common)
            renderers[name] = json.loads((work / name / "timings.json").read_text())
            renderers[name]["load_average_1min"] = {"before": before, "after": loadavg()}
            (work / name / "timings.json").write_text(json.dumps(renderers[name], indent=2) + "\n")

    # The reference last: the renderers' timings above are not taken right after an hour-long job.
    halves = []
    for k, seed in enumerate((100, 200)):
        prefix = f"half{k}_"
        if not (work / "reference" / f"{prefix}rgb_spp{args.reference_spp}.npy").exists():
            render_peer(
                sys.executable,
                "mitsuba_render.py",
                work,
                "reference",
                str(args.reference_spp),
                "--repeats",
                "0",
                *half_options(args.threads, seed, prefix),
                "--no-aov",
                env=env,
            )
        halves.append(np.load(work / "reference" / f"{prefix}rgb_spp{args.reference_spp}.npy").astype(np.float64))
    ref = (halves[0] + halves[1]) / 2
    var_ref = float(np.mean((halves[0] - halves[1]) ** 2)) / 4
    rms_ref = float(np.sqrt(np.mean(ref**2)))
    result["reference"] = {
        "renderer": "mitsuba llvm_ad_rgb",
        "spp": 2 * args.reference_spp,
        "halves_spp": args.reference_spp,
        "mean_w_m2_sr": float(ref.mean()),
        "rms_w_m2_sr": rms_ref,
        "own_rel_rmse_estimate": math.sqrt(var_ref) / rms_ref,
        "halves_rel_difference": float(np.sqrt(np.mean((halves[0] - halves[1]) ** 2))) / rms_ref,
        "error_correction": "rel_rmse = sqrt(max(0, MSE - var_ref)) / RMS(ref), var_ref = mean((h1-h2)^2)/4",
    }

    # Each renderer's own reference (two halves too): its error against it is its noise alone,
    # whatever systematic difference separates it from Mitsuba's image.
    own_spp = {k: int(v) for k, v in (item.split(":") for item in args.own_reference_spp.split(",") if item)}
    own = {"mitsuba": (halves, var_ref, args.reference_spp)}
    for name, spp in own_spp.items():
        if name not in renderers:
            continue
        own_halves = []
        for k, seed in enumerate((100, 200)):
            prefix = f"ownref{k}_"
            path = work / name / f"{prefix}rgb_spp{spp}.npy"
            if not path.exists():
                if name == "moonbot":
                    render_moonbot(
                        config,
                        spec or parity_spec(config),
                        [spp],
                        args.threads,
                        0,
                        0,
                        work / name,
                        seed=seed * 1000,
                        prefix=prefix,
                    )
                else:
                    render_peer(
                        args.bpy_python,
                        "cycles_render.py",
                        work,
                        name,
                        str(spp),
                        "--repeats",
                        "1",
                        "--repeat-max-spp",
                        "0",
                        *half_options(args.threads, seed, prefix),
                    )
            own_halves.append(np.load(path)[..., :3].astype(np.float64))
        own[name] = (own_halves, float(np.mean((own_halves[0] - own_halves[1]) ** 2)) / 4, spp)
    own_refs = {n: ((h[0] + h[1]) / 2, v, spp) for n, (h, v, spp) in own.items()}

    def block(x: np.ndarray, b: int = 8) -> np.ndarray:
        hh, ww = x.shape[0] // b * b, x.shape[1] // b * b
        return x[:hh, :ww].reshape(hh // b, b, ww // b, b, -1).mean(axis=(1, 3))

    cross = {}
    for a in own_refs:
        for b in own_refs:
            if a < b:
                ra, va, _ = own_refs[a]
                rb, vb, _ = own_refs[b]
                cross[f"{a} vs {b}"] = {
                    "rel_rmse": math.sqrt(max(0.0, float(np.mean((ra - rb) ** 2)) - va - vb)) / rms_ref,
                    "rel_rmse_raw": float(np.sqrt(np.mean((ra - rb) ** 2))) / rms_ref,
                    "rel_rmse_8x8_blocks": float(np.sqrt(np.mean((block(ra) - block(rb)) ** 2))) / rms_ref,
                    "mean_ratio": float(ra.mean() / rb.mean()),
                }
    result["own_references"] = {
        n: {"spp": 2 * spp, "own_rel_rmse_estimate": math.sqrt(v) / rms_ref} for n, (_, v, spp) in own_refs.items()
    }
    result["reference_cross_differences"] = cross

    curves, own_curves = {}, {}
    previews = [ref]
    for name, r in renderers.items():
        for row in r["rows"]:
            img = np.load(work / name / f"rgb_spp{row['spp']}.npy")[..., :3]
            row.update(rel_errors(img, ref, var_ref))
            if name in own_refs:
                o = rel_errors(img, own_refs[name][0], own_refs[name][1])
                row.update({"own_ref_rel_rmse": o["rel_rmse"], "own_ref_rel_rmse_raw": o["rel_rmse_raw"]})
        previews.append(np.load(work / name / f"rgb_spp{r['rows'][-1]['spp']}.npy")[..., :3])
        label = {
            "moonbot": "moonbot (Embree 3, own tracer)",
            "mitsuba": f"Mitsuba {r.get('version')} {r.get('variant')}",
            "cycles": f"Blender Cycles {r.get('version')} (bpy)",
        }[name]
        curves[label] = [(row["render_s"], row["rel_rmse"], str(row["spp"])) for row in r["rows"]]
        r["at_error"] = {str(t): at_error(r["rows"], t) for t in targets}
        if name in own_refs:
            own_rows = [{**row, "rel_rmse": row["own_ref_rel_rmse"]} for row in r["rows"]]
            r["at_error_own_reference"] = {str(t): at_error(own_rows, t) for t in targets}
            own_curves[label] = [(row["render_s"], row["own_ref_rel_rmse"], str(row["spp"])) for row in r["rows"]]
        r["time_fit"] = fit = time_fit(r["rows"])
        for key in ("at_error", "at_error_own_reference"):
            for a in r.get(key, {}).values():
                if a:
                    a["fit_seconds_per_frame"] = fit["overhead_s"] + fit["seconds_per_sample"] * a["spp"]
    levels = renderers["moonbot"].get("levels", [])
    for row in levels:
        img = np.load(work / "moonbot" / f"level_{row['level']}_rgb.npy")[..., :3]
        if row["level"] == "default":
            previews.append(img)
        row.update(rel_errors(img, ref, var_ref))
        if "moonbot" in own_refs:
            o = rel_errors(img, own_refs["moonbot"][0], own_refs["moonbot"][1])
            row.update({"own_ref_rel_rmse": o["rel_rmse"], "own_ref_rel_rmse_raw": o["rel_rmse_raw"]})
        print(
            f"moonbot level {row['level']:>7}: {row['render_s']:.3f} s a frame (alone {row['first_render_s']:.3f} s), "
            f"rel. RMSE {row['rel_rmse']:.4f} (own reference {row.get('own_ref_rel_rmse', float('nan')):.4f})"
        )
    # Every ladder (moonbot's path tracer, Mitsuba, Cycles) at each level's error: what the same
    # error costs by uniform sampling, against the shared reference and against each one's own.
    for row in levels:
        row["ladders_at_level_error"] = {}
        row["ladders_at_level_error_own_reference"] = {}
        for name, r in renderers.items():
            row["ladders_at_level_error"][name] = at_error(r["rows"], row["rel_rmse"])
            if "own_ref_rel_rmse" in row and all("own_ref_rel_rmse" in x for x in r["rows"]):
                own_rows = [{**x, "rel_rmse": x["own_ref_rel_rmse"]} for x in r["rows"]]
                row["ladders_at_level_error_own_reference"][name] = at_error(own_rows, row["own_ref_rel_rmse"])
        for name, a in row["ladders_at_level_error_own_reference"].items():
            if a:
                print(
                    f"  {name} at {row['level']}'s error (own references): {a['spp']:.1f} spp, "
                    f"{a['seconds_per_frame']:.2f} s ({a['seconds_per_frame'] / row['render_s']:.1f}x)"
                )
    if levels:
        label = "moonbot levels (adaptive + light cache)"
        curves[label] = [(row["render_s"], row["rel_rmse"], row["level"]) for row in levels]
        if "moonbot" in own_refs:
            own_curves[label] = [(row["render_s"], row["own_ref_rel_rmse"], row["level"]) for row in levels]
    table = equal_error_table(renderers, targets, "at_error")
    own_table = equal_error_table(renderers, targets, "at_error_own_reference")
    result["renderers"] = renderers
    result["equal_error"] = table
    result["equal_error_own_reference"] = own_table

    # Depth and object index against moonbot's (pixel centres there; Mitsuba's 1-spp AOV pass is
    # jittered within the pixel, so edges differ).
    checks = {}
    mb_depth, mb_index = np.load(work / "moonbot" / "depth.npy"), np.load(work / "moonbot" / "index.npy")
    for name in ("mitsuba", "cycles"):
        if name in renderers and (work / name / "depth.npy").exists():
            d, i = np.load(work / name / "depth.npy"), np.load(work / name / "index.npy")
            both = (d > 0) & (mb_depth > 0)
            rel = np.abs(d[both] - mb_depth[both]) / mb_depth[both]
            checks[name] = {
                "depth_median_rel_diff": float(np.median(rel)),
                "depth_p90_rel_diff": float(np.percentile(rel, 90)),
                "hit_agreement": float(np.mean((d > 0) == (mb_depth > 0))),
                "index_agreement": float(np.mean(i == mb_index)),
                "bag_pixels": {"moonbot": int(np.sum(mb_index > 0)), name: int(np.sum(i > 0))},
            }
    result["depth_index_check"] = checks
    result["load_average_1min"]["end"] = loadavg()

    scale = 0.3 / float(ref.mean())
    tonemap_png(work / "previews.png", previews, scale)
    slug = machine_slug(m)
    out = args.out or RESULTS / f"peers-{slug}.json"
    result["previews"] = (
        f"{work / 'previews.png'}: reference, then each renderer's highest spp ({', '.join(renderers)})"
        + (", then moonbot's default level" if any(row["level"] == "default" for row in levels) else "")
    )
    out.write_text(json.dumps(result, indent=2) + "\n")
    time_error_plot(
        out.with_name(out.stem + "-own-reference.svg"),
        f"Same scene, {args.width}x{args.height}, "
        f"{args.threads} threads: render time vs error against each renderer's own reference",
        own_curves,
        x_label="seconds per frame (render only)",
        y_label="relative RMSE of linear radiance",
    )
    time_error_plot(
        out.with_suffix(".svg"),
        f"Same scene, {args.width}x{args.height}, {args.threads} threads: "
        "render time vs error against a shared reference",
        curves,
        x_label="seconds per frame (render only)",
        y_label="relative RMSE of linear radiance",
    )

    print(
        f"\nreference: Mitsuba {2 * args.reference_spp} spp, own rel. RMSE ≈ {result['reference']['own_rel_rmse_estimate']:.4f}"
    )
    for name, r in renderers.items():
        print(
            f"{name}: " + "  ".join(f"{row['spp']}:{row['render_s']:.2f}s/{row['rel_rmse']:.4f}" for row in r["rows"])
        )
    for n, r in renderers.items():
        f = r["time_fit"]
        print(
            f"{n}: time fit {f['overhead_s']:.3f} s + {f['seconds_per_sample']:.4f} s/spp (worst point off by {f['max_rel_residual']:.0%})"
        )
    print(
        f"\n{'target':>7} {'renderer':>8} {'spp':>7} {'s/frame':>8} {'s/sample':>9} {'x moonbot':>9} {'fit s/frame':>11} {'fit x':>6}"
    )
    print_equal_error(table, renderers)
    print("\nagainst each renderer's own reference; cross differences of the references:")
    for k, c in cross.items():
        print(
            f"  {k}: rel RMSE {c['rel_rmse']:.4f} (raw {c['rel_rmse_raw']:.4f}, 8x8 blocks {c['rel_rmse_8x8_blocks']:.4f}), mean ratio {c['mean_ratio']:.4f}"
        )
    print_equal_error(own_table, renderers)
    print(f"\nwritten {out} and {out.with_suffix('.svg')}; previews {work / 'previews.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
