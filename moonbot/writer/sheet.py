"""A contact sheet for people debugging a scene: per view, the written rgb.png, depth_preview.png
and mask.png (coloured by instance) side by side, read back from disk so the sheet shows exactly
what was written."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from moonbot import _core

_GAP = 2          # pixels between tiles and cells
_GAP_GREY = 64


def colour_mask(instance: np.ndarray) -> np.ndarray:
    """Instance ids (H, W) uint8 → (H, W, 3) uint8 colours: 0 (background) black, each id a
    distinct saturated hue (golden-angle steps, so neighbouring ids differ strongly)."""
    ids = np.arange(256)
    hue = (ids * 0.381966) % 1.0
    k = (np.array([5.0, 3.0, 1.0])[None, :] + hue[:, None] * 6.0) % 6.0  # HSV→RGB, S = V = 1
    palette = (255 * (1.0 - np.clip(np.minimum(k, 4.0 - k), 0.0, 1.0))).astype(np.uint8)
    palette[0] = 0
    return palette[instance]


def write_sheet(view_dirs: list[Path], path: Path, png_compression: int = 1) -> None:
    """Writes `path` (PNG): one cell per view directory, each rgb | depth | mask, cells in a grid
    about as wide as it is tall. Large images are shown at an integer reduction (nearest pixel)."""
    cells = []
    for d in view_dirs:
        rgb = _core.read_image(str(d / "rgb.png"))
        depth = _core.read_image(str(d / "depth_preview.png"))
        mask = colour_mask(_core.read_image(str(d / "mask.png")))
        tiles = [rgb, np.repeat(depth[..., None], 3, axis=2), mask]
        cells.append(_hstack(tiles))
    step = max(1, math.ceil(cells[0].shape[1] / (960 if len(cells) == 1 else 480)))
    cells = [c[::step, ::step] for c in cells]
    columns = max(1, round(math.sqrt(len(cells) * cells[0].shape[0] / cells[0].shape[1])))
    rows = [_hstack(cells[i:i + columns], pad_to=columns) for i in range(0, len(cells), columns)]
    _core.write_image(str(path), _vstack(rows), png_compression)


def _hstack(images: list[np.ndarray], pad_to: int = 0) -> np.ndarray:
    h, w = images[0].shape[:2]
    n = max(len(images), pad_to)
    out = np.full((h, n * w + (n - 1) * _GAP, 3), _GAP_GREY, np.uint8)
    for i, img in enumerate(images):
        out[:, i * (w + _GAP):i * (w + _GAP) + w] = img
    return out


def _vstack(images: list[np.ndarray]) -> np.ndarray:
    h, w = images[0].shape[:2]
    out = np.full((len(images) * h + (len(images) - 1) * _GAP, w, 3), _GAP_GREY, np.uint8)
    for i, img in enumerate(images):
        out[i * (h + _GAP):i * (h + _GAP) + h] = img
    return out
