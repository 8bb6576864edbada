"""The zero-shot baseline: poses recovered from a model rendered at a known pose (camera
straight above, oblique, near grazing, a sliver left by occlusion), and over the smoke dataset's
test split the recall this test states, the same poses on 1 and 2 workers, blindness to the
ground truth, and errors that name the file or field."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from moonbot.baseline import ModelCloud, Settings, estimate_pose, run_baseline
from moonbot.bop.models import model_info
from moonbot.bop.reader import DatasetError, Model, read_models, scenes
from moonbot.cli import main
from moonbot.config import load_config
from moonbot.eval.matching import evaluate
from moonbot.eval.metrics import adds
from moonbot.eval.results import read_results
from moonbot.eval.tables import summarize
from moonbot.eval.validate import render_at_gt
from moonbot.pipeline.generate import generate
from moonbot.scene.bag_mesh import folded_cuboid

pytestmark = pytest.mark.integration

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
# The smoke test split's instances with visible pixels: every one is found within 20 % of the
# diameter (ADD-S) today; the test holds the baseline to 95 %.
SMOKE_RECALL_20 = 0.95


@pytest.fixture(scope="module")
def folded() -> tuple[Model, ModelCloud]:
    vertices, triangles = folded_cuboid()
    mm = vertices.astype(np.float64) * 1000.0
    info = model_info(mm, triangles)
    model = Model(3, mm, triangles.astype(np.int64), info.diameter, ())
    return model, ModelCloud.from_model(model)


def look_at(eye: np.ndarray, target: np.ndarray) -> np.ndarray:
    """World→camera rotation (3, 3) of a camera at `eye` looking at `target`, image y down."""
    forward = (target - eye) / np.linalg.norm(target - eye)
    up = np.array([0.0, 0.0, 1.0]) if abs(forward[2]) < 0.99 else np.array([0.0, 1.0, 0.0])
    right = np.cross(forward, up)
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    return np.stack([right, down, forward])


def rendered(model: Model, R: np.ndarray, t: np.ndarray, width: int = 320, height: int = 240):
    """Depth (H, W) mm and the instance's mask of the model at (R, t), and K."""
    K = np.array([[277.0, 0.0, width / 2], [0.0, 277.0, height / 2], [0.0, 0.0, 1.0]])
    cam = {"cam_K": K.reshape(-1).tolist()}
    depth, labels = render_at_gt(
        {model.obj_id: (model.vertices, model.triangles)},
        [{"obj_id": model.obj_id, "cam_R_m2c": R.reshape(-1).tolist(), "cam_t_m2c": list(t)}],
        cam,
        (height, width),
    )
    return depth, labels == 1, K


def pose_from(eye_mm: np.ndarray, yaw_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """The pose (model→camera) of a bag lying flat at the origin, turned by yaw, seen from eye."""
    a = np.radians(yaw_deg)
    R_model = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
    R_w2c = look_at(eye_mm, np.zeros(3))
    return R_w2c @ R_model, -R_w2c @ eye_mm


@pytest.mark.parametrize(
    "eye, yaw",
    [
        (np.array([0.0, 0.0, 1200.0]), 30.0),  # straight above: only the top face
        (np.array([900.0, -400.0, 800.0]), 70.0),  # oblique, as in the orbits
        (np.array([1100.0, 300.0, 60.0]), 10.0),  # 3° above the ground: one side, at grazing
    ],
)
def test_a_rendered_bag_is_found_to_a_millimetre(folded, eye, yaw):
    model, cloud = folded
    R, t = pose_from(eye, yaw)
    depth, mask, K = rendered(model, R, t)
    assert mask.sum() > 500
    found = estimate_pose(depth, mask, K, cloud)
    points = model.vertices
    assert adds(found.R, found.t, R, t, points) < 0.005 * model.diameter
    assert found.inliers > 0.95 and np.isfinite(found.score)
    assert abs(np.linalg.det(found.R) - 1.0) < 1e-9


def test_the_estimate_is_the_same_every_time(folded):
    model, cloud = folded
    R, t = pose_from(np.array([900.0, -400.0, 800.0]), 70.0)
    depth, mask, K = rendered(model, R, t)
    a, b = estimate_pose(depth, mask, K, cloud), estimate_pose(depth, mask, K, cloud)
    assert np.array_equal(a.R, b.R) and np.array_equal(a.t, b.t) and a.score == b.score


def test_a_sliver_stays_finite_and_near_and_an_empty_mask_gives_nothing(folded):
    model, cloud = folded
    R, t = pose_from(np.array([900.0, -400.0, 800.0]), 70.0)
    depth, mask, K = rendered(model, R, t)
    rows = np.nonzero(mask.any(axis=1))[0]
    sliver = mask.copy()
    sliver[rows[0] + 4 :] = False  # an occluder hides all but the top few rows
    assert 20 <= sliver.sum() < 400
    found = estimate_pose(depth, sliver, K, cloud)
    assert found is not None and np.all(np.isfinite(found.R)) and np.all(np.isfinite(found.t))
    assert np.linalg.norm(found.t - t) < model.diameter  # bounded ICP steps: no flying off
    assert estimate_pose(depth, np.zeros_like(mask), K, cloud) is None


def test_settings_name_a_bad_field():
    with pytest.raises(ValueError, match="fine_points"):
        Settings(fine_points=0)


@pytest.fixture(scope="module")
def smoke(tmp_path_factory) -> Path:
    """configs/smoke.yaml's test split: three meshes, clear and dusty, 2 bags, 2 views, 64×48."""
    out = tmp_path_factory.mktemp("smoke")
    splits = yaml.safe_load((CONFIGS / "smoke.yaml").read_text())["sweep"]["splits"]
    config = load_config(CONFIGS / "smoke.yaml", {"sweep.splits": [s for s in splits if s["name"] == "test"]})
    result = generate(config, out, workers=2, progress=None)
    assert not result.failed
    return out / "dataset"


def recall_at_20(dataset: Path, csv: Path) -> tuple[float, int]:
    """moonbot eval's ADD-S recall at 20 % of the diameter (a fraction) of the CSV over the test
    split's instances with visible pixels, and how many instances that is."""
    evaluation = evaluate(scenes(dataset, "test"), read_models(dataset, "models_eval"), read_results(csv))
    summary = summarize(evaluation.evaluated)
    return summary.adds_recall_20 / 100.0, summary.instances


def test_the_baseline_reaches_its_stated_recall_on_the_smoke_test_split(smoke, tmp_path):
    report = run_baseline(smoke, "test", tmp_path / "one.csv", workers=1)
    assert report.estimated > 0 and report.instances == report.estimated + report.skipped
    recall, instances = recall_at_20(smoke, tmp_path / "one.csv")
    assert instances >= 15
    assert recall >= SMOKE_RECALL_20, recall
    # Two workers: the same poses and scores in the same order (only the time column differs).
    run_baseline(smoke, "test", tmp_path / "two.csv", workers=2)
    one, two = read_results(tmp_path / "one.csv"), read_results(tmp_path / "two.csv")
    assert [(e.scene_id, e.im_id, e.obj_id, e.score) for e in one] == [
        (e.scene_id, e.im_id, e.obj_id, e.score) for e in two
    ]
    assert all(np.array_equal(a.R, b.R) and np.array_equal(a.t, b.t) for a, b in zip(one, two))


def test_the_baseline_never_reads_the_ground_truth_poses(smoke, tmp_path):
    run_baseline(smoke, "test", tmp_path / "true.csv", workers=1)
    blind = tmp_path / "dataset"
    shutil.copytree(smoke, blind, symlinks=True)
    for path in blind.glob("test/*/scene_gt.json"):
        gt = json.loads(path.read_text())
        for instances in gt.values():
            for inst in instances:
                inst["cam_R_m2c"], inst["cam_t_m2c"] = np.eye(3).reshape(-1).tolist(), [0.0, 0.0, 1.0]
        path.write_text(json.dumps(gt))
    run_baseline(blind, "test", tmp_path / "blind.csv", workers=1)
    a, b = read_results(tmp_path / "true.csv"), read_results(tmp_path / "blind.csv")
    assert len(a) == len(b) and all(np.array_equal(x.R, y.R) and np.array_equal(x.t, y.t) for x, y in zip(a, b))


def test_the_cli_writes_into_eval_and_names_a_missing_model(smoke, tmp_path):
    copy = tmp_path / "dataset"
    shutil.copytree(smoke, copy, symlinks=True)
    result = CliRunner().invoke(main, ["baseline", str(copy), "--workers", "1"])
    assert result.exit_code == 0, result.output
    assert (copy / "eval" / "baseline_test.csv").is_file() and "instances estimated" in result.output
    (copy / "models" / "obj_000002.ply").unlink()
    result = CliRunner().invoke(main, ["baseline", str(copy), "--workers", "1", "--out", str(tmp_path / "x.csv")])
    assert result.exit_code != 0 and "obj_000002.ply" in result.output
    assert not (tmp_path / "x.csv").exists()
    with pytest.raises(DatasetError, match="train_pbr: no scene directory"):
        run_baseline(copy, "train", tmp_path / "y.csv")
