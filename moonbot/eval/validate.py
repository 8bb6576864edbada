"""`moonbot validate`: a merged BOP dataset checked against itself. Every file against the
manifest (size and SHA-256, nothing unlisted but `moonbot eval`'s reports in eval/), and every link
of the by_condition/ view against it (its target, resolving to its scene); the tree
(moonbot.bop.layout: each scene in `<bop split>/<scene_id:06d>/` as its scene_meta.json says,
scene_index.json and .parquet row for row what the scene_meta.json files say); the JSON
files' BOP fields, types and units; per image, the 16-bit depth PNG × depth_scale against the
metric .npy (to the PNG's 1 mm rounding) and no pixel below the horizon without depth, and per instance its masks against scene_gt_info.json
(the visible mask inside the amodal one, visible masks of one image disjoint, counts, boxes and
fractions as bop_toolkit defines them, moonbot/bop/gt_info.py). Each failure names the file and
the check.

And the pose: each image's models (models/, mm) rendered at their ground-truth poses with cam_K
must reproduce depth.npy inside each instance's visible mask — the median absolute residual under
POSE_MEDIAN_MM and the 95th percentile under POSE_P95_MM (a sound sample is exact to float32
rounding; a pose off by a few mm is caught)."""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq

from moonbot import _core
from moonbot.bop.gt_info import bbox_of
from moonbot.bop.layout import (
    SCENE_INDEX_JSON,
    SCENE_INDEX_PARQUET,
    SCENE_META,
    VIEW_ROOT,
    scene_dirs,
    scene_rel,
    view_rel,
)
from moonbot.bop.models import read_ply
from moonbot.bop.scene_index import COLUMNS, index_rows
from moonbot.render.view import core_camera
from moonbot.scene.orbit import CameraPose
from moonbot.writer.checksum import file_sha256

EVAL_DIR = "eval"  # moonbot eval's default output folder inside the dataset, not in the manifest
DEPTH_TOLERANCE_MM = 0.5 + 1e-3  # the PNG rounds to 1 mm
POSE_MEDIAN_MM = 0.5
POSE_P95_MM = 2.0
# A pixel-centre ray this far below the horizon meets the ground within 60 m of a camera 1 m up,
# far inside any location's extent: if it reports no depth, it slipped between triangles.
HOLE_DEPRESSION_DEG = 1.0


@dataclass
class ValidationReport:
    """`checked`: how many items each check looked at; `failures`: (file, check, message)."""

    checked: dict = field(default_factory=dict)
    failures: list = field(default_factory=list)

    def count(self, check: str, n: int = 1) -> None:
        self.checked[check] = self.checked.get(check, 0) + n

    def fail(self, path: Path | str, check: str, message: str) -> None:
        self.failures.append((str(path), check, message))

    @property
    def ok(self) -> bool:
        return not self.failures


def check_manifest(dataset: Path, report: ValidationReport) -> None:
    path = dataset / "manifest.json"
    try:
        manifest = json.loads(path.read_text())
        files, listed_links = manifest["files"], manifest.get("links", {})
    except (OSError, ValueError, KeyError, AttributeError) as e:
        report.fail(path, "manifest", f"unreadable ({e})")
        return
    tree = list(dataset.rglob("*"))  # not into the view's links: they are checked as links
    on_disk = {str(p.relative_to(dataset)) for p in tree if p.is_file() and not p.is_symlink()} - {"manifest.json"}
    links = {str(p.relative_to(dataset)) for p in tree if p.is_symlink()}
    for name in sorted(links - set(listed_links)):
        report.fail(dataset / name, "manifest", "a link not listed in manifest.json")
    for name, target in sorted(listed_links.items()):
        report.count("links")
        p = dataset / name
        if not p.is_symlink():
            report.fail(p, "manifest", f"listed as a link to {target} but missing or not a link")
        elif os.readlink(p) != target:
            report.fail(p, "manifest", f"links to {os.readlink(p)}, manifest.json says {target}")
        elif not p.resolve().is_dir() or dataset.resolve() not in p.resolve().parents:
            report.fail(p, "manifest", f"{target} is not a directory of the dataset")
    # `moonbot eval` writes its reports into DATASET/eval/ by default: results, not dataset files.
    for name in sorted(n for n in on_disk - set(files) if not n.startswith(f"{EVAL_DIR}/")):
        report.fail(dataset / name, "manifest", "not listed in manifest.json")
    for name, entry in sorted(files.items()):
        report.count("manifest")
        p = dataset / name
        if not p.is_file():
            report.fail(p, "manifest", "listed but missing")
        elif p.stat().st_size != entry["bytes"]:
            report.fail(p, "manifest", f"{p.stat().st_size} bytes, manifest says {entry['bytes']}")
        elif file_sha256(p)[1] != entry["sha256"]:
            report.fail(p, "manifest", "sha256 differs from manifest.json")


def _numbers(value, n: int) -> bool:
    return (
        isinstance(value, list)
        and len(value) == n
        and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)
    )


def _check_json(scene: Path, report: ValidationReport) -> tuple[dict, dict, dict] | None:
    loaded = []
    for name in ("scene_gt.json", "scene_camera.json", "scene_gt_info.json"):
        try:
            loaded.append(json.loads((scene / name).read_text()))
        except (OSError, ValueError) as e:
            report.fail(scene / name, "json", f"unreadable ({e})")
            return None
    gt, camera, info = loaded
    for im, cam in camera.items():
        report.count("json")
        where = scene / "scene_camera.json"
        if not (
            _numbers(cam.get("cam_K"), 9) and _numbers(cam.get("cam_R_w2c"), 9) and _numbers(cam.get("cam_t_w2c"), 3)
        ):
            report.fail(where, "json", f"image {im}: cam_K (9), cam_R_w2c (9) and cam_t_w2c (3, mm) must be numbers")
        if not (isinstance(cam.get("depth_scale"), (int, float)) and cam["depth_scale"] > 0):
            report.fail(where, "json", f"image {im}: depth_scale must be a positive number (mm per PNG unit)")
    for im, instances in gt.items():
        for k, inst in enumerate(instances):
            report.count("json")
            if not (
                _numbers(inst.get("cam_R_m2c"), 9)
                and _numbers(inst.get("cam_t_m2c"), 3)
                and isinstance(inst.get("obj_id"), int)
                and inst["obj_id"] > 0
            ):
                report.fail(
                    scene / "scene_gt.json",
                    "json",
                    f"image {im} instance {k}: cam_R_m2c (9), cam_t_m2c (3, mm) and obj_id (int > 0) required",
                )
            elif abs(np.linalg.det(np.array(inst["cam_R_m2c"]).reshape(3, 3)) - 1) > 1e-6:
                report.fail(scene / "scene_gt.json", "json", f"image {im} instance {k}: cam_R_m2c is not a rotation")
        entries = info.get(im)
        if not isinstance(entries, list) or len(entries) != len(instances):
            report.fail(scene / "scene_gt_info.json", "json", f"image {im}: one entry per scene_gt instance required")
    return gt, camera, info


def depth_holes(depth: np.ndarray, K: np.ndarray, R_w2c: np.ndarray) -> np.ndarray:
    """The pixels (H, W) bool of a z-depth image (metres, 0 = no hit) that have no depth although
    their pixel-centre ray, from the pinhole camera K (3, 3) with world-to-camera rotation R_w2c
    (3, 3; world z up), points more than HOLE_DEPRESSION_DEG below the horizon, where the ground
    lies under everything: holes in the depth ground truth."""
    h, w = depth.shape
    u, v = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    rays = np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones_like(u)], axis=-1) @ R_w2c
    down = -rays[..., 2] / np.linalg.norm(rays, axis=-1)
    return (depth <= 0) & (down > math.sin(math.radians(HOLE_DEPRESSION_DEG)))


def render_at_gt(
    models: dict, instances: list[dict], cam: dict, shape: tuple[int, int]
) -> tuple[np.ndarray, np.ndarray]:
    """The image's models at their ground-truth poses, seen through cam_K from the camera's own
    frame (millimetres): (z-depth (H, W) mm, 0 = none; labels (H, W) uint8, instance index + 1)."""
    scene = _core.Scene()
    prototypes = {}
    for k, inst in enumerate(instances):
        obj = inst["obj_id"]
        if obj not in prototypes:
            prototypes[obj] = scene.add_mesh(*models[obj])
        pose = np.eye(4)
        pose[:3, :3] = np.array(inst["cam_R_m2c"], np.float64).reshape(3, 3)
        pose[:3, 3] = inst["cam_t_m2c"]
        scene.add_instance(prototypes[obj], pose, k + 1, (0.5, 0.5, 0.5))
    scene.commit()
    K = np.array(cam["cam_K"], np.float64).reshape(3, 3)
    camera = core_camera(K, shape[1], shape[0], CameraPose(np.eye(3), np.zeros(3)))  # poses are model-to-camera
    out = _core.render(scene, camera, None, passes=["depth", "instance"])
    return out["depth"].astype(np.float64), out["instance"]


def check_scene(scene: Path, report: ValidationReport, models: dict | None = None) -> None:
    loaded = _check_json(scene, report)
    if loaded is None:
        return
    gt, camera, info = loaded
    for im in sorted(gt, key=int):
        name = f"{int(im):06d}"
        png_path, npy_path = scene / "depth" / f"{name}.png", scene / "depth_npy" / f"{name}.npy"
        try:
            png = _core.read_image(str(png_path)).astype(np.float64) * camera[im]["depth_scale"]
            metres = np.load(npy_path)
        except (OSError, ValueError) as e:
            report.fail(png_path, "depth", f"unreadable ({e})")
            continue
        report.count("depth")
        if png.shape[:2] != metres.shape:
            report.fail(png_path, "depth", f"shape {png.shape} differs from {npy_path.name}'s {metres.shape}")
            continue
        png = png.reshape(metres.shape)
        mm = metres.astype(np.float64) * 1000.0
        representable = (mm > 0) & (mm <= 65535.0)
        bad = (representable & (np.abs(png - mm) > DEPTH_TOLERANCE_MM)) | (~representable & (png != 0))
        if bad.any():
            y, x = np.argwhere(bad)[0]
            report.fail(
                png_path,
                "depth",
                f"{int(bad.sum())} pixels disagree with {npy_path.name} (first at x={x}, "
                f"y={y}: {png[y, x]:.1f} mm vs {mm[y, x]:.3f} mm)",
            )
        holes = depth_holes(
            metres, np.reshape(camera[im]["cam_K"], (3, 3)), np.reshape(camera[im]["cam_R_w2c"], (3, 3))
        )
        if holes.any():
            y, x = np.argwhere(holes)[0]
            report.fail(
                npy_path,
                "depth",
                f"{int(holes.sum())} pixels below the horizon have no depth (first at "
                f"x={x}, y={y}): rays slipped between triangles",
            )
        valid = png > 0
        seen = np.zeros(metres.shape, bool)
        rendered = None
        if models is not None and all(inst.get("obj_id") in models for inst in gt[im]):
            rendered = render_at_gt(models, gt[im], camera[im], metres.shape)
        for k, entry in enumerate(info.get(im, [])):
            report.count("masks")
            masks = []
            for kind in ("mask", "mask_visib"):
                path = scene / kind / f"{name}_{k:06d}.png"
                try:
                    masks.append(_core.read_image(str(path)).reshape(metres.shape) > 0)
                except (OSError, ValueError) as e:
                    report.fail(path, "masks", f"unreadable ({e})")
            if len(masks) != 2:
                continue
            amodal, visible = masks
            where = scene / "mask_visib" / f"{name}_{k:06d}.png"
            if (visible & ~amodal).any():
                report.fail(where, "masks", "visible pixels outside the amodal mask")
            if (visible & seen).any():
                report.fail(where, "masks", "visible pixels shared with another instance")
            seen |= visible
            expected = {
                "px_count_visib": int(visible.sum()),
                "bbox_visib": list(bbox_of(visible)),
                "px_count_valid": int((amodal & valid).sum()),
            }
            for key, value in expected.items():
                if entry.get(key) != value:
                    report.fail(
                        where, "gt_info", f"{key} is {entry.get(key)} in scene_gt_info.json, the masks give {value}"
                    )
            all_px = entry.get("px_count_all", -1)
            if not isinstance(all_px, int) or all_px < int(amodal.sum()):
                report.fail(
                    scene / "mask" / f"{name}_{k:06d}.png",
                    "gt_info",
                    f"px_count_all {all_px} is below the amodal mask's {int(amodal.sum())} pixels",
                )
            elif not math.isclose(
                entry.get("visib_fract", -1.0), expected["px_count_visib"] / all_px if all_px else 0.0, abs_tol=1e-9
            ):
                report.fail(where, "gt_info", "visib_fract is not px_count_visib / px_count_all")
            if rendered is not None and visible.any():
                report.count("pose")
                depth_mm, labels = rendered
                here = visible & (labels == k + 1)
                if here.sum() < 0.9 * visible.sum():
                    report.fail(
                        scene / "scene_gt.json",
                        "pose",
                        f"image {im} instance {k}: the model at its pose "
                        f"covers {int(here.sum())} of its {int(visible.sum())} visible pixels",
                    )
                    continue
                residual = np.abs(depth_mm[here] - mm[here])
                median, p95 = float(np.median(residual)), float(np.percentile(residual, 95))
                if median > POSE_MEDIAN_MM or p95 > POSE_P95_MM:
                    report.fail(
                        scene / "scene_gt.json",
                        "pose",
                        f"image {im} instance {k}: depth residual median "
                        f"{median:.3f} mm, 95th percentile {p95:.3f} mm against the model at its pose",
                    )


def validate_dataset(dataset: Path) -> ValidationReport:
    """Checks a merged dataset (moonbot merge's tree) and returns what failed."""
    dataset = Path(dataset)
    report = ValidationReport()
    check_manifest(dataset, report)
    models = {}
    for path in sorted((dataset / "models").glob("obj_*.ply")):
        try:
            models[int(path.stem.split("_")[1])] = read_ply(path)
        except ValueError as e:
            report.fail(path, "models", str(e))
    metas = []
    for scene in scene_dirs(dataset):
        report.count("scenes")
        meta = check_layout(dataset, scene, report)
        if meta is not None:
            metas.append(meta)
        check_scene(scene, report, models)
    if not report.checked.get("scenes"):
        report.fail(dataset, "scenes", f"no scene directory (<bop split>/NNNNNN/ with {SCENE_META})")
    else:
        check_index(dataset, metas, report)
    return report


def check_layout(dataset: Path, scene: Path, report: ValidationReport) -> dict | None:
    """The scene sits where its scene_meta.json's split and scene_id put it, and its by_condition
    link leads to it. Returns the scene_meta.json content (None when unreadable)."""
    path = scene / SCENE_META
    try:
        meta = json.loads(path.read_text())
        want, view = (
            scene_rel(meta["split"], meta["scene_id"]),
            view_rel(meta["split"], meta["mesh"], meta["location"], meta["scene_id"]),
        )
    except (OSError, ValueError, KeyError, TypeError) as e:
        report.fail(path, "layout", f"unreadable or lacks split, scene_id, mesh or location ({e})")
        return None
    report.count("layout")
    here = scene.relative_to(dataset).as_posix()
    if here != want or meta.get("scene_dir") != want:
        report.fail(
            path,
            "layout",
            f"the scene is at {here} and says scene_dir {meta.get('scene_dir')!r}; its split "
            f"{meta['split']!r} and scene_id {meta['scene_id']} put it at {want}",
        )
    if meta.get("view") != view or not (dataset / view).is_dir() or (dataset / view).resolve() != scene.resolve():
        report.fail(dataset / view, "layout", f"the {VIEW_ROOT}/ link does not lead to {here}")
    return meta


def check_index(dataset: Path, metas: list[dict], report: ValidationReport) -> None:
    """scene_index.json and scene_index.parquet hold exactly the rows the scene_meta.json files
    give (moonbot.bop.scene_index), in dataset order."""
    try:
        want = {(r["bop_split"], r["scene_id"], r["task_in_scene"]): r for r in index_rows(metas)}
    except (KeyError, TypeError, ValueError) as e:
        report.fail(dataset, "index", f"a {SCENE_META} lacks a field the index needs ({e!r})")
        return
    for name in (SCENE_INDEX_JSON, SCENE_INDEX_PARQUET):
        path = dataset / name
        report.count("index")
        try:
            if name == SCENE_INDEX_JSON:
                content = json.loads(path.read_text())
                columns, rows = content["columns"], content["rows"]
            else:
                table = pq.read_table(path)
                columns, rows = table.column_names, table.to_pylist()
        except (OSError, ValueError, KeyError, TypeError) as e:
            report.fail(path, "index", f"unreadable ({e})")
            continue
        if list(columns) != list(COLUMNS):
            report.fail(path, "index", f"columns {list(columns)}, expected {list(COLUMNS)}")
            continue
        got = {(r["bop_split"], r["scene_id"], r["task_in_scene"]): r for r in rows}
        for key in sorted(set(want) | set(got), key=str):
            if want.get(key) != got.get(key):
                report.fail(
                    path, "index", f"row {key} is {got.get(key)}, the scene's {SCENE_META} gives {want.get(key)}"
                )
                break
