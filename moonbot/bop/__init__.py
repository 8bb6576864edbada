"""The BOP layout: object models now; paths, merge and gt_info as the generation issue lands."""

from moonbot.bop.models import (ModelInfo, diameter, find_symmetries, model_info, sample_surface,
                                vertex_normals, write_models, write_ply)

__all__ = ["ModelInfo", "diameter", "find_symmetries", "model_info", "sample_surface",
           "vertex_normals", "write_models", "write_ply"]
