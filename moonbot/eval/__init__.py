"""Evaluation (issue 8): pose-error metrics as the BOP toolkit and the YCB-Video convention define
them, and the BOP results CSV the estimates come in."""

from moonbot.eval.metrics import add, adds, auc, match_greedy, recall, translation_error
from moonbot.eval.results import Estimate, ResultsError, read_results

__all__ = ["Estimate", "ResultsError", "add", "adds", "auc", "match_greedy", "read_results", "recall",
           "translation_error"]
