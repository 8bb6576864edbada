"""Where things sit in a merged moonbot dataset: BOP's own tree, which bop_toolkit's
`dataset_params` builds its paths from, plus the paper's hierarchy as a view of links.

    DATASET/
      camera.json  dataset_info.json  manifest.json  test_targets_bop19.json
      scene_index.json  scene_index.parquet                     one row per task (see index_rows)
      models/  models_eval/
      <bop split>/<scene_id:06d>/                               the scenes themselves
      by_condition/<split>/<mesh>/<location>/scene_<scene_id:06d>  →  ../../../../<bop split>/<scene_id:06d>

Split directories: the sweep's split `test` is BOP's `test` (what eval_bop19_pose and
test_targets_bop19.json expect); every other split `s` is `s_pbr` (BOP's name for physically based
renders: bop_toolkit's split "s" with split type "pbr"), so train → train_pbr, val → val_pbr.
The map is one-to-one (nothing else ends up as `test`, and `s_pbr` determines s).

Scene ids: a scene's index in its split's sweep order (meshes › locations › bag counts › stain
seeds › dust, moonbot.sweep.tasks), from 0 — fixed by the config alone, never by which tasks ran
or finished first, unique within a split. Scene and image ids lie in 0..MAX_ID, BOP's six digits
zero-padded (a sweep that would exceed them is refused when its config is read).

The `by_condition/` view is relative symbolic links only (the tree can be moved or copied with
`cp -a`/`rsync -a`); it lies beside the split directories, never inside one, because
bop_toolkit's get_present_scene_ids reads every directory of a split as a scene id.
"""

from __future__ import annotations

import re
from pathlib import Path

MAX_ID = 999_999  # BOP's {scene_id:06d} and {im_id:06d}
TEST_SPLIT = "test"
PBR_SUFFIX = "_pbr"
VIEW_ROOT = "by_condition"
SCENE_META = "scene_meta.json"
SCENE_INDEX_JSON = "scene_index.json"
SCENE_INDEX_PARQUET = "scene_index.parquet"
TEST_TARGETS = "test_targets_bop19.json"
_SCENE_NAME = re.compile(r"[0-9]{6}")


def bop_split(split: str) -> str:
    """The BOP directory of sweep split `split`: `test` stays `test`, any other gets `_pbr`."""
    return split if split == TEST_SPLIT else split + PBR_SUFFIX


def check_id(value: int, what: str) -> int:
    """`value` when it is an int in 0..MAX_ID, else ValueError naming `what`."""
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= MAX_ID:
        raise ValueError(f"{what}: must be an integer in 0..{MAX_ID} (BOP's six digits), got {value!r}")
    return value


def scene_rel(split: str, scene_id: int) -> str:
    """The scene's directory relative to the dataset: `<bop split>/<scene_id:06d>`."""
    return f"{bop_split(split)}/{check_id(scene_id, 'scene_id'):06d}"


def view_rel(split: str, mesh: str, location: str, scene_id: int) -> str:
    """The scene's link in the paper's hierarchy: `by_condition/<split>/<mesh>/<location>/scene_NNNNNN`."""
    return f"{VIEW_ROOT}/{split}/{mesh}/{location}/scene_{check_id(scene_id, 'scene_id'):06d}"


def view_target(split: str, scene_id: int) -> str:
    """What view_rel's link holds: the scene directory relative to the link's own folder."""
    return "../../../../" + scene_rel(split, scene_id)


def scene_dirs(dataset: Path) -> list[Path]:
    """The scene directories of a dataset in BOP layout, `<split dir>/<NNNNNN>/` (real
    directories; the view's links are not followed), sorted by path."""
    dataset = Path(dataset)
    if not dataset.is_dir():
        return []
    found = []
    for split_dir in sorted(p for p in dataset.iterdir() if p.is_dir() and not p.is_symlink()):
        if split_dir.name == VIEW_ROOT or split_dir.name.startswith("."):
            continue
        found += sorted(
            p for p in split_dir.iterdir() if _SCENE_NAME.fullmatch(p.name) and p.is_dir() and not p.is_symlink()
        )
    return found
