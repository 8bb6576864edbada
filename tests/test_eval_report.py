"""`moonbot eval` on a freshly generated smoke test split — three meshes,
clean and stained, clear and dusty, two bags a scene: ground truth given back scores perfectly; a
translation by d costs ADD = d; a turn by the model's symmetry costs ADD-S nothing but ADD much;
a dropped estimate is a miss; of two estimates for one instance the higher-scored one matches; a
stray estimate does not displace a good one; the tables' counts add up; the plots are PNGs; bad
input fails naming the file and line. The lazy matching against metrics.match_greedy, and the
model-frame ADD-S against metrics.adds."""

from __future__ import annotations

import csv
import io
import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner
from PIL import Image

from moonbot.bop.reader import read_models, scenes
from moonbot.cli import main
from moonbot.eval import Estimate, add, adds, match_greedy, read_results, write_results
from moonbot.eval.matching import ModelPoints, _Pairs, assign_greedy, evaluate
from moonbot.eval.tables import check_bins, table3, table4
from moonbot.eval.validate import ValidationReport, check_manifest

pytestmark = pytest.mark.integration

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
TEST_SPLIT = {
    "name": "test",
    "meshes": ["sandbag-01", "sandbag-02", "sandbag-03"],
    "bag_counts": [2],
    "stain_seeds": [0, 15],
    "dust": [False, True],
    "sun_elevations_deg": [30.0],
    "sun_azimuths_deg": [90.0],
    "camera_heights_m": [1.0],
}


@pytest.fixture(scope="module")
def dataset(tmp_path_factory) -> Path:
    """configs/smoke.yaml with its test split widened to both stains (12 scenes, 24 images),
    generated through the CLI."""
    config = yaml.safe_load((CONFIGS / "smoke.yaml").read_text())
    config["sweep"]["splits"] = [TEST_SPLIT]
    config_file = tmp_path_factory.mktemp("config") / "eval-smoke.yaml"
    config_file.write_text(yaml.safe_dump(config))
    out = tmp_path_factory.mktemp("eval-smoke")
    result = CliRunner().invoke(
        main, ["generate", str(config_file), "--out", str(out), "--workers", "1", "--threads", "1"]
    )
    assert result.exit_code == 0, result.output
    return out / "dataset"


@pytest.fixture(scope="module")
def split(dataset):
    return scenes(dataset, "test")


@pytest.fixture(scope="module")
def models(dataset):
    return read_models(dataset, "models_eval")


def truth(split, score: float = 1.0) -> list[Estimate]:
    """The ground-truth pose of every instance with a visible pixel, as estimates."""
    return [
        Estimate(s.scene_id, im, i.obj_id, score, i.R, i.t, -1.0)
        for s in split
        for im, instances in sorted(s.images.items())
        for i in instances
        if i.px_visib > 0
    ]


def numbered(estimates: list[Estimate]) -> list[Estimate]:
    """The estimates with the line numbers a results CSV of them gives (header on line 1)."""
    return [
        Estimate(e.scene_id, e.im_id, e.obj_id, e.score, e.R, e.t, e.time_s, k + 2) for k, e in enumerate(estimates)
    ]


def read_csv(path: Path) -> list[dict]:
    return list(csv.DictReader(io.StringIO(path.read_text())))


def all_row(rows):
    return next(r for r in rows if r.level == "all").summary


def image_with_two_visible(split):
    """(scene, im_id, [instances]) of an image with two visible instances of one object."""
    for s in split:
        for im, instances in sorted(s.images.items()):
            visible = [i for i in instances if i.px_visib > 0]
            if len(visible) == 2 and visible[0].obj_id == visible[1].obj_id:
                return s, im, visible
    pytest.skip("no image with two visible instances of one object")


def test_ground_truth_as_results_scores_perfectly_through_the_cli(dataset, split, tmp_path):
    results = tmp_path / "gt_synbag-test.csv"
    write_results(results, truth(split))
    result = CliRunner().invoke(main, ["eval", str(dataset), "--results", str(results), "--workers", "1"])
    assert result.exit_code == 0, result.output
    assert "Table 3" in result.output and "Table 4" in result.output
    out = dataset / "eval"
    instances = read_csv(out / "per_instance.csv")
    evaluated = [r for r in instances if r["evaluated"] == "1"]
    assert len(evaluated) == len(truth(split)) and len(instances) > len(evaluated)  # some bags are hidden
    for r in evaluated:
        assert r["matched"] == "1" and float(r["add_mm"]) == 0.0 and float(r["te_mm"]) == 0.0
        assert float(r["adds_mm"]) < 1e-6
        assert all(r[f"{k}_correct_{p}"] == "1" for k in ("add", "adds") for p in (10, 20))
    total = next(r for r in read_csv(out / "table3.csv") if r["level"] == "all")
    assert int(total["instances"]) == len(evaluated) and total["missed"] == "0"
    for column in ("add_recall_10", "add_recall_20", "adds_recall_10", "adds_recall_20"):
        assert float(total[column]) == 100.0
    # ADD-S is ~1e-13 mm, not 0 (Rᵀ·R rounds), so accuracy at the 0 mm threshold is 0: one half-step less.
    assert float(total["adds_auc"]) == pytest.approx(99.5)
    assert float(total["adds_mm"]) < 1e-6 and float(total["add_mm"]) == 0.0
    # The plots are PNGs a decoder reads, of some size and not blank.
    for name in ("adds_vs_visible_pixels.png", "recall_by_condition.png"):
        path = out / name
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 10_000
        with Image.open(path) as image:
            pixels = np.asarray(image.convert("L"))
        assert pixels.shape[0] > 300 and pixels.shape[1] > 500 and pixels.std() > 10
    for name in ("table3.txt", "table4.txt", "table3.csv", "table4.csv"):
        assert (out / name).stat().st_size > 0
    assert not list(out.glob(".*.tmp"))  # no leftover temporaries
    # The reports inside the dataset do not break its manifest check.
    report = ValidationReport()
    check_manifest(dataset, report)
    assert report.ok, report.failures


def test_a_translation_by_d_costs_add_d(split, models):
    d = np.array([3.0, 4.0, 12.0])  # 13 mm
    one_per_mesh = list({s.mesh: s for s in split}.values())  # ADD-S queries 13 mm off take a while
    shifted = [Estimate(e.scene_id, e.im_id, e.obj_id, e.score, e.R, e.t + d, e.time_s) for e in truth(one_per_mesh)]
    evaluation = evaluate(one_per_mesh, models, shifted)
    evaluated = evaluation.evaluated
    assert evaluated and all(r.matched for r in evaluated)
    for r in evaluated:
        assert r.add_mm == pytest.approx(13.0, abs=1e-9) and r.te_mm == pytest.approx(13.0, abs=1e-9)
        assert 0.0 < r.adds_mm <= 13.0 + 1e-9
    s = all_row(table3(evaluation))
    assert s.add_mm == pytest.approx(13.0) and s.te_mm == pytest.approx(13.0) and s.adds_recall_10 == 100.0


def test_a_turn_by_the_symmetry_costs_adds_nothing_but_add_much(split, models):
    symmetric = [s for s in split if any(i.obj_id == 1 for ins in s.images.values() for i in ins)]
    S = models[1].symmetries[0]
    assert symmetric and not np.allclose(S[:3, :3], np.eye(3))
    turned = [
        Estimate(e.scene_id, e.im_id, e.obj_id, e.score, e.R @ S[:3, :3], e.t + e.R @ S[:3, 3], e.time_s)
        for e in truth(symmetric)
    ]
    evaluated = evaluate(symmetric, models, turned).evaluated
    assert evaluated and all(r.matched and r.obj_id == 1 for r in evaluated)
    for r in evaluated:
        assert r.adds_mm < 1.0  # the eval points are a sampling: the turned set is not the same points
        assert r.add_mm > 0.1 * r.diameter_mm
        assert r.adds_correct_10 and not r.add_correct_10


def test_a_dropped_estimate_is_a_miss(split, models):
    some = split[:4]
    estimates = truth(some)
    dropped = estimates.pop(len(estimates) // 2)
    evaluation = evaluate(some, models, estimates)
    missed = [r for r in evaluation.evaluated if not r.matched]
    assert [(r.scene_id, r.im_id, r.obj_id) for r in missed] == [(dropped.scene_id, dropped.im_id, dropped.obj_id)]
    assert not missed[0].adds_correct_20 and np.isnan(missed[0].adds_mm)
    s = all_row(table3(evaluation))
    n = s.instances
    assert s.missed == 1 and s.matched == n - 1
    assert s.adds_recall_20 == pytest.approx(100 * (n - 1) / n) and s.adds_mm < 1e-6  # the miss is not in the mean
    assert s.adds_auc == pytest.approx(99.5 * (n - 1) / n)  # 99.5: see the ground-truth test


def test_of_two_estimates_for_one_instance_the_higher_scored_matches(split, models):
    scene, im, (a, b) = image_with_two_visible(split)
    off = np.array([0.0, 0.0, 5.0])
    for perfect_score, shifted_score in ((0.9, 0.4), (0.4, 0.9)):
        estimates = numbered(
            [
                Estimate(scene.scene_id, im, a.obj_id, perfect_score, a.R, a.t, -1.0),
                Estimate(scene.scene_id, im, a.obj_id, shifted_score, a.R, a.t + off, -1.0),
                Estimate(scene.scene_id, im, b.obj_id, 0.5, b.R, b.t, -1.0),
            ]
        )
        evaluation = evaluate([scene], models, estimates)
        rows = {r.index: r for r in evaluation.evaluated if r.im_id == im}
        assert evaluation.matched_estimates == 2 and evaluation.unmatched_estimates == 1
        winner = 2 if perfect_score > shifted_score else 3
        assert rows[a.index].line == winner and rows[a.index].te_mm == pytest.approx(0.0 if winner == 2 else 5.0)
        assert rows[b.index].line == 4 and rows[b.index].adds_mm < 1e-6


def test_a_stray_estimate_with_a_higher_score_does_not_displace_a_good_one(split, models):
    scene, im, (a, b) = image_with_two_visible(split)
    stray_t = a.t + np.array([0.0, 0.0, 1.5]) * models[a.obj_id].diameter  # deep below both: fits neither
    estimates = numbered(
        [
            Estimate(scene.scene_id, im, a.obj_id, 0.9, a.R, stray_t, -1.0),
            Estimate(scene.scene_id, im, a.obj_id, 0.5, a.R, a.t, -1.0),
            Estimate(scene.scene_id, im, b.obj_id, 0.4, b.R, b.t, -1.0),
        ]
    )
    evaluation = evaluate([scene], models, estimates)
    rows = {r.index: r for r in evaluation.evaluated if r.im_id == im}
    assert rows[a.index].line == 3 and rows[b.index].line == 4
    assert rows[a.index].adds_correct_10 and rows[b.index].adds_correct_10
    assert evaluation.unmatched_estimates == 1


def test_the_tables_counts_add_up(split, models):
    estimates = truth(split)[::2]  # every other instance missed
    evaluation = evaluate(split, models, estimates)
    rows3 = table3(evaluation)
    total = all_row(rows3)
    assert total.instances == len(evaluation.evaluated) and total.missed == total.instances - len(estimates)
    for level in ("condition", "mesh", "location", "stain", "dust"):
        chosen = [r.summary for r in rows3 if r.level == level]
        assert chosen and sum(s.instances for s in chosen) == total.instances
        assert sum(s.missed for s in chosen) == total.missed
    assert {r.stain for r in rows3 if r.level == "stain"} == {"clean", "stained"}
    assert {r.dust for r in rows3 if r.level == "dust"} == {"clear", "dusty"}
    assert len([r for r in rows3 if r.level == "condition"]) == 12
    edges = (0, 60, 120, 180)
    rows4 = table4(evaluation, edges)
    px = np.array([r.px_visib for r in evaluation.evaluated])
    overall = [r for r in rows4 if r.mesh == "all"]
    assert [r.summary.instances for r in overall] == [
        int(((px >= lo) & (px < hi)).sum()) for lo, hi in zip(edges, [*edges[1:], np.inf])
    ]
    for mesh_row in (r for r in rows3 if r.level == "mesh"):
        assert sum(r.summary.instances for r in rows4 if r.mesh == mesh_row.mesh) == mesh_row.summary.instances
    with pytest.raises(ValueError, match="increasing"):
        check_bins((0, 500, 100))


def test_min_visib_fract_leaves_instances_out(split, models):
    evaluation = evaluate(split, models, [], min_visib_fract=0.99)
    for r in evaluation.instances:
        assert r.evaluated == (r.px_visib > 0 and r.visib_fract >= 0.99)
    assert 0 < len(evaluation.evaluated) < sum(1 for r in evaluation.instances if r.px_visib > 0)


def test_adds_in_the_model_frame_equals_metrics_adds(models):
    rng = np.random.default_rng(3)
    for full in models.values():
        model = replace(full, vertices=full.vertices[::20])  # the identity holds for any point set; fast
        mp = ModelPoints(model)
        for _ in range(2):
            R_gt, R_est = (np.linalg.qr(rng.normal(size=(3, 3)))[0] for _ in range(2))
            R_gt, R_est = R_gt * np.sign(np.linalg.det(R_gt)), R_est * np.sign(np.linalg.det(R_est))
            t_gt = rng.normal(size=3) * 50 + [0, 0, 900]
            t_est = t_gt + rng.normal(size=3) * 30
            points = model.vertices
            expected = adds(R_est, t_est, R_gt, t_gt, points)
            assert mp.adds(R_est, t_est, R_gt, t_gt) == pytest.approx(expected, rel=1e-9)
            assert mp.adds_lower_bound(R_est, t_est, R_gt, t_gt) <= expected + 1e-9
            assert mp.add(R_est, t_est, R_gt, t_gt) == pytest.approx(add(R_est, t_est, R_gt, t_gt, points), rel=1e-12)


def test_written_results_read_back_the_same_with_their_lines(split, tmp_path):
    estimates = truth(split)[:5]
    path = tmp_path / "round_synbag-test.csv"
    write_results(path, estimates)
    back = read_results(path)
    assert [e.line for e in back] == [2, 3, 4, 5, 6]
    for a, b in zip(estimates, back):
        assert (a.scene_id, a.im_id, a.obj_id, a.score, a.time_s) == (b.scene_id, b.im_id, b.obj_id, b.score, b.time_s)
        np.testing.assert_array_equal(a.R, b.R)
        np.testing.assert_array_equal(a.t, b.t)


def test_lazy_greedy_matching_equals_match_greedy():
    rng = np.random.default_rng(11)
    for case in range(400):
        n_est, n_gt = rng.integers(1, 6), rng.integers(1, 6)  # match_greedy cannot reshape 0 estimates
        errors = rng.choice([1.0, 2.0, 3.0, 5.0, 8.0, 13.0], size=(n_est, n_gt))  # ties on purpose
        scores = rng.choice([0.1, 0.5, 0.9], size=n_est)
        bounds = errors * rng.random(size=errors.shape) * (rng.random() < 0.8)
        threshold = [np.inf, 4.0, 8.0][case % 3]
        calls = []

        def error(e, g):
            calls.append((e, g))
            return errors[e, g]

        estimate_of = assign_greedy(scores, n_gt, error, lambda e, g: bounds[e, g], threshold)
        got = np.array([errors[e, g] if e >= 0 else np.inf for g, e in enumerate(estimate_of)])
        np.testing.assert_array_equal(got, match_greedy(errors, scores, threshold))
        assert len(calls) <= n_est * n_gt


def test_the_first_matching_pass_is_the_toolkits_at_10_percent(split, models):
    scene, im, (a, b) = image_with_two_visible(split)
    rng = np.random.default_rng(5)
    full = models[a.obj_id]
    mp = ModelPoints(replace(full, vertices=full.vertices[::10]))
    for _ in range(3):
        ests = [
            Estimate(scene.scene_id, im, a.obj_id, float(rng.random()), g.R, g.t + rng.normal(size=3) * 25, -1.0)
            for g in (a, b, a)
        ]
        pairs = _Pairs(mp, ests, [a, b])
        scores = [e.score for e in ests]
        first = assign_greedy(scores, 2, pairs.adds, pairs.adds_bound, 0.1 * mp.diameter)
        np.testing.assert_array_equal(first >= 0, pairs.toolkit_correct("adds", 0.1 * mp.diameter))


def test_bad_input_fails_naming_the_file_and_line(dataset, split, tmp_path):
    runner = CliRunner()
    good = truth(split)[:2]
    bad = tmp_path / "bad.csv"
    write_results(bad, good)
    bad.write_text(bad.read_text() + "0,0,1,0.9,1 2 3,10 20 800,-1\n")
    result = runner.invoke(main, ["eval", str(dataset), "--results", str(bad), "--out", str(tmp_path / "o")])
    assert result.exit_code != 0 and f"{bad}:4" in result.output and "R must be 9" in result.output
    # An estimate of an image the split lacks: an error naming its line, a warning when allowed.
    stray = tmp_path / "stray.csv"
    write_results(stray, [*good, Estimate(999, 0, 1, 0.5, np.eye(3), np.array([0.0, 0.0, 900.0]), -1.0)])
    result = runner.invoke(main, ["eval", str(dataset), "--results", str(stray), "--out", str(tmp_path / "o")])
    assert result.exit_code != 0 and f"{stray}:4: scene 999 image 0 is not in split 'test'" in result.output
    result = runner.invoke(
        main,
        [
            "eval",
            str(dataset),
            "--results",
            str(stray),
            "--out",
            str(tmp_path / "o"),
            "--allow-unknown",
            "--workers",
            "1",
        ],
    )
    assert result.exit_code == 0 and "warning: 1 estimates ignored" in result.output
    result = runner.invoke(main, ["eval", str(dataset), "--results", str(stray), "--px-bins", "0,500,100"])
    assert result.exit_code != 0 and "increasing" in result.output
    # A dataset without models_eval's models_info.json.
    copy = tmp_path / "dataset"
    shutil.copytree(dataset, copy, symlinks=True)  # the by_condition/ view stays links
    (copy / "models_eval" / "models_info.json").unlink()
    result = runner.invoke(
        main, ["eval", str(copy), "--results", str(bad.with_name("stray.csv")), "--out", str(tmp_path / "o")]
    )
    assert result.exit_code != 0 and str(copy / "models_eval" / "models_info.json") in result.output
