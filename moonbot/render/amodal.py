"""Amodal instance masks: each bag's silhouette rendered alone, ignoring everything that occludes
it (BOP's `mask/`; the view's own mask.png is the visible part, BOP's `mask_visib/`).

A task builds one small `_core.Scene` per bag, holding that bag alone (`build_amodal_scenes`,
once per task, reused for every view). Per view each is rendered with the instance pass only
(`render_amodal_masks`): camera rays through pixel centres and nothing else — no shading, no
shadow or bounce rays.

bop_toolkit (scripts/calc_gt_info.py) renders an object alone on a canvas of 3W × 3H pixels
whose principal point is shifted by (W, H), so that `px_count_all` and `bbox_obj` include the
parts of the silhouette truncated by the image border. Rendering that whole canvas would cost
nine images of rays per bag; instead each bag is rendered only over the window of the canvas its
projected vertices can cover (a convex mesh's silhouette lies inside the projection of its
vertices' bounding rectangle when every vertex is in front of the camera; otherwise the whole
canvas is rendered). The window camera is the view camera with its principal point shifted by
the window's integer offset, so every pixel's ray is bit for bit the view's own ray through that
pixel centre (the offset and the principal point W/2, H/2 are exact in double): where the view's
mask.png shows the bag, its amodal mask shows it too.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from moonbot import _core
from moonbot.scene.compose import SceneSpec
from moonbot.scene.orbit import CameraPose

# bop_toolkit's canvas for truncated silhouettes: CANVAS_FACTOR·W × CANVAS_FACTOR·H pixels, the
# image at its centre (offset W, H).
CANVAS_FACTOR = 3
# Pixels added around each projected window: covers rounding in the projection (a ray through a
# pixel centre just outside the projected vertices' rectangle never hits the bag).
WINDOW_MARGIN_PX = 1
# A vertex this close to the camera plane (metres, along the optical axis) or behind it makes the
# projection unbounded: the whole canvas is rendered instead of a window.
MIN_WINDOW_DEPTH_M = 1e-6


@dataclass(frozen=True)
class AmodalMask:
    """One bag's silhouette alone in one view. `mask` (H, W) bool: the image pixels whose centre
    ray hits the bag, occluders ignored. `px_count_all`: pixels of the silhouette on bop_toolkit's
    3W × 3H canvas (parts outside the image included, beyond the canvas excluded). `bbox_all`:
    (x, y, w, h) of that canvas silhouette in image pixel coordinates (x may be negative or beyond
    W), bop_toolkit's convention w = max x − min x, h = max y − min y (no +1); (-1, -1, -1, -1)
    when the silhouette is empty. `rays`: camera rays traced for it."""

    instance_id: int
    obj_id: int
    mask: np.ndarray
    px_count_all: int
    bbox_all: tuple[int, int, int, int]
    rays: int


@dataclass(frozen=True)
class AmodalMasks:
    """The amodal masks of every bag of one view, in the scene's bag order, and what they cost:
    `seconds` (wall, windows and renders) and `rays` (camera rays, all bags)."""

    masks: tuple[AmodalMask, ...]
    seconds: float
    rays: int


@dataclass(frozen=True)
class _SoloBag:
    instance_id: int
    obj_id: int
    scene: _core.Scene
    world_from_model: np.ndarray  # (4, 4) float64, metres
    vertices: np.ndarray  # (N, 3) float64, model frame, metres


@dataclass(frozen=True)
class AmodalScenes:
    """One committed single-bag `_core.Scene` per bag of a scene (built once per task);
    `seconds` is what building them cost (mesh copies and BVH builds)."""

    bags: tuple[_SoloBag, ...]
    seconds: float


def build_amodal_scenes(spec: SceneSpec, embree_isa: str = "auto") -> AmodalScenes:
    """Builds, for every bag of `spec`, a scene holding that bag alone at its pose with its
    instance id (plain material: only the instance pass is ever rendered from it), traced with
    `embree_isa`'s kernels (render.embree_isa)."""
    start = time.perf_counter()
    bags = []
    for bag in spec.bags:
        vertices, triangles = spec.meshes[bag.obj_id]
        scene = _core.Scene(embree_isa)
        mesh = scene.add_mesh(vertices, triangles)
        scene.add_instance(mesh, bag.world_from_model, bag.instance_id, (1.0, 1.0, 1.0))
        scene.commit()
        bags.append(
            _SoloBag(
                bag.instance_id,
                bag.obj_id,
                scene,
                np.asarray(bag.world_from_model, np.float64),
                np.asarray(vertices, np.float64),
            )
        )
    return AmodalScenes(tuple(bags), time.perf_counter() - start)


def canvas_window(
    K: np.ndarray, pose: CameraPose, world_from_model: np.ndarray, vertices: np.ndarray, width: int, height: int
) -> tuple[int, int, int, int] | None:
    """The window of bop_toolkit's 3W × 3H canvas that can hold the silhouette of a mesh with
    model-frame `vertices` (N, 3) metres placed at `world_from_model` (4, 4), seen by the camera
    (K (3, 3) pixels, `pose` world-to-camera): (x0, y0, x1, y1) in image pixel coordinates,
    half-open, inside [-W, 2W) × [-H, 2H). The whole canvas when a vertex is not in front of the
    camera; None when the window misses the canvas."""
    lo_x, lo_y = -width * (CANVAS_FACTOR // 2), -height * (CANVAS_FACTOR // 2)
    hi_x, hi_y = lo_x + CANVAS_FACTOR * width, lo_y + CANVAS_FACTOR * height
    world = vertices @ world_from_model[:3, :3].T + world_from_model[:3, 3]
    cam = world @ pose.R.T + pose.t
    z = cam[:, 2]
    if not (np.isfinite(cam).all() and z.min() > MIN_WINDOW_DEPTH_M):
        return lo_x, lo_y, hi_x, hi_y
    u = K[0, 0] * cam[:, 0] / z + K[0, 2]
    v = K[1, 1] * cam[:, 1] / z + K[1, 2]
    # Pixel i's centre is i + 0.5: the centres inside [u.min, u.max] are ceil(u.min - 0.5) ..
    # floor(u.max - 0.5).
    x0 = max(lo_x, math.ceil(u.min() - 0.5) - WINDOW_MARGIN_PX)
    x1 = min(hi_x, math.floor(u.max() - 0.5) + 1 + WINDOW_MARGIN_PX)
    y0 = max(lo_y, math.ceil(v.min() - 0.5) - WINDOW_MARGIN_PX)
    y1 = min(hi_y, math.floor(v.max() - 0.5) + 1 + WINDOW_MARGIN_PX)
    if x0 >= x1 or y0 >= y1:
        return None
    return x0, y0, x1, y1


def render_amodal_masks(
    scenes: AmodalScenes, K: np.ndarray, pose: CameraPose, width: int, height: int, threads: int = 0
) -> AmodalMasks:
    """Renders every bag of `scenes` alone through the view camera (K (3, 3) pixels, `pose`
    world-to-camera, an image of `width` × `height` pixels) with the instance pass only, over its
    canvas window, on `threads` core threads (0 = all). Returns each bag's in-image mask and its
    canvas pixel count and box (bop_toolkit's px_count_all and bbox_obj before its
    visible-or-not rule)."""
    start = time.perf_counter()
    fx, fy, cx, cy = float(K[0, 0]), float(K[1, 1]), float(K[0, 2]), float(K[1, 2])
    masks, total_rays = [], 0
    for bag in scenes.bags:
        mask = np.zeros((height, width), dtype=bool)
        window = canvas_window(K, pose, bag.world_from_model, bag.vertices, width, height)
        count, bbox, rays = 0, (-1, -1, -1, -1), 0
        if window is not None:
            x0, y0, x1, y1 = window
            camera = _core.Camera(fx, fy, cx - x0, cy - y0, x1 - x0, y1 - y0, pose.R, pose.t)
            out = _core.render(
                bag.scene, camera, None, _core.RenderSettings(threads=threads, exact_depth=False), passes=["instance"]
            )
            hit = out["instance"] == bag.instance_id
            rays = int(out["camera_rays"])
            count = int(np.count_nonzero(hit))
            if count:
                ys, xs = np.nonzero(hit)
                bx, by = int(xs.min()) + x0, int(ys.min()) + y0
                bbox = (bx, by, int(xs.max()) + x0 - bx, int(ys.max()) + y0 - by)
                # The in-image part: window rows/columns that fall inside [0, W) × [0, H).
                ix0, iy0, ix1, iy1 = max(x0, 0), max(y0, 0), min(x1, width), min(y1, height)
                if ix0 < ix1 and iy0 < iy1:
                    mask[iy0:iy1, ix0:ix1] = hit[iy0 - y0 : iy1 - y0, ix0 - x0 : ix1 - x0]
        total_rays += rays
        masks.append(AmodalMask(bag.instance_id, bag.obj_id, mask, count, bbox, rays))
    return AmodalMasks(tuple(masks), time.perf_counter() - start, total_rays)
