"""What the Moon's materials look like in the renderer: regolith's granular micro-texture
(terrain.photometry.grain), the cloth's sheen (bags.fabric.sheen), the dust stain mode
(bags.stain.mode) and the ejecta's regolith material. The numerics are tested in
cpp/tests/test_regolith_texture.cpp, test_fabric.cpp and test_soiling.cpp; these check them
through the bindings, the config and rendered images."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

from moonbot import _core
from moonbot.config import ConfigError, load_config
from moonbot.render import SceneDust, build_scene, render_view
from moonbot.render.view import regolith, regolith_grain
from moonbot.scene import compose_scene, intrinsics, orbit_pose

from scenes import CLOSE_BAG_VIEW

pytestmark = pytest.mark.unit

# Every new look off: the renderer as it was before them.
OFF = {
    "terrain.roughness.subgrid_shading": False,
    "terrain.craters.subgrid_shading": False,
    "terrain.photometry.grain.albedo_rms": 0.0,
    "terrain.photometry.grain.slope_rms_deg": 0.0,
    "bags.fabric.sheen": 0.0,
}


def render(overrides: dict, seed: int = 3, azimuth_deg: float = 30.0):
    """(rgb, instance) of one view of a fresh scene built from the default config and `overrides`."""
    config = load_config(None, overrides)
    spec = compose_scene(config)
    pose = orbit_pose(spec.target, config.orbit.radius_m, config.orbit.height_m, azimuth_deg)
    view = render_view(build_scene(spec), config, intrinsics(config.camera), pose, seed=seed)
    return view.rgb, view.instance


# --- the paper's look is kept ---------------------------------------------------------------------

# sha256 of the rgb bytes of render({**CLOSE_BAG_VIEW, **OFF, **PATH, "bags.stain.seeds": 90}) (Embree's
# avx2 kernels). Recorded when the grain, the sheen and the dust mode were added, with them off
# (the same bytes as before them); re-recorded when the bags settled into their wrinkled shape and
# the small craters were worn, which moved the geometry under the same stamps; and when the
# textures' prefilter narrowed to the pixel's box (render.texture_filter_px), which sharpened the
# weave under them; and when the pixel's samples began to read the weave once, at the pixel's
# centre, through two boxes (render.cpp's texture_point and cloth). The stamp algorithm itself
# (cpp/src/stain.cpp) is unchanged since the paper's mode was written.
PAPER_STAMP_90_SHA256 = "c6d0ca9d6d2a6c0e7f1e6e9ebf5829e10120a821427dc8f20b4e8efada4a9cbc"
# The brute-force renderer at the Sun rays it was recorded with, so the pin follows the stain and
# the geometry, not the light cache's, adaptive sampling's or the shadow rays' tuning.
PATH = {"render.indirect": "path", "render.adaptive_spp": 0, "render.light_samples": 2}


def test_paper_stamp_stain_with_the_new_looks_off_keeps_its_bytes():
    if _core.resolve_embree_isa("auto") != "avx2":
        pytest.skip("the reference bytes were recorded with Embree's avx2 kernels")
    rgb, _ = render({**CLOSE_BAG_VIEW, **OFF, **PATH, "bags.stain.seeds": 90})
    assert hashlib.sha256(rgb.tobytes()).hexdigest() == PAPER_STAMP_90_SHA256


def test_stamp_mode_ignores_the_dust_modes_settings():
    base = {**CLOSE_BAG_VIEW, **OFF, "bags.stain.seeds": 15, "camera.width": 80, "camera.height": 60}
    a, _ = render(base)
    b, _ = render(
        {
            **base,
            "bags.stain.contact_height_m": 0.2,
            "bags.stain.deposit_radius_m": 0.01,
            "bags.stain.handled_share": 1.0,
            "bags.stain.speckle": 0.0,
        }
    )
    assert a.tobytes() == b.tobytes()


# --- regolith grain -------------------------------------------------------------------------------


def test_grain_config_defaults_and_off():
    grain = load_config(None, {}).terrain.photometry.grain
    assert grain.enabled and grain.octaves == 5 and regolith_grain(grain) is not None
    off = load_config(None, OFF).terrain.photometry.grain
    assert not off.enabled and regolith_grain(off) is None  # no texture object, no texture code
    with pytest.raises(ConfigError, match=r"terrain\.photometry\.grain\.albedo_rms: must be < 0\.165"):
        load_config(None, {"terrain.photometry.grain.albedo_rms": 0.3})
    with pytest.raises(ConfigError, match=r"terrain\.photometry\.grain\.coarsest_cell_m: must be >= finest"):
        load_config(None, {"terrain.photometry.grain.coarsest_cell_m": 0.0001})
    with pytest.raises(ValueError, match=r"grain\.slope_rms_deg"):
        _core.RegolithGrain(_core.GrainParams(slope_rms_deg=50.0))


def test_grain_mean_is_the_base_albedo_and_far_away_exactly():
    params = _core.GrainParams(albedo_rms=0.08, slope_rms_deg=15.0, seed=5)
    grain = _core.RegolithGrain(params)
    points = np.random.default_rng(1).uniform(-10.0, 10.0, (200_000, 3))
    points[:, 2] *= 0.01
    factor, gradient = grain.eval(points, 0.0)
    assert factor.dtype == np.float64 and gradient.shape == (200_000, 3)
    assert factor.mean() == pytest.approx(1.0, abs=1e-3)
    assert factor.std() == pytest.approx(0.08, rel=0.03)
    # 1-D RMS slope along x: tan 15°.
    assert np.sqrt(np.mean(gradient[:, 0] ** 2)) == pytest.approx(np.tan(np.radians(15.0)), rel=0.03)
    far_factor, far_gradient = grain.eval(points[:1000], grain.flat_footprint_m)
    assert np.all(far_factor == 1.0) and np.all(far_gradient == 0.0)
    again, _ = _core.RegolithGrain(params).eval(points[:1000], 0.002)
    assert again.tobytes() == grain.eval(points[:1000], 0.002)[0].tobytes()


def test_far_ground_renders_exactly_as_untextured_ground():
    """Seen from 36 m every pixel covers more than the texture's flat footprint: the image is the
    untextured one, bit for bit."""
    far = {
        "terrain.location": "plane",
        "orbit.radius_m": 20.0,
        "orbit.height_m": 30.0,
        "camera.width": 80,
        "camera.height": 60,
        "bags.fabric.sheen": 0.0,
    }
    textured, _ = render(far)
    plain, _ = render({**far, **OFF})
    assert textured.tobytes() == plain.tobytes()


def test_grain_is_visible_near_and_every_sample_of_a_pixel_reads_it_alike():
    """Lambertian plane, a point Sun, no bounces, albedo texture only: the texture term rgb/rgb_off
    on fully lit ground varies by several percent, and every sample of a pixel reads the texture
    where the pixel's centre ray meets the ground, once a pixel, so on that ground two render
    seeds (16 jittered samples a pixel each) and one sample agree to float32's rounding, where the
    texture varies by 8 %: the prefilter leaves no noise, and the samples have nothing to average."""
    scene = {
        **CLOSE_BAG_VIEW,
        "render.bounces": 0,
        "render.spp": 16,
        "render.adaptive_spp": 0,
        "sun.angular_diameter_deg": 0.0,
        "terrain.photometry.model": "lambert",
        "terrain.photometry.grain.slope_rms_deg": 0.0,
        "terrain.roughness.subgrid_shading": False,  # the albedo speckle alone
        "terrain.craters.subgrid_shading": False,
        "bags.fabric.sheen": 0.0,
    }
    one = {**scene, "render.spp": 1}
    plain = [render({**scene, **OFF}, seed=s)[0] for s in (1, 2)] + [render({**one, **OFF})[0]]
    textured = [render(scene, seed=s) for s in (1, 2)]
    one_sample = render(one)[0]
    ground = textured[0][1] == 0
    lit = np.median(plain[0][..., 1][ground])  # sunlit ground, the same in every unshadowed pixel
    # Ground every sample of every render saw fully lit: away from the bag and its shadow's edges.
    keep = ground & np.all([np.isclose(p[..., 1], lit, rtol=1e-6) for p in plain], axis=0)
    keep[: 2 * keep.shape[0] // 3] = False  # the nearest third of the image: ground within ~0.6 m
    assert keep.sum() > 2000
    term = [t[0][..., 1][keep] / lit for t in textured]
    assert term[0].mean() == pytest.approx(1.0, abs=0.01)
    assert term[0].std() > 0.3 * 0.08
    np.testing.assert_allclose(term[1], term[0], rtol=1e-6)
    np.testing.assert_allclose(one_sample[..., 1][keep] / lit, term[0], rtol=1e-6)


def test_a_wider_texture_filter_blurs_the_grain_and_a_bad_width_names_the_field():
    """render.texture_filter_px is the box each sample's textures are prefiltered over: at 1 pixel
    the grain's texture term varies more from pixel to pixel than at 4 pixels, whose blur removes
    octaves the camera resolves; both keep the plain ground's mean (the texture's mean factor is 1)."""
    scene = {
        **CLOSE_BAG_VIEW,
        "render.bounces": 0,
        "render.spp": 4,
        "render.adaptive_spp": 0,
        "sun.angular_diameter_deg": 0.0,
        "terrain.photometry.model": "lambert",
        "terrain.photometry.grain.slope_rms_deg": 0.0,
        "terrain.roughness.subgrid_shading": False,  # the albedo speckle alone
        "terrain.craters.subgrid_shading": False,
        "bags.fabric.sheen": 0.0,
    }
    plain = render({**scene, **OFF})[0]
    sharp, instance = render(scene)
    wide = render({**scene, "render.texture_filter_px": 4.0})[0]
    ground = instance == 0
    lit = np.median(plain[..., 1][ground])
    keep = ground & np.isclose(plain[..., 1], lit, rtol=1e-6)
    keep[: keep.shape[0] // 2] = False  # the near half: ground the grain's octaves reach
    assert keep.sum() > 2000
    sharp_term, wide_term = sharp[..., 1][keep] / lit, wide[..., 1][keep] / lit
    assert sharp_term.mean() == pytest.approx(1.0, abs=0.01) and wide_term.mean() == pytest.approx(1.0, abs=0.01)
    assert wide_term.std() < 0.7 * sharp_term.std()
    with pytest.raises(ConfigError, match=r"render\.texture_filter_px"):
        load_config(None, {"render.texture_filter_px": 0.1})
    with pytest.raises(ValueError, match="texture_filter_px"):
        _core.RenderSettings(texture_filter_px=9.0)


# --- sheen ----------------------------------------------------------------------------------------


def test_sheen_config_and_errors():
    fabric = load_config(None, {}).bags.fabric
    assert (fabric.sheen, fabric.sheen_along, fabric.sheen_across) == (0.1, 0.35, 0.12)
    with pytest.raises(ConfigError, match=r"bags\.fabric\.sheen: must be <= 1\.0"):
        load_config(None, {"bags.fabric.sheen": 1.5})
    with pytest.raises(ValueError, match="sheen_across"):
        _core.WovenSurface(fabric=_core.FabricParams(sheen=0.1, sheen_across=0.0))


def test_sheen_adds_a_highlight_and_keeps_the_clean_weave_elsewhere():
    """Looking against the Sun over the bag's top (forward scattering) the glossy tapes brighten
    it; with sheen 0 the bag is the matte weave's."""
    against = {
        **CLOSE_BAG_VIEW,
        **OFF,
        "camera.width": 80,
        "camera.height": 60,
        "orbit.radius_m": 0.4,
        "orbit.height_m": 0.25,
        "sun.elevation_deg": 20.0,
    }
    matte, mask = render(against, azimuth_deg=300.0)
    glossy, _ = render({**against, "bags.fabric.sheen": 0.3}, azimuth_deg=300.0)
    bag = mask == 1
    assert bag.sum() > 500
    assert glossy[bag].max() > 1.2 * matte[bag].max()


# --- dust stain mode ------------------------------------------------------------------------------


def test_dust_mode_with_zero_seeds_is_clean_and_bad_modes_name_the_field():
    base = {**CLOSE_BAG_VIEW, **OFF, "camera.width": 80, "camera.height": 60}
    clean, _ = render(base)
    none, _ = render({**base, "bags.stain.mode": "dust"})
    assert clean.tobytes() == none.tobytes()
    with pytest.raises(ConfigError, match=r"bags\.stain\.mode: must be one of stamp, dust"):
        load_config(None, {"bags.stain.mode": "mud"})
    with pytest.raises(ValueError, match="stain_mode"):
        _core.WovenSurface(stain_mode="mud")


def test_dust_gathers_low_on_the_bag_and_is_regolith_grey():
    """90 deposits, the bag's side seen level from its own height: its lower rows lose more of
    their brightness than its upper rows (the ground-contact band), and dusted fabric turns toward
    the grey dirt colour (its red/blue ratio falls from the tan cloth's)."""
    base = {**CLOSE_BAG_VIEW, **OFF, "bags.stain.mode": "dust", "render.spp": 4, "orbit.height_m": 0.0}
    clean, mask = render(base)
    dusty, _ = render({**base, "bags.stain.seeds": 90})
    rows = np.nonzero((mask == 1).any(axis=1))[0]
    low_rows, high_rows = rows[rows > np.median(rows)], rows[rows <= np.median(rows)]

    def ratio(selected):
        pick = (mask == 1) & np.isin(np.arange(mask.shape[0]), selected)[:, None]
        return dusty[pick].sum() / clean[pick].sum()

    assert ratio(low_rows) < ratio(high_rows) < 1.0
    bag = mask == 1
    assert (dusty[bag][:, 0].sum() / dusty[bag][:, 2].sum()) < (clean[bag][:, 0].sum() / clean[bag][:, 2].sum())


# --- ejecta ---------------------------------------------------------------------------------------


def test_ejecta_are_regolith_not_white():
    """The fragments take regolith's albedo, photometric function and grain: where they appear,
    no pixel is brighter than sunlit regolith can be (albedo A ≈ 0.043 under the Lunar-Lambert
    shape, at most 2·(1 + B0) = 5.6 times A·E/π, times the grain's largest factor), whereas a
    white Lambertian facing the Sun would reach E/π."""
    config = load_config(
        None,
        {
            "dust.enabled": True,
            "dust.cloud.optical_depth": 0.0,
            "camera.width": 160,
            "camera.height": 120,
            "render.bounces": 0,
        },
    )
    spec = compose_scene(config)
    scene = build_scene(spec)
    pose = orbit_pose(spec.target, config.orbit.radius_m, config.orbit.height_m, 90.0)
    K = intrinsics(config.camera)
    free = render_view(scene, config, K, pose, seed=1)
    dust = SceneDust(scene, spec, config, [9])
    view = dust.for_view(9)
    ejecta = render_view(scene, config, K, pose, seed=1, medium=view.medium)
    moved = ejecta.depth != free.depth
    assert moved.sum() > 50
    _, albedo = regolith(spec.terrain_photometry, spec.terrain_albedo)
    white = config.sun.irradiance_w_m2 / np.pi
    grain = spec.terrain_photometry.grain
    largest_factor = 1 + grain.albedo_rms * np.sqrt(grain.octaves / ((26 / 35) ** 3 / 3))
    bound = white * albedo[0] * 2 * (1 + config.terrain.photometry.surge_amplitude) * largest_factor
    assert ejecta.rgb[moved].max() <= bound < 0.5 * white
