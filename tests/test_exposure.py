"""Physical exposure (EV100, `auto` metering) and the tone map's hard cases: values against hand
computations, a 1e6:1 dynamic range, NaN/Inf/negative radiance, and rgb.exr written with a view
and read back by an independent decoder (the OpenEXR package)."""

from __future__ import annotations

import json
import math

import numpy as np
import OpenEXR
import pytest

from moonbot import _core
from moonbot.config import Config, load_config
from moonbot.render import RenderedView, resolve_exposure
from moonbot.render.exposure import (
    AUTO_MIN_ELEVATION_DEG,
    EV100_MIN,
    LUMINOUS_EFFICACY_LM_W,
    auto_ev100,
    exposure_for_ev100,
    metered_ev100,
    regolith_reflectance,
    saturation_luminance,
)
from moonbot.scene.orbit import CameraPose
from moonbot.writer import RADIANCE_UNIT, finite_radiance, write_sample

from scenes import VIEW_META

pytestmark = pytest.mark.unit


def grey(values) -> np.ndarray:
    """(1, N, 3) float32 grey pixels of the given radiances."""
    v = np.asarray(values, dtype=np.float32)
    return np.repeat(v[None, :, None], 3, axis=2)


def test_saturation_luminance_and_scale_by_hand():
    """ISO 100, q = 0.65: L_sat = 78 / (100 · 0.65) · 2^EV = 1.2 · 2^EV cd/m²; the scale is
    (1.27e5 / 1361) lm/W over it."""
    assert saturation_luminance(0.0) == pytest.approx(1.2, rel=1e-12)
    assert saturation_luminance(10.0) == pytest.approx(1228.8, rel=1e-12)
    assert LUMINOUS_EFFICACY_LM_W == pytest.approx(93.3137, rel=1e-5)
    # EV100 14: L_sat = 1.2 · 16384 = 19660.8 cd/m²; scale = 93.3137 / 19660.8 sr·m²/W.
    assert exposure_for_ev100(14.0).scale == pytest.approx(93.31374 / 19660.8, rel=1e-6)
    # A reflected-light meter (K = 12.5) reads L = 12.5 / 100 · 2^EV: 128 cd/m² is EV100 10.
    assert metered_ev100(128.0) == pytest.approx(10.0, abs=1e-12)


@pytest.mark.parametrize(
    ("albedo", "elevation", "irradiance"),
    [
        (0.12, 30.0, 1361.0),
        (0.12, 10.0, 1361.0),
        (0.12, 12.0, 1361.0),
        (0.07, 5.0, 1361.0),
        (0.18, 45.0, 1316.0),
        (0.12, 90.0, 1408.0),
    ],
)
def test_auto_ev100_is_the_closed_form(albedo, elevation, irradiance):
    """auto = log2(L · 100 / 12.5), L = ρ · E · 93.31 lm/W · sin(el) / π."""
    luminance = albedo * irradiance * (1.27e5 / 1361.0) * math.sin(math.radians(elevation)) / math.pi
    assert auto_ev100(albedo, elevation, irradiance) == pytest.approx(math.log2(8.0 * luminance), abs=1e-12)


def test_auto_reproduces_the_reference_values():
    """docs/physics.md: regolith of albedo 0.12 is EV100 ≈ 14.2 at 30° (Apollo's sunlit
    f/11, 1/250 s, ISO 160 is 14.2) and ≈ 12.7 at 10°; the default config (12°) is 12.98."""
    assert auto_ev100(0.12, 30.0, 1361.0) == pytest.approx(14.24, abs=0.005)
    assert auto_ev100(0.12, 10.0, 1361.0) == pytest.approx(12.72, abs=0.005)
    assert math.log2(11**2 * 250) + math.log2(100 / 160) == pytest.approx(14.2, abs=0.05)
    lambert = load_config(None, {"terrain.photometry.model": "lambert"})
    assert lambert.tonemap.ev100 == "auto"
    assert resolve_exposure(lambert).ev100 == pytest.approx(12.98, abs=0.005)
    # Lunar-Lambert regolith of the same normal albedo, cross-lit at 12°, reads darker: its
    # reflectance seen from the orbit camera (26.6° down), averaged over azimuth, is ρ = 0.088.
    default = load_config()
    assert regolith_reflectance(default) == pytest.approx(0.088, abs=0.002)
    assert resolve_exposure(default).ev100 == pytest.approx(auto_ev100(regolith_reflectance(default), 12.0, 1361.0))


@pytest.mark.parametrize("elevation", [AUTO_MIN_ELEVATION_DEG, 0.5, 0.0, -0.25, -10.0, -90.0])
def test_auto_with_the_sun_at_or_below_the_horizon_is_finite(elevation):
    """Below 1° the meter is held at its 1° reading (EV100 9.40 for albedo 0.12), never -inf."""
    ev = auto_ev100(0.12, elevation, 1361.0)
    assert math.isfinite(ev) and ev == pytest.approx(math.log2(8 * 0.12 * 1.27e5 * math.sin(math.radians(1)) / math.pi))
    assert math.isfinite(exposure_for_ev100(ev).scale)


def test_auto_with_no_light_is_the_lowest_ev():
    assert auto_ev100(0.0, 30.0, 1361.0) == auto_ev100(0.12, 30.0, 0.0) == EV100_MIN


def test_resolve_uses_the_number_or_meters_the_terrain():
    fixed = resolve_exposure(load_config(None, {"tonemap.ev100": 14}))
    assert fixed.ev100 == 14.0 and fixed.setting == 14.0
    assert fixed.metadata()["saturation_luminance_cd_m2"] == pytest.approx(19660.8)
    bright = resolve_exposure(load_config(None, {"sun.elevation_deg": 30}))
    dark = resolve_exposure(load_config(None, {"terrain.albedo": 0.06, "sun.elevation_deg": 30}))
    assert dark.setting == "auto" and dark.ev100 == pytest.approx(bright.ev100 - 1, abs=1e-12)


def test_metered_regolith_lands_on_the_meter_grey():
    """A Lambertian plane of the terrain's albedo, rendered at the `auto` exposure, is at
    12.5/(100·1.2) = 0.104 of saturation: Reinhard 0.0943, sRGB 0.3395 → code 87."""
    for albedo, elevation in ((0.12, 12.0), (0.07, 5.0), (0.18, 30.0)):
        exposure = exposure_for_ev100(auto_ev100(albedo, elevation, 1361.0))
        radiance = albedo * 1361.0 * math.sin(math.radians(elevation)) / math.pi
        out, invalid = _core.tonemap_reinhard(grey([radiance]), exposure.scale)
        assert out[0, 0].tolist() == [87] * 3 and invalid == 0


@pytest.mark.parametrize("colour", [(1.0, 1.0, 1.0), (0.12, 0.11, 0.10), (0.55, 0.45, 0.32), (1.0, 0.01, 0.02)])
def test_a_million_to_one_is_finite_and_monotone(colour):
    """Radiance 1e-3 … 1e3 W/(m²·sr) (1e6:1) of one chromaticity, at the default exposure and at
    Apollo's: every channel is non-decreasing with luminance, the ends differ, and the ramp
    continued past the largest float and to +Inf saturates rather than turning black."""
    ramp = np.concatenate([np.logspace(-3, 3, 2000), [1e30, 3.4e38, np.inf]])
    rgb = (ramp[:, None] * np.asarray(colour)[None, :]).astype(np.float32)[None]
    for ev100 in (resolve_exposure(Config()).ev100, 14.2):
        out, invalid = _core.tonemap_reinhard(rgb, exposure_for_ev100(ev100).scale)
        assert invalid == 1  # the +Inf pixel
        channels = out[0].astype(int)
        assert (np.diff(channels, axis=0) >= 0).all()
        assert channels[0].max() <= 1 and channels[1999].max() >= 128 and (channels[-1] == 255).all()


def test_invalid_radiance_gives_finite_output_and_is_counted():
    """NaN, -Inf and negative channels count as 0 (black), +Inf as the brightest value; the count
    is of pixels with any such channel (-0.0 is fine)."""
    rgb = np.array(
        [
            [
                [np.nan] * 3,
                [-np.inf] * 3,
                [-1.0] * 3,
                [np.inf] * 3,
                [np.nan, 1.0, 1.0],
                [1.0, -5.0, 1.0],
                [-0.0, 0.0, 0.0],
                [1.0, 1.0, 1.0],
            ]
        ],
        np.float32,
    )
    out, invalid = _core.tonemap_reinhard(rgb, 1.0)
    assert invalid == 6
    assert out[0, :3].max() == 0 and out[0, 3].tolist() == [255] * 3
    assert out[0, 4].tolist() == [0, 197, 197]  # (0, 1, 1): Y = 0.7874 → 1/1.7874 = 0.5595 → 197.2
    assert out[0, 6].tolist() == [0] * 3 and out[0, 7].tolist() == [188] * 3
    # An exposure just above float32's largest (finite as a double) keeps black black.
    black, _ = _core.tonemap_reinhard(np.zeros((1, 2, 3), np.float32), 3.4028235677973366e38)
    assert (black == 0).all()
    clean = finite_radiance(rgb)
    assert np.isfinite(clean).all() and (clean >= 0).all() and clean.dtype == np.float32
    assert clean[0, 3].tolist() == [np.finfo(np.float32).max] * 3 and clean[0, :3].max() == 0
    np.testing.assert_array_equal(clean[0, 7], rgb[0, 7])
    assert not np.signbit(clean).any()


def test_invalid_count_does_not_depend_on_the_threads_float_mode():
    """After Embree has built and rendered on the thread pool (which leaves denormals-are-zero
    set on its workers), a negative subnormal still counts as negative, on every worker: the
    core classifies samples by their bits."""
    from scenes import ground_and_box

    scene, _ = ground_and_box()
    cam = _core.Camera(50.0, 50.0, 32.0, 24.0, 64, 48, np.eye(3), np.array([0.0, 0.0, 2.0]))
    _core.render(scene, cam, _core.DirectionalLight(120.0, 30.0, 1361.0), _core.RenderSettings(spp=1))
    rgb = np.full((300, 300, 3), 1e-39, np.float32)
    rgb[::2] = -1e-39
    out, invalid = _core.tonemap_reinhard(rgb, 1.0)
    assert invalid == 150 * 300 and (out == 0).all()


def view_of(rgb: np.ndarray) -> RenderedView:
    h, w, _ = rgb.shape
    return RenderedView(rgb=rgb, depth=np.ones((h, w), np.float32), instance=np.zeros((h, w), np.uint8), stats={})


def write(tmp_path, rgb: np.ndarray, exr: bool, ev100: float = 13.0) -> dict:
    """write_sample's gt.json record, as the JSON object it wrote."""
    h, w, _ = rgb.shape
    K = np.array([[100.0, 0, w / 2], [0, 100.0, h / 2], [0, 0, 1]])
    pose = CameraPose(R=np.eye(3), t=np.zeros(3))
    return write_sample(
        tmp_path, view_of(rgb), exposure_for_ev100(ev100), K, pose, (), 1, VIEW_META, {}, exr=exr
    ).as_json()


def read_exr(path) -> tuple[np.ndarray, dict]:
    with OpenEXR.File(str(path)) as f:
        channels = f.channels()
        pixels = channels["RGB"].pixels if "RGB" in channels else np.stack([channels[c].pixels for c in "RGB"], axis=-1)
        return pixels, dict(f.header())


def test_rgb_exr_round_trips_exactly_with_its_unit(tmp_path):
    """rgb.exr holds the rendered float32 radiance bit for bit (twelve decades), its header and
    gt.json say W/(m²·sr), whiteLuminance (cd/m² of RGB 1.0) and the EV100 of rgb.png; rgb.png is
    the tone map of what rgb.exr holds."""
    rng = np.random.default_rng(11)
    rgb = (10.0 ** rng.uniform(-6, 6, size=(24, 32, 3))).astype(np.float32)
    gt = write(tmp_path, rgb, exr=True, ev100=12.5)
    back, header = read_exr(tmp_path / "rgb.exr")
    assert back.dtype == np.float32
    np.testing.assert_array_equal(back, rgb)
    assert header["moonbot:radianceUnit"] == RADIANCE_UNIT == "W/(m^2*sr)"
    assert header["whiteLuminance"] == pytest.approx(LUMINOUS_EFFICACY_LM_W, rel=1e-6)
    assert header["moonbot:ev100"] == pytest.approx(12.5)
    on_disk = json.loads((tmp_path / "gt.json").read_text())
    assert on_disk == gt
    assert gt["rgb_exr"]["unit"] == RADIANCE_UNIT and gt["rgb_exr"]["sample_type"] == "float32"
    assert gt["exposure"]["ev100"] == 12.5 and gt["rgb_invalid_pixels"] == 0
    png = _core.read_image(str(tmp_path / "rgb.png"))
    np.testing.assert_array_equal(png, _core.tonemap_reinhard(back, gt["exposure"]["scale_sr_m2_w"])[0])


def test_rgb_exr_is_absent_by_default(tmp_path):
    gt = write(tmp_path, np.ones((4, 5, 3), np.float32), exr=False)
    assert not (tmp_path / "rgb.exr").exists() and "rgb_exr" not in gt
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        ["rgb.png", "depth.npy", "depth.png", "depth_preview.png", "mask.png", "gt.json"]
    )


def test_invalid_radiance_never_reaches_the_files(tmp_path):
    """A render with NaN, ±Inf and negatives writes finite rgb.exr and rgb.png and records how
    many pixels were replaced; the valid pixels are written unchanged."""
    rgb = np.full((6, 7, 3), 2.5, np.float32)
    rgb[0, 0] = np.nan
    rgb[1, 1, 0] = np.inf
    rgb[2, 2, 1] = -np.inf
    rgb[3, 3] = -1e-3
    gt = write(tmp_path, rgb, exr=True)
    assert gt["rgb_invalid_pixels"] == 4
    back, _ = read_exr(tmp_path / "rgb.exr")
    assert np.isfinite(back).all() and (back >= 0).all()
    np.testing.assert_array_equal(back, finite_radiance(rgb))
    assert back[1, 1, 0] == np.finfo(np.float32).max and back[0, 0].max() == 0
    png = _core.read_image(str(tmp_path / "rgb.png"))
    assert png[0, 0].tolist() == [0, 0, 0] and png[1, 1, 0] == 255
    assert np.isnan(rgb[0, 0]).all()  # the caller's array is not changed
