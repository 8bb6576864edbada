"""Realism benchmark: statistics of moonbot renders against Apollo surface photographs.

Thin runner for moonbot.benchmark.realism_bench (the comparison) and moonbot.benchmark.realism
(the statistics, with their definitions, units and caveats); the same as `moonbot bench realism`.

--photos DIR is required: a folder of photos and a SOURCES.csv with a header row naming at least
the columns `file` (the photo's file name in DIR) and `approx_sun_elevation_deg` (text starting
"~a-b" or "~a", degrees; the range's mid-point is rendered, and the photo is compared with
renders whose elevation lies in the range); `what_it_shows` is optional. The photos themselves
are not part of the repository. bench/realism-photo-rois.csv holds each photo's ground region.

Writes bench/results/realism-<machine>.json and bench/results/realism-sheet.png. Run:
  .venv/bin/python bench/bench_realism.py --photos DIR [--spp 16] [--width 768]
"""

from __future__ import annotations

import sys

from moonbot.cli import main

if __name__ == "__main__":
    sys.exit(main(["bench", "realism", *sys.argv[1:]]))
