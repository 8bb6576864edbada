"""Evaluation: pose-error metrics as the BOP toolkit and the YCB-Video convention define
them, the BOP results CSV the estimates come in, estimates scored per condition and per visible-pixel
bin (`moonbot eval`: report.py, with matching.py, tables.py, formatting.py and plots.py), and a
merged dataset's self-consistency."""

from moonbot.eval.matching import EvalError, Evaluation, InstanceResult, ModelPoints, assign_greedy, evaluate
from moonbot.eval.metrics import add, adds, auc, match_greedy, recall, translation_error
from moonbot.eval.report import EvalReport, run_eval
from moonbot.eval.results import Estimate, ResultsError, format_estimate, read_results, write_results
from moonbot.eval.tables import DEFAULT_PX_BINS, ConditionRow, PixelRow, Summary, summarize, table3, table4
from moonbot.eval.validate import ValidationReport, validate_dataset

__all__ = [
    "DEFAULT_PX_BINS",
    "ConditionRow",
    "Estimate",
    "EvalError",
    "EvalReport",
    "Evaluation",
    "InstanceResult",
    "ModelPoints",
    "PixelRow",
    "ResultsError",
    "Summary",
    "ValidationReport",
    "add",
    "adds",
    "assign_greedy",
    "auc",
    "evaluate",
    "format_estimate",
    "match_greedy",
    "read_results",
    "recall",
    "run_eval",
    "summarize",
    "table3",
    "table4",
    "translation_error",
    "validate_dataset",
    "write_results",
]
