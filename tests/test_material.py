"""The bag's appearance through the bindings: the woven fabric and the dirt stain (paper 3.3.2,
3.4). The numerics are tested in cpp/tests/test_fabric.cpp and test_stain.cpp; these check the
Python surface: shapes, dtypes, errors naming the argument, the allocation counters, and the
config fields."""

from __future__ import annotations

import gc

import numpy as np
import pytest

from moonbot import _core
from moonbot.config import Config, ConfigError, load_config

from scenes import CLOSE_BAG_VIEW

pytestmark = pytest.mark.unit

PITCH = 0.0015


def period_grid(n: int = 64, pitch: float = PITCH) -> np.ndarray:
    """An n × n grid over one weave period (2 pitch) as (n², 2) metres."""
    t = np.arange(n) * (2 * pitch / n)
    x, y = np.meshgrid(t, t)
    return np.column_stack([x.ravel(), y.ravel()])


def test_fabric_means_over_a_period():
    xy = period_grid()
    albedo, normal = _core.fabric_eval(xy, np.zeros(len(xy)))
    assert albedo.shape == normal.shape == (len(xy), 3) and albedo.dtype == np.float64
    np.testing.assert_allclose(albedo.mean(axis=0), [0.55, 0.45, 0.32], atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(normal, axis=1), 1.0, atol=1e-14)
    np.testing.assert_allclose(normal[:, :2].mean(axis=0), 0.0, atol=1e-12)
    # Low contrast: ±4 % of the mean at most.
    assert np.abs(albedo / albedo.mean(axis=0) - 1).max() == pytest.approx(0.04, abs=1e-9)


def test_fabric_far_away_is_the_mean():
    xy = period_grid(16) + [0.123, 0.456]
    albedo, normal = _core.fabric_eval(xy, np.full(len(xy), 40 * PITCH), _core.FabricParams(albedo=[0.3, 0.3, 0.3]))
    assert np.all(albedo == 0.3)
    assert np.all(normal == [0.0, 0.0, 1.0])


def test_fabric_arguments_are_checked():
    with pytest.raises(ValueError, match="xy: must have shape"):
        _core.fabric_eval(np.zeros((4, 3)), np.zeros(4))
    with pytest.raises(ValueError, match="footprint: must have one value per point"):
        _core.fabric_eval(np.zeros((4, 2)), np.zeros(3))
    with pytest.raises(ValueError, match="footprint: must be finite"):
        _core.fabric_eval(np.zeros((1, 2)), [-1.0])
    flat = _core.FabricParams()
    flat.pitch_m = 0.0  # a field written after construction is checked where the core takes it
    with pytest.raises(ValueError, match="pitch_m"):
        _core.fabric_eval(np.zeros((1, 2)), [0.0], flat)
    with pytest.raises(ValueError, match="xy: must be a floating-point array"):
        _core.fabric_eval(np.zeros((1, 2), dtype=np.int64), [0.0])


def test_no_stamps_allocate_nothing():
    gc.collect()
    bytes_before, ever_before = _core.stain_mask_bytes(), _core.stain_masks_allocated()
    assert _core.stain_mask(7, _core.StainParams(stamps=0)) is None
    assert _core.stain_mask_bytes() == bytes_before
    assert _core.stain_masks_allocated() == ever_before
    clean = np.array([[0.55, 0.45, 0.32], [0.1, 0.2, 0.3]])
    assert np.array_equal(_core.stained_base_colour(clean, np.zeros(2), [0.12, 0.11, 0.10]), clean)


def test_mask_lifetime_is_counted():
    gc.collect()
    bytes_before, ever_before = _core.stain_mask_bytes(), _core.stain_masks_allocated()
    mask = _core.stain_mask(7, _core.StainParams(stamps=15, resolution=64))
    view = np.asarray(mask)
    assert view.shape == (64, 64) and view.dtype == np.float32 and not view.flags.writeable
    assert _core.stain_mask_bytes() == bytes_before + 64 * 64 * 4
    assert _core.stain_masks_allocated() == ever_before + 1
    del mask
    assert _core.stain_mask_bytes() == bytes_before + 64 * 64 * 4  # the view keeps it alive
    del view
    gc.collect()
    assert _core.stain_mask_bytes() == bytes_before
    assert _core.stain_masks_allocated() == ever_before + 1


def test_one_stamp_is_alpha_times_the_splat():
    r, s, alpha = 128, 0.18, 0.5
    mask = np.asarray(_core.stain_mask(11, _core.StainParams(stamps=1, brush_size=s, opacity=alpha, resolution=r)))
    cu, cv = _core.stamp_centres(11, 1)[0]
    t = (np.arange(r) + 0.5) / r
    du = (t - cu + 0.5) % 1.0 - 0.5  # u wraps
    lu, lv = np.meshgrid(du / s + 0.5, (t - cv) / s + 0.5)  # rows are v
    want = alpha * _core.splat(np.column_stack([lu.ravel(), lv.ravel()])).reshape(r, r)
    np.testing.assert_allclose(mask, want, atol=1e-7)
    assert mask.max() > 0.99 * alpha


def test_same_seed_same_bytes_any_threads():
    a = np.asarray(_core.stain_mask(3, _core.StainParams(stamps=90), threads=1))
    b = np.asarray(_core.stain_mask(3, _core.StainParams(stamps=90), threads=0))
    c = np.asarray(_core.stain_mask(4, _core.StainParams(stamps=90)))
    assert a.tobytes() == b.tobytes()
    assert a.tobytes() != c.tobytes()


@pytest.mark.parametrize("stamps", [15, 30, 90])
def test_coverage_within_sampling_error(stamps):
    """Fraction of stained texels (M > 0) away from the clipped v edges, over 20 seeds, against
    the Boolean model 1 − (1 − s²A)^N (A the splat's support area)."""
    s, r = 0.18, 128
    expected = 1 - (1 - s * s * _core.splat_support_area()) ** stamps
    rows = slice(int(np.ceil(s / 2 * r)), int(r - np.ceil(s / 2 * r)))
    fractions = [
        (np.asarray(_core.stain_mask(seed, _core.StainParams(stamps=stamps, resolution=r)))[rows] > 0).mean()
        for seed in range(100, 120)
    ]
    assert np.mean(fractions) == pytest.approx(expected, abs=0.04)


def test_sample_wraps_u_and_clamps_v():
    mask = _core.stain_mask(5, _core.StainParams(stamps=40, resolution=32))
    texels = np.asarray(mask)
    t = (np.arange(32) + 0.5) / 32
    np.testing.assert_allclose(mask.sample(np.column_stack([t + 1.0, np.full(32, t[3])])), texels[3], atol=1e-6)
    np.testing.assert_allclose(mask.sample(np.column_stack([t, np.full(32, -0.5)])), texels[0], atol=1e-7)
    with pytest.raises(ValueError, match="uv: must be finite"):
        mask.sample([[np.nan, 0.0]])


def test_stain_arguments_are_checked():
    with pytest.raises(ValueError, match="opacity: must be in"):
        _core.StainParams(stamps=3, opacity=1.5)
    with pytest.raises(ValueError, match="brush_size"):
        _core.StainParams(stamps=3, brush_size=0.0)
    bad = _core.StainParams()
    bad.stamps = -1  # a field written after construction is checked where the core takes it
    with pytest.raises(ValueError, match="stamps: must be >= 0"):
        _core.stain_mask(0, bad)
    with pytest.raises(ValueError, match="threads"):
        _core.stain_mask(0, _core.StainParams(stamps=1), threads=-2)


def test_config_fields():
    config = Config()
    assert config.bags.stain.seeds == 0 and config.bags.fabric.pitch_m == PITCH
    loaded = load_config(None, {"bags.stain.seeds": 90, "bags.stain.dirt_colour": [0.1, 0.1, 0.1]})
    assert loaded.bags.stain.seeds == 90 and loaded.bags.stain.dirt_colour == (0.1, 0.1, 0.1)
    for field, value, message in [
        ("bags.stain.opacity", 1.5, "bags.stain.opacity: must be <= 1.0"),
        ("bags.stain.brush_size", 0, "bags.stain.brush_size: must be > 0.0"),
        ("bags.stain.seeds", -1, "bags.stain.seeds: must be >= 0"),
        ("bags.stain.dirt_colour", [0.1, 0.1], "bags.stain.dirt_colour: must have 3 items"),
        ("bags.fabric.pitch_m", 0.0, "bags.fabric.pitch_m: must be >= 1e-05"),
        ("bags.fabric.contrast", 2, "bags.fabric.contrast: must be <= 1.0"),
    ]:
        with pytest.raises(ConfigError, match=message.replace("(", r"\(")):
            load_config(None, {field: value})


# --- in the render -------------------------------------------------------------------------------


def render_bag(stain_seeds: int, opacity: float = 0.5):
    """View 0 of a close orbit around one bag on the plane, in a process-wide fresh scene; returns
    (rgb, stain mask bytes alive while the scene lived, masks allocated by building it)."""
    from moonbot.render import build_scene, render_view
    from moonbot.scene import compose_scene, intrinsics, orbit_pose

    config = load_config(None, {**CLOSE_BAG_VIEW, "bags.stain.seeds": stain_seeds, "bags.stain.opacity": opacity})
    spec = compose_scene(config)
    allocated = _core.stain_masks_allocated()
    scene = build_scene(spec)
    alive = _core.stain_mask_bytes()
    allocated = _core.stain_masks_allocated() - allocated
    pose = orbit_pose(spec.target, config.orbit.radius_m, config.orbit.height_m, 30.0)
    rgb = render_view(scene, config, intrinsics(config.camera), pose, seed=3).rgb
    del scene
    gc.collect()
    return rgb, alive, allocated


def test_clean_bags_allocate_no_mask_and_match_a_blank_stain_bit_for_bit():
    """Zero stain seeds paint and allocate nothing, and the image is the same bytes
    as bags whose 15 stamps have zero opacity (masks allocated, all zero): lerp(clean, 0, 0) is
    clean exactly. With opacity the stain shows."""
    gc.collect()
    clean, alive, allocated = render_bag(0)
    assert alive == 0 and allocated == 0
    blank, alive, allocated = render_bag(15, opacity=0.0)
    assert allocated == 1 and alive == 512 * 512 * 4
    assert clean.tobytes() == blank.tobytes()
    stained, *_ = render_bag(15)
    assert stained.tobytes() != clean.tobytes()
    assert stained.mean() < clean.mean()  # regolith-coloured dirt darkens the tan cloth
