"""The BOP layout: object models (models.py), scene_gt_info entries as bop_toolkit defines them
(gt_info.py), what OUT/tasks holds (inventory.py) and the merge of complete tasks into one BOP
dataset with a manifest (merge.py: scene folders in scene_build.py, dataset_info.json in
dataset_info.py, files and the manifest in dataset_files.py)."""

from moonbot.bop.gt_info import bbox_of, gt_info_entry
from moonbot.bop.inventory import Inventory, MergeError, SceneTasks, TaskDir, scan_tasks
from moonbot.bop.merge import EXIT_INCOMPLETE, MergeReport, merge_dataset
from moonbot.bop.models import ModelInfo, diameter, find_symmetries, model_info, sample_surface, write_models, write_ply

__all__ = [
    "EXIT_INCOMPLETE",
    "Inventory",
    "MergeError",
    "MergeReport",
    "ModelInfo",
    "SceneTasks",
    "TaskDir",
    "bbox_of",
    "diameter",
    "find_symmetries",
    "gt_info_entry",
    "merge_dataset",
    "model_info",
    "sample_surface",
    "scan_tasks",
    "write_models",
    "write_ply",
]
