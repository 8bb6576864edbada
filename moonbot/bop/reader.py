"""Reading a merged moonbot dataset (moonbot merge's tree, docs/dataset-format.md): its splits' scenes with
their conditions and BOP annotations, each image's metric depth and visible masks, and the object
models with their models_info.json. The evaluation and the baseline read through here.

Layout (moonbot.bop.layout): DATASET/<bop split>/NNNNNN/ with scene_gt.json, scene_camera.json,
scene_gt_info.json and scene_meta.json (moonbot's conditions: split, mesh, location, bags,
stain_seeds, dust); depth_npy/NNNNNN.npy (H, W) float32 metres; mask_visib/NNNNNN_KKKKKK.png
(instance K's visible pixels, 0/255). Scene ids are unique within a split, so (split, scene_id,
im_id) names an image, and the BOP results CSV's scene_id is the split's scene_id."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from moonbot import _core
from moonbot.bop.layout import SCENE_META, bop_split, scene_dirs
from moonbot.bop.models import read_ply


class DatasetError(ValueError):
    """A dataset file is missing or malformed; the message names the file."""


def load_json(path: Path):
    """A dataset JSON file's content; DatasetError naming the file when it is missing or not JSON."""
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise DatasetError(f"{path}: missing") from None
    except (OSError, ValueError) as e:
        raise DatasetError(f"{path}: unreadable ({e})") from None


@dataclass(frozen=True)
class Instance:
    """One ground-truth object instance in one image. R (3, 3) float64 model→camera, t (3,)
    float64 mm; `px_visib` its visible pixels and `visib_fract` the visible share of its
    silhouette (scene_gt_info.json); `index` its position in the image's scene_gt list (the K of
    its mask files)."""

    index: int
    obj_id: int
    R: np.ndarray
    t: np.ndarray
    px_visib: int
    visib_fract: float


@dataclass(frozen=True)
class Scene:
    """One scene directory and what its JSON files say. `images` maps im_id to its instances;
    `cameras` maps im_id to cam_K (3, 3) float64 pixels."""

    path: Path
    split: str
    scene_id: int
    mesh: str
    location: str
    bags: int
    stain_seeds: int
    dust: bool
    images: dict[int, list[Instance]]
    cameras: dict[int, np.ndarray]

    @property
    def stain(self) -> str:
        """'clean' (no stain seeds) or 'stained'; the paper's Table 3 clean/dirty column."""
        return "clean" if self.stain_seeds == 0 else "stained"

    def depth_m(self, im_id: int) -> np.ndarray:
        """Image im_id's z-depth (H, W) float32 metres, 0 where no surface."""
        path = self.path / "depth_npy" / f"{im_id:06d}.npy"
        try:
            return np.load(path)
        except (OSError, ValueError) as e:
            raise DatasetError(f"{path}: unreadable ({e})") from None

    def mask_visib(self, im_id: int, index: int, shape: tuple[int, int]) -> np.ndarray:
        """Instance `index`'s visible mask in image im_id, (H, W) bool."""
        path = self.path / "mask_visib" / f"{im_id:06d}_{index:06d}.png"
        try:
            return _core.read_image(str(path)).reshape(shape) > 0
        except (OSError, ValueError) as e:
            raise DatasetError(f"{path}: unreadable ({e})") from None


def read_scene(path: Path) -> Scene:
    """Reads one scene directory's JSON files. Raises DatasetError naming the file."""
    path = Path(path)
    meta = load_json(path / SCENE_META)
    gt = load_json(path / "scene_gt.json")
    info = load_json(path / "scene_gt_info.json")
    camera = load_json(path / "scene_camera.json")
    images, cameras = {}, {}
    try:
        for im, entries in gt.items():
            instances = []
            for k, entry in enumerate(entries):
                gi = info[im][k]
                instances.append(
                    Instance(
                        k,
                        int(entry["obj_id"]),
                        np.array(entry["cam_R_m2c"], np.float64).reshape(3, 3),
                        np.array(entry["cam_t_m2c"], np.float64).reshape(3),
                        int(gi["px_count_visib"]),
                        float(gi["visib_fract"]),
                    )
                )
            images[int(im)] = instances
            cameras[int(im)] = np.array(camera[im]["cam_K"], np.float64).reshape(3, 3)
    except (KeyError, IndexError, TypeError, ValueError) as e:
        raise DatasetError(
            f"{path}: scene_gt/scene_gt_info/scene_camera.json disagree or lack a field ({e!r})"
        ) from None
    try:
        return Scene(
            path,
            str(meta["split"]),
            int(meta["scene_id"]),
            str(meta["mesh"]),
            str(meta["location"]),
            int(meta["bags"]),
            int(meta["stain_seeds"]),
            bool(meta["dust"]),
            images,
            cameras,
        )
    except (KeyError, TypeError, ValueError) as e:
        raise DatasetError(f"{path / SCENE_META}: lacks a field ({e!r})") from None


def scenes(dataset: Path, split: str | None = None) -> list[Scene]:
    """Every scene of the dataset (or of one split, named as the sweep names it, `train`, or by
    its BOP directory, `train_pbr`), in (split, scene_id) order. Raises DatasetError naming the
    dataset when there is none."""
    dataset = Path(dataset)
    paths = scene_dirs(dataset)
    if split is not None:
        paths = [p for p in paths if p.parent.name in (split, bop_split(split))]
    found = [read_scene(p) for p in paths]
    if split is not None:
        found = [s for s in found if split in (s.split, bop_split(s.split))]
    if not found:
        where = f"{dataset}/{bop_split(split)}" if split else str(dataset)
        raise DatasetError(
            f"{where}: no scene directory (<bop split>/NNNNNN/ with {SCENE_META}); "
            "a dataset is what `moonbot merge` writes"
        )
    return sorted(found, key=lambda s: (s.split, s.scene_id))


@dataclass(frozen=True)
class Model:
    """One object model: vertices (N, 3) float64 mm, triangles (M, 3) int64, its diameter (mm)
    and discrete symmetries (tuple of (4, 4) float64, model frame, mm) from models_info.json."""

    obj_id: int
    vertices: np.ndarray
    triangles: np.ndarray
    diameter: float
    symmetries: tuple[np.ndarray, ...]


def read_models(dataset: Path, kind: str = "models_eval") -> dict[int, Model]:
    """The dataset's models of one kind ('models' or 'models_eval', docs/dataset-format.md) by obj_id.
    Raises DatasetError naming the file."""
    folder = Path(dataset) / kind
    info = load_json(folder / "models_info.json")
    models = {}
    for obj, entry in info.items():
        path = folder / f"obj_{int(obj):06d}.ply"
        try:
            vertices, triangles = read_ply(path)
        except FileNotFoundError:
            raise DatasetError(f"{path}: missing (listed in {folder / 'models_info.json'})") from None
        except (OSError, ValueError) as e:
            raise DatasetError(f"{path}: unreadable ({e})") from None
        symmetries = tuple(np.array(s, np.float64).reshape(4, 4) for s in entry.get("symmetries_discrete", []))
        models[int(obj)] = Model(int(obj), vertices, triangles, float(entry["diameter"]), symmetries)
    return models
