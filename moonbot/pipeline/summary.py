"""A one-screen, human-readable summary of rendered views."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from moonbot.config import Config
from moonbot.pipeline.views import ViewResult
from moonbot.render import resolve_exposure
from moonbot.writer import AMODAL_FILE


def format_summary(config: Config, results: list[ViewResult], sheet: Path | None = None) -> str:
    """Scene, per-view stage timings in milliseconds and visible pixels, and where the files are."""
    c = config
    lines = [
        f"scene   {c.terrain.location} terrain, {c.bags.count} × {c.bags.mesh}, "
        f"Sun az {c.sun.azimuth_deg:g}° el {c.sun.elevation_deg:g}°",
        "terrain "
        + (
            f"built in {results[0].timings['terrain']:.2f} s"
            if results and results[0].timings["terrain"] > 0
            else "from this process's cache"
        ),
        f"camera  {c.camera.width}×{c.camera.height}, hfov {c.camera.hfov_deg:g}°, orbit r "
        f"{c.orbit.radius_m:g} m h {c.orbit.height_m:g} m, {c.render.spp} spp, "
        f"EV100 {resolve_exposure(c).ev100:.2f}" + (" (auto)" if c.tonemap.ev100 == "auto" else ""),
        "bags    "
        + (
            f"{c.bags.layout}, settled under {c.bags.settle.gravity_m_s2:g} m/s² in "
            f"{1e3 * results[0].timings['settle']:.1f} ms"
            if results and "settle" in results[0].timings
            else f"{c.bags.layout}, at geometric rest (not settled)"
        ),
    ]
    if results and results[0].dust is not None:  # only a dust scene has a dust stage
        d, times = results[0].dust, [r.dust["capture_time_s"] for r in results]
        lines.append(
            f"dust    {d['fragments']} ejecta fragments, {d['puffs']} cloud puffs (view {results[0].view}), "
            f"captured at {min(times):g}–{max(times):g} s, "
            f"{1e3 * float(np.median([r.timings['dust'] for r in results])):.1f} ms a view (median)"
        )
    lines += [
        "",
        f"{'view':>4} {'az°':>6} {'compose':>8} {'bvh':>7} {'render':>7} {'tonemap':>8} "
        f"{'encode':>7} {'Mrays/s':>8}  visible px (id: px)",
    ]
    rows = [_row(c, r) for r in results]
    if len(rows) > 8:  # one screen: the first views, then the median and the total
        stages = ("compose", "build_bvh", "render", "tonemap", "encode_write")
        median = {k: float(np.median([r.timings[k] for r in results])) for k in stages}
        total = sum(sum(r.timings[k] for k in stages) for r in results)
        pixels = [p for r in results for p in r.instance_pixels.values()]
        rows = rows[:3] + [
            f"{'…':>4}",
            f"{'med':>4} {'':>6} " + _stage_cells(median) + f"  views {len(results)}, {total:.2f} s of stages in all, "
            f"visible px {min(pixels)}–{max(pixels)}",
        ]
    lines += rows
    lines += ["", "files   " + (str(results[0].out_dir.parent) if results else "(none)")]
    names = (
        ("rgb.png",)
        + (("rgb.exr",) if c.output.exr else ())
        + ("depth.npy", "depth.png", "depth_preview.png", "mask.png")
    )
    for name in names:
        lines.append(f"        view_NNN/{name}")
    lines.append(
        "        view_NNN/"
        + AMODAL_FILE.format(instance_id=0).replace("000", "NNN")
        + " (instance NNN alone, occluders ignored: BOP's mask/)"
    )
    lines.append("        view_NNN/gt.json")
    if sheet is not None:
        lines.append(f"        {sheet.name} (rgb | depth | mask per view, labelled)")
    return "\n".join(lines)


def _stage_cells(t: dict) -> str:
    return (
        f"{1e3 * t['compose']:>6.1f}ms {1e3 * t['build_bvh']:>5.1f}ms {1e3 * t['render']:>5.1f}ms "
        f"{1e3 * t['tonemap']:>6.1f}ms {1e3 * t['encode_write']:>5.1f}ms"
    )


def _row(c: Config, r: ViewResult) -> str:
    rays = r.rays["camera_rays"] + r.rays["shadow_rays"]
    mrays = rays / r.timings["render"] / 1e6 if r.timings["render"] > 0 else float("nan")
    azimuth = c.orbit.start_azimuth_deg + r.view * c.orbit.step_deg
    pixels = ", ".join(f"{k}: {v}" for k, v in r.instance_pixels.items())
    return f"{r.view:>4} {azimuth:>6.1f} {_stage_cells(r.timings)} {mrays:>8.2f}  {pixels}"
