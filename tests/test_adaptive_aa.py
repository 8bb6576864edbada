"""Adaptive anti-aliasing of direct light (RenderSettings.adaptive_spp): only pixels whose base
samples disagree get more samples, a pixel left alone keeps its bytes, the image comes closer to
a high-sample render than the base samples alone, and the images stay deterministic."""

from __future__ import annotations

import numpy as np
import pytest

from moonbot import _core
from moonbot.config import ConfigError, load_config
from moonbot.render import build_scene, render_view
from moonbot.scene import compose_scene, intrinsics, orbit_pose

from scenes import CLOSE_BAG_VIEW, box

pytestmark = pytest.mark.unit

E = 1361.0
W, H, F = 48, 36, 60.0


def floating_box() -> _core.Scene:
    """A 1 m box (label 1) alone against the black sky."""
    scene = _core.Scene()
    scene.add_instance(scene.add_mesh(*box((1.0, 1.0, 1.0))), np.eye(4), 1, (0.5, 0.4, 0.3))
    scene.commit()
    return scene


def corner_camera(scale: int = 1) -> _core.Camera:
    """Looking at the box's corner (+x, −y, +z) from 3.5 m: three faces, each under another
    cosine to the Sun, and the silhouette against the sky. `scale` multiplies the resolution
    (the same view, each pixel split into scale × scale)."""
    centre = np.array([2.0, -2.2, 1.8])
    z = -centre / np.linalg.norm(centre)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    R = np.stack([x, np.cross(z, x), z])
    f = F * scale
    return _core.Camera(f, f, W * scale / 2, H * scale / 2, W * scale, H * scale, R, -R @ centre)


# A point Sun: a face's direct light is one value, so a pixel is mixed only where faces meet.
SUN = _core.DirectionalLight(-35.0, 40.0, E, 0.0)


def render_box(scene: _core.Scene, all_passes: bool = False, **settings) -> dict:
    """`scene` from corner_camera() under SUN with RenderSettings(**settings): the rgb pass only,
    or every pass."""
    passes = {} if all_passes else {"passes": ["rgb"]}
    return _core.render(scene, corner_camera(), SUN, _core.RenderSettings(**settings), **passes)


def rel_rmse(out: dict, reference: np.ndarray) -> float:
    """Relative RMSE of a render's rgb against `reference` ((H, W, 3) float64)."""
    return np.sqrt(np.mean((out["rgb"].astype(np.float64) - reference) ** 2)) / reference.mean()


def reference_rgb(scene: _core.Scene) -> np.ndarray:
    """(H, W, 3) float: 1024 samples a pixel."""
    return render_box(scene, spp=1024, seed=11)["rgb"]


def centre_grid(scene: _core.Scene) -> np.ndarray:
    """(H, W, 256): each pixel's 16 × 16 centre rays' green radiance (one value per face, 0 for the sky)."""
    fine = _core.render(scene, corner_camera(16), SUN, _core.RenderSettings(spp=1), passes=["rgb"])["rgb"][..., 1]
    return fine.reshape(H, 16, W, 16).transpose(0, 2, 1, 3).reshape(H, W, 256)


def interior_pixels(blocks: np.ndarray) -> np.ndarray:
    """(H, W) bool: the pixel and its eight neighbours all of one value under `blocks`
    (centre_grid's; a pixel the grid finds uniform may still hold a sliver thinner than its
    spacing)."""
    value = np.where(np.all(blocks == blocks[..., :1], axis=-1), blocks[..., 0], np.nan)
    padded = np.pad(value, 1, constant_values=np.nan)
    return np.all(
        [padded[1 + dy : 1 + dy + H, 1 + dx : 1 + dx + W] == value for dy in (-1, 0, 1) for dx in (-1, 0, 1)], axis=0
    )


def test_refines_the_edges_and_leaves_the_faces_alone():
    """The refined pixels whose bytes change (those where the box's silhouette or an edge between
    its faces crosses lit faces; a face turned from the Sun against the sky is refined too, black
    on black) are none of the faces' interior pixels that a 16 × 16 grid of centre rays finds
    uniform, and all but a few of those it finds well mixed; all refined pixels lie within two
    pixels of a mixed one (a pixel is refined where it or a neighbour disagrees)."""
    scene = floating_box()
    base = render_box(scene, spp=4, seed=3)
    adaptive = render_box(scene, spp=4, seed=3, adaptive_spp=32, adaptive_threshold=0.1)
    refined = np.any(base["rgb"] != adaptive["rgb"], axis=-1)
    assert 0 < refined.sum() <= adaptive["refined_pixels"]
    # 28 extra samples, each a camera ray and (on a face toward the Sun) one shadow ray.
    assert 28 * adaptive["refined_pixels"] <= adaptive["camera_rays"] - base["camera_rays"]
    assert adaptive["refinement_rays"] == (
        adaptive["camera_rays"]
        - base["camera_rays"]
        + adaptive["shadow_rays"]
        - base["shadow_rays"]
        + adaptive["second_look_rays"]
        - base["second_look_rays"]
    )
    blocks = centre_grid(scene)
    interior = interior_pixels(blocks)
    # The minority's share of the pixel: at least 30 % is a well mixed pixel.
    values = [np.unique(b, return_counts=True)[1] for b in blocks.reshape(-1, 256)]
    minority = np.array([1.0 - c.max() / 256 for c in values]).reshape(H, W)
    mixed = minority >= 0.3
    assert interior.sum() > H * W // 2
    assert not np.any(refined & interior)
    grown = np.pad(~interior, 1)  # refined: a disagreeing pixel's neighbours too
    near_edge = np.any(
        [grown[1 + dy : 1 + dy + H, 1 + dx : 1 + dx + W] for dy in (-1, 0, 1) for dx in (-1, 0, 1)], axis=0
    )
    assert adaptive["refined_pixels"] <= near_edge.sum()
    assert mixed.sum() > 20
    assert refined[mixed].mean() >= 0.9


def test_adaptive_image_comes_close_to_a_high_sample_render():
    """Against 1024 samples the base samples' error (relative RMSE, 0.27 here: the box is small
    on a black sky) is aliasing on the edges. Refining to 64 samples where 4 base samples
    disagree (a pixel's own or a neighbour's) leaves the error of 64 samples everywhere (0.039)
    for a fifth of their camera rays."""
    scene = floating_box()
    reference = reference_rgb(scene)
    base = render_box(scene, spp=4, seed=3)
    adaptive = render_box(scene, spp=4, seed=3, adaptive_spp=64, adaptive_threshold=0.1)
    brute_force = render_box(scene, spp=64, seed=3)
    assert rel_rmse(base, reference) > 0.25
    assert rel_rmse(adaptive, reference) < 0.05
    assert rel_rmse(adaptive, reference) < 1.05 * rel_rmse(brute_force, reference)
    assert adaptive["camera_rays"] - base["camera_rays"] < 0.25 * (brute_force["camera_rays"] - base["camera_rays"])


def lunar_test_scene() -> _core.Scene:
    """The box on a ground plane: bounces and the Sun's disk have something to do."""
    from scenes import ground_and_box

    return ground_and_box((0.4, 0.4, 0.4))[0]


def ground_camera(centre=(1.2, -1.0, 0.7), width: int = W, height: int = H, f: float = F) -> _core.Camera:
    """From `centre` (world metres) toward a point 15 cm above the origin, width × height pixels
    of focal length f, image x level."""
    centre = np.asarray(centre, dtype=float)
    z = np.array([0.0, 0.0, 0.15]) - centre
    z /= np.linalg.norm(z)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    R = np.stack([x, np.cross(z, x), z])
    return _core.Camera(f, f, width / 2, height / 2, width, height, R, -R @ centre)


DISK_SUN = _core.DirectionalLight(-60.0, 12.0, E, 0.533)
QUALITY = {"spp": 4, "light_samples": 2, "bounces": 2}


def quality(**settings) -> _core.RenderSettings:
    """QUALITY's settings with `settings` on top."""
    return _core.RenderSettings(**QUALITY, **settings)


def test_same_bytes_for_any_thread_count_and_the_seed_matters():
    scene = lunar_test_scene()
    images = [
        _core.render(scene, ground_camera(), DISK_SUN, quality(seed=seed, threads=threads, adaptive_spp=16))
        for seed, threads in ((5, 1), (5, 2), (6, 2))
    ]
    assert images[0]["refined_pixels"] == images[1]["refined_pixels"] > 0
    assert images[0]["rgb"].tobytes() == images[1]["rgb"].tobytes()
    assert images[0]["rgb"].tobytes() != images[2]["rgb"].tobytes()
    # Depth and labels come from the pixel-centre ray: adaptive sampling leaves them alone.
    plain = _core.render(scene, ground_camera(), DISK_SUN, quality(seed=5))
    for key in ("depth", "instance"):
        assert plain[key].tobytes() == images[0][key].tobytes()


def test_off_is_the_brute_force_path_bit_for_bit():
    """adaptive_spp 0 is today's renderer (the default arguments); with it on, a pixel not refined
    keeps those bytes and a refined one changes."""
    scene = lunar_test_scene()
    default = _core.render(scene, ground_camera(), DISK_SUN, quality(seed=5))
    off = _core.render(scene, ground_camera(), DISK_SUN, quality(seed=5, adaptive_spp=0, adaptive_threshold=0.7))
    on = _core.render(scene, ground_camera(), DISK_SUN, quality(seed=5, adaptive_spp=16))
    assert default["rgb"].tobytes() == off["rgb"].tobytes()
    assert off["refined_pixels"] == off["refinement_rays"] == 0
    changed = np.any(on["rgb"] != off["rgb"], axis=-1)
    assert 0 < changed.sum() <= on["refined_pixels"] < changed.size // 2
    # The base samples' bounce paths are the same in both: the refinement traces no bounce rays.
    assert on["bounce_rays"] == off["bounce_rays"]


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"spp": 4, "adaptive_spp": 4}, "adaptive_spp: must be 0 (off) or in spp + 1..65536"),
        ({"spp": 4, "adaptive_spp": -1}, "adaptive_spp: must be 0"),
        ({"spp": 4, "adaptive_spp": 70000}, "adaptive_spp: must be 0"),
        ({"spp": 1, "adaptive_spp": 1}, "adaptive_spp: must be 0 (off) or in spp + 1..65536"),
        ({"spp": 4, "adaptive_spp": 8, "adaptive_threshold": -0.5}, "adaptive_threshold: must be a finite number >= 0"),
        ({"spp": 4, "adaptive_spp": 8, "adaptive_threshold": float("nan")}, "adaptive_threshold: must be a finite"),
        ({"spp": 4, "adaptive_spp": 8, "penumbra_light_samples": 0}, "penumbra_light_samples: must be in 1..1024"),
        ({"spp": 4, "adaptive_spp": 8, "adaptive_full_spread": -1.0}, "adaptive_full_spread: must be a finite number"),
        ({"spp": 4, "adaptive_spp": 8, "adaptive_full_spread": float("inf")}, "adaptive_full_spread: must be a finite"),
        ({"spp": 4, "adaptive_spp": 8, "adaptive_contrast": -1.0}, "adaptive_contrast: must be a finite number >= 0"),
        ({"spp": 4, "adaptive_spp": 8, "adaptive_contrast": float("nan")}, "adaptive_contrast: must be a finite"),
        (
            {"spp": 4, "adaptive_spp": 8, "adaptive_error_target": -0.1},
            "adaptive_error_target: must be a finite number in",
        ),
        (
            {"spp": 4, "adaptive_spp": 8, "adaptive_error_target": 2.0},
            "adaptive_error_target: must be a finite number in",
        ),
    ],
)
def test_bad_settings_name_the_field(kwargs, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)").replace("+", r"\+")):
        _core.render(floating_box(), corner_camera(), SUN, _core.RenderSettings(**kwargs))


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        ({"render.adaptive_spp": -2}, "render.adaptive_spp: must be >= 0"),
        ({"render.adaptive_threshold": -0.1}, "render.adaptive_threshold: must be >= 0"),
        ({"render.penumbra_light_samples": 0}, "render.penumbra_light_samples: must be >= 1"),
        ({"render.adaptive_full_spread": -1.0}, "render.adaptive_full_spread: must be >= 0"),
        ({"render.adaptive_contrast": -1.0}, "render.adaptive_contrast: must be >= 0"),
        ({"render.adaptive_error_target": 1.5}, "render.adaptive_error_target: must be <= 1"),
    ],
)
def test_bad_config_names_the_field(overrides, message):
    with pytest.raises(ConfigError) as caught:
        load_config(None, overrides)
    assert message in str(caught.value)


def test_refinement_applies_only_above_spp():
    """The config's adaptive_spp refines only above spp: a render asked for as many uniform
    samples or more refines nothing (no error: the default's cap must not forbid render.spp 64).
    Over the one pixel-centre sample it applies."""
    default = load_config(None, {}).render
    assert default.refinement_spp == default.adaptive_spp > default.spp
    assert load_config(None, {"render.spp": 64, "render.adaptive_spp": 32}).render.refinement_spp == 0
    assert load_config(None, {"render.spp": 1, "render.adaptive_spp": 16}).render.refinement_spp == 16
    assert load_config(None, {"render.adaptive_spp": 0}).render.refinement_spp == 0


def test_over_the_centre_sample_only_the_edges_are_refined_to_the_error_of_brute_force():
    """spp 1: the pixel-centre ray the depth and labels trace is the base sample, and a pixel is
    refined where the centre samples of its 3×3 neighbourhood disagree. None of the box's
    interior pixels (the pixel and its neighbours of one value under a 16 × 16 grid of centre
    rays) is refined, and each keeps the bytes of the plain one-sample render; the refined pixels
    get 64 jittered samples of their whole radiance, which leaves the error of 64 samples
    everywhere for a small share of their rays."""
    scene = floating_box()
    reference = reference_rgb(scene)
    plain = render_box(scene, all_passes=True, spp=1, seed=3)
    adaptive = render_box(scene, all_passes=True, spp=1, seed=3, adaptive_spp=64, adaptive_threshold=0.1)
    brute_force = render_box(scene, spp=64, seed=3)
    interior = interior_pixels(centre_grid(scene))
    changed = np.any(plain["rgb"] != adaptive["rgb"], axis=-1)
    assert interior.sum() > H * W // 2
    assert not np.any(changed & interior)
    assert 0 < changed.sum() <= adaptive["refined_pixels"] <= (~interior).sum()
    # Depth and labels are the centre rays' in both.
    for key in ("depth", "instance"):
        assert plain[key].tobytes() == adaptive[key].tobytes()
    # 64 samples a refined pixel, each a camera ray (and a shadow ray on a face toward the Sun).
    assert adaptive["camera_rays"] - plain["camera_rays"] == 64 * adaptive["refined_pixels"]
    assert rel_rmse(plain, reference) > 0.25
    assert rel_rmse(adaptive, reference) < 1.1 * rel_rmse(brute_force, reference) < 0.05
    assert adaptive["camera_rays"] < 0.2 * brute_force["camera_rays"]


def test_over_the_centre_sample_the_same_bytes_for_any_thread_count():
    """spp 1 with a disk Sun, bounces through a light cache and refinement: the same bytes on 1
    and 2 threads, and the refinement reads the cache (it traces no bounce ray on this static
    scene)."""
    scene = lunar_test_scene()
    cache = _core.LightCache(scene, DISK_SUN, settings=_core.LightCacheSettings(bounces=2, rays_background=64, seed=1))
    images = [
        _core.render(
            scene,
            ground_camera(),
            DISK_SUN,
            _core.RenderSettings(
                seed=5, threads=threads, spp=1, light_samples=1, bounces=2, adaptive_spp=16, adaptive_threshold=0.5
            ),
            light_cache=cache,
        )
        for threads in (1, 2)
    ]
    assert images[0]["refined_pixels"] == images[1]["refined_pixels"] > 0
    assert images[0]["rgb"].tobytes() == images[1]["rgb"].tobytes()
    assert images[0]["bounce_rays"] == 0


def test_with_the_light_cache_refinement_reads_no_cache_and_traces_no_bounces():
    """With the light cache the base samples take their indirect light from it; the refinement
    samples are direct light only, so adaptive sampling adds camera and shadow rays alone, and a
    pixel not refined keeps the bytes of the render without it."""
    scene = lunar_test_scene()
    cache = _core.LightCache(scene, DISK_SUN, settings=_core.LightCacheSettings(bounces=2, rays_background=64, seed=1))
    off = _core.render(scene, ground_camera(), DISK_SUN, quality(seed=5), light_cache=cache)
    on = _core.render(scene, ground_camera(), DISK_SUN, quality(seed=5, adaptive_spp=16), light_cache=cache)
    assert on["refined_pixels"] > 0
    assert on["bounce_rays"] == off["bounce_rays"]
    added = (
        (on["camera_rays"] - off["camera_rays"])
        + (on["shadow_rays"] - off["shadow_rays"])
        + (on["second_look_rays"] - off["second_look_rays"])
    )
    assert added == on["refinement_rays"]
    changed = np.any(on["rgb"] != off["rgb"], axis=-1)
    assert 0 < changed.sum() <= on["refined_pixels"]


def test_only_refinement_samples_in_a_penumbra_cast_penumbra_light_samples():
    """penumbra_light_samples is the Sun-disk rays of a refinement sample in a penumbra: raising
    it from 1 to 3 under a disk Sun adds up to two shadow rays per such sample (none where the
    sample misses or the disk point lies below its facet's horizon), refines the same pixels (the
    decisions come from the base samples, which cast light_samples), and changes no pixel that is
    not refined."""
    scene = lunar_test_scene()
    base = {**QUALITY, "light_samples": 1, "adaptive_spp": 16, "bounces": 0, "seed": 5}
    one, three = (
        _core.render(scene, ground_camera(), DISK_SUN, _core.RenderSettings(**base, penumbra_light_samples=n))
        for n in (1, 3)
    )
    assert one["refined_pixels"] == three["refined_pixels"] > 0
    added = three["shadow_rays"] - one["shadow_rays"]
    assert 0 < added < 2 * (16 - 4) * one["refined_pixels"]  # not every refined pixel is in a penumbra
    assert three["camera_rays"] == one["camera_rays"]
    changed = np.any(three["rgb"] != one["rgb"], axis=-1)
    assert 0 < changed.sum() < one["refined_pixels"]


def test_refined_pixels_get_samples_in_proportion_to_their_spread():
    """adaptive_full_spread f: a refined pixel gets a share of the adaptive_spp − spp samples past
    its base in proportion to its neighbourhood's spread over f frame means, at least one, moved
    to the nearest power of two. The same pixels are refined whatever f. With f = 0 each gets all
    60 extra camera rays; with a huge f each gets 4 (8 samples, the first power of two past the
    4 base ones); in between, fewer than all, and the extra rays 4 a refined pixel more than a
    multiple of 8, as counts of 8, 16, 32 or 64 give them. The images stay the same bytes
    on 1 and 2 threads (a tile's refined pixels are sampled in batches of up to 64 rays, a pixel's
    samples together: with f = 0 its 60 fill most of one batch and the next pixel's spill over)."""
    scene = lunar_test_scene()
    base = {**QUALITY, "light_samples": 1, "adaptive_spp": 64, "bounces": 0, "seed": 5}

    def run(full_spread: float, threads: int = 1) -> dict:
        settings = _core.RenderSettings(**base, adaptive_full_spread=full_spread, threads=threads)
        return _core.render(scene, ground_camera(), DISK_SUN, settings)

    off = _core.render(scene, ground_camera(), DISK_SUN, _core.RenderSettings(**{**base, "adaptive_spp": 0}))
    all_, one, some = run(0.0), run(1e9), run(8.0)
    refined = all_["refined_pixels"]
    assert refined > 0 and one["refined_pixels"] == some["refined_pixels"] == refined
    assert all_["camera_rays"] - off["camera_rays"] == refined * (64 - 4)
    assert one["camera_rays"] - off["camera_rays"] == refined * (8 - 4)
    extra = some["camera_rays"] - off["camera_rays"]
    assert refined * (8 - 4) < extra < refined * (64 - 4)
    assert (extra - refined * 4) % 8 == 0
    np.testing.assert_array_equal(run(8.0, threads=2)["rgb"], some["rgb"])
    np.testing.assert_array_equal(run(0.0, threads=2)["rgb"], all_["rgb"])


def grazing_box_view() -> tuple[_core.Scene, _core.Camera]:
    """The box on dark ground (albedo 0.12), 96 × 72 pixels: under a Sun 5° up, a face toward it
    is lit ten times as brightly as the ground, and the frame is mostly ground."""
    return lunar_test_scene(), ground_camera((1.6, -1.2, 0.5), 96, 72, 120.0)


def test_a_sunlit_face_in_a_dim_frame_is_refined_by_its_neighbourhood_contrast():
    """Where a face lit by a Sun 5° up meets ground that the same Sun grazes, a pixel's own base
    samples and each neighbour's may each see part of the contrast, and a miss costs a pixel all
    of it. adaptive_contrast refines a pixel whose neighbourhood's samples together spread beyond
    it times √(their mean × the frame's), its share following that spread. Direct light against
    1024 samples over three Sun azimuths, at the product's settings (threshold 0.5, contrast 4,
    up to 128 samples from 10 frame means): the error falls by a tenth (0.0145 to 0.0130 relative
    RMSE) for 1 % more camera rays; 0 is the renderer without the rule, bit for bit; the images
    stay the same bytes for 1 and 2 threads."""
    scene, camera = grazing_box_view()
    base = {
        "spp": 4,
        "seed": 3,
        "adaptive_spp": 128,
        "adaptive_threshold": 0.5,
        "adaptive_full_spread": 10.0,
        "bounces": 0,
    }
    squared, rays = {0.0: [], 4.0: []}, {0.0: 0, 4.0: 0}
    for azimuth in (-60.0, 30.0, 120.0):
        sun = _core.DirectionalLight(azimuth, 5.0, E, 0.533)
        settings = _core.RenderSettings(spp=1024, seed=5, light_samples=2, bounces=0)
        reference = _core.render(scene, camera, sun, settings, passes=["rgb"])["rgb"].astype(np.float64)
        out = {c: _core.render(scene, camera, sun, _core.RenderSettings(**base, adaptive_contrast=c)) for c in squared}
        for contrast in squared:
            squared[contrast].append(np.mean((out[contrast]["rgb"] - reference) ** 2) / reference.mean() ** 2)
            rays[contrast] += out[contrast]["camera_rays"]
        if azimuth == -60.0:
            plain = _core.render(scene, camera, sun, _core.RenderSettings(**base))  # the default: 0
            assert plain["rgb"].tobytes() == out[0.0]["rgb"].tobytes()
            two = _core.render(scene, camera, sun, _core.RenderSettings(**base, adaptive_contrast=4.0, threads=2))
            one = _core.render(scene, camera, sun, _core.RenderSettings(**base, adaptive_contrast=4.0, threads=1))
            assert one["rgb"].tobytes() == two["rgb"].tobytes() == out[4.0]["rgb"].tobytes()
            assert one["refined_pixels"] > plain["refined_pixels"]
    off, on = (np.sqrt(np.mean(squared[c])) for c in (0.0, 4.0))
    assert on < 0.92 * off
    assert rays[0.0] < rays[4.0] <= 1.03 * rays[0.0]


def test_an_error_target_sets_each_views_share_from_its_predicted_error():
    """adaptive_error_target picks the share's spread f per view, the largest f₀·2^(j/8) whose
    refined pixels' predicted error (√(k·Σ s²/N^1.5 / P) over the frame's mean, k fitted on the
    bench scenes) is at most the target. On this scene, which the fit never saw, direct light
    against 1024 samples under a Sun 5° and 30° up: the measured error lands within a fifth of
    targets of 2 % and 3 % (the refined pixels hold nearly all of it here); a tighter target
    traces more rays; one no view can meet is the fixed share f₀, bit for bit; and the images are
    the same bytes for 1 and 2 threads."""
    scene, camera = grazing_box_view()
    base = {"spp": 4, "seed": 3, "adaptive_spp": 128, "adaptive_threshold": 0.5, "adaptive_contrast": 4.0}
    base.update(bounces=0, adaptive_full_spread=4.0)
    for elevation in (5.0, 30.0):
        sun = _core.DirectionalLight(-60.0, elevation, E, 0.533)
        settings = _core.RenderSettings(spp=1024, seed=5, light_samples=2, bounces=0)
        reference = _core.render(scene, camera, sun, settings, passes=["rgb"])["rgb"].astype(np.float64)
        out = {
            t: _core.render(scene, camera, sun, _core.RenderSettings(**base, adaptive_error_target=t))
            for t in (0.03, 0.02, 1e-6)
        }
        for target in (0.03, 0.02):
            assert rel_rmse(out[target], reference) == pytest.approx(target, rel=0.2)
        assert out[0.03]["camera_rays"] < out[0.02]["camera_rays"] < out[1e-6]["camera_rays"]
        fixed = _core.render(scene, camera, sun, _core.RenderSettings(**base))
        assert fixed["rgb"].tobytes() == out[1e-6]["rgb"].tobytes()
        if elevation == 5.0:
            two = _core.render(scene, camera, sun, _core.RenderSettings(**base, adaptive_error_target=0.02, threads=2))
            one = _core.render(scene, camera, sun, _core.RenderSettings(**base, adaptive_error_target=0.02, threads=1))
            assert one["rgb"].tobytes() == two["rgb"].tobytes() == out[0.02]["rgb"].tobytes()


def test_with_dust_the_refinement_weighs_the_error_the_image_shows():
    """With dust the rules weigh each pixel as the image shows it: its spread dimmed by the
    dust's transmittance to the camera, against means that include the cloud's glow. The error
    target: a puff before the box (optical depth 1.25 through its centre, albedo 0.02) under a
    Sun 30° up, direct light against 1024 samples through the same puff, leaves an error within
    15 % of targets of 3 % and 2 % (predicting from the undimmed spreads and the clear frame's
    mean left it 31 % under the 3 %, on more rays). The threshold: the same puff glowing (albedo
    0.6) veils the box's edges, and fewer than half the clear view's pixels are refined (judged
    by the surface alone, the same ones were). The images are the same bytes for 1 and 2 threads."""
    scene, camera = grazing_box_view()
    base = {"spp": 4, "seed": 3, "adaptive_spp": 128, "adaptive_threshold": 0.5, "adaptive_contrast": 4.0}
    base.update(bounces=0, adaptive_full_spread=4.0)
    puff = [[0.8, -0.6, 0.35, 0.5, 1.0]]
    medium = _core.Medium(puff, albedo=(0.02, 0.02, 0.02), voxel_m=0.02)
    sun = _core.DirectionalLight(-60.0, 30.0, E, 0.533)
    settings = _core.RenderSettings(spp=1024, seed=5, light_samples=2, bounces=0)
    reference = _core.render(scene, camera, sun, settings, passes=["rgb"], medium=medium)["rgb"].astype(np.float64)
    for target in (0.03, 0.02):
        out = _core.render(
            scene, camera, sun, _core.RenderSettings(**base, adaptive_error_target=target), medium=medium
        )
        assert rel_rmse(out, reference) == pytest.approx(target, rel=0.15)
    one, two = (
        _core.render(
            scene, camera, sun, _core.RenderSettings(**base, adaptive_error_target=0.02, threads=t), medium=medium
        )
        for t in (1, 2)
    )
    assert one["rgb"].tobytes() == two["rgb"].tobytes() == out["rgb"].tobytes()
    glowing = _core.Medium(puff, albedo=(0.6, 0.6, 0.6), voxel_m=0.02)
    clear = _core.render(scene, camera, sun, _core.RenderSettings(**base))
    veiled = _core.render(scene, camera, sun, _core.RenderSettings(**base), medium=glowing)
    assert 0 < veiled["refined_pixels"] < clear["refined_pixels"] / 2


def test_the_threshold_weighs_the_spread_by_the_pixel_and_the_frame():
    """A pixel is refined where its base samples' direct luminance spreads beyond threshold ×
    √(its mean × the frame's mean): the decisions do not change when the Sun is ten times
    brighter (spread and scale grow alike), and a threshold high enough refines nothing."""
    scene = lunar_test_scene()
    bright = _core.DirectionalLight(-60.0, 12.0, 10 * E, 0.533)
    settings = quality(seed=5, adaptive_spp=16, adaptive_threshold=0.5)
    dim, lit = (_core.render(scene, ground_camera(), sun, settings) for sun in (DISK_SUN, bright))
    assert dim["refined_pixels"] == lit["refined_pixels"] > 0
    assert dim["refinement_rays"] == lit["refinement_rays"]
    # The spread is at most max − 0 and the mean at least max/spp, so spread/√(m·M) is at most
    # √(spp·max/M): a threshold past it for every pixel refines none.
    never = quality(seed=5, adaptive_spp=16, adaptive_threshold=1e4)
    assert _core.render(scene, ground_camera(), DISK_SUN, never)["refined_pixels"] == 0


def test_the_regolith_grain_does_not_make_pixels_disagree():
    """Every sample of a pixel reads the grain (albedo and relief) where the pixel's centre ray
    meets the facet it hit, so the texture does not spread a pixel's samples: the close bag view
    under the default 12° Sun with the grain on refines about as many pixels as without it (the
    edges of the bag and its shadow). Read at each sample's own point, the grain's relief made
    five times as many disagree."""

    def refined(overrides: dict) -> int:
        config = load_config(
            None,
            {**CLOSE_BAG_VIEW, "sun.elevation_deg": 12.0, "render.indirect": "path", "render.bounces": 0, **overrides},
        )
        spec = compose_scene(config)
        pose = orbit_pose(spec.target, config.orbit.radius_m, config.orbit.height_m, 30.0)
        view = render_view(build_scene(spec), config, intrinsics(config.camera), pose, seed=3)
        return view.stats["refined_pixels"]

    without = refined({"terrain.photometry.grain.albedo_rms": 0.0, "terrain.photometry.grain.slope_rms_deg": 0.0})
    assert 0 < refined({}) < 1.2 * without
