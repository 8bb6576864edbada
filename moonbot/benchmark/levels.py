"""The quality levels `moonbot bench throughput` runs: each a set of config overrides on the
render's three lighting knobs (moonbot/config/schema.py, RenderConfig), everything else as the
benchmark config has it. What each knob costs and buys alone is measured by
bench/bench_accuracy.py (bench/results/accuracy-*.json): pixel sampling dominates the error at
every level, so a level is chiefly its spp.

- draft: 1 spp (the unjittered pixel-centre ray: aliased, noiseless), 1 shadow ray toward the
  Sun's disk, 1 bounce (shadows filled to within ~2 %). For layouts, labels and smoke runs.
- default: the config defaults — 4 spp, 2 Sun-disk rays, 2 bounces. What SynBag-1.0 renders.
- high: 8 spp, 4 Sun-disk rays, 3 bounces: 40 % less pixel noise than default (the sampler's nets),
  softer shadow edges and inter-reflections to within 0.03 %.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from moonbot.config import Config, load_config


@dataclass(frozen=True)
class Level:
    name: str
    overrides: dict  # config field → value, as `load_config`'s overrides take them
    description: str


LEVELS: dict[str, Level] = {level.name: level for level in (
    Level("draft", {"render.spp": 1, "render.light_samples": 1, "render.bounces": 1},
          "1 spp (pixel-centre ray), 1 Sun-disk shadow ray, 1 bounce"),
    Level("default", {"render.spp": 4, "render.light_samples": 2, "render.bounces": 2},
          "4 spp, 2 Sun-disk shadow rays, 2 bounces (the config defaults)"),
    Level("high", {"render.spp": 8, "render.light_samples": 4, "render.bounces": 3},
          "8 spp, 4 Sun-disk shadow rays, 3 bounces"),
)}


def parse_levels(text: str) -> list[str]:
    """"draft,default" → ["draft", "default"] (in the order given, without repeats); raises
    ValueError naming an unknown level."""
    names = list(dict.fromkeys(n.strip() for n in text.split(",") if n.strip()))
    unknown = [n for n in names if n not in LEVELS]
    if unknown or not names:
        raise ValueError(f"levels: unknown {', '.join(map(repr, unknown)) or 'empty list'}; "
                         f"choose from {', '.join(LEVELS)}")
    return names


def level_config(path: str | Path | None, level: str, overrides: dict | None = None) -> Config:
    """The config at `path` (None: the embedded default) with `overrides`, then the level's
    render settings on top (they win)."""
    return load_config(path, {**(overrides or {}), **LEVELS[level].overrides})
