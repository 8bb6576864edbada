"""`moonbot validate` passes on a freshly generated smoke dataset and fails,
naming the file and the check, on each corruption: a flipped mask, a depth PNG in the wrong unit,
a truncated file, an edited count, an unlisted file, a shifted pose."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from moonbot import _core
from moonbot.cli import main
from moonbot.config import load_config
from moonbot.eval.validate import validate_dataset
from moonbot.pipeline.generate import generate

pytestmark = pytest.mark.integration

CONFIGS = Path(__file__).resolve().parents[1] / "configs"


@pytest.fixture(scope="module")
def dataset(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("smoke")
    config = load_config(
        CONFIGS / "smoke.yaml",
        {
            "sweep.splits": [
                {
                    "name": "test",
                    "meshes": ["sandbag-02"],
                    "bag_counts": [3],
                    "stain_seeds": [0],
                    "dust": [False, True],
                    "sun_elevations_deg": [30.0],
                    "sun_azimuths_deg": [90.0],
                    "camera_heights_m": [1.0],
                }
            ]
        },
    )
    result = generate(config, out, workers=2, progress=None)
    assert not result.failed and result.merge.images == 4
    return out / "dataset"


def copy_of(dataset: Path, tmp_path: Path) -> Path:
    copy = tmp_path / "dataset"
    shutil.copytree(dataset, copy, symlinks=True)  # the by_condition/ view stays links
    return copy


def failures(dataset: Path) -> list[tuple[str, str, str]]:
    return validate_dataset(dataset).failures


def test_a_fresh_dataset_passes(dataset):
    report = validate_dataset(dataset)
    assert report.ok, report.failures
    assert report.checked["depth"] == 4 and report.checked["masks"] == 12
    result = CliRunner().invoke(main, ["validate", str(dataset)])
    assert result.exit_code == 0 and "manifest" in result.output


def test_a_flipped_mask_fails(dataset, tmp_path):
    d = copy_of(dataset, tmp_path)
    path = next(p for p in sorted(d.glob("test/*/mask_visib/*.png")) if _core.read_image(str(p)).any())
    mask = _core.read_image(str(path))
    _core.write_image(str(path), np.ascontiguousarray(mask[::-1]))
    found = failures(d)
    assert any(f[0] == str(path) and f[1] == "gt_info" for f in found), found
    result = CliRunner().invoke(main, ["validate", str(d)])
    assert result.exit_code == 1 and str(path) in result.output


def test_a_depth_png_in_the_wrong_unit_fails(dataset, tmp_path):
    d = copy_of(dataset, tmp_path)
    path = sorted(d.glob("test/*/depth/*.png"))[0]
    depth = _core.read_image(str(path)).astype(np.uint32)
    _core.write_image(str(path), np.ascontiguousarray((depth // 10).astype(np.uint16)))  # centimetres
    assert any(f[0] == str(path) and f[1] == "depth" for f in failures(d))


def test_a_truncated_file_and_an_unlisted_one_fail(dataset, tmp_path):
    d = copy_of(dataset, tmp_path)
    path = sorted(d.glob("test/*/rgb/*.png"))[0]
    path.write_bytes(path.read_bytes()[:100])
    (d / "stray.txt").write_text("x")
    found = failures(d)
    assert any(f[0] == str(path) and f[1] == "manifest" for f in found)
    assert any(f[0] == str(d / "stray.txt") and "not listed" in f[2] for f in found)


def test_an_edited_count_fails(dataset, tmp_path):
    d = copy_of(dataset, tmp_path)
    path = sorted(d.glob("test/*/scene_gt_info.json"))[0]
    info = json.loads(path.read_text())
    info["0"][0]["px_count_visib"] += 1
    path.write_text(json.dumps(info))
    assert any(f[1] == "gt_info" and "px_count_visib" in f[2] for f in failures(d))


def test_a_shifted_pose_fails(dataset, tmp_path):
    # The model rendered at the recorded pose must give the image's depth (exact to float32 here).
    assert validate_dataset(dataset).checked["pose"] >= 4
    d = copy_of(dataset, tmp_path)
    path = sorted(d.glob("test/*/scene_gt.json"))[0]
    gt = json.loads(path.read_text())
    info = json.loads((path.parent / "scene_gt_info.json").read_text())
    k = next(i for i, e in enumerate(info["0"]) if e["px_count_visib"] > 0)
    gt["0"][k]["cam_t_m2c"][2] += 5.0  # 5 mm farther along the optical axis
    path.write_text(json.dumps(gt))
    found = [f for f in failures(d) if f[1] == "pose"]
    assert any(f[0] == str(path) and f"image 0 instance {k}" in f[2] for f in found), found


def test_the_counts_say_what_they_count(dataset):
    """pose counts the instances with visible pixels, masks every instance: the output says so."""
    report = validate_dataset(dataset)
    result = CliRunner().invoke(main, ["validate", str(dataset)])
    rows = {line.split()[0]: line for line in result.output.splitlines() if " checked " in line}
    assert report.checked["pose"] <= report.checked["masks"]
    assert f"{report.checked['pose']} checked" in rows["pose"] and "instances with visible pixels" in rows["pose"]
    assert "instances:" in rows["masks"] and "images:" in rows["depth"]


def test_a_generate_folder_validates_its_dataset(dataset):
    result = CliRunner().invoke(main, ["validate", str(dataset.parent)])
    assert result.exit_code == 0, result.output
    assert f"validating its dataset {dataset}" in result.stderr
    assert "manifest" in result.stdout


def test_an_unmerged_generate_folder_names_the_commands(dataset, tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    shutil.copy(dataset.parent / "config.json", out / "config.json")
    shutil.copytree(dataset.parent / "tasks", out / "tasks")
    result = CliRunner().invoke(main, ["validate", str(out)])
    assert result.exit_code == 1
    assert f"run `moonbot merge {out}`, then `moonbot validate {out / 'dataset'}`" in result.output
    merged = CliRunner().invoke(main, ["merge", str(out)])
    assert merged.exit_code == 0, merged.output
    assert CliRunner().invoke(main, ["validate", str(out)]).exit_code == 0


def test_a_wrong_view_link_and_an_index_that_disagrees_fail(dataset, tmp_path):
    d = copy_of(dataset, tmp_path)
    link = sorted(p for p in (d / "by_condition").rglob("scene_*") if p.is_symlink())[0]
    link.unlink()
    link.symlink_to("../../../../test/000001", target_is_directory=True)  # another scene
    index = json.loads((d / "scene_index.json").read_text())
    index["rows"][0]["stain_seeds"] = 15
    (d / "scene_index.json").write_text(json.dumps(index))
    found = failures(d)
    assert any(f[0] == str(link) and f[1] == "manifest" and "links to" in f[2] for f in found), found
    assert any(f[0] == str(link) and f[1] == "layout" for f in found), found
    assert any(f[0] == str(d / "scene_index.json") and f[1] == "index" and "stain_seeds" in f[2] for f in found), found
    assert not any(f[0] == str(d / "scene_index.parquet") and f[1] == "index" for f in found), found
