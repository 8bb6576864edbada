"""The realism statistics (moonbot/benchmark/realism.py) against analytic answers on synthetic
images: spectrum slope of 1/f^β noise, shadow fraction, dark blob counts and sizes, sky and
reseau masks, percentile normalisation, octave contrast of a sinusoid, the Laplacian, resampling,
the tone-free statistics' indifference to the tone curve, the classifier two-sample test and
SOURCES.csv parsing."""

from __future__ import annotations

import math

import numpy as np
import pytest

from moonbot.benchmark import realism

pytestmark = pytest.mark.unit


def power_law_noise(size: int, beta: float, seed: int) -> np.ndarray:
    """A periodic (size, size) Gaussian field with power spectrum ∝ |f|^-β, zero mean, unit std."""
    rng = np.random.default_rng(seed)
    f = realism.radial_frequency(size)
    amplitude = np.where(f > 0, f, 1.0) ** (-beta / 2.0)
    amplitude[0, 0] = 0.0
    field = np.fft.ifft2(np.fft.fft2(rng.standard_normal((size, size))) * amplitude).real
    return field / field.std()


# β = 3 is steeper than any ground measured (−1.7 to −2.7): the window's leakage biases it by ≈ −0.06.
@pytest.mark.parametrize("beta, tolerance", [(1.0, 0.1), (2.0, 0.1), (2.5, 0.1), (3.0, 0.15)])
def test_spectrum_slope_of_power_law_noise_is_minus_beta(beta, tolerance):
    y = 0.5 + 0.05 * power_law_noise(512, beta, seed=int(beta * 10))
    mask = np.ones(y.shape, bool)
    tiles = realism.ground_tiles(y, mask)
    assert len(tiles) == 64
    slope = realism.spectrum_slope(realism.contrast_periodogram(tiles, float(y.mean())))
    assert slope == pytest.approx(-beta, abs=tolerance)


def test_spectrum_slope_ignores_exposure():
    y = 0.3 + 0.03 * power_law_noise(256, 2.0, seed=3)
    mask = np.ones(y.shape, bool)
    a = realism.image_statistics(y, mask, px_per_deg=16.0)
    b = realism.image_statistics(2.0 * y, mask, px_per_deg=16.0)
    assert a["spectrum_slope"] == pytest.approx(b["spectrum_slope"], abs=1e-9)
    assert a["octave_rms_contrast"] == pytest.approx(b["octave_rms_contrast"], rel=1e-9)


def test_periodogram_sums_to_contrast_variance():
    y = 1.0 + 0.1 * power_law_noise(256, 1.0, seed=5)
    tiles = realism.ground_tiles(y, np.ones(y.shape, bool))
    periodogram = realism.contrast_periodogram(tiles, 1.0)
    within_tiles = np.mean([t.var() for t in tiles])
    # the Hann window weights the tile's centre; on a stationary field the mean is the variance
    assert periodogram.sum() == pytest.approx(within_tiles, rel=0.05)


def test_octave_contrast_of_a_sinusoid():
    t = 64
    amplitude = 0.2
    f = 12 / t  # 0.1875 cycles/px: inside the second octave [0.125, 0.25)
    x = np.arange(512)
    y = 1.0 + amplitude * np.sin(2 * math.pi * f * x)[None, :] * np.ones((512, 1))
    tiles = realism.ground_tiles(y, np.ones(y.shape, bool), t)
    octaves = realism.octave_rms_contrast(realism.contrast_periodogram(tiles, 1.0))
    assert octaves[1] == pytest.approx(amplitude / math.sqrt(2), rel=0.03)
    # removing each tile's plane leaks a little of the sine into the coarsest band
    assert max(octaves[0], *octaves[2:]) < 0.03 * octaves[1]


def test_shadow_fraction_counts_pixels_below_five_percent_of_p99():
    y = np.full((100, 100), 0.8)
    y.flat[::10] = 0.01  # 10 %: below 0.05 × 0.8 = 0.04
    y.flat[1::50] = 0.05  # 2 %: dark but above the level
    mask = np.ones(y.shape, bool)
    assert realism.shadow_fraction(y, mask) == pytest.approx(0.10)
    # masked-out pixels do not count
    mask[:50] = False
    assert realism.shadow_fraction(y, mask) == pytest.approx(0.10)
    with pytest.raises(ValueError, match="empty"):
        realism.shadow_fraction(y, np.zeros(y.shape, bool))
    # a lifted black level hides the shadows unless it is taken off
    lifted = 0.05 + 0.9 * y
    assert realism.shadow_fraction(lifted, mask) == 0.0
    assert realism.shadow_fraction(lifted, mask, black=0.05) == pytest.approx(0.10)
    assert realism.black_level(lifted) == pytest.approx(0.05 + 0.9 * 0.01)


def test_percentiles_over_the_median():
    y = np.linspace(0.1, 0.9, 10001).reshape(73, 137)  # 10001 = 73 × 137
    expected = {f"p{p}": (0.1 + 0.8 * p / 100) / 0.5 for p in realism.PERCENTILES}
    mask = np.ones(y.shape, bool)
    assert realism.luma_percentiles(y, mask) == pytest.approx(expected, rel=1e-9)
    # independent of exposure
    assert realism.luma_percentiles(0.5 * y, mask) == pytest.approx(expected, rel=1e-9)


def draw_disk(y: np.ndarray, row: float, col: float, radius: float, value: float) -> int:
    rr, cc = np.mgrid[: y.shape[0], : y.shape[1]]
    inside = (rr - row) ** 2 + (cc - col) ** 2 <= radius**2
    y[inside] = value
    return int(inside.sum())


def test_dark_blobs_count_and_size():
    px_per_deg = 20.0  # the largest blob kept is 1° = 20 px across
    y = np.full((300, 400), 0.7)
    radii = [1.5, 2.0, 3.0, 4.0, 5.0, 6.5, 8.0]
    areas = [draw_disk(y, 40 + 35 * k, 60 + 40 * k, r, 0.05) for k, r in enumerate(radii)]
    draw_disk(y, 150, 340, 15.0, 0.05)  # 30 px across: a crater's shadow, not a pebble's
    draw_disk(y, 0, 200, 4.0, 0.05)  # cut by the image's edge: size unknown
    y[200, 380] = 0.05  # a single pixel: noise
    mask = np.ones(y.shape, bool)
    blobs = realism.dark_blobs(y, mask, px_per_deg)
    assert len(blobs.diameters_px) == len(radii)
    assert sorted(blobs.diameters_px) == pytest.approx([2 * math.sqrt(a / math.pi) for a in areas], rel=1e-9)
    assert sorted(blobs.diameters_px) == pytest.approx([2 * r for r in radii], rel=0.15)
    assert blobs.covered_px == sum(areas)
    stats = realism.blob_statistics(blobs, px_per_deg)
    assert stats["blobs_per_deg2"] == pytest.approx(len(radii) / (300 * 400 / px_per_deg**2))


def test_dark_blobs_are_dark_relative_to_their_surroundings():
    # the same faint disk is a blob on bright ground and not on dim ground
    px_per_deg = 20.0
    y = np.full((100, 200), 0.2)
    y[:, 100:] = 0.8
    draw_disk(y, 50, 50, 4, 0.15)
    draw_disk(y, 50, 150, 4, 0.15)
    blobs = realism.dark_blobs(y, np.ones(y.shape, bool), px_per_deg)
    assert len(blobs.diameters_px) == 1


def test_sky_mask_is_the_dark_run_from_the_top():
    h, w = 120, 160
    cols = np.arange(w)
    horizon = (40 + 10 * np.sin(cols / 20)).astype(int)  # a tilted, wavy horizon
    y = np.full((h, w), 0.5)
    rows = np.arange(h)[:, None]
    y[rows < horizon[None, :]] = 0.01
    y[80:100, 30:60] = 0.0  # a black shadow on the ground, not touching the sky
    sky = realism.sky_mask(y, smooth_px=1)
    assert np.array_equal(sky, rows < horizon[None, :])
    ground = realism.ground_mask(y, px_per_deg=16.0, detect_reseau=False)
    # with the default smoothing the sky may end a row early; the margin covers that row
    margin = realism.HORIZON_MARGIN_PX
    assert not ground.mask[rows < horizon[None, :]].any()
    assert ground.mask[rows >= horizon[None, :] + margin].all()
    assert ground.mask.sum() >= ((rows >= horizon[None, :] + margin).sum())
    assert ground.mask.sum() <= ((rows >= horizon[None, :] + margin - 1).sum())
    assert ground.mask[80:100, 30:60].all()


def draw_cross(y: np.ndarray, row: int, col: int, arm: int, value: float) -> None:
    y[row, col - arm : col + arm + 1] = value
    y[row - arm : row + arm + 1, col] = value


def test_reseau_crosses_on_a_grid_are_masked_and_lone_shapes_are_not():
    px_per_deg = 16.0
    step = round(realism.RESEAU_GRID_DEG * px_per_deg)  # 151 px
    arm = round(0.35 * px_per_deg)
    rng = np.random.default_rng(0)
    y = 0.5 + 0.02 * rng.standard_normal((400, 500))
    centres = [(60 + step * i, 80 + step * j) for i in range(2) for j in range(3)]
    for r, c in centres:
        draw_cross(y, r, c, arm, 0.2)
    draw_cross(y, 360, 460, arm, 0.2)  # a lone cross: no grid partner
    y[330, 20:200] = 0.2  # a long thin line (a staff's shadow)
    mask = realism.reseau_cross_mask(y, px_per_deg)
    for r, c in centres:
        assert mask[r - arm : r + arm + 1, c].all() and mask[r, c - arm : c + arm + 1].all()
    assert not mask[360, 460]
    assert not mask[330, 20:200].any()
    assert mask.sum() <= len(centres) * (2 * round(1.5 * round(realism.RESEAU_ARM_DEG * px_per_deg)) + 1) ** 2


def test_laplacian_contrast():
    rr, cc = np.mgrid[:64, :64]
    mask = np.ones((64, 64), bool)
    assert realism.laplacian_contrast(0.2 + 0.001 * rr + 0.002 * cc, mask) == pytest.approx(0.0, abs=1e-9)
    a, m = 0.05, 0.4
    checker = m + a * np.where((rr + cc) % 2 == 0, 1.0, -1.0)
    assert realism.laplacian_contrast(checker, mask) == pytest.approx(8 * a / m, rel=1e-9)


def test_area_resample_conserves_the_mean_and_averages_boxes():
    rng = np.random.default_rng(1)
    image = rng.random((200, 300))
    half = realism.area_resample(image, (100, 150))
    assert half == pytest.approx(image.reshape(100, 2, 150, 2).mean(axis=(1, 3)), abs=1e-12)
    odd = realism.area_resample(image, (77, 113))
    assert odd.mean() == pytest.approx(image.mean(), rel=1e-12)
    checker = np.indices((200, 300)).sum(axis=0) % 2
    assert realism.area_resample(checker.astype(float), (100, 150)) == pytest.approx(0.5)


def test_measure_one_path_for_an_8bit_image():
    rng = np.random.default_rng(2)
    y = np.clip(0.5 + 0.1 * power_law_noise(384, 2.0, seed=7), 0, 1)
    rgb8 = np.repeat((y * 255).round().astype(np.uint8)[..., None], 3, axis=2)
    rgb8[:64] = 0  # sky
    measured = realism.measure(rgb8, hfov_deg=48.0, px_per_deg=4.0)  # 384 px → 192
    assert measured.luma.shape == (192, 192)
    assert not measured.ground.mask[:32].any()
    assert measured.stats["spectrum_slope"] == pytest.approx(-2.0, abs=0.3)
    with pytest.raises(ValueError, match="no ground"):
        realism.measure(np.zeros((64, 64, 3), np.uint8), 48.0, 1.0)
    with pytest.raises(ValueError, match="uint8"):
        realism.luma(rng.random((4, 4, 3)))


def test_two_sample_accuracy():
    rng = np.random.default_rng(3)
    same = realism.two_sample_accuracy(rng.standard_normal((400, 3)), rng.standard_normal((400, 3)), seed=1)
    assert abs(same["accuracy"] - 0.5) < 0.08
    shifted = rng.standard_normal((400, 3))
    shifted[:, 1] += 4.0
    apart = realism.two_sample_accuracy(rng.standard_normal((400, 3)), shifted, seed=1)
    assert apart["accuracy"] > 0.95
    assert np.argmax(apart["single_feature_accuracy"]) == 1
    assert np.argmax(np.abs(apart["weights"])) == 1


def test_read_sources_and_regions(tmp_path):
    (tmp_path / "a.jpg").write_bytes(b"")
    (tmp_path / "b.jpg").write_bytes(b"")
    (tmp_path / "SOURCES.csv").write_text(
        "file,what_it_shows,approx_sun_elevation_deg,licence,\n"
        'a.jpg,"ground, rocks","~14-15 (EVA 02:39, Sun 10.8 deg",x\n'
        "b.jpg,ground,~12,x\n"
    )
    a, b = realism.read_sources(tmp_path)
    assert (a.sun_low_deg, a.sun_high_deg, a.sun_mid_deg, a.what) == (14.0, 15.0, 14.5, "ground, rocks")
    assert (b.sun_low_deg, b.sun_high_deg) == (12.0, 12.0)
    (tmp_path / "SOURCES.csv").write_text("file,approx_sun_elevation_deg\na.jpg,~14-15\nb.jpg,high\n")
    with pytest.raises(ValueError, match=r"SOURCES.csv: line 3: approx_sun_elevation_deg"):
        realism.read_sources(tmp_path)
    (tmp_path / "SOURCES.csv").write_text("file,sun\na.jpg,~14-15\n")
    with pytest.raises(ValueError, match="line 1: missing column"):
        realism.read_sources(tmp_path)
    (tmp_path / "SOURCES.csv").write_text("file,approx_sun_elevation_deg\nc.jpg,~14-15\n")
    with pytest.raises(ValueError, match="line 2: photo c.jpg not found"):
        realism.read_sources(tmp_path)
    regions = tmp_path / "rois.csv"
    regions.write_text("# comment\nfile,x0,y0,x1,y1\na.jpg,0.1,0.2,0.9,0.8\nb.jpg,0.5,0.2,0.4,0.8\n")
    with pytest.raises(ValueError, match="rois.csv: line 4"):
        realism.read_regions(regions)
    regions.write_text("file,x0,y0,x1,y1\na.jpg,0.1,0.2,0.9,0.8\n")
    assert realism.read_regions(regions)["a.jpg"] == realism.RegionOfInterest(0.1, 0.2, 0.9, 0.8)


def test_fine_to_coarse_contrast():
    assert realism.fine_to_coarse([3.0, 4.0, 9.0, 6.0, 8.0]) == pytest.approx(0.5)
    assert math.isnan(realism.fine_to_coarse([3.0, 4.0, 9.0, 0.0, 0.0]))


def test_look_pose_points_the_optical_axis_down_the_azimuth():
    from moonbot.benchmark.realism_bench import look_pose

    eye = np.array([1.0, 2.0, 1.5])
    pose = look_pose(eye, azimuth_deg=90.0, pitch_deg=30.0)  # looking East, 30° down
    assert pose.center == pytest.approx(eye)
    assert pose.R[2] == pytest.approx([math.cos(math.radians(30)), 0.0, -math.sin(math.radians(30))], abs=1e-12)
    assert pose.R[0][2] == pytest.approx(0.0)  # image x level
    assert pose.R[1][2] < 0  # image y points down
    assert pose.R @ pose.R.T == pytest.approx(np.eye(3), abs=1e-12)
    assert np.linalg.det(pose.R) == pytest.approx(1.0)


def test_render_plans_and_separation():
    from moonbot.benchmark.realism_bench import Options, render_plans, separation

    plans = render_plans([12.5, 14.5], Options(locations=("flat", "hilly")))
    assert [p.name for p in plans] == [
        "flat-sun12.5-cross-seed1",
        "flat-sun12.5-down-seed1",
        "flat-sun14.5-cross-seed1",
        "flat-sun14.5-down-seed1",
        "flat-sun12.5-cross-bag-seed1",
        "hilly-sun12.5-cross-seed1",
        "hilly-sun14.5-cross-seed1",
        "flat-sun12.5-cross-seed2",
    ]
    s = separation([1.0, 2.0, 3.0, 4.0, 5.0], [9.0, 11.0, 4.5])
    assert s["score"] == pytest.approx((9.0 - 3.0) / 2.0)
    assert s["outside_fraction"] == pytest.approx(2 / 3)


def test_tone_free_statistics_do_not_depend_on_the_tone_curve():
    # A granular field with dark blobs, and the same under a strictly increasing curve (a film's
    # S-shaped curve): the luma statistics move, the tone-free ones are the same to rounding.
    y = np.exp(0.3 * power_law_noise(256, 2.0, seed=11))
    y[40:44, 60:63] *= 0.2
    mask = np.ones_like(y, dtype=bool)
    mask[:20] = False
    curved = 1.0 / (1.0 + np.exp(-4.0 * (np.log(y) - 0.1)))
    plain = realism.image_statistics(y, mask, px_per_deg=16.0)
    bent = realism.image_statistics(curved, mask, px_per_deg=16.0)
    assert bent["laplacian_contrast"] != pytest.approx(plain["laplacian_contrast"], rel=0.05)
    a, b = realism.flatten(plain["tone_free"]), realism.flatten(bent["tone_free"])
    assert a.keys() == b.keys() and "octave_rms_contrast.1-2_cyc_per_deg" in a
    for key in a:
        assert b[key] == pytest.approx(a[key], rel=1e-9, abs=1e-12, nan_ok=True), key


def test_tone_free_luma_is_lognormal_of_fixed_spread_on_the_ground():
    rng = np.random.default_rng(5)
    y = rng.random((64, 64)) ** 3
    y[10, :8] = 0.5  # ties share one value
    mask = np.ones_like(y, dtype=bool)
    mask[:4] = False
    t = realism.tone_free(y, mask)
    assert np.all(t[~mask] == 1.0)
    logs = np.log(t[mask])
    assert np.median(logs) == pytest.approx(0.0, abs=1e-3)
    assert logs.std() == pytest.approx(realism.TONE_FREE_SIGMA, rel=0.02)
    assert np.unique(t[10, :8]).size == 1
    assert np.all(np.diff(t[mask][np.argsort(y[mask], kind="stable")]) >= 0)  # order kept


def test_compared_statistics_include_the_tone_free_ones():
    from moonbot.benchmark.realism_bench import compared_statistics

    stats = realism.image_statistics(np.exp(0.3 * power_law_noise(128, 2.0, seed=3)), np.ones((128, 128), bool), 8.0)
    compared = compared_statistics(stats)
    assert "spectrum_slope" in compared and "tone_free.spectrum_slope" in compared
    assert "tone_free.octave_rms_contrast.0.5-1_cyc_per_deg" in compared
    assert "tone_free.luma_median" not in compared and "tone_free.blobs_per_deg2" in compared


def test_sheet_shows_each_render_and_photo_as_measured_and_tone_free(tmp_path):
    from PIL import Image

    from moonbot.benchmark.realism_bench import Rendered, RenderPlan, matched_crops, write_sheet

    def granular(seed: int, gamma: float) -> np.ndarray:
        y = np.clip(0.45 * np.exp(0.3 * power_law_noise(256, 2.0, seed=seed)), 0, 1) ** gamma
        return np.repeat((y * 255).round().astype(np.uint8)[..., None], 3, axis=2)

    render, photo = granular(1, 1.0), granular(2, 1.8)  # the photo under a steeper curve
    Image.fromarray(photo).save(tmp_path / "photo.png")
    measured = [realism.measure(x, 40.0, 6.4) for x in (render, photo)]
    source = realism.PhotoSource(tmp_path / "photo.png", 10.0, 15.0, "synthetic")
    plan = RenderPlan("flat", 12.5, "cross", False)
    sheet = tmp_path / "sheet.png"
    write_sheet(sheet, [(Rendered(plan, render, 12.0, {}), measured[0])], [(source, measured[1])], 6.4)
    with Image.open(sheet) as image:
        assert image.width > 5 * image.height  # one row: render, photo and four crops (two: 4.1)
    # The tone-free crops are the same tiles as the luma crops, each an increasing map of its own.
    luma = matched_crops(*measured)
    for m in measured:
        np.testing.assert_array_equal(m.tone_free_luma, realism.tone_free(m.luma, m.ground.mask))
    free = [realism.Measured(m.stats, m.tone_free_luma, m.ground, m.tone_free_luma) for m in measured]
    for a, b in zip(luma, matched_crops(*free)):
        assert a.shape == b.shape and a.size
        order = np.argsort(a, axis=None, kind="stable")
        assert np.all(np.diff(b.ravel()[order]) >= 0)


def test_cli_names_the_bad_sources_file(tmp_path):
    from click.testing import CliRunner

    from moonbot.cli import main

    (tmp_path / "a.jpg").write_bytes(b"")
    (tmp_path / "SOURCES.csv").write_text("file,approx_sun_elevation_deg\na.jpg,dusk\n")
    result = CliRunner().invoke(
        main, ["bench", "realism", "--photos", str(tmp_path), "--out", str(tmp_path / "r.json")]
    )
    assert result.exit_code != 0
    assert "SOURCES.csv: line 2: approx_sun_elevation_deg" in result.output
    assert not (tmp_path / "r.json").exists()
