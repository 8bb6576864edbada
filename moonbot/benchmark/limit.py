"""The yardstick of `moonbot bench throughput`: what Embree alone and the encoders alone take for
the work a benchmark task does, on the same scene and the same images.

Rays (`embree_limit`): the task's scene is composed and built as the task builds it — terrain,
rocks, bags as instances, a dust scene's ejecta fragments of view 0 — except that the bags are
not settled (settling moves them by millimetres and costs seconds; it changes no ray's cost).
`_core.measure_embree_limit` then times Embree alone, on view 0, on the pixel-centre camera rays,
the Sun shadow rays from their hits, `bounces` generations of diffuse bounce rays (cosine-
distributed about each hit's normal, generation g + 1 from generation g's hits, as the renderer's
paths go) and the Sun shadow rays from each generation's hits, each kind as the renderer traces
it (64-ray streams through `rtcIntersect1M` and `rtcOccluded1M`, in Embree's incoherent mode as
every query of the renderer's: accel.h), the busiest thread's sum, at the thread counts asked
for. That gives seconds per ray of each kind, and of each bounce generation, on that scene.

A run's Embree limit is then its own ray counts (stats.json) at those costs: bounce rays and the
shadow rays from bounce vertices (`bounce_shadow_rays`) at the pooled costs of the probe's
generations 1..B, B the level's bounces. The light cache's gather rays (`light_cache_rays`, every
generation of its gather paths) and their vertices' shadow rays (`light_cache_shadow_rays`) are
the same kinds of ray, cosine-distributed from surface points and continued as bounces are, and
count at the same pooled costs: a level that reads indirect light from the cache is held to the
rays it traces to fill it, as a path-traced level is to its bounce rays. (The cache's probe rays,
one a lattice node along a lattice axis, about 1 % of its gather rays, are not in the views'
counts and not in the limit.) The dust medium's Sun rays
(`medium_rays`, coherent closest-hit rays of the dust stage) count at the camera rays' rate; the
amodal masks' instance passes (against one-bag scenes) and the dust medium's ray marching have no
Embree counterpart and are not in the limit: they are overhead.

Encoding (`encode_limit`): every file of every view the task wrote (rgb.png, depth.png,
depth_preview.png, mask.png, amodal_NNN.png, rgb.exr when written) is read back and written
again by the same encoder (`_core.write_image`, OpenImageIO, at the config's PNG level) into a
scratch directory, and depth.npy by `numpy.save`, each file alone, median of repeats: no
staging, renames, thread pool, tone map, depth conversion or gt.json. With P threads a view's
files take at best max(the longest file, the sum / P).
"""

from __future__ import annotations

import dataclasses
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from moonbot import _core
from moonbot.config import Config
from moonbot.render import SceneDust, build_scene
from moonbot.render.view import view_inputs
from moonbot.scene import compose_scene
from moonbot.sweep import Task, task_config


@dataclasses.dataclass
class ProbeView:
    """View 0 of a benchmark task as the probe sees it: the task's config (`config`, the sweep's
    task applied), the built scene (bags unsettled, a dust scene's view-0 fragments in place),
    the camera (`K` 3×3 pixels, `pose` the orbit's camera pose) and `camera`/`sun` as the core
    takes them, and `medium` the view's dust cloud (None in a clear scene)."""

    config: Config
    scene: object
    camera: object
    sun: object
    K: np.ndarray
    pose: object
    medium: object | None


def limit_scene(config: Config, task: Task) -> ProbeView:
    """View 0 of `task` of `config`'s sweep, built as the task builds it but with its bags
    unsettled, and with a dust scene's view-0 ejecta fragments in place."""
    c = task_config(config, task)
    c = dataclasses.replace(
        c, bags=dataclasses.replace(c.bags, settle=dataclasses.replace(c.bags.settle, enabled=False))
    )
    spec = compose_scene(c)
    scene = build_scene(spec, c.render.embree_isa)
    medium = None
    if c.dust.enabled:
        medium = SceneDust(scene, spec, c, [0]).for_view(0).medium  # adds the fragments' mesh and commits
    view = view_inputs(c, spec, 0)
    return ProbeView(c, scene, view.camera, view.sun, view.K, view.pose, medium)


def embree_limit(config: Config, task: Task, threads: list[int], bounces: int, repeats: int = 3) -> list[dict]:
    """Embree's own time for view 0's camera, shadow and `bounces` generations of bounce rays on
    `task`'s scene, once per thread count in `threads`: one dict each with the probe's raw figures
    and the derived seconds per ray and Mrays/s (streams, and one ray at a time for scale)."""
    view = limit_scene(config, task)
    return [probe(view, task.task_id, t, bounces, repeats) for t in threads]


def probe(view: ProbeView, task_id: str, threads: int, bounces: int, repeats: int = 3) -> dict:
    """`_core.measure_embree_limit` on `view` with `threads` threads and `bounces` bounce
    generations (median of `repeats`), as the dict embree_limit returns for one thread count."""
    m = _core.measure_embree_limit(view.scene, view.camera, view.sun, threads=threads, repeats=repeats, bounces=bounces)
    cam, sh = int(m["camera_rays"]), int(m["shadow_rays"])
    bounce_rays = [int(n) for n in m["bounce_rays"]]
    return {
        "task_id": task_id,
        "threads": threads,
        "camera_rays": cam,
        "shadow_rays": sh,
        "bounce_rays": bounce_rays,
        "intersect_stream_s": m["intersect_stream_s"],
        "occluded_stream_s": m["occluded_stream_s"],
        "bounce_stream_s": list(m["bounce_stream_s"]),
        "bounce_shadow_rays": [int(n) for n in m["bounce_shadow_rays"]],
        "bounce_shadow_stream_s": list(m["bounce_shadow_stream_s"]),
        "intersect_single_s": m["intersect_single_s"],
        "occluded_single_s": m["occluded_single_s"],
        "bounce_single_s": list(m["bounce_single_s"]),
        "camera_s_per_ray": _per(m["intersect_stream_s"], cam),
        "shadow_s_per_ray": _per(m["occluded_stream_s"], sh),
        "primary_mrays_per_s": _mrays(cam, m["intersect_stream_s"]),
        "shadow_mrays_per_s": _mrays(sh, m["occluded_stream_s"]),
        "bounce_mrays_per_s": [_mrays(n, s) for n, s in zip(bounce_rays, m["bounce_stream_s"])],
        "bounce_shadow_mrays_per_s": [
            _mrays(n, s) for n, s in zip(m["bounce_shadow_rays"], m["bounce_shadow_stream_s"])
        ],
        "primary_single_mrays_per_s": _mrays(cam, m["intersect_single_s"]),
        "shadow_single_mrays_per_s": _mrays(sh, m["occluded_single_s"]),
        "bounce_single_mrays_per_s": [_mrays(n, s) for n, s in zip(bounce_rays, m["bounce_single_s"])],
    }


def _per(seconds: float, rays: int) -> float:
    return seconds / max(rays, 1)


def _mrays(rays: int, seconds: float) -> float:
    return rays / seconds / 1e6 if seconds > 0 else 0.0


def bounce_s_per_ray(row: dict, bounces: int, kind: str = "bounce") -> float:
    """A bounce ray's (kind "bounce") or a bounce vertex's shadow ray's (kind "bounce_shadow")
    Embree seconds on `row`'s scene for a render of `bounces` bounces: the probe's generations
    1..bounces pooled (their seconds over their rays)."""
    rays = sum(row[f"{kind}_rays"][:bounces])
    return sum(row[f"{kind}_stream_s"][:bounces]) / rays if rays > 0 else 0.0


def ray_limit_seconds(rays: dict, row: dict, bounces: int) -> float:
    """Embree seconds for a task's `rays` (its stats.json counts) rendered with `bounces` bounces,
    at `row`'s per-ray costs: camera and medium rays at the camera-ray rate, the camera hits'
    shadow rays at the shadow-ray rate, bounce rays and the light cache's gather rays at the
    pooled bounce rate, and the shadow rays from both kinds' vertices at the pooled rate of the
    bounce vertices' shadow rays (see the module docstring). Amodal rays are not counted."""
    bounce_shadow = rays.get("bounce_shadow_rays", 0)
    return (
        row["camera_s_per_ray"] * (rays.get("camera_rays", 0) + rays.get("medium_rays", 0))
        + row["shadow_s_per_ray"] * (rays.get("shadow_rays", 0) - bounce_shadow)
        + bounce_s_per_ray(row, bounces) * (rays.get("bounce_rays", 0) + rays.get("light_cache_rays", 0))
        + bounce_s_per_ray(row, bounces, "bounce_shadow") * (bounce_shadow + rays.get("light_cache_shadow_rays", 0))
    )


def _median_seconds(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def encode_view(view_dir: Path, png_compression: int, scratch: Path, repeats: int = 3) -> list[dict]:
    """Each file of one written view re-encoded alone (see the module docstring): one dict per
    file with its raw (decoded) bytes, its file bytes and the median seconds."""
    rows = []
    for path in sorted(view_dir.iterdir()):
        if path.suffix == ".npy":
            array = np.load(path)
            target = scratch / path.name
            seconds = _median_seconds(lambda: np.save(target, array), repeats)
        elif path.suffix in (".png", ".exr"):
            array = _core.read_image(str(path))
            target = scratch / path.name
            if path.suffix == ".png":
                seconds = _median_seconds(lambda: _core.write_image(str(target), array, png_compression), repeats)
            else:
                seconds = _median_seconds(lambda: _core.write_image(str(target), array), repeats)
        else:
            continue  # gt.json: ours, not an encoder's
        rows.append(
            {"file": path.name, "raw_bytes": int(array.nbytes), "file_bytes": target.stat().st_size, "seconds": seconds}
        )
    return rows


def encode_limit(task_dirs: list[Path], png_compression: int, repeats: int = 3) -> dict:
    """The encoders' time for every view of `task_dirs` (a generate run's OUT/tasks/*): per view
    the files' serial sum and longest file, and the totals and raw MB/s over all views."""
    views = []
    with tempfile.TemporaryDirectory(prefix=".encode-limit-", dir=task_dirs[0].parent) as tmp:
        for task in task_dirs:
            for view in sorted(task.glob("view_*")):
                files = encode_view(view, png_compression, Path(tmp), repeats)
                views.append(
                    {
                        "task_id": task.name,
                        "view": view.name,
                        "files": len(files),
                        "raw_bytes": sum(f["raw_bytes"] for f in files),
                        "file_bytes": sum(f["file_bytes"] for f in files),
                        "serial_s": sum(f["seconds"] for f in files),
                        "longest_s": max((f["seconds"] for f in files), default=0.0),
                    }
                )
    serial = sum(v["serial_s"] for v in views)
    raw = sum(v["raw_bytes"] for v in views)
    return {
        "views": views,
        "serial_s": serial,
        "raw_bytes": raw,
        "file_bytes": sum(v["file_bytes"] for v in views),
        "raw_mb_per_s": raw / serial / 1e6 if serial > 0 else 0.0,
    }


def encode_limit_seconds(limit: dict, threads: int, task_id: str | None = None) -> float:
    """The encoders' best time for the views of `limit` (all, or one task's) on `threads` threads:
    Σ over views of max(longest file, serial sum / threads)."""
    return sum(
        max(v["longest_s"], v["serial_s"] / max(threads, 1))
        for v in limit["views"]
        if task_id is None or v["task_id"] == task_id
    )
