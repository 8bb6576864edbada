"""Renders a bench/peers export with Blender Cycles (pip `bpy`, CPU) at a list of spp.

bpy pins numpy 1.26 (and its own Python ABI), so it lives in its own venv (bench/peers/README.md):

  .venv-peers-bpy/bin/python bench/peers/cycles_render.py SCENE_DIR OUT_DIR --spp 1,4,16 [--threads 2]

Scene (the parity settings of export_scene.py), built from the PLY arrays with foreach_set (no
importer in between): flat-shaded meshes; one material each, a Diffuse BSDF of roughness 0
(Lambertian; Cycles' diffuse is two-sided) whose colour is the mesh's constant albedo or, on the
terrain, a float colour attribute of its per-vertex albedo (linear, no colour management);
the Sun a Sun light of angle 0 (a delta light: hard shadows) with strength = the export's
irradiance in W/m² (Cycles' Sun strength is irradiance: a white Lambertian facing it reflects
strength/π W/(m²·sr); compare.py checks the images' means agree); a world of strength 0 (black
sky); a perspective camera with the export's horizontal fov and pose. Cycles: CPU, fixed
`--threads`, max_bounces = diffuse_bounces = the export's bounces (others 0), no caustics,
no light or sample clamping (Cycles clamps indirect samples at 10 by default), no adaptive
sampling, no denoising, box pixel filter 1 px wide, Cycles' default sampling pattern, persistent
data on (the BVH is built once, by the warm-up render), shadow terminator offsets 0.
Passes: Combined, Depth (Cycles' Z: z-depth, distance along the camera's view axis) and
Object Index (IndexOB: the object's pass index = the export's instance id) are enabled on the
view layer and copied, float32, straight out of Cycles' RenderResult in memory: the Cycles
engine class's `render` method is wrapped so that, as soon as Cycles has finished a frame and
before Blender frees the result, `RenderEngine.get_result()` gives the result's layer and each
pass's `rect` is read with `foreach_get` into numpy (0.7 ms at 640×480 for all three; rows
flipped, Blender's are bottom-up). Nothing is written to disk. With bpy 5.0.1 (pip) the file
route loses the passes: `render(write_still=True)` to a multilayer EXR (and `save_render` of
the Render Result) held only Combined although the engine's result had Depth and Object Index
too, with or without `use_compositing`; with a compositor node group
(`scene.compositing_node_group`) the EXR held only the composite. Depth and Object Index are
not averages over the samples: on the bench scene they came out the same at every seed and
spp, integer indices, and equal to moonbot's pixel-centre depth to ~1e-5 (median), so they
belong to one ray through the pixel centre.

Timing: `load_s` is reading the PLYs and building the Blender data; `first_render_s` is a 1-spp
warm-up render (scene sync to Cycles and BVH build); then every spp up to --repeat-max-spp is
rendered `--repeats` times (a larger one once), each timed around `bpy.ops.render.render`
including the copy of its passes into numpy, median reported. `--no-depth-index` copies
Combined alone (Depth and Object Index stay enabled in Cycles): the extraction's cost is the
difference (0.2 ms at 640×480; the whole copy 0.7 ms, where the old EXR write took ~17 ms).
Each render sets `scene.render.filepath` first: that tags the scene, without which Blender
hands the persistent Cycles session no change and it returns the previous frame unrendered
(Cycles' samples and seed settings do not tag it).

Writes OUT_DIR/rgb_sppN.npy (H, W, 3) float32, depth.npy (float32 metres, 0 where the ray
missed) and index.npy (uint8) from each spp's last render (the highest spp's are kept), and
timings.json.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from ply import read_ply  # noqa: E402


def add_mesh(
    bpy,
    name: str,
    v: np.ndarray,
    t: np.ndarray,
    albedo_rgb: np.ndarray | None,
    constant: list[float] | None,
    pass_index: int,
):
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(len(v))
    mesh.vertices.foreach_set("co", np.ascontiguousarray(v, np.float32).ravel())
    mesh.loops.add(3 * len(t))
    mesh.loops.foreach_set("vertex_index", np.ascontiguousarray(t, np.int32).ravel())
    mesh.polygons.add(len(t))
    mesh.polygons.foreach_set("loop_start", np.arange(0, 3 * len(t), 3, dtype=np.int32))
    mesh.polygons.foreach_set("use_smooth", np.zeros(len(t), dtype=bool))
    mesh.update()
    material = bpy.data.materials.new(name + "_material")
    material.use_nodes = True
    nodes, links = material.node_tree.nodes, material.node_tree.links
    nodes.clear()
    diffuse = nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Roughness"].default_value = 0.0
    output = nodes.new("ShaderNodeOutputMaterial")
    links.new(diffuse.outputs["BSDF"], output.inputs["Surface"])
    if albedo_rgb is not None:
        attr = mesh.color_attributes.new(name="albedo", type="FLOAT_COLOR", domain="POINT")
        rgba = np.ones((len(v), 4), np.float32)
        rgba[:, :3] = albedo_rgb
        attr.data.foreach_set("color", rgba.ravel())
        node = nodes.new("ShaderNodeAttribute")
        node.attribute_type = "GEOMETRY"
        node.attribute_name = "albedo"
        links.new(node.outputs["Color"], diffuse.inputs["Color"])
    else:
        diffuse.inputs["Color"].default_value = (*constant, 1.0)
    mesh.materials.append(material)
    obj = bpy.data.objects.new(name, mesh)
    obj.pass_index = pass_index
    for attr_name in ("shadow_terminator_offset", "shadow_terminator_geometry_offset"):
        if hasattr(obj.cycles if hasattr(obj, "cycles") else obj, attr_name):
            setattr(obj.cycles if hasattr(obj, "cycles") else obj, attr_name, 0.0)
        elif hasattr(obj, attr_name):
            setattr(obj, attr_name, 0.0)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def build_scene(bpy, scene_dir: Path, scene_json: dict, threads: int) -> None:
    import mathutils

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    for m in scene_json["meshes"]:
        v, t, extra = read_ply(scene_dir / m["file"])
        albedo = (
            np.column_stack([extra["albedo_r"], extra["albedo_g"], extra["albedo_b"]]) if "albedo_r" in extra else None
        )
        add_mesh(
            bpy, Path(m["file"]).stem, v, t, albedo, None if albedo is not None else m["albedo"], int(m["instance_id"])
        )

    sun_json = scene_json["sun"]
    light = bpy.data.lights.new("sun", "SUN")
    light.energy = float(sun_json["irradiance_w_m2"])
    light.color = sun_json["rgb"]
    light.angle = math.radians(sun_json["angular_diameter_deg"])
    sun = bpy.data.objects.new("sun", light)
    # A Sun light shines along its local -Z: local +Z toward the Sun.
    sun.rotation_mode = "QUATERNION"
    sun.rotation_quaternion = mathutils.Vector(sun_json["direction_to_sun"]).to_track_quat("Z", "Y")
    scene.collection.objects.link(sun)

    cam_json = scene_json["camera"]
    cam_data = bpy.data.cameras.new("camera")
    cam_data.type = "PERSP"
    cam_data.sensor_fit = "HORIZONTAL"
    cam_data.angle = math.radians(cam_json["hfov_deg"])
    cam_data.shift_x = cam_data.shift_y = 0.0  # principal point at the centre
    cam_data.clip_start, cam_data.clip_end = 1e-3, 1e5
    cam = bpy.data.objects.new("camera", cam_data)
    # Blender's camera: +X right, +Y up, looks along -Z. World-from-camera columns.
    R = np.array(cam_json["R_world_to_cam"], float)
    M = np.eye(4)
    M[:3, 0], M[:3, 1], M[:3, 2] = R[0], -R[1], -R[2]
    M[:3, 3] = cam_json["position_m"]
    cam.matrix_world = mathutils.Matrix(M.tolist())
    scene.collection.objects.link(cam)
    scene.camera = cam

    world = bpy.data.worlds.new("black")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0, 0, 0, 1)
    scene.world = world

    r = scene.render
    r.engine = "CYCLES"
    r.resolution_x, r.resolution_y, r.resolution_percentage = cam_json["width"], cam_json["height"], 100
    r.pixel_aspect_x = r.pixel_aspect_y = 1.0
    r.threads_mode, r.threads = "FIXED", threads
    r.use_persistent_data = True
    r.film_transparent = False
    c = scene.cycles
    c.device = "CPU"
    c.use_adaptive_sampling = False
    c.use_denoising = False
    bounces = int(scene_json["integrator"]["bounces"])
    c.max_bounces, c.diffuse_bounces = bounces, bounces
    c.glossy_bounces = c.transmission_bounces = c.volume_bounces = c.transparent_max_bounces = 0
    c.caustics_reflective = c.caustics_refractive = False
    c.sample_clamp_direct = c.sample_clamp_indirect = 0.0
    c.pixel_filter_type, c.filter_width = "BOX", 1.0
    c.use_animated_seed = False
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure, scene.view_settings.gamma = 0.0, 1.0
    layer = scene.view_layers[0]
    layer.use_pass_combined = True
    layer.use_pass_z = True
    layer.use_pass_object_index = True


class PassGrabber:
    """Copies passes out of Cycles' render result into numpy while Blender still holds it.

    bpy 5.0.1 does not write Depth or Object Index to the multilayer EXR it saves (module
    docstring), but Cycles' own RenderResult has them: the Cycles engine class's `render`
    (called by Blender once a frame) is wrapped, and after Cycles returns, the result's first
    layer gives each pass's `rect` (H·W·channels floats, rows bottom-up)."""

    PASSES = {"rgb": ("Combined", 3), "depth": ("Depth", 1), "index": ("Object Index", 1)}

    def __init__(self, bpy, names: tuple[str, ...]):
        engines = [c for c in bpy.types.RenderEngine.__subclasses__() if getattr(c, "bl_idname", "") == "CYCLES"]
        if len(engines) != 1:
            raise RuntimeError(f"expected one Cycles RenderEngine class, found {engines}")
        self.names = names
        self.arrays: dict[str, np.ndarray] = {}
        engine_class = engines[0]
        cycles_render = engine_class.render
        grabber = self

        def render(engine, depsgraph):
            grabber.arrays = {}
            cycles_render(engine, depsgraph)
            grabber.grab(engine.get_result())

        engine_class.render = render

    def grab(self, result) -> None:
        if result is None or not len(result.layers):
            raise RuntimeError("Cycles left no render result")
        w, h = result.resolution_x, result.resolution_y
        passes = {p.name: p for p in result.layers[0].passes}
        for name in self.names:
            pass_name, keep = self.PASSES[name]
            if pass_name not in passes:
                raise RuntimeError(f"render result has no {pass_name} pass: {sorted(passes)}")
            p = passes[pass_name]
            flat = np.empty(w * h * p.channels, np.float32)
            p.rect.foreach_get(flat)
            self.arrays[name] = flat.reshape(h, w, p.channels)[::-1, :, :keep]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene_dir", type=Path)
    parser.add_argument("out_dir", type=Path)
    parser.add_argument("--spp", default="1,4,16")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--repeat-max-spp", type=int, default=16, help="spp above this get one timed render")
    parser.add_argument("--prefix", default="", help="prefix of the output files (e.g. a reference's)")
    parser.add_argument(
        "--no-depth-index",
        action="store_true",
        help="copy Combined alone out of each render (Depth and Object Index stay enabled): to time the extraction",
    )
    args = parser.parse_args()

    start = time.perf_counter()
    import bpy

    import_s = time.perf_counter() - start
    scene_json = json.loads((args.scene_dir / "scene.json").read_text())
    args.out_dir.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    build_scene(bpy, args.scene_dir, scene_json, args.threads)
    load_s = time.perf_counter() - start
    scene = bpy.context.scene

    names = ("rgb",) if args.no_depth_index else ("rgb", "depth", "index")
    grabber = PassGrabber(bpy, names)

    def render(spp: int, seed: int) -> float:
        scene.cycles.samples = spp
        scene.cycles.seed = seed
        # Cycles' own settings (samples, seed) carry no update callback: without a tag on the
        # scene, Blender's next render hands the persistent Cycles session no change, and Cycles
        # returns the previous frame's pixels unrendered. Setting a render setting tags it, and
        # Cycles re-reads its settings without re-syncing the geometry (nothing is written there:
        # write_still=False). scene.update_tag() would re-sync everything (~0.7 s at 160×120).
        scene.render.filepath = str(args.out_dir / f"{args.prefix}unused")
        t0 = time.perf_counter()
        bpy.ops.render.render(write_still=False)
        seconds = time.perf_counter() - t0
        missing = [n for n in names if n not in grabber.arrays]
        if missing:
            raise RuntimeError(f"no {missing} from this render")
        return seconds

    first_render_s = render(1, args.seed)
    rows = []
    for spp in [int(s) for s in args.spp.split(",") if s]:
        times = []
        for r in range(max(args.repeats, 1) if spp <= args.repeat_max_spp else 1):
            s = render(spp, args.seed + 1 + r)
            times.append(s)
        frame = grabber.arrays
        np.save(args.out_dir / f"{args.prefix}rgb_spp{spp}.npy", np.ascontiguousarray(frame["rgb"]))
        rows.append({"spp": spp, "render_s": statistics.median(times), "render_s_all": times})
        print(f"cycles spp {spp:>5}: {rows[-1]['render_s']:.3f} s", flush=True)
        if "depth" in frame:
            # Cycles' Z of a ray that hit nothing is 1e10: 0 there, as moonbot's depth.
            depth = frame["depth"][..., 0]
            np.save(
                args.out_dir / f"{args.prefix}depth.npy",
                np.where((depth > 0) & (depth < 1e9), depth, 0).astype(np.float32),
            )
            np.save(args.out_dir / f"{args.prefix}index.npy", np.rint(frame["index"][..., 0]).astype(np.uint8))
    out = {
        "renderer": "cycles",
        "version": bpy.app.version_string,
        "threads": args.threads,
        "import_bpy_s": import_s,
        "load_s": load_s,
        "first_render_s": first_render_s,
        "passes": (
            "Combined + Depth + Object Index enabled in every render"
            + (
                ", all three copied from the RenderResult into numpy inside the timed render (no file written)"
                if not args.no_depth_index
                else ", Combined alone copied from the RenderResult (--no-depth-index)"
            )
        ),
        "passes_extracted": [grabber.PASSES[n][0] for n in names],
        "rows": rows,
    }
    (args.out_dir / f"{args.prefix}timings.json").write_text(json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
