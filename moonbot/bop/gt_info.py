"""scene_gt_info.json entries as bop_toolkit's scripts/calc_gt_info.py defines them
(as bop_toolkit's scripts/calc_gt_info.py computes it), from moonbot's masks instead of a re-render:

- `px_count_all`: pixels of the instance's silhouette rendered alone on a 3W × 3H canvas (so the
  part cut off by the image border counts) — computed when the view is rendered
  (moonbot.render.amodal) and read from gt.json;
- `px_count_valid`: pixels of the in-image amodal silhouette where the depth image is valid
  (depth.png > 0);
- `px_count_visib`: pixels of the visible mask (mask_visib);
- `visib_fract` = px_count_visib / px_count_all (0.0 when px_count_all is 0);
- `bbox_obj`: box of the whole canvas silhouette in image coordinates (may reach outside the
  image), `bbox_visib`: box of the visible mask; both [x, y, w, h] with w = max x − min x and
  h = max y − min y (no +1, bop_toolkit's misc.calc_2d_bbox), and both [-1, -1, -1, -1] when
  px_count_visib is 0 (bbox_obj too, as bop_toolkit does).

Pixel (x, y) is the square [x, x+1) × [y, y+1); its ray passes through its centre (x + 0.5,
y + 0.5), as bop_toolkit's renderer assumes.

The visible mask is the renderer's instance mask (mask.png == instance id): the pixels whose
centre ray meets this instance first. bop_toolkit instead estimates visibility from depth with a
tolerance δ (15 mm by default), which also calls visible the pixels where the instance lies less
than δ behind another surface; the two differ only along contacts (a bag on another or on the
ground), where bop_toolkit's masks of neighbours overlap and moonbot's do not.
"""

from __future__ import annotations

import numpy as np

NO_BOX = (-1, -1, -1, -1)


def bbox_of(mask: np.ndarray) -> tuple[int, int, int, int]:
    """[x, y, w, h] of the True pixels of `mask` (H, W) bool, bop_toolkit's convention (w = max x −
    min x, no +1), in pixel indices; NO_BOX when the mask is empty."""
    rows = np.flatnonzero(mask.any(axis=1))
    if rows.size == 0:
        return NO_BOX
    cols = np.flatnonzero(mask.any(axis=0))
    return int(cols[0]), int(rows[0]), int(cols[-1] - cols[0]), int(rows[-1] - rows[0])


def gt_info_entry(
    amodal: np.ndarray,
    visible: np.ndarray,
    depth_valid: np.ndarray,
    px_count_all: int,
    bbox_all: tuple[int, int, int, int] | list[int],
) -> dict:
    """One scene_gt_info.json entry. `amodal` (H, W) bool: the instance alone, in the image;
    `visible` (H, W) bool: its visible part; `depth_valid` (H, W) bool: depth.png > 0;
    `px_count_all` and `bbox_all` ([x, y, w, h], image pixels): its silhouette alone on the
    3W × 3H canvas, as recorded in gt.json. Returns the six bop_toolkit fields (ints; visib_fract
    a float in [0, 1])."""
    px_count_visib = int(np.count_nonzero(visible))
    px_count_valid = int(np.count_nonzero(amodal & depth_valid))
    visib_fract = px_count_visib / float(px_count_all) if px_count_all > 0 else 0.0
    return {
        "bbox_obj": [int(v) for v in bbox_all] if px_count_visib > 0 else list(NO_BOX),
        "bbox_visib": list(bbox_of(visible)),
        "px_count_all": int(px_count_all),
        "px_count_valid": px_count_valid,
        "px_count_visib": px_count_visib,
        "visib_fract": float(visib_fract),
    }
