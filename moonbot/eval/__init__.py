"""Evaluation (issue 8): pose-error metrics as the BOP toolkit and the YCB-Video convention define
them, the BOP results CSV the estimates come in, and a merged dataset's self-consistency."""

from moonbot.eval.metrics import add, adds, auc, match_greedy, recall, translation_error
from moonbot.eval.results import Estimate, ResultsError, read_results
from moonbot.eval.validate import ValidationReport, validate_dataset

__all__ = ["Estimate", "ResultsError", "ValidationReport", "add", "adds", "auc", "match_greedy", "read_results",
           "recall", "translation_error", "validate_dataset"]
