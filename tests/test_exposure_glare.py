"""The lens's veiling glare (ISO 9358 integral method) in the tone-mapping stage: a black spot in a
uniform field reads the glare index; 0 changes nothing; invalid pixels stay invalid; the writer
and the config carry it."""

from __future__ import annotations

import json

import numpy as np
import pytest

from moonbot import _core
from moonbot.config import load_config
from moonbot.render import RenderedView, resolve_exposure
from moonbot.render.exposure import exposure_for_ev100, tonemap
from moonbot.scene.orbit import CameraPose
from moonbot.writer import write_sample

from scenes import VIEW_META

pytestmark = pytest.mark.unit


def veiled(rgb: np.ndarray, glare_index: float) -> np.ndarray:
    """The veil written out in numpy, as the test's oracle: radiance plus glare_index × each
    channel's mean over the pixels whose channels are all finite and >= 0 (summed in float64
    in pixel order), added to those pixels only. A new array."""
    rgb = np.asarray(rgb, dtype=np.float32)
    sound = np.isfinite(rgb).all(axis=2) & (rgb >= 0.0).all(axis=2)
    out = rgb.copy()
    if sound.any():
        out[sound] += (glare_index * rgb[sound].astype(np.float64).mean(axis=0)).astype(np.float32)
    return out


def codes(radiance: float, exposure) -> np.ndarray:
    """The 8-bit codes of a uniform radiance (W/(m²·sr)) at `exposure`, no glare."""
    return _core.tonemap_reinhard(np.full((1, 1, 3), radiance, np.float32), exposure.scale)[0][0, 0]


def test_black_spot_in_a_uniform_field_reads_the_glare_index():
    # ISO 9358: VGI = irradiance in the image of a black spot / that of the bright field around it.
    # With a spot of area fraction f, the mean is (1 - f)·L, so the spot reads g(1 - f)L and the
    # field L(1 + g(1 - f)): the index recovered from the image is g(1-f)/(1+g(1-f)).
    L, g = 3.0, 0.02
    rgb = np.full((100, 100, 3), L, np.float32)
    rgb[45:55, 45:55] = 0.0  # f = 0.01
    exposure = exposure_for_ev100(12.0, veiling_glare=g)
    out, invalid = tonemap(rgb, exposure)
    veil = g * 0.99 * L
    assert invalid == 0
    assert (out[50, 50] == codes(veil, exposure)).all() and out[50, 50, 0] > 0
    assert (out[0, 0] == codes(L + veil, exposure)).all()
    assert (rgb[50, 50] == 0).all()  # the input is not changed


def test_veil_is_per_channel_mean():
    rgb = np.zeros((2, 2, 3), np.float32)
    rgb[0, 0] = [4.0, 8.0, 0.0]
    exposure = exposure_for_ev100(8.0, veiling_glare=0.1)
    out, _ = tonemap(rgb, exposure)
    expected, _ = _core.tonemap_reinhard(np.array([[[0.1, 0.2, 0.0]]], np.float32), exposure.scale)
    assert (out[1, 1] == expected[0, 0]).all() and out[1, 1, 1] > out[1, 1, 0] > 0 == out[1, 1, 2]


def test_the_core_veil_is_the_numpy_formula_bit_for_bit():
    # A frame with every kind of bad pixel (NaN, ±Inf, negative) and -0.0: the core sums in
    # float64 in pixel order as numpy's axis-0 mean does, so the bytes agree.
    rng = np.random.default_rng(7)
    rgb = (10.0 ** rng.uniform(-3, 2, size=(48, 64, 3))).astype(np.float32)
    rgb[3, 5, 1] = np.nan
    rgb[7, 9, 0] = -np.inf
    rgb[11, 2, 2] = np.inf
    rgb[13, 4, 0] = -0.5
    rgb[19, 8] = -0.0
    for g in (0.02, 0.3):
        exposure = exposure_for_ev100(11.0, veiling_glare=g)
        out, invalid = tonemap(rgb, exposure)
        expected, expected_invalid = _core.tonemap_reinhard(veiled(rgb, g), exposure.scale)
        np.testing.assert_array_equal(out, expected)
        assert invalid == expected_invalid == 4
    # A negative subnormal channel makes its pixel invalid, never veiled, whatever the calling
    # thread's denormal mode (numpy's own comparison depends on it, so the oracle is not asked).
    rgb[17, 6, 1] = -1e-40
    out, invalid = tonemap(rgb, exposure_for_ev100(11.0, veiling_glare=0.3))
    bare, _ = _core.tonemap_reinhard(rgb, exposure_for_ev100(11.0).scale)
    assert invalid == 5 and (out[17, 6] == bare[17, 6]).all() and (out[17, 7] != bare[17, 7]).any()
    with pytest.raises(ValueError, match="^veiling_glare"):
        _core.tonemap_reinhard(rgb, 1.0, -0.01)
    with pytest.raises(ValueError, match="^veiling_glare"):
        _core.tonemap_reinhard(rgb, 1.0, float("nan"))


def test_zero_glare_is_bit_identical_to_the_core_tone_map():
    rng = np.random.default_rng(1)
    rgb = (10.0 ** rng.uniform(-4, 2, size=(16, 24, 3))).astype(np.float32)
    exposure = exposure_for_ev100(12.0)
    assert exposure.veiling_glare == 0.0
    a, ia = tonemap(rgb, exposure)
    b, ib = _core.tonemap_reinhard(rgb, exposure.scale)
    np.testing.assert_array_equal(a, b)
    assert ia == ib == 0


def test_glare_lifts_black_to_the_veil_and_leaves_invalid_pixels_counted():
    rgb = np.zeros((4, 4, 3), np.float32)
    rgb[0] = 2.0
    rgb[3, 3] = np.nan
    exposure = exposure_for_ev100(12.0, veiling_glare=0.05)
    out, invalid = tonemap(rgb, exposure)
    assert invalid == 1
    # The sound pixels' mean is 2·4/15; black pixels get 5 % of it, then the same tone map.
    veil = np.float32(0.05 * 2.0 * 4 / 15)
    expected, _ = _core.tonemap_reinhard(np.full((1, 1, 3), veil, np.float32), exposure.scale)
    assert (out[1, 1] == expected[0, 0]).all() and out[1, 1, 0] > 0
    all_bad = np.full((2, 2, 3), np.nan, np.float32)
    assert tonemap(all_bad, exposure)[1] == 4


def test_config_default_and_range_and_metadata(tmp_path):
    config = load_config(None, {})
    assert config.tonemap.veiling_glare == 0.02
    exposure = resolve_exposure(config)
    assert exposure.veiling_glare == 0.02
    with pytest.raises(Exception, match="veiling_glare"):
        load_config(None, {"tonemap.veiling_glare": -0.1})
    off = resolve_exposure(load_config(None, {"tonemap.veiling_glare": 0.0}))
    rgb = np.zeros((6, 8, 3), np.float32)
    rgb[:3] = 1.0
    view = RenderedView(rgb=rgb, depth=np.ones((6, 8), np.float32), instance=np.zeros((6, 8), np.uint8), stats={})
    K = np.array([[100.0, 0, 4], [0, 100.0, 3], [0, 0, 1]])
    pose = CameraPose(R=np.eye(3), t=np.zeros(3))
    for name, e in (("on", exposure), ("off", off)):
        out = tmp_path / name
        out.mkdir()
        gt = write_sample(out, view, e, K, pose, (), 1, VIEW_META, {})
        assert gt.exposure["veiling_glare_index"] == e.veiling_glare
        assert json.loads((out / "gt.json").read_text())["exposure"]["veiling_glare_index"] == e.veiling_glare
