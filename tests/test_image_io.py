"""Image encoding round trips through decoders other than the one that wrote the file, and the
tone curve's hard cases."""

from __future__ import annotations

import time

import numpy as np
import OpenEXR
import pytest
from PIL import Image

from moonbot import _core

pytestmark = pytest.mark.unit


def test_exr_float_round_trip_is_exact(tmp_path):
    """Linear HDR written by OpenImageIO (zip) reads back bit-exactly with the OpenEXR package,
    across twelve decades of radiance."""
    rng = np.random.default_rng(7)
    hdr = (10.0 ** rng.uniform(-6, 6, size=(9, 13, 3))).astype(np.float32)
    path = tmp_path / "hdr.exr"
    _core.write_image(str(path), hdr)
    with OpenEXR.File(str(path)) as f:
        channels = f.channels()
        back = channels["RGB"].pixels if "RGB" in channels else np.stack([channels[c].pixels for c in "RGB"], axis=-1)
    assert back.dtype == np.float32
    np.testing.assert_array_equal(back, hdr)


def test_exr_bytes_do_not_depend_on_when_it_was_written(tmp_path):
    """The same pixels give the same EXR bytes a second later: OpenImageIO's time stamp (capDate)
    is left empty, so the dataset's bytes stay a function of config and seed."""
    hdr = np.linspace(0.0, 5.0, 4 * 5 * 3, dtype=np.float32).reshape(4, 5, 3)
    first, second = tmp_path / "first.exr", tmp_path / "second.exr"
    _core.write_image(str(first), hdr)
    time.sleep(1.1)  # past the stamp's one-second resolution
    _core.write_image(str(second), hdr)
    assert first.read_bytes() == second.read_bytes()


# 16-bit PNGs are single-channel here (depth); Pillow cannot decode 16-bit RGB as 16 bits.
@pytest.mark.parametrize(("dtype", "channels"), [(np.uint8, 1), (np.uint8, 3), (np.uint8, 4), (np.uint16, 1)])
@pytest.mark.parametrize("level", [0, 1, 9])
def test_png_round_trip_is_exact(tmp_path, dtype, channels, level):
    rng = np.random.default_rng(channels)
    shape = (17, 23) if channels == 1 else (17, 23, channels)
    pixels = rng.integers(0, np.iinfo(dtype).max, size=shape, endpoint=True, dtype=dtype)
    path = tmp_path / "x.png"
    _core.write_image(str(path), pixels, level)
    back = np.array(Image.open(path))
    assert back.dtype == dtype
    np.testing.assert_array_equal(back, pixels)


def test_overwrite_is_atomic_and_leaves_no_temporaries(tmp_path):
    path = tmp_path / "m.png"
    _core.write_image(str(path), np.zeros((4, 4), np.uint8))
    _core.write_image(str(path), np.full((4, 4), 9, np.uint8))
    assert [p.name for p in tmp_path.iterdir()] == ["m.png"]
    assert (np.array(Image.open(path)) == 9).all()


def test_tonemap_huge_dynamic_range_is_finite_and_monotone():
    """Hard case: radiance over 1e-6 … 1e6 (a 1e12:1 range) maps monotonically into [0, 255];
    NaN, -Inf and negatives map to 0, +Inf to white, and each such pixel is counted."""
    ramp = np.logspace(-6, 6, 500, dtype=np.float32)
    rgb = np.repeat(ramp[None, :, None], 3, axis=2)
    out, invalid = _core.tonemap_reinhard(rgb, 1.0)
    out = out[0, :, 0].astype(int)
    assert (np.diff(out) >= 0).all() and out[0] == 0 and out[-1] == 255 and invalid == 0
    bad = np.array([[[np.nan] * 3, [-np.inf] * 3, [-1.0] * 3, [np.inf] * 3]], np.float32)
    out, invalid = _core.tonemap_reinhard(bad, 1.0)
    assert (out[0, :3] == 0).all() and (out[0, 3] == 255).all() and invalid == 4


def test_tonemap_value_is_reinhard_then_srgb():
    """Grey Y = 1 → Y/(1+Y) = 0.5 → sRGB 0.7354 → 188; Y = 3 (exposure 3) → 0.75 → 225."""
    rgb = np.ones((1, 1, 3), np.float32)
    assert _core.tonemap_reinhard(rgb, 1.0)[0][0, 0].tolist() == [188] * 3
    assert _core.tonemap_reinhard(rgb, 3.0)[0][0, 0].tolist() == [225] * 3


@pytest.mark.parametrize(
    ("dtype", "ext", "shape"),
    [
        (np.uint8, ".png", (5, 7, 3)),
        (np.uint8, ".png", (5, 7)),
        (np.uint16, ".png", (5, 7)),
        (np.float32, ".exr", (5, 7, 3)),
    ],
)
def test_read_image_returns_what_was_written(tmp_path, dtype, ext, shape):
    rng = np.random.default_rng(3)
    pixels = (rng.random(shape) * 1000).astype(dtype)
    path = str(tmp_path / f"x{ext}")
    _core.write_image(path, pixels)
    back = _core.read_image(path)
    assert back.dtype == dtype and back.shape == shape
    np.testing.assert_array_equal(back, pixels)


def test_read_image_errors_name_the_path(tmp_path):
    with pytest.raises(OSError, match="missing.png"):
        _core.read_image(str(tmp_path / "missing.png"))
    broken = tmp_path / "broken.png"
    broken.write_bytes(b"\x89PNG\r\n\x1a\n" + b"not really")
    with pytest.raises(OSError, match="broken.png"):
        _core.read_image(str(broken))
