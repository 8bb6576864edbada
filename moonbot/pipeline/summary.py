"""A one-screen, human-readable summary of rendered views."""

from __future__ import annotations

from moonbot.config import Config
from moonbot.pipeline.views import ViewResult


def format_summary(config: Config, results: list[ViewResult]) -> str:
    """Scene, per-view stage timings in milliseconds and visible pixels, and where the files are."""
    c = config
    lines = [
        f"scene   {c.terrain.kind} terrain, {c.bags.count} bag(s) {c.bags.size_m} m, "
        f"Sun az {c.sun.azimuth_deg:g}° el {c.sun.elevation_deg:g}°",
        f"camera  {c.camera.width}×{c.camera.height}, hfov {c.camera.hfov_deg:g}°, orbit r "
        f"{c.orbit.radius_m:g} m h {c.orbit.height_m:g} m, {c.render.spp} spp",
        "",
        f"{'view':>4} {'az°':>6} {'compose':>8} {'bvh':>7} {'render':>7} {'tonemap':>8} "
        f"{'encode':>7} {'Mrays/s':>8}  visible px (id: px)",
    ]
    for r in results:
        t = r.timings
        rays = r.rays["camera_rays"] + r.rays["shadow_rays"]
        mrays = rays / t["render"] / 1e6 if t["render"] > 0 else float("nan")
        azimuth = c.orbit.start_azimuth_deg + r.view * c.orbit.step_deg
        pixels = ", ".join(f"{k}: {v}" for k, v in r.instance_pixels.items())
        lines.append(
            f"{r.view:>4} {azimuth:>6.1f} {1e3 * t['compose']:>6.1f}ms {1e3 * t['build_bvh']:>5.1f}ms "
            f"{1e3 * t['render']:>5.1f}ms {1e3 * t['tonemap']:>6.1f}ms {1e3 * t['encode_write']:>5.1f}ms "
            f"{mrays:>8.2f}  {pixels}")
    lines += ["", "files   " + (str(results[0].out_dir.parent) if results else "(none)")]
    for name in ("rgb.png", "depth.npy", "depth.png", "depth_preview.png", "mask.png", "gt.json"):
        lines.append(f"        view_NNN/{name}")
    return "\n".join(lines)
