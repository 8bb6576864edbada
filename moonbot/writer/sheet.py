"""A contact sheet for people debugging a scene: per view, the written rgb.png, depth_preview.png
and mask.png (coloured by instance) side by side under a label naming the view, its azimuth and
each tile, read back from disk so the sheet shows exactly what was written."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from moonbot import _core
from moonbot.records.base import RecordError
from moonbot.records.gt import GT, read_gt

_GAP = 2  # pixels between tiles and cells
_GAP_GREY = 64
LABEL_PX = 14  # height of the label strip above each view's tiles
_LABEL_GREY = 32


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
    """Writes `path` (PNG): one cell per view directory, each a label strip (LABEL_PX rows: "view
    NNN, az A°", "depth", "mask" over their tiles) above rgb | depth (near: bright) | coloured
    mask, cells in a grid about as wide as it is tall. Large images are shown at an integer
    reduction (nearest pixel); the labels are not reduced."""
    tiles_per_view = []
    for d in view_dirs:
        rgb = _core.read_image(str(d / "rgb.png"))
        depth = _core.read_image(str(d / "depth_preview.png"))
        mask = colour_mask(_core.read_image(str(d / "mask.png")))
        tiles_per_view.append([rgb, np.repeat(depth[..., None], 3, axis=2), mask])
    tile_w = tiles_per_view[0][0].shape[1]
    step = max(1, math.ceil((3 * tile_w + 2 * _GAP) / (960 if len(view_dirs) == 1 else 480)))
    cells = []
    for d, tiles in zip(view_dirs, tiles_per_view):
        tiles = [t[::step, ::step] for t in tiles]
        labels = [_view_name(d), "depth", "mask"]
        cells.append(np.concatenate([label_strip(labels, tiles[0].shape[1], _GAP), _hstack(tiles)]))
    columns = max(1, round(math.sqrt(len(cells) * cells[0].shape[0] / cells[0].shape[1])))
    rows = [_hstack(cells[i : i + columns], pad_to=columns) for i in range(0, len(cells), columns)]
    _core.write_image(str(path), _vstack(rows), png_compression)


def _view_name(view_dir: Path) -> str:
    """ "view NNN, az A°" from the view's gt.json (its folder's name alone when that is unreadable)."""
    try:
        azimuth = read_gt(view_dir / GT).camera_azimuth_deg
        return f"{view_dir.name.replace('_', ' ')}, az {azimuth:g}°"
    except RecordError:
        return view_dir.name.replace("_", " ")


def label_strip(labels: list[str], tile_w: int, gap: int) -> np.ndarray:
    """(LABEL_PX, n·tile_w + (n-1)·gap, 3) uint8: each label in light grey on dark grey, left-aligned
    over its tile and clipped to it, drawn by matplotlib's Agg renderer (DejaVu Sans, shipped with
    matplotlib, so the pixels are the same on every machine with the same matplotlib)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import Rectangle

    width = len(labels) * tile_w + (len(labels) - 1) * gap
    dpi = 100
    fig = Figure(figsize=(width / dpi, LABEL_PX / dpi), dpi=dpi, facecolor=(_LABEL_GREY / 255,) * 3)
    canvas = FigureCanvasAgg(fig)
    for i, text in enumerate(labels):
        left = i * (tile_w + gap)
        artist = fig.text(
            (left + 2) / width,
            0.5,
            text,
            ha="left",
            va="center",
            color="0.85",
            fontsize=0.62 * LABEL_PX * 72 / dpi,
            family="DejaVu Sans",
        )
        artist.set_clip_path(Rectangle((left, 0), tile_w, LABEL_PX, transform=None))  # display pixels
    canvas.draw()
    pixels = np.asarray(canvas.buffer_rgba())[..., :3]
    strip = np.full((LABEL_PX, width, 3), _LABEL_GREY, np.uint8)
    h, w = min(LABEL_PX, pixels.shape[0]), min(width, pixels.shape[1])
    strip[:h, :w] = pixels[:h, :w]
    return strip


def _hstack(images: list[np.ndarray], pad_to: int = 0) -> np.ndarray:
    h, w = images[0].shape[:2]
    n = max(len(images), pad_to)
    out = np.full((h, n * w + (n - 1) * _GAP, 3), _GAP_GREY, np.uint8)
    for i, img in enumerate(images):
        out[:, i * (w + _GAP) : i * (w + _GAP) + w] = img
    return out


def _vstack(images: list[np.ndarray]) -> np.ndarray:
    h, w = images[0].shape[:2]
    out = np.full((len(images) * h + (len(images) - 1) * _GAP, w, 3), _GAP_GREY, np.uint8)
    for i, img in enumerate(images):
        out[i * (h + _GAP) : i * (h + _GAP) + h] = img
    return out
