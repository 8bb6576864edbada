"""BOP-webdataset shards of a dataset, in the layout bop_toolkit's
`bop_toolkit_lib/dataset/bop_webdataset.py` reads (the format of MegaPose's training data): each
split becomes

    OUT/<split>_web/
      shard-000000.tar  shard-000001.tar  ...   at most `shard_size` images each
      key_to_shard.json                        {"<key>": shard index, ...}

and each image one sample of consecutive tar members named `<key>.<field>`, key =
`<scene_id:06d>_<im_id:06d>` (bop_toolkit's image key), in this order:

    camera.json      the image's scene_camera.json entry
    depth.png        depth/<im_id>.png as it is (uint16; × depth_scale = mm)
    gt.json          its scene_gt.json list (one entry per instance)
    gt_info.json     its scene_gt_info.json list
    mask.json        {instance index: uncompressed COCO RLE of mask/ (amodal)}
    mask_visib.json  {instance index: RLE of mask_visib/ (visible)}
    rgb.png          rgb/<im_id>.png as it is (bop_webdataset's readers take rgb_suffix=".png")

The JSON members hold what bop_toolkit's scene-to-imagewise conversion writes: poses, cam_K and
the world-to-camera pose as floats, laid out as its save_json lays them out
(moonbot.bop.toolkit_json). Images go in dataset order (split, scene_id, im_id), or in the
order of NumPy's legacy `RandomState(seed).permutation` when a shuffle seed is given (its stream
is frozen across NumPy versions).

Bytes: every member is a POSIX ustar entry, mode 0444, uid and gid 0, no user or group name,
mtime 0, so a shard is a pure function of the dataset, the shard size and the seed. Each split's
folder is built beside its final place and renamed into it whole.
"""

from __future__ import annotations

import io
import json
import tarfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from moonbot.atomic_io import staged_directory
from moonbot.bop.coco import read_mask, rgb_name
from moonbot.bop.reader import DatasetError, load_json
from moonbot.bop.rle import encode_rle
from moonbot.bop.toolkit_json import dumps_toolkit_json
from moonbot.export.scenes import SceneDir, dataset_scenes

SHARD_NAME = "shard-{:06d}.tar"
KEY_TO_SHARD = "key_to_shard.json"
# bop_toolkit's converter puts 1000 images in a shard (MegaPose's shards hold 1000 too).
DEFAULT_SHARD_SIZE = 1000


@dataclass(frozen=True)
class SplitShards:
    """One split's shards: their folder, how many images and shards."""

    split: str
    folder: Path
    images: int
    shards: int


def image_key(scene_id: int, im_id: int) -> str:
    """bop_toolkit's key of an image: `<scene_id:06d>_<im_id:06d>`."""
    return f"{scene_id:06d}_{im_id:06d}"


def _floats(entry: dict, fields: tuple[str, ...]) -> dict:
    """`entry` with the listed matrix/vector fields as lists of floats (bop_toolkit reads them
    into float64 arrays and writes them back as lists)."""
    return {k: [float(x) for x in v] if k in fields else v for k, v in entry.items()}


def _read(path: Path) -> bytes:
    try:
        return path.read_bytes()
    except FileNotFoundError:
        raise DatasetError(f"{path}: missing") from None
    except OSError as e:
        raise DatasetError(f"{path}: unreadable ({e.strerror or e})") from None


@dataclass(frozen=True)
class _Image:
    scene: SceneDir
    im_id: int

    @property
    def key(self) -> str:
        return image_key(self.scene.scene_id, self.im_id)


def _scene_images(scene: SceneDir) -> list[_Image]:
    gt = load_json(scene.path / "scene_gt.json")
    try:
        return [_Image(scene, int(im)) for im in gt]
    except (TypeError, ValueError):
        raise DatasetError(f"{scene.path / 'scene_gt.json'}: keys must be image ids") from None


class _SceneFiles:
    """One scene's JSON files, read once, and its images' samples."""

    def __init__(self, scene: SceneDir) -> None:
        self.path = scene.path
        self.gt = load_json(scene.path / "scene_gt.json")
        self.gt_info = load_json(scene.path / "scene_gt_info.json")
        self.camera = load_json(scene.path / "scene_camera.json")

    def sample(self, im_id: int) -> list[tuple[str, bytes]]:
        """(field, bytes) of image im_id's members, in member order."""
        im = str(im_id)
        try:
            gt, gt_info, camera = self.gt[im], self.gt_info[im], self.camera[im]
            if len(gt_info) != len(gt):
                raise ValueError(f"{len(gt_info)} scene_gt_info entries for {len(gt)} instances")
            gt = [_floats(inst, ("cam_R_m2c", "cam_t_m2c")) for inst in gt]
            camera = _floats(camera, ("cam_K", "cam_R_w2c", "cam_t_w2c"))
        except (KeyError, TypeError, ValueError, AttributeError) as e:
            raise DatasetError(
                f"{self.path}: scene_gt, scene_gt_info and scene_camera.json disagree on image {im_id} ({e})"
            ) from None
        depth = _read(self.path / "depth" / f"{im_id:06d}.png")
        rgb_file = rgb_name(self.path, im_id)
        rgb = _read(self.path / rgb_file)
        height, width = _png_size(depth, self.path / "depth" / f"{im_id:06d}.png")
        masks = {}
        for folder in ("mask", "mask_visib"):
            masks[folder] = dumps_toolkit_json(
                {
                    k: encode_rle(read_mask(self.path / folder / f"{im_id:06d}_{k:06d}.png", height, width))
                    for k in range(len(gt))
                }
            )
        suffix = rgb_file.rsplit(".", 1)[1]
        return [
            ("camera.json", dumps_toolkit_json(camera)),
            ("depth.png", depth),
            ("gt.json", dumps_toolkit_json(gt)),
            ("gt_info.json", dumps_toolkit_json(gt_info)),
            ("mask.json", masks["mask"]),
            ("mask_visib.json", masks["mask_visib"]),
            (f"rgb.{suffix}", rgb),
        ]


def _png_size(data: bytes, path: Path) -> tuple[int, int]:
    """(height, width) from a PNG's IHDR chunk."""
    if data[:8] != b"\x89PNG\r\n\x1a\n" or data[12:16] != b"IHDR":
        raise DatasetError(f"{path}: not a PNG")
    return int.from_bytes(data[20:24], "big"), int.from_bytes(data[16:20], "big")


def _member(name: str, data: bytes) -> tarfile.TarInfo:
    info = tarfile.TarInfo(name)
    info.size, info.mtime, info.mode = len(data), 0, 0o444
    info.uid = info.gid = 0
    info.uname = info.gname = ""
    return info


def _chunks(items: list, size: int) -> Iterator[list]:
    for start in range(0, len(items), size):
        yield items[start : start + size]


def write_split_shards(
    scenes: list[SceneDir], split: str, folder: Path, shard_size: int, shuffle_seed: int | None = None
) -> SplitShards:
    """Writes the shards and key_to_shard.json of one split's `scenes` into `folder` (replaced
    whole). DatasetError naming the file when a scene file is missing or malformed; then
    `folder` is left as it was."""
    if shard_size < 1:
        raise ValueError(f"shard_size must be at least 1, got {shard_size}")
    images = [image for scene in scenes for image in _scene_images(scene)]
    if shuffle_seed is not None:
        images = [images[k] for k in np.random.RandomState(shuffle_seed).permutation(len(images))]
    files: dict[Path, _SceneFiles] = {}
    key_to_shard = {}
    with staged_directory(Path(folder)) as stage:
        for shard, chunk in enumerate(_chunks(images, shard_size)):
            with tarfile.open(stage / SHARD_NAME.format(shard), "w", format=tarfile.USTAR_FORMAT) as tar:
                for image in chunk:
                    scene_files = files.get(image.scene.path)
                    if scene_files is None:
                        # Shuffled images visit scenes in any order: their JSON files stay loaded.
                        scene_files = files[image.scene.path] = _SceneFiles(image.scene)
                    if image.key in key_to_shard:
                        raise DatasetError(
                            f"{image.scene.path}: image key {image.key} also names an image of "
                            "another scene of the split (scene ids must be unique in a split)"
                        )
                    for field, data in scene_files.sample(image.im_id):
                        tar.addfile(_member(f"{image.key}.{field}", data), io.BytesIO(data))
                    key_to_shard[image.key] = shard
        (stage / KEY_TO_SHARD).write_text(json.dumps(dict(sorted(key_to_shard.items()))), encoding="utf-8")
    return SplitShards(split, Path(folder), len(images), -(-len(images) // shard_size))


def write_shards(
    dataset: Path, out_dir: Path, shard_size: int = DEFAULT_SHARD_SIZE, shuffle_seed: int | None = None
) -> list[SplitShards]:
    """BOP-webdataset shards of every split of `dataset` under `out_dir`/<split>_web/ (module
    docstring). DatasetError or DatasetError naming the file when the dataset is malformed."""
    scenes = dataset_scenes(Path(dataset))
    splits = list(dict.fromkeys(s.split for s in scenes))
    return [
        write_split_shards(
            [s for s in scenes if s.split == split], split, Path(out_dir) / f"{split}_web", shard_size, shuffle_seed
        )
        for split in splits
    ]
