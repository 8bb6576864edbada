"""The quality levels `moonbot bench throughput` runs: each a set of config overrides on the
render's lighting knobs (moonbot/config/schema.py, RenderConfig), everything else as the
benchmark config has it. bench/bench_accuracy.py measures each against a 1024-spp reference of
the brute-force path tracer (`render.indirect: path`, the reference mode): with the per-task
light cache the indirect light is nearly noiseless, and the error left is the direct light's
pixel footprint at bright edges, which adaptive anti-aliasing refines where a pixel's (or a
neighbour's) base samples disagree (bench/results/accuracy-adaptive-cache-*.json at 320×240 and
accuracy-adaptive-cache-levels-640px-*.json at the sweep's 640×480; median of three locations;
relative RMSE at 22° / 5° Sun, rays a 320×240 view at 22°; the default's at 640×480):

- draft: 2 base samples, a pixel whose samples disagree (threshold 0.5) refined to up to 64 in
  proportion to its spread (all 64 from 10× the frame's mean), one Sun-disk ray a base sample and
  2 a refinement sample in a penumbra, light cache: ~2.4 % / 3.8 %, 0.53 M rays, about half the
  default's rays and time at either Sun.
- default: the config defaults — 4 base samples, a pixel whose samples disagree (threshold 0.5)
  refined to up to 128 in proportion to its spread, all 128 from 4× the frame's mean, that scale
  raised per view (by steps of 2^(1/8)) while the refined pixels' predicted error stays within
  1.4 % (render.adaptive_error_target), one Sun-disk ray a base sample and 2 a refinement sample
  in a penumbra, 2 bounces through the light cache: at 640×480 1.3–1.5 % / 1.6–1.9 %, 3.0 / 4.8 M
  rays a view (median), the hard view (the crater at 5°) 12.1 M. What SynBag-1.0 renders.
- high: 4 base samples refined to up to 256 at threshold 0.25 (all from 4× the frame's mean):
  ~0.8 % / 1.3 %, 2.5 M rays.
- path: the brute force for comparison, 4 spp with per-pixel bounce paths.

The draft was the pixel-centre sample refined to 16 where its 3×3 neighbourhood disagrees
(~2.5 % / 4.2 %): under a low Sun it refined most pixels and traced more rays than the default
(docs/performance.md). At 5° the error is the pixel footprint's own spread (long penumbrae,
grazing light on the grain and the mesh) that even 64 uniform samples leave at 1.7 %, and more
where a view lies mostly in shadow (docs/performance.md).
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


LEVELS: dict[str, Level] = {
    level.name: level
    for level in (
        Level(
            "draft",
            {
                "render.spp": 2,
                "render.adaptive_spp": 64,
                "render.adaptive_full_spread": 10.0,
                "render.adaptive_error_target": 0.0,
                "render.adaptive_contrast": 4.0,
                "render.adaptive_threshold": 0.5,
                "render.light_samples": 1,
                "render.penumbra_light_samples": 2,
                "render.bounces": 2,
                "render.indirect": "cache",
            },
            "2 spp refined to up to 64 by the spread, 1 Sun-disk shadow ray a base sample and 2 a refinement sample "
            "in a penumbra, 2 bounces through the light cache",
        ),
        Level(
            "default",
            {
                "render.spp": 4,
                "render.adaptive_spp": 128,
                "render.adaptive_full_spread": 4.0,
                "render.adaptive_error_target": 0.014,
                "render.adaptive_contrast": 4.0,
                "render.adaptive_threshold": 0.5,
                "render.light_samples": 1,
                "render.penumbra_light_samples": 2,
                "render.bounces": 2,
                "render.indirect": "cache",
            },
            "4 spp refined to up to 128 by the spread, its scale chosen per view for a predicted 1.4 % on the refined "
            "pixels, 1 Sun-disk shadow ray a base sample and 2 a refinement sample in a penumbra, 2 bounces through "
            "the light cache (the config defaults)",
        ),
        Level(
            "high",
            {
                "render.spp": 4,
                "render.adaptive_spp": 256,
                "render.adaptive_full_spread": 4.0,
                "render.adaptive_error_target": 0.0,
                "render.adaptive_contrast": 4.0,
                "render.adaptive_threshold": 0.25,
                "render.light_samples": 1,
                "render.penumbra_light_samples": 2,
                "render.bounces": 2,
                "render.indirect": "cache",
            },
            "4 spp refined to up to 256 by the spread (all from 4x the frame's mean), threshold 0.25, 1 Sun-disk "
            "shadow ray a base sample and 2 a refinement sample in a penumbra, 2 bounces through the light cache",
        ),
        Level(
            "path",
            {
                "render.spp": 4,
                "render.adaptive_spp": 0,
                "render.light_samples": 2,
                "render.bounces": 2,
                "render.indirect": "path",
            },
            "4 spp, 2 Sun-disk shadow rays, 2 bounce paths per pixel (the brute-force reference mode)",
        ),
    )
}


def parse_levels(text: str) -> list[str]:
    """ "draft,default" → ["draft", "default"] (in the order given, without repeats); raises
    ValueError naming an unknown level."""
    names = list(dict.fromkeys(n.strip() for n in text.split(",") if n.strip()))
    unknown = [n for n in names if n not in LEVELS]
    if unknown or not names:
        raise ValueError(
            f"levels: unknown {', '.join(map(repr, unknown)) or 'empty list'}; choose from {', '.join(LEVELS)}"
        )
    return names


def level_config(path: str | Path | None, level: str, overrides: dict | None = None) -> Config:
    """The config at `path` (None: the embedded default) with `overrides`, then the level's
    render settings on top (they win)."""
    return load_config(path, {**(overrides or {}), **LEVELS[level].overrides})
