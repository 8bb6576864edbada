"""Pose metrics and the results CSV (moonbot/eval) on hand-made cases with known answers:
identity → 0, a translation by d → ADD = d, a symmetric object turned by its symmetry → ADD-S 0
while ADD > 0, strict recall thresholds, the toolkit's greedy matching, the AUC's trapezoids, and
malformed results rejected with their line number."""

from __future__ import annotations

import numpy as np
import pytest

from moonbot.eval import ResultsError, add, adds, auc, match_greedy, read_results, recall, translation_error

pytestmark = pytest.mark.unit

# A box's corners and face centres, 320 × 200 × 120 mm: symmetric under 180° turns about each axis.
HALF = np.array([160.0, 100.0, 60.0])
BOX = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * HALF
BOX = np.vstack([BOX, np.diag(HALF), -np.diag(HALF)])
I = np.eye(3)
T = np.array([10.0, -20.0, 800.0])


def rot_z(deg: float) -> np.ndarray:
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def test_identity_is_zero():
    assert add(I, T, I, T, BOX) == 0.0 and adds(I, T, I, T, BOX) == 0.0 and translation_error(T, T) == 0.0


def test_a_translation_by_d_is_d():
    d = np.array([3.0, 4.0, 12.0])  # |d| = 13
    assert add(I, T + d, I, T, BOX) == pytest.approx(13.0, abs=1e-12)
    assert translation_error(T + d, T) == pytest.approx(13.0, abs=1e-12)
    assert adds(I, T + d, I, T, BOX) <= 13.0 + 1e-12


def test_a_symmetry_costs_adds_nothing_but_add_something():
    R = rot_z(180.0)
    assert adds(R, T, I, T, BOX) == pytest.approx(0.0, abs=1e-9)
    # ADD: each point moves to its mirror through the z axis, 2·|(x, y)| on average.
    expected = np.mean(2 * np.linalg.norm(BOX[:, :2], axis=1))
    assert add(R, T, I, T, BOX) == pytest.approx(expected, rel=1e-12)


def test_recall_is_strict_and_counts_unmatched_as_misses():
    diameter = 2 * np.linalg.norm(HALF)
    errors = np.array([0.1 * diameter, 0.0999 * diameter, 0.15 * diameter, np.inf])
    assert recall(errors, np.full(4, diameter), 0.1) == 0.25
    assert recall(errors, np.full(4, diameter), 0.2) == 0.75
    assert np.isnan(recall(np.array([]), np.array([]), 0.1))


def test_greedy_matching_by_score():
    # Two instances of one object; the best-scored estimate takes the instance it fits best.
    errors = np.array(
        [
            [50.0, 5.0],  # estimate 0 (score 0.9): best on instance 1
            [4.0, 3.0],  # estimate 1 (score 0.5): instance 1 is taken → instance 0
            [1.0, 1.0],
        ]
    )  # estimate 2 (score 0.1): nothing left
    matched = match_greedy(errors, np.array([0.9, 0.5, 0.1]), threshold=10.0)
    np.testing.assert_array_equal(matched, [4.0, 5.0])
    # An error at the threshold does not match (strict).
    np.testing.assert_array_equal(match_greedy(np.array([[10.0]]), np.array([1.0]), 10.0), [np.inf])


def test_auc_trapezoids():
    assert auc(np.zeros(5)) == 1.0
    assert auc(np.full(3, 100.0)) == pytest.approx(0.5 / 100)  # accuracy 1 only at the last threshold
    assert auc(np.full(3, 150.0)) == 0.0
    # A step at 50 mm: 0 below, 1 from 50 on → the trapezoid 49–50 gives 0.5, then 50 whole steps.
    assert auc(np.array([50.0])) == pytest.approx(50.5 / 100)
    assert auc(np.array([0.0, 150.0])) == pytest.approx(0.5)


def test_results_csv_reads_and_names_bad_lines(tmp_path):
    good = tmp_path / "moonbot_synbag-test.csv"
    R = " ".join(map(str, rot_z(30.0).reshape(-1)))
    good.write_text(f"scene_id,im_id,obj_id,score,R,t,time\n0,3,1,0.9,{R},10 20 800,0.5\n0,3,3,0.4,{R},-5 0 900,0.5\n")
    rows = read_results(good)
    assert len(rows) == 2 and rows[1].obj_id == 3 and rows[0].t.tolist() == [10.0, 20.0, 800.0]
    np.testing.assert_allclose(rows[0].R, rot_z(30.0), atol=1e-12)
    cases = {
        "0,3,1,0.9,1 2 3,10 20 800,0.5": "R must be 9",
        "0,3,1,0.9," + R + ",10 20,0.5": "t must be 3",
        "0,x,1,0.9," + R + ",10 20 800,0.5": "im_id must be an integer",
        "0,3,1,high," + R + ",10 20 800,0.5": "score must be numbers",
        "0,3,1,0.9," + R + ",10 20 nan,0.5": "t must be finite",
        "0,3,1,0.9," + R + ",10 20 800": "expected 7",
        "0,3,1,0.9," + R + ",10 20 800,0.7": "differs",
    }
    for line, message in cases.items():
        bad = tmp_path / "bad.csv"
        bad.write_text("scene_id,im_id,obj_id,score,R,t,time\n" + f"0,3,2,0.9,{R},10 20 800,0.5\n" + line + "\n")
        with pytest.raises(ResultsError, match=rf"bad.csv:3: .*{message}"):
            read_results(bad)
    header = tmp_path / "header.csv"
    header.write_text("scene,im,obj\n")
    with pytest.raises(ResultsError, match="header.csv:1"):
        read_results(header)
