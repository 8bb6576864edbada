"""COCO run-length encoding of binary masks, as pycocotools defines it and as bop_toolkit's
`calc_gt_coco` and BOP-webdataset `mask*.json` files store it: the uncompressed form.

A mask (H, W) is read in column-major order (down the first column, then the next: Fortran
order, as pycocotools' `mask.encode` reads a Fortran-ordered array), and `counts` lists the
lengths of its alternating runs, starting with a run of 0s (of length 0 when the first pixel
is set). `size` is [H, W]. pycocotools decodes this form after `mask.frPyObjects(rle, H, W)`.
"""

from __future__ import annotations

import numpy as np


def encode_rle(mask: np.ndarray) -> dict:
    """Uncompressed COCO RLE of `mask` ((H, W), any dtype: nonzero = set): {"counts": [int, ...],
    "size": [H, W]}. The counts add up to H × W; an empty (0-pixel) mask has no counts."""
    mask = np.asarray(mask)
    if mask.ndim != 2:
        raise ValueError(f"a mask must be (H, W), got shape {mask.shape}")
    height, width = mask.shape
    column_major = (mask != 0).ravel(order="F")
    if column_major.size == 0:
        return {"counts": [], "size": [height, width]}
    starts = np.flatnonzero(column_major[1:] != column_major[:-1]) + 1
    runs = np.diff(np.concatenate(([0], starts, [column_major.size])))
    counts = ([0] if column_major[0] else []) + runs.tolist()
    return {"counts": counts, "size": [height, width]}
