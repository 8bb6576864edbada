"""The zero-shot pose baseline: principal-axes hypotheses refined by point-to-plane ICP
against the object's mesh, from depth, a visible mask and K (estimator.py), run over a dataset
split into a BOP results CSV (run.py)."""

from moonbot.baseline.estimator import Estimate, ModelCloud, Settings, estimate_pose
from moonbot.baseline.run import BaselineReport, default_workers, run_baseline

__all__ = ["BaselineReport", "Estimate", "ModelCloud", "Settings", "default_workers", "estimate_pose", "run_baseline"]
