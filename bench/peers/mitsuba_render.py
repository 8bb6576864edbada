"""Renders a bench/peers export with Mitsuba 3 (pip `mitsuba`; a CPU or CUDA variant) at a list of spp.

Run as a script in a venv with `mitsuba` (the main .venv with the `peers` extra):

  DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 \\
  .venv/bin/python bench/peers/mitsuba_render.py SCENE_DIR OUT_DIR --spp 1,4,16 [--threads 2]

Scene (the parity settings of export_scene.py): each PLY becomes an `mi.Mesh` built from the
arrays (flat shading: no vertex normals), with a `twosided` `diffuse` BSDF — the terrain's albedo
a `mesh_attribute` texture of its per-vertex albedo, the others constant RGB; the Sun a
`directional` emitter of irradiance E (RGB E, E, E: Mitsuba's rgb variants take the value as is);
no environment emitter (black sky); a `perspective` sensor with the export's horizontal fov
and pose, an `hdrfilm` of float32 linear RGB with a `box` filter; the `path` integrator with
max_depth = bounces + 2 (camera→first hit→bounce vertex, each with emitter sampling; a delta
light is never hit by BSDF sampling, so MIS changes nothing), Russian roulette past the depths
used, and Mitsuba's default `independent` sampler.

Timing: `load_s` is building the meshes and `mi.load_dict` (BVH); every spp up to
--repeat-max-spp is rendered once untimed (JIT compilation of its kernels), then `--repeats`
times, each timed from `mi.render` until the image is in a numpy array, median reported; a
larger spp is rendered once, timed. A frame of more than --chunk spp is rendered in chunks
(distinct seeds, averaged): one render's wavefront is width × height × spp lanes. Depth and object index: a separate `aov` integrator pass (depth, shape_index) at
1 spp, timed the same way (Mitsuba's AOVs per sample would multiply the RGB render's cost: docs/design.md). Mitsuba's depth is the distance along the ray; it
is written as z-depth (× the cosine to the optical axis at the pixel centre).

Writes OUT_DIR/rgb_sppN.npy (H, W, 3) float32, depth.npy (H, W) float32 z metres (0 = no hit),
index.npy (H, W) uint8 instance ids (0 = terrain/rocks/sky), timings.json.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from ply import read_ply  # noqa: E402


def build_scene(mi, scene_dir: Path, scene: dict) -> tuple:
    """(Mitsuba scene dict, instance id per shape key). Meshes from the PLY arrays."""
    d: dict = {"type": "scene"}
    ids = {}
    for k, m in enumerate(scene["meshes"]):
        v, t, extra = read_ply(scene_dir / m["file"])
        name = Path(m["file"]).stem
        if "albedo_r" in extra:
            reflectance = {"type": "mesh_attribute", "name": "vertex_albedo"}
        else:
            reflectance = {"type": "rgb", "value": [float(c) for c in m["albedo"]]}
        props = mi.Properties()
        props["bsdf"] = mi.load_dict({"type": "twosided", "material": {"type": "diffuse", "reflectance": reflectance}})
        mesh = mi.Mesh(name, len(v), len(t), props=props)
        params = mi.traverse(mesh)
        params["vertex_positions"] = mi.Float(np.ascontiguousarray(v, np.float32).ravel())
        params["faces"] = mi.UInt32(np.ascontiguousarray(t, np.uint32).ravel())
        if "albedo_r" in extra:
            albedo = np.column_stack([extra["albedo_r"], extra["albedo_g"], extra["albedo_b"]]).astype(np.float32)
            mesh.add_attribute("vertex_albedo", 3, mi.Float(albedo.ravel()))
        params.update()
        d[f"shape_{k:02d}_{name}"] = mesh
        ids[name] = int(m["instance_id"])
    cam = scene["camera"]
    pos, fwd, up = (np.array(cam[k], float) for k in ("position_m", "forward", "up"))
    # Mitsuba's look_at puts the image's +x at cross(up, forward): from the camera looking
    # along `forward` with `up` up, that is the viewer's left for a right-handed frame, and
    # Mitsuba's perspective sensor maps +x to the left of the image, so the image comes out as
    # seen. (Verified against moonbot's own render of the same export: previews agree.)
    d["sensor"] = {
        "type": "perspective",
        "fov": cam["hfov_deg"],
        "fov_axis": "x",
        "near_clip": 1e-3,
        "far_clip": 1e5,
        "to_world": mi.ScalarTransform4f().look_at(origin=pos.tolist(), target=(pos + fwd).tolist(), up=up.tolist()),
        "film": {
            "type": "hdrfilm",
            "width": cam["width"],
            "height": cam["height"],
            "pixel_format": "rgb",
            "component_format": "float32",
            "rfilter": {"type": "box"},
            "sample_border": False,
        },
        "sampler": {"type": "independent", "sample_count": 1},
    }
    sun = scene["sun"]
    e = float(sun["irradiance_w_m2"])
    d["sun"] = {
        "type": "directional",
        "direction": (-np.array(sun["direction_to_sun"])).tolist(),
        "irradiance": {"type": "rgb", "value": [e * c for c in sun["rgb"]]},
    }
    depth = scene["integrator"]["max_path_vertices_mitsuba_max_depth"]
    path = {"type": "path", "max_depth": depth, "rr_depth": depth + 1, "hide_emitters": True}
    d["integrator"] = path
    return d, ids


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene_dir", type=Path)
    parser.add_argument("out_dir", type=Path)
    parser.add_argument("--spp", default="1,4,16", help="comma-separated samples per pixel")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--variant", default="llvm_ad_rgb")
    parser.add_argument("--repeats", type=int, default=3, help="timed renders per spp (median); 0: one untimed")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--repeat-max-spp", type=int, default=16, help="spp above this get one timed render and no warm-up"
    )
    parser.add_argument("--chunk", type=int, default=64, help="render at most this many spp at once")
    parser.add_argument("--prefix", default="", help="prefix of the output files (e.g. a reference's)")
    parser.add_argument("--no-aov", action="store_true", help="skip the depth + shape_index pass")
    args = parser.parse_args()

    import drjit as dr
    import mitsuba as mi

    mi.set_variant(args.variant)
    mi.set_log_level(mi.LogLevel.Warn)
    if args.variant.startswith(("llvm", "cuda")):
        dr.set_thread_count(args.threads)
    # Scalar variants render on Mitsuba's own thread pool.
    mi.Thread.thread().set_thread_count(args.threads) if hasattr(mi.Thread, "set_thread_count") else None

    scene_json = json.loads((args.scene_dir / "scene.json").read_text())
    args.out_dir.mkdir(parents=True, exist_ok=True)
    spps = [int(s) for s in args.spp.split(",") if s]

    start = time.perf_counter()
    d, ids = build_scene(mi, args.scene_dir, scene_json)
    scene = mi.load_dict(d)
    load_s = time.perf_counter() - start

    def render(spp: int, seed: int, integrator=None):
        """One frame at `spp`, as renders of at most --chunk spp with distinct seeds, averaged
        (bounds the JIT variants' wavefront: width × height × spp lanes)."""
        chunks = [min(args.chunk, spp - k) for k in range(0, spp, args.chunk)]
        t0 = time.perf_counter()
        acc = None
        for c, n in enumerate(chunks):
            img = np.array(mi.render(scene, spp=n, seed=seed * 1000 + c, integrator=integrator), dtype=np.float64)
            acc = img * n if acc is None else acc + img * n
        return (acc / spp).astype(np.float32), time.perf_counter() - t0

    rows = []
    first_render_s = None
    for spp in spps:
        # Up to --repeat-max-spp: one untimed render first (JIT compilation of its kernels),
        # then --repeats timed. Above it one timed render (any compilation, well under a
        # second, then falls inside a render of many seconds).
        repeats = args.repeats if spp <= args.repeat_max_spp else 1
        if spp <= args.repeat_max_spp or first_render_s is None:
            img, s = render(spp, args.seed)
            first_render_s = s if first_render_s is None else first_render_s
        times = []
        for r in range(repeats):
            img, s = render(spp, args.seed + 1 + r)
            times.append(s)
        np.save(args.out_dir / f"{args.prefix}rgb_spp{spp}.npy", img[..., :3].astype(np.float32))
        rows.append({"spp": spp, "render_s": statistics.median(times) if times else None, "render_s_all": times})
        print(f"mitsuba {args.variant} spp {spp:>5}: {rows[-1]['render_s']}", flush=True)

    out = {
        "renderer": "mitsuba",
        "variant": args.variant,
        "version": mi.__version__,
        "drjit": dr.__version__,
        "threads": args.threads,
        "load_s": load_s,
        "first_render_s": first_render_s,
        "rows": rows,
    }

    if not args.no_aov:
        aov = mi.load_dict({"type": "aov", "aovs": "dd.y:depth,id:shape_index"})
        img, s = render(1, args.seed, aov)  # compile
        times = []
        for r in range(max(args.repeats, 1)):
            img, s = render(1, args.seed + 1 + r, aov)
            times.append(s)
        # Channels: the integrator's own (none for a bare aov: its RGB is empty), then the AOVs.
        t_ray, shape_index = img[..., -2], img[..., -1]
        cam = scene_json["camera"]
        w, h = cam["width"], cam["height"]
        u, v = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
        cos_axis = 1.0 / np.sqrt(1 + ((u - cam["cx"]) / cam["fx"]) ** 2 + ((v - cam["cy"]) / cam["fy"]) ** 2)
        depth = (t_ray * cos_axis).astype(np.float32)
        # shape_index is 1 + the shape's index in scene.shapes(), 0 where nothing is hit.
        shapes = scene.shapes()
        lut = np.array([0] + [ids.get(sh.id().split("_", 2)[-1], 0) for sh in shapes], np.uint8)
        idx = np.rint(shape_index).astype(np.int64)
        idx = np.where((idx >= 0) & (idx < len(lut)), idx, 0)
        np.save(args.out_dir / f"{args.prefix}depth.npy", np.where(depth > 0, depth, 0).astype(np.float32))
        np.save(args.out_dir / f"{args.prefix}index.npy", lut[idx])
        out["aov_pass"] = {
            "spp": 1,
            "channels": "depth (ray distance → z), shape_index → instance id",
            "render_s": statistics.median(times),
            "render_s_all": times,
        }
        print(f"mitsuba aov pass: {out['aov_pass']['render_s']:.3f} s", flush=True)
    (args.out_dir / f"{args.prefix}timings.json").write_text(json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
