"""Where a merged dataset's scenes are: the one place the exports learn the tree's layout from.
Everything else in moonbot.export reads only the standard BOP files inside a scene directory."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from moonbot.bop.reader import scenes


@dataclass(frozen=True)
class SceneDir:
    """One scene of a dataset: its split (the sweep's name, train, val or test; its directory
    under the dataset root is moonbot.bop.layout.bop_split of it), its BOP scene_id (unique
    within the split) and its directory."""

    split: str
    scene_id: int
    path: Path


def dataset_scenes(dataset: Path) -> list[SceneDir]:
    """Every scene of `dataset`, in (split, scene_id) order. DatasetError naming the dataset (or
    the malformed file) when there is none."""
    return [SceneDir(s.split, s.scene_id, s.path) for s in scenes(Path(dataset))]
