"""Exports moonbot's embedded default scene once, for rendering by other renderers .

moonbot's own code composes the scene (`compose_scene`: the default `flat` location's terrain,
the settled bag, the rocks left after clearing the site) and places the camera of orbit view 0
(`moonbot.render.view.orbit_view`) exactly as `moonbot render-one` does. This writes:

  terrain.ply   the terrain mesh in world metres (float32 x, y, z) with per-vertex float32
                albedo_r, albedo_g, albedo_b: terrain.albedo × moonbot's per-vertex albedo factor
  rocks.ply     every rock instance already transformed into the world, merged (uniform albedo)
  bag_NNN.ply   each bag instance NNN already transformed into the world (uniform albedo)
  scene.json    camera (centre, world-to-camera R and t in OpenCV axes, look-at, K, fov,
                resolution), the Sun as a distant directional light (unit direction toward the
                Sun, irradiance in W/m² on a plane facing it), materials, meshes with triangle
                counts and bounds, the parity settings below, and units

Parity: what all three renderers (moonbot, Mitsuba 3, Blender Cycles) are set to render, and
what that changes from moonbot's default scene (`PARITY_OVERRIDES`, `PARITY`):
  * BRDF: plain Lambertian everywhere, albedo/π (terrain.photometry.model = lambert instead of
    lunar-lambert; no regolith grain: terrain.photometry.grain's albedo_rms and slope_rms_deg 0,
    and no subgrid relief or craters: terrain.roughness.subgrid_shading and
    terrain.craters.subgrid_shading false;
    the bags' woven fabric with relief_m = 0, contrast = 0 and sheen = 0, which moonbot's fabric
    evaluates to the plain bag albedo and the geometric normal; no stain: seeds = 0).
  * Normals: flat (geometric) shading everywhere. moonbot's terrain and bags normally shade with
    smooth per-vertex normals; each renderer treats a shading normal differently (moonbot
    samples the bounce about the geometric normal, Mitsuba's diffuse BSDF is black where the
    camera sees a facet past its shading normal's horizon, Cycles bends such normals), so they
    are left out of the export and of moonbot's scene (parity_spec drops the terrain's;
    build_scene(..., smooth_bags=False) the bags'), and the images can agree.
  * Albedos: terrain 0.12 × per-vertex factor (0.85–1.16, interpolated across each triangle),
    rocks 0.12, bag (0.55, 0.45, 0.32), linear RGB. Two-sided (a back face reflects like a front).
  * Light: the Sun only, a distant directional light (angular diameter 0: hard shadows, so one
    shadow ray per vertex; sun.angular_diameter_deg = 0, render.light_samples = 1) of irradiance
    1361 W/m² (RGB 1, 1, 1), no Earthshine, black sky (nothing is lit from the background).
  * Light transport: direct sunlight at the first hit plus one diffuse bounce with its own Sun
    shadow ray (render.bounces = 1; Mitsuba path max_depth = 3; Cycles max/diffuse bounces 1).
  * Camera: pinhole, square pixels, principal point at the image centre, box pixel filter of one
    pixel (uniform jitter within the pixel), linear radiance in W/(m²·sr), no tone map.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
from pathlib import Path

import numpy as np

from moonbot import __version__
from moonbot.config import load_config
from moonbot.config.schema import Config
from moonbot.render.view import orbit_view, regolith, scene_lights
from moonbot.scene import SceneSpec, compose_scene
from moonbot.scene.compose import TERRAIN_MESH

sys.path.insert(0, str(Path(__file__).resolve().parent))
from ply import write_ply  # noqa: E402  (bench/peers/ is not a package: the Cycles venv runs these as scripts)

SCHEMA_VERSION = 1
# The config changes that make moonbot render what the peers can render alike (module docstring).
PARITY_OVERRIDES = {
    "terrain.photometry.model": "lambert",
    "bags.fabric.relief_m": 0.0,
    "bags.fabric.contrast": 0.0,
    "bags.stain.seeds": 0,
    "sun.angular_diameter_deg": 0.0,
    "sun.earthshine": False,
    "render.light_samples": 1,
    "render.bounces": 1,
    "terrain.photometry.grain.albedo_rms": 0.0,  # no granular micro-texture (0 and 0: off)
    "terrain.photometry.grain.slope_rms_deg": 0.0,
    "terrain.roughness.subgrid_shading": False,  # no bump for the relief the mesh does not hold
    "terrain.craters.subgrid_shading": False,  # nor shadows of the craters it does not draw
    "bags.fabric.sheen": 0.0,  # matte tapes
}
PARITY = {
    "brdf": "Lambertian albedo/pi, two-sided, on every surface",
    "normals": "geometric (flat) shading everywhere; moonbot's smooth terrain and bag normals are left out",
    "light": "the Sun only: distant directional light, angular diameter 0 (hard shadows), "
    "irradiance sun.irradiance_w_m2 on a plane facing it, RGB (1, 1, 1); no Earthshine",
    "sky": "black: nothing is lit from the background",
    "bounces": "direct sunlight at the first hit + 1 diffuse bounce with its Sun shadow ray "
    "(moonbot render.bounces=1, Mitsuba path max_depth=3, Cycles max_bounces=diffuse_bounces=1)",
    "pixel_filter": "box, one pixel wide (uniform jitter within the pixel)",
    "output": "linear radiance W/(m^2 sr), float32, no tone map",
    "camera": "pinhole, square pixels, principal point at the image centre",
}
UNITS = {
    "length": "m",
    "irradiance": "W/m^2",
    "radiance": "W/(m^2 sr)",
    "angle": "deg",
    "albedo": "linear RGB reflectance (Lambertian, BRDF = albedo/pi)",
    "camera_axes": "OpenCV: x right, y down, z forward; x_cam = R @ x_world + t",
    "world_axes": "East-North-Up",
}


def parity_config(width: int = 640, height: int = 480, overrides: dict | None = None) -> Config:
    """The embedded default config with PARITY_OVERRIDES, at width × height, plus `overrides`."""
    return load_config(
        overrides={**PARITY_OVERRIDES, "camera.width": width, "camera.height": height, **(overrides or {})}
    )


def parity_spec(config: Config) -> SceneSpec:
    """moonbot's scene for the config, without the terrain's smooth shading normals (parity)."""
    return dataclasses.replace(compose_scene(config), terrain_normals=None)


def _bounds(vertices: np.ndarray) -> list[list[float]]:
    return [np.asarray(vertices, np.float64).min(0).tolist(), np.asarray(vertices, np.float64).max(0).tolist()]


def _to_world(world_from_model: np.ndarray, vertices: np.ndarray) -> np.ndarray:
    m = np.asarray(world_from_model, np.float64)
    return (np.asarray(vertices, np.float64) @ m[:3, :3].T + m[:3, 3]).astype(np.float32)


def export_scene(out: Path, config: Config, spec: SceneSpec, view: int = 0) -> dict:
    """Writes the PLYs and scene.json of `spec` seen from orbit view `view` into `out`; returns
    the scene.json content."""
    out.mkdir(parents=True, exist_ok=True)
    meshes = []
    _, regolith_albedo = regolith(spec.terrain_photometry, spec.terrain_albedo)
    if spec.terrain_photometry.model != "lambert":
        raise ValueError("export: the peers render Lambertian surfaces only (terrain.photometry.model=lambert)")

    vertices, triangles = spec.meshes[TERRAIN_MESH]
    scale = (
        np.ones(len(vertices), np.float32)
        if spec.terrain_albedo_scale is None
        else np.asarray(spec.terrain_albedo_scale, np.float32)
    )
    albedo = {f"albedo_{c}": (regolith_albedo[k] * scale).astype(np.float32) for k, c in enumerate("rgb")}
    write_ply(out / "terrain.ply", vertices, triangles, albedo, comment="moonbot terrain, world metres")
    meshes.append(
        {
            "file": "terrain.ply",
            "kind": "terrain",
            "instance_id": 0,
            "albedo": "per vertex: albedo_r, albedo_g, albedo_b",
            "albedo_base": list(regolith_albedo),
            "albedo_factor_range": [float(scale.min()), float(scale.max())],
            "vertices": len(vertices),
            "triangles": len(triangles),
            "bounds_m": _bounds(vertices),
        }
    )

    if spec.rocks:
        parts_v, parts_t, offset = [], [], 0
        for key, pose in spec.rocks:
            v, t = spec.meshes[key]
            parts_v.append(_to_world(pose, v))
            parts_t.append(np.asarray(t, np.int64) + offset)
            offset += len(v)
        rv, rt = np.concatenate(parts_v), np.concatenate(parts_t).astype(np.int32)
        write_ply(out / "rocks.ply", rv, rt, comment=f"moonbot rocks: {len(spec.rocks)} instances, world metres")
        meshes.append(
            {
                "file": "rocks.ply",
                "kind": "rocks",
                "instance_id": 0,
                "instances": len(spec.rocks),
                "albedo": list(regolith_albedo),
                "vertices": len(rv),
                "triangles": len(rt),
                "bounds_m": _bounds(rv),
            }
        )

    for bag in spec.bags:
        v, t = spec.meshes[bag.obj_id]
        bv = _to_world(bag.world_from_model, v)
        name = f"bag_{bag.instance_id:03d}.ply"
        write_ply(
            out / name, bv, t, comment=f"moonbot bag instance {bag.instance_id} (obj_id {bag.obj_id}), world metres"
        )
        meshes.append(
            {
                "file": name,
                "kind": "bag",
                "instance_id": bag.instance_id,
                "obj_id": bag.obj_id,
                "albedo": list(bag.albedo),
                "world_from_model": np.asarray(bag.world_from_model).tolist(),
                "vertices": len(bv),
                "triangles": len(t),
                "bounds_m": _bounds(bv),
            }
        )

    K, pose = orbit_view(config, spec, view)
    w, h = config.camera.width, config.camera.height
    center = pose.center
    forward, down = pose.R[2], pose.R[1]
    s = config.sun
    sun, _ = scene_lights(config)
    scene = {
        "schema_version": SCHEMA_VERSION,
        "source": f"moonbot {__version__}: embedded default config + parity overrides, orbit view {view}",
        "config_overrides": {**PARITY_OVERRIDES, "camera.width": w, "camera.height": h},
        "units": UNITS,
        "parity": PARITY,
        "camera": {
            "width": w,
            "height": h,
            "K": K.tolist(),
            "fx": K[0, 0],
            "fy": K[1, 1],
            "cx": K[0, 2],
            "cy": K[1, 2],
            "hfov_deg": math.degrees(2 * math.atan(w / 2 / K[0, 0])),
            "vfov_deg": math.degrees(2 * math.atan(h / 2 / K[1, 1])),
            "position_m": center.tolist(),
            "R_world_to_cam": pose.R.tolist(),
            "t_world_to_cam_m": pose.t.tolist(),
            "forward": forward.tolist(),
            "up": (-down).tolist(),
            "right": pose.R[0].tolist(),
            "look_at_m": spec.target.tolist(),
            "depth": "z-depth along the optical axis, metres, 0 where nothing is hit",
        },
        "sun": {
            "type": "directional",
            "direction_to_sun": np.asarray(sun.direction).tolist(),
            "azimuth_deg": s.azimuth_deg,
            "elevation_deg": s.elevation_deg,
            "irradiance_w_m2": s.irradiance_w_m2,
            "rgb": [1.0, 1.0, 1.0],
            "angular_diameter_deg": 0.0,
        },
        "sky": {"radiance_w_m2_sr": 0.0},
        "integrator": {
            "bounces": config.render.bounces,
            "light_samples": config.render.light_samples,
            "max_path_vertices_mitsuba_max_depth": config.render.bounces + 2,
        },
        "meshes": meshes,
        "triangles_total": sum(m["triangles"] for m in meshes),
    }
    (out / "scene.json").write_text(json.dumps(scene, indent=2) + "\n")
    return scene


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", type=Path, help="folder to write the PLYs and scene.json into")
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=480)
    parser.add_argument("--view", type=int, default=0)
    args = parser.parse_args()
    config = parity_config(args.width, args.height)
    scene = export_scene(args.out, config, parity_spec(config), args.view)
    print(f"wrote {args.out}: {scene['triangles_total']} triangles in {len(scene['meshes'])} meshes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
