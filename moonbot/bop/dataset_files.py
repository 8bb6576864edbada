"""The files of a dataset being merged (moonbot.bop.merge) and what records them: each file is
written once into the staging tree and its size and sha256 go into `entries` (dataset-relative
path → (bytes, sha256)), from which manifest.json is made last. JSON is canonical (sorted keys,
image ids in numeric order), so merging again gives the same bytes."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
from pathlib import Path

import numpy as np

from moonbot import _core
from moonbot.writer.checksum import file_sha256

MANIFEST = "manifest.json"


def put_bytes(root: Path, rel: str, data: bytes, entries: dict) -> None:
    """Writes `data` to root/rel (inside the staging tree: no per-file atomicity needed) and
    records its size and sha256."""
    path = root / rel
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data)
    entries[rel] = (len(data), hashlib.sha256(data).hexdigest())


def put_png(root: Path, rel: str, pixels: np.ndarray, level: int, entries: dict) -> None:
    """Encodes `pixels` as PNG at zlib `level` to root/rel and records its size and sha256."""
    path = root / rel
    _core.write_image(str(path), pixels, level)
    entries[rel] = file_sha256(path)


def link_or_copy(src: Path, dst: Path) -> bool:
    """Hard-links `src` at `dst`; copies when the file system cannot (another device, no links).
    Returns whether it linked."""
    try:
        os.link(src, dst)
        return True
    except OSError:
        shutil.copyfile(src, dst)
        return False


def _canonical(value):
    """`value` with every dict's keys in a stable order: integer keys numerically, before the
    others, which are sorted as strings."""
    if isinstance(value, dict):
        keys = sorted(value, key=lambda k: (0, int(k), "") if str(k).lstrip("-").isdigit() else (1, 0, str(k)))
        return {str(k): _canonical(value[k]) for k in keys}
    if isinstance(value, (list, tuple)):
        return [_canonical(v) for v in value]
    return value


def dumps_json(value) -> bytes:
    """Canonical JSON bytes (UTF-8, indent 2, stable key order, trailing newline)."""
    return (json.dumps(_canonical(value), indent=2, ensure_ascii=False) + "\n").encode("utf-8")


def dumps_scene_json(per_image: dict) -> bytes:
    """A BOP per-scene file: {"im_id": value}, one image a line (bop_toolkit's own layout), image
    ids in numeric order, each value compact with sorted keys."""
    lines = [
        f'  "{im}": {json.dumps(_canonical(per_image[im]), separators=(", ", ": "))}'
        for im in sorted(per_image, key=int)
    ]
    return ("{\n" + ",\n".join(lines) + "\n}\n").encode("utf-8")


def write_manifest(root: Path, entries: dict, links: dict[str, str]) -> tuple[dict, bytes]:
    """Writes root/manifest.json: every file under `root` with its size and sha256 (those in
    `entries` as recorded there, any other hashed now), and every link → its target. Returns the
    manifest and its bytes."""
    for path in sorted(p for p in root.rglob("*") if p.is_file()):
        rel = path.relative_to(root).as_posix()
        if rel not in entries:
            entries[rel] = file_sha256(path)
    manifest = {
        "algorithm": "sha256",
        "file_count": len(entries),
        "total_bytes": sum(size for size, _ in entries.values()),
        "files": {rel: {"bytes": size, "sha256": sha} for rel, (size, sha) in sorted(entries.items())},
        "links": dict(sorted(links.items())),
    }
    manifest_bytes = dumps_json(manifest)
    (root / MANIFEST).write_bytes(manifest_bytes)
    return manifest, manifest_bytes
