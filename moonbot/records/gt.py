"""gt.json: one rendered view's ground truth, written last into its view folder
(moonbot.writer.sample), so its presence marks a complete view; merge reads it into the BOP scene
files. Keys in the order below (not sorted), indent 2.

Units and frames are bop_toolkit's: mm, R row-major (9 numbers), OpenCV camera; `cam_*_w2c` take
world points (m × 1000) to the camera, `cam_*_m2c` model points (mm) to the camera.

Version 1 (no schema_version) has the same fields."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from moonbot.records.base import SCHEMA_VERSION, add_schema_version, decode, read_json, to_json, write_json

GT = "gt.json"


def _numbers(n: int) -> dict:
    return {"length": n}


@dataclass(frozen=True, kw_only=True)
class InstanceRecord:
    """One bag in the view: its instance id (the label in mask.png), BOP obj_id, pose, visible
    pixels; with amodal masks also the mask's file in the view folder, the pixels of its
    silhouette on bop_toolkit's 3W × 3H canvas and its [x, y, w, h] box (image pixels,
    [-1, -1, -1, -1] when empty)."""

    instance_id: int = dataclasses.field(metadata={"lo": 1})
    obj_id: int = dataclasses.field(metadata={"lo": 0})
    cam_R_m2c: tuple[float, ...] = dataclasses.field(metadata=_numbers(9))
    cam_t_m2c: tuple[float, ...] = dataclasses.field(metadata=_numbers(3))
    px_count_visib: int = dataclasses.field(metadata={"lo": 0})
    mask_amodal: str | None = None
    px_count_all: int | None = None
    bbox_all: tuple[int, ...] | None = dataclasses.field(default=None, metadata=_numbers(4))

    def __post_init__(self) -> None:
        if self.mask_amodal is not None and ("/" in self.mask_amodal or self.mask_amodal.startswith(".")):
            raise ValueError(f"mask_amodal: must be a file name in the view, got {self.mask_amodal!r}")


@dataclass(frozen=True, kw_only=True)
class GtRecord:
    """gt.json. `cam_K` the 3 × 3 intrinsics row-major (pixels), `depth_scale` mm per depth.png
    unit, `instances` the scene's bags in instance-id order. The nested objects no reader
    interprets are kept as written: `exposure` (moonbot.render.exposure), `rgb_exr` (present when
    rgb.exr was written), `sun`, `dust` (present in a dusty scene), `site` (present at a DEM
    location: the world frame is its East-North-Up), `timings_s` (seconds per stage)."""

    cam_K: tuple[float, ...] = dataclasses.field(metadata=_numbers(9))
    width: int = dataclasses.field(metadata={"lo": 1})
    height: int = dataclasses.field(metadata={"lo": 1})
    depth_scale: float = dataclasses.field(metadata={"lo": 0, "lo_open": True})
    cam_R_w2c: tuple[float, ...] = dataclasses.field(metadata=_numbers(9))
    cam_t_w2c: tuple[float, ...] = dataclasses.field(metadata=_numbers(3))
    instances: tuple[InstanceRecord, ...]
    exposure: dict[str, Any]
    rgb_invalid_pixels: int = dataclasses.field(metadata={"lo": 0})
    rgb_exr: dict[str, Any] | None = None
    view: int = dataclasses.field(metadata={"lo": 0})
    camera_azimuth_deg: float
    camera_height_m: float
    sun: dict[str, Any]
    render_seed: int
    config_hash: str
    moonbot_version: str
    dust: dict[str, Any] | None = None
    site: dict[str, Any] | None = None
    timings_s: dict[str, float]
    schema_version: int = SCHEMA_VERSION

    def as_json(self) -> dict:
        """The record as the JSON object gt.json holds."""
        return to_json(self)


UPGRADES = {1: add_schema_version}


def read_gt(path: Path, sha256: str | None = None) -> GtRecord:
    """A gt.json file; with `sha256`, its bytes must have that checksum (DONE.json's). RecordError
    naming the file and the field path (e.g. "instances[2].cam_R_m2c: must have 9 items, got 8")."""
    return decode(GtRecord, read_json(path, sha256), str(path), UPGRADES)


def write_gt(path: Path, record: GtRecord) -> None:
    """`record` to `path` atomically (keys in field order, indent 2)."""
    write_json(path, record, sort_keys=False)
