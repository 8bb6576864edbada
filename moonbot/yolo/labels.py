"""YOLO label rows and dataset YAMLs in the Ultralytics layout
(docs.ultralytics.com/datasets/detect and /segment):

    <root>/data.yaml
    <root>/images/<split>/<name>.png
    <root>/labels/<split>/<name>.txt      one row per visible instance; empty: no instance visible

A detection row is `class cx cy w h`, a segmentation row `class x1 y1 x2 y2 ... xn yn`, all
normalised by the image width and height to [0, 1], six decimals. Class = BOP obj_id − 1
(sandbag-01 → 0). Both are taken from the instance's visible mask: the box spans its pixels' edges
(x from the leftmost pixel's left edge to the rightmost pixel's right edge, so its width in pixels
is bop_toolkit's bbox_visib w + 1), the polygon is moonbot.yolo.polygon.mask_polygon (one ring
per instance, at least four distinct points, its extent exactly that box). A file holds rows of
one kind only: Ultralytics reads a whole file as segments when any row has more than 6 columns.
"""

from __future__ import annotations

import numpy as np

from moonbot.config.schema import MeshesConfig
from moonbot.yolo.polygon import DEFAULT_TOLERANCE_PX, mask_polygon

# Class index → name of the built-in variants: obj_id − 1 → the mesh; user meshes follow
# (MeshesConfig.objects).
CLASS_NAMES = {obj_id - 1: name for obj_id, name in MeshesConfig().objects().items()}


def yolo_class(obj_id: int) -> int:
    """The YOLO class of a BOP obj_id (1-based → 0-based). ValueError for an obj_id below 1."""
    if obj_id < 1:
        raise ValueError(f"obj_id: {obj_id} is not a BOP object id (1, 2, ...)")
    return obj_id - 1


def _fmt(values) -> str:
    return " ".join(f"{float(v):.6f}" for v in values)


def detect_row(obj_id: int, visible: np.ndarray) -> str | None:
    """`class cx cy w h` of the box around the True pixels of `visible` (H, W) bool, normalised
    by W and H; None when nothing is visible."""
    rows = np.flatnonzero(visible.any(axis=1))
    if rows.size == 0:
        return None
    cols = np.flatnonzero(visible.any(axis=0))
    h, w = visible.shape
    x0, x1 = float(cols[0]), float(cols[-1] + 1)  # pixel edges
    y0, y1 = float(rows[0]), float(rows[-1] + 1)
    return f"{yolo_class(obj_id)} " + _fmt(((x0 + x1) / (2 * w), (y0 + y1) / (2 * h), (x1 - x0) / w, (y1 - y0) / h))


def segment_row(obj_id: int, visible: np.ndarray, tolerance: float = DEFAULT_TOLERANCE_PX) -> str | None:
    """`class x1 y1 ... xn yn`: the ring of `visible` (H, W) bool normalised by W and H; None when
    nothing is visible."""
    ring = mask_polygon(visible, tolerance)
    if ring is None:
        return None
    h, w = visible.shape
    xy = np.clip(ring / (w, h), 0.0, 1.0)
    return f"{yolo_class(obj_id)} " + _fmt(xy.reshape(-1))


def data_yaml(splits: list[str], task: str, objects: dict[int, str] | None = None) -> str:
    """The dataset YAML of one YOLO tree whose images/ holds `splits` (dataset order). `train` is
    the split named train, else the first that is neither val nor test; `val` the split named val.
    A model must not be selected on its test images, so without a val split `val` is the training
    images, and a comment says so (Ultralytics requires a `val`). A dataset of evaluation splits
    only (val and/or test) points train and val at the first of them, to be scored with `yolo val`.
    `test` is the split named test when there is one. No `path`: Ultralytics then takes the YAML's
    own directory as the root, so the tree can be moved. `objects`: {obj_id: name} of the dataset
    (MeshesConfig.objects; None: the built-in variants), ids 1..n without gaps as MeshesConfig
    numbers them."""
    if not splits:
        raise ValueError("splits: a YOLO dataset needs at least one split")
    lines = [f"# moonbot {task} labels of the visible instance masks (Ultralytics layout); class = BOP obj_id - 1"]
    training = [s for s in splits if s not in ("val", "test")]
    train = "train" if "train" in splits else training[0] if training else splits[0]
    if not training:
        lines.append(f"# evaluation splits only: train and val are the {train} images, for `yolo val`")
        val = train
    elif "val" in splits:
        val = "val"
    else:
        lines.append(
            "# no val split in this dataset (a sweep split with draw_from adds one): val is the training images"
        )
        val = train
    lines += [f"train: images/{train}", f"val: images/{val}"]
    if "test" in splits:
        lines.append("test: images/test")
    names = CLASS_NAMES if objects is None else {obj_id - 1: name for obj_id, name in objects.items()}
    lines.append(f"nc: {len(names)}")
    lines.append("names:")
    lines += [f"  {k}: {name}" for k, name in sorted(names.items())]
    return "\n".join(lines) + "\n"
