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
from moonbot.render.exposure import add_veiling_glare, exposure_for_ev100, tonemap
from moonbot.scene.orbit import CameraPose
from moonbot.writer import write_sample

from scenes import VIEW_META

pytestmark = pytest.mark.unit


def test_black_spot_in_a_uniform_field_reads_the_glare_index():
    # ISO 9358: VGI = irradiance in the image of a black spot / that of the bright field around it.
    # With a spot of area fraction f, the mean is (1 - f)·L, so the spot reads g(1 - f)L and the
    # field L(1 + g(1 - f)): the index recovered from the image is g(1-f)/(1+g(1-f)).
    L, g = 3.0, 0.02
    rgb = np.full((100, 100, 3), L, np.float32)
    rgb[45:55, 45:55] = 0.0  # f = 0.01
    out = add_veiling_glare(rgb, g)
    veil = g * 0.99 * L
    np.testing.assert_allclose(out[50, 50], veil, rtol=1e-6)
    np.testing.assert_allclose(out[0, 0], L + veil, rtol=1e-6)
    assert out[50, 50, 0] / out[0, 0, 0] == pytest.approx(veil / (L + veil), rel=1e-6)
    assert (rgb[50, 50] == 0).all()  # the input is not changed


def test_veil_is_per_channel_mean():
    rgb = np.zeros((2, 2, 3), np.float32)
    rgb[0, 0] = [4.0, 8.0, 0.0]
    out = add_veiling_glare(rgb, 0.1)
    np.testing.assert_allclose(out[1, 1], [0.1, 0.2, 0.0], rtol=1e-6)


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
