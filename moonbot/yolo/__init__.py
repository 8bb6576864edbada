"""YOLO (Ultralytics) labels of the visible instance masks: one polygon per instance
(moonbot.yolo.polygon), detection and segmentation rows and the dataset YAML (moonbot.yolo.labels),
and the yolo/ trees of a merged dataset, read from it (moonbot.yolo.export)."""

from moonbot.yolo.labels import CLASS_NAMES, data_yaml, detect_row, segment_row, yolo_class
from moonbot.yolo.polygon import DEFAULT_TOLERANCE_PX, boundary_loops, mask_polygon, simplify_loop

__all__ = [
    "CLASS_NAMES",
    "DEFAULT_TOLERANCE_PX",
    "boundary_loops",
    "data_yaml",
    "detect_row",
    "mask_polygon",
    "segment_row",
    "simplify_loop",
    "yolo_class",
]
