"""`moonbot eval`: pose estimates (a BOP results CSV) scored against a merged dataset's ground
truth, per condition as the paper's Table 3 and per visible-pixel bin as its Table 4. The parts:
the matching and each instance's errors (moonbot.eval.matching, which documents the rules), the
tables (moonbot.eval.tables), their text and CSV (moonbot.eval.formatting) and the plots
(moonbot.eval.plots)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from moonbot.atomic_io import atomic_write
from moonbot.bop.reader import read_models
from moonbot.bop.reader import scenes as read_scenes
from moonbot.eval import plots
from moonbot.eval.formatting import format_table3, format_table4, per_instance_csv, table3_csv, table4_csv
from moonbot.eval.matching import EvalError, Evaluation, evaluate, unknown_message
from moonbot.eval.results import read_results
from moonbot.eval.tables import DEFAULT_PX_BINS, ConditionRow, PixelRow, check_bins, table3, table4


@dataclass
class EvalReport:
    """What run_eval did: the evaluation, both tables and their text, the files written."""

    evaluation: Evaluation
    table3: list[ConditionRow]
    table4: list[PixelRow]
    table3_text: str
    table4_text: str
    files: list[Path]


def run_eval(
    dataset: Path,
    results_path: Path,
    split: str = "test",
    out_dir: Path | None = None,
    min_visib_fract: float = 0.0,
    px_bins: Sequence[float] = DEFAULT_PX_BINS,
    allow_unknown: bool = False,
    workers: int = 1,
    progress: Callable[[int, int], None] | None = None,
) -> EvalReport:
    """`moonbot eval`: reads the split's scenes, models_eval and the results CSV, evaluates, and
    writes table3.txt/.csv, table4.txt/.csv, per_instance.csv, adds_vs_visible_pixels.png and
    recall_by_condition.png into out_dir (default DATASET/eval), each file atomically. Raises
    ResultsError (malformed CSV, naming file:line), DatasetError (naming the missing or bad file),
    EvalError (estimates of images or objects the split lacks, unless allow_unknown), ValueError
    (bad bin edges) and OSError."""
    dataset, results_path = Path(dataset), Path(results_path)
    px_bins = check_bins(px_bins)
    estimates = read_results(results_path)
    split_scenes = read_scenes(dataset, split)
    models = read_models(dataset, "models_eval")
    evaluation = evaluate(split_scenes, models, estimates, min_visib_fract, workers, progress)
    if evaluation.unknown and not allow_unknown:
        raise EvalError(
            f"{len(evaluation.unknown)} estimates do not fit {dataset} split {split!r}:\n"
            + unknown_message(evaluation, results_path)
        )
    rows3, rows4 = table3(evaluation), table4(evaluation, px_bins)
    text3, text4 = format_table3(rows3, evaluation), format_table4(rows4, evaluation)
    out_dir = Path(out_dir) if out_dir is not None else dataset / "eval"
    out_dir.mkdir(parents=True, exist_ok=True)
    texts = {
        "table3.txt": text3,
        "table3.csv": table3_csv(rows3),
        "table4.txt": text4,
        "table4.csv": table4_csv(rows4),
        "per_instance.csv": per_instance_csv(evaluation),
    }
    files = []
    for name, text in texts.items():
        atomic_write(out_dir / name, "w", lambda f, text=text: f.write(text))
        files.append(out_dir / name)
    title = f"{dataset.name} {split} — {results_path.name}"
    for name, png in (
        ("adds_vs_visible_pixels.png", plots.adds_vs_visible_pixels(evaluation, px_bins, title)),
        ("recall_by_condition.png", plots.recall_by_condition(rows3, title)),
    ):
        atomic_write(out_dir / name, "wb", lambda f, png=png: f.write(png))
        files.append(out_dir / name)
    return EvalReport(evaluation, rows3, rows4, text3, text4, files)
