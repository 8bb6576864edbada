"""JSON bytes laid out as bop_toolkit's `inout.save_json` writes them, so that a file moonbot
writes in one of bop_toolkit's formats (scene_gt_coco.json, a webdataset sample's gt.json or
mask.json) is byte for byte the file its own scripts would write from the same content.

The layout: an object has one top-level entry a line, in sorted key order, each value compact
(`json.dumps` with sorted keys, ", " and ": " separators); a list has one element a line; there
is no trailing newline.
"""

from __future__ import annotations

import json


def dumps_toolkit_json(content: dict | list) -> bytes:
    """`content` as bop_toolkit's save_json lays it out (UTF-8, ASCII escapes as json.dumps'
    default). Object keys must be of one kind (all str, or all int as in mask.json), since they
    are sorted as they are."""
    if isinstance(content, dict):
        items = sorted(content.items(), key=lambda item: item[0])
        lines = [f'  "{key}": {json.dumps(value, sort_keys=True)}' for key, value in items]
        return (
            "{\n" + "".join(line + (",\n" if k < len(lines) - 1 else "\n") for k, line in enumerate(lines)) + "}"
        ).encode("utf-8")
    if isinstance(content, list):
        lines = [f"  {json.dumps(value, sort_keys=True)}" for value in content]
        return (
            "[\n" + "".join(line + (",\n" if k < len(lines) - 1 else "\n") for k, line in enumerate(lines)) + "]"
        ).encode("utf-8")
    raise TypeError(f"expected a dict or a list, got {type(content).__name__}")
