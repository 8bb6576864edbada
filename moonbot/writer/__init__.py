"""The writer stage: one sample's files, encoded and written atomically."""

from moonbot.writer.sample import DEPTH_SCALE_MM, depth_preview, depth_to_png16, pose_m2c, write_sample

__all__ = ["DEPTH_SCALE_MM", "depth_preview", "depth_to_png16", "pose_m2c", "write_sample"]
