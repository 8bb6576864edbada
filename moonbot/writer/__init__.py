"""The writer stage: one sample's files, encoded and written atomically (a file and a whole
view directory are each complete or absent: moonbot.atomic_io)."""

from moonbot.writer.sample import (
    AMODAL_FILE,
    DEPTH_SCALE_MM,
    RADIANCE_UNIT,
    depth_preview,
    depth_to_png16,
    finite_radiance,
    pose_m2c,
    write_sample,
)
from moonbot.writer.sheet import colour_mask, write_sheet

__all__ = [
    "AMODAL_FILE",
    "DEPTH_SCALE_MM",
    "RADIANCE_UNIT",
    "colour_mask",
    "depth_preview",
    "depth_to_png16",
    "finite_radiance",
    "pose_m2c",
    "write_sample",
    "write_sheet",
]
