"""A merged dataset in the formats other tools read: one COCO file per split for detectron2 /
mmdetection (coco.py, gathering the scenes' scene_gt_coco.json, which moonbot.bop.coco writes as
bop_toolkit's calc_gt_coco does) and BOP-webdataset shards (webdataset.py). scenes.py is the one
place that knows where a dataset's scenes are. It reads datasets through moonbot.bop, which never
imports it."""

from moonbot.export.coco import split_coco, write_split_cocos
from moonbot.export.scenes import SceneDir, dataset_scenes
from moonbot.export.webdataset import SplitShards, write_shards

__all__ = ["SceneDir", "SplitShards", "dataset_scenes", "split_coco", "write_shards", "write_split_cocos"]
