"""A merged dataset in the formats other tools read: COCO instance annotations (coco.py:
scene_gt_coco.json as bop_toolkit's calc_gt_coco writes it, and one file per split for
detectron2 / mmdetection) and BOP-webdataset shards (webdataset.py). scenes.py is the one place
that knows where a dataset's scenes are."""

from moonbot.export.coco import (ExportError, scene_coco, scene_gt_coco_bytes, split_coco,
                                 write_split_cocos)
from moonbot.export.rle import encode_rle
from moonbot.export.scenes import SceneDir, dataset_scenes
from moonbot.export.webdataset import SplitShards, write_shards

__all__ = ["ExportError", "SceneDir", "SplitShards", "dataset_scenes", "encode_rle", "scene_coco",
           "scene_gt_coco_bytes", "split_coco", "write_shards", "write_split_cocos"]
