"""`moonbot bench realism`: moonbot's renders against Apollo surface photographs, statistic by
statistic (definitions: moonbot/benchmark/realism.py).

Renders are matched to the photos' geometry: a camera `camera_height_m` (1.5 m) above the
ground under it, looking `pitch_deg` (20°) down, with the Hasselblad's 49.2° horizontal field
(60 mm lens, 55 mm frame: 2·atan(27.5/60)), at each Sun elevation the photos were taken under
(the mid-points of SOURCES.csv's ranges), looking across the Sun (Sun to the left) and down-Sun
(Sun behind), on the flat location, plus the hilly and crater variants across the Sun, plus one
view with a bag in frame. Every scene is built through the configuration API
(load_config with overrides, compose_scene, build_scene, render_view) and tone-mapped with the
project's exposure (`auto` metered at the camera's depression angle) to 8-bit sRGB, so photo and
render pass through one statistics code path. The first flat view is rendered again with a
second seed: the statistics' change is their Monte-Carlo uncertainty, and the noise's RMS
contrast per octave is set beside the render's.

Photos are compared within their Sun elevation band: a render at elevation e is compared with
the photos whose SOURCES.csv range contains e. For each statistic the record gives the band's
photo range (min, median, max), each render's value and whether it falls inside, and, over all
photos and renders, a separation score |median(renders) − median(photos)| / IQR(photos) and the
fraction of renders outside the photos' full range. A logistic-regression two-sample test on
32-pixel patches (realism.patch_features) says how well patches alone tell renders from photos.
"""

from __future__ import annotations

import dataclasses
import io
import json
import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from moonbot.benchmark import realism
from moonbot.benchmark.fingerprint import RESULTS_DIR, machine
from moonbot.host import machine_slug

SCHEMA_VERSION = 1
HASSELBLAD_HFOV_DEG = 2.0 * math.degrees(math.atan(27.5 / 60.0))  # 55 mm frame behind a 60 mm lens: 49.25°
DEFAULT_REGIONS = Path("bench") / "realism-photo-rois.csv"  # the checkout's, from the working directory
UNLISTED_PHOTO_REGION = realism.RegionOfInterest(0.03, 0.03, 0.97, 0.97)  # inside the film rebate


@dataclass(frozen=True)
class Options:
    """What the benchmark renders and how. Quality: `spp`, `light_samples`, `bounces` (the
    render section's knobs), `threads` (0 = all cores). Geometry: `width` × `height` pixels over
    `hfov_deg`, `camera_height_m` above the ground, `pitch_deg` down, the camera `standoff_m`
    behind the target (the bag) looking at it for the bag view, and `away_standoff_m` in front
    of it looking away for the views without a bag: rocks are drawn within 300·D of the target
    (terrain/rocks.py), 1 cm pebbles within 3 m, so the ground these views see (1.9-6 m ahead)
    must start near it. `detail_extent_m` widens the terrain's fine tile
    so the foreground the camera sees (1.9-6 m ahead at 20° pitch) is on it (0 = the config's).
    `overrides` are further config fields; `locations` the variants beside flat."""

    width: int = 768
    height: int = 576
    hfov_deg: float = HASSELBLAD_HFOV_DEG
    spp: int = 16
    light_samples: int = 1
    bounces: int = 2  # render.bounces' default: shadowed ground lit by the sunlit ground around it
    threads: int = 0
    camera_height_m: float = 1.5
    pitch_deg: float = 20.0
    standoff_m: float = 2.5
    away_standoff_m: float = 0.5
    detail_extent_m: float = 6.0
    noise_seed: int = 2
    locations: tuple[str, ...] = ("flat", "hilly", "crater")
    overrides: dict = dataclasses.field(default_factory=dict)
    tile_px: int = realism.TILE_PX
    patch_px: int = realism.PATCH_PX

    @property
    def px_per_deg(self) -> float:
        """The analysis scale: the renders' own pixels per degree."""
        return self.width / self.hfov_deg


@dataclass(frozen=True)
class RenderPlan:
    """One render: `location`, Sun `elevation_deg`, `sun_side` ("cross": the Sun 90° to the
    left of the view; "down": behind the camera), `bag_in_frame`, `seed`."""

    location: str
    elevation_deg: float
    sun_side: str
    bag_in_frame: bool
    seed: int = 1

    @property
    def name(self) -> str:
        bag = "-bag" if self.bag_in_frame else ""
        return f"{self.location}-sun{self.elevation_deg:g}-{self.sun_side}{bag}-seed{self.seed}"


def render_plans(elevations: list[float], options: Options) -> list[RenderPlan]:
    """Flat at every elevation, across and down the Sun; one flat view with the bag in frame
    (lowest elevation, across); the other locations across the Sun at every elevation; last,
    the first flat view again with the noise seed."""
    plans = [RenderPlan("flat", e, side, False) for e in elevations for side in ("cross", "down")]
    plans.append(RenderPlan("flat", elevations[0], "cross", True))
    plans += [RenderPlan(loc, e, "cross", False) for loc in options.locations if loc != "flat" for e in elevations]
    plans.append(dataclasses.replace(plans[0], seed=options.noise_seed))
    return plans


def look_pose(eye: np.ndarray, azimuth_deg: float, pitch_deg: float):
    """World-to-camera pose (OpenCV axes) of a camera at `eye` (world, metres) looking toward
    `azimuth_deg` (clockwise from North) and `pitch_deg` below the horizontal, image x level."""
    from moonbot.scene.orbit import CameraPose

    a, p = math.radians(azimuth_deg), math.radians(pitch_deg)
    forward = np.array([math.sin(a) * math.cos(p), math.cos(a) * math.cos(p), -math.sin(p)])
    right = np.array([math.cos(a), -math.sin(a), 0.0])
    R = np.stack([right, np.cross(forward, right), forward])
    return CameraPose(R=R, t=-R @ eye)


def base_overrides(location: str, options: Options) -> dict:
    """The config overrides every render of `location` shares. The orbit's depression angle is
    set to the pitch so that `tonemap.ev100: auto` meters the regolith as this camera sees it."""
    out = {
        "terrain.location": location,
        "camera.width": options.width,
        "camera.height": options.height,
        "camera.hfov_deg": options.hfov_deg,
        "render.spp": options.spp,
        "render.light_samples": options.light_samples,
        "render.bounces": options.bounces,
        "render.threads": options.threads,
        "orbit.radius_m": 1.0,
        "orbit.height_m": math.tan(math.radians(options.pitch_deg)),
    }
    if options.detail_extent_m > 0:
        out["terrain.detail_extent_m"] = options.detail_extent_m
    out.update(options.overrides)
    return out


@dataclass(frozen=True)
class Rendered:
    """A render's `plan`, 8-bit sRGB `rgb8` (H, W, 3), the EV100 it was exposed at, the core's
    ray counts and seconds (`stats`)."""

    plan: RenderPlan
    rgb8: np.ndarray
    ev100: float
    stats: dict


def render_all(plans: list[RenderPlan], options: Options, say: Callable[[str], None]) -> list[Rendered]:
    """Renders every plan, building each location's scene once (the Sun only changes lights)."""
    from moonbot.config import load_config
    from moonbot.render import build_scene, render_view
    from moonbot.render.exposure import resolve_exposure, tonemap
    from moonbot.render.view import build_light_cache
    from moonbot.scene import compose_scene, intrinsics

    out = []
    for location in dict.fromkeys(p.location for p in plans):
        start = time.perf_counter()
        config = load_config(None, base_overrides(location, options))
        spec = compose_scene(config)
        scene = build_scene(spec, config.render.embree_isa)
        say(f"{location}: scene built in {time.perf_counter() - start:.1f} s")
        K = intrinsics(config.camera)
        for plan in (p for p in plans if p.location == location):
            sun = dataclasses.replace(config.sun, elevation_deg=plan.elevation_deg)
            view_config = dataclasses.replace(config, sun=sun)
            # cross: the Sun 90° left of the view (shadows fall to the right); down: behind.
            azimuth = sun.azimuth_deg + (90.0 if plan.sun_side == "cross" else 180.0)
            ahead = np.array([math.sin(math.radians(azimuth)), math.cos(math.radians(azimuth))])
            # The bag view stands behind the target looking at it; the others in front, looking away.
            xy = spec.target[:2] + (-options.standoff_m if plan.bag_in_frame else options.away_standoff_m) * ahead
            ground = float(spec.ground.height(np.array([xy[0]]), np.array([xy[1]]))[0])
            pose = look_pose(np.array([xy[0], xy[1], ground + options.camera_height_m]), azimuth, options.pitch_deg)
            # The product's indirect light: a light cache for this Sun (None where render.indirect is path).
            view = render_view(
                scene, view_config, K, pose, plan.seed, light_cache=build_light_cache(scene, view_config)
            )
            exposure = resolve_exposure(view_config)
            rgb8, _ = tonemap(view.rgb, exposure)
            out.append(Rendered(plan, np.asarray(rgb8), exposure.ev100, view.stats))
            say(f"  {plan.name}: {view.stats['core_seconds']:.1f} s, EV100 {exposure.ev100:.2f}")
    return out


def read_photo(path: Path) -> np.ndarray:
    """(H, W, 3) uint8 sRGB of a JPEG/PNG photo (Pillow: matplotlib's own image dependency)."""
    from PIL import Image

    with Image.open(path) as image:
        return np.asarray(image.convert("RGB"))


def band_range(values: list[float]) -> dict:
    """min, median, max of the finite `values` (NaN each when none)."""
    v = np.array([x for x in values if np.isfinite(x)])
    if v.size == 0:
        return {"min": float("nan"), "median": float("nan"), "max": float("nan"), "n": 0}
    return {"min": float(v.min()), "median": float(np.median(v)), "max": float(v.max()), "n": int(v.size)}


def separation(photo_values: list[float], render_values: list[float]) -> dict:
    """|median(renders) − median(photos)| over the photos' interquartile range (∞ when the IQR
    is 0 and the medians differ), and the fraction of renders outside [min, max] of the photos."""
    p = np.array([x for x in photo_values if np.isfinite(x)])
    r = np.array([x for x in render_values if np.isfinite(x)])
    if p.size == 0 or r.size == 0:
        return {"score": float("nan"), "outside_fraction": float("nan")}
    gap = abs(float(np.median(r) - np.median(p)))
    iqr = float(np.subtract(*np.percentile(p, [75, 25])))
    score = gap / iqr if iqr > 0 else (math.inf if gap > 0 else 0.0)
    outside = float(np.mean((r < p.min()) | (r > p.max())))
    return {
        "score": score,
        "outside_fraction": outside,
        "photos_median": float(np.median(p)),
        "renders_median": float(np.median(r)),
    }


def noise_record(a: realism.Measured, b: realism.Measured, tile_px: int) -> dict:
    """Monte-Carlo noise of a render from two seeds on `a`'s ground mask: the per-pixel luma
    noise (RMS of the difference / √2) over the mean, its RMS contrast per octave beside the
    render's own, and every statistic's change between the seeds."""
    mask = a.ground.mask & b.ground.mask
    diff = (a.luma - b.luma) / math.sqrt(2.0)
    mean = float(a.luma[mask].mean())
    tiles = realism.ground_tiles(diff, mask, tile_px)
    window = np.outer(np.hanning(tile_px), np.hanning(tile_px))
    spectrum = (np.abs(np.fft.fft2(tiles / mean * window)) ** 2).mean(axis=0) / (tile_px**4 * np.mean(window**2))
    noise_octaves = realism.octave_rms_contrast(spectrum)
    fa, fb = realism.flatten(a.stats), realism.flatten(b.stats)
    return {
        "pixel_noise_over_mean": float(diff[mask].std() / mean),
        "noise_octave_rms_contrast": dict(zip(a.stats["octave_rms_contrast"], noise_octaves)),
        "render_octave_rms_contrast": a.stats["octave_rms_contrast"],
        "statistic_change_between_seeds": {k: fb[k] - fa[k] for k in fa if k in fb},
    }


COMPARED = (
    "shadow_fraction",
    "shadow_fraction_black_corrected",
    "luma_percentiles_over_median.p5",
    "luma_percentiles_over_median.p25",
    "luma_percentiles_over_median.p75",
    "luma_percentiles_over_median.p95",
    "luma_percentiles_over_median.p99",
    "spectrum_slope",
    "fine_to_coarse_contrast",
    "laplacian_contrast",
    "blobs_per_deg2",
    "blob_cover_fraction",
    "d50_deg",
    "d90_deg",
)


def compared_statistics(stats: dict) -> dict[str, float]:
    """The statistics the comparison ranks: COMPARED plus every octave contrast, and the same
    spatial ones of the tone-free image (`tone_free.`...)."""
    flat = realism.flatten(stats)

    def compared(key: str) -> bool:
        return key in COMPARED or key.startswith("octave_rms_contrast.")

    return {
        k: v
        for k, v in flat.items()
        if compared(k) or (k.startswith("tone_free.") and compared(k.removeprefix("tone_free.")))
    }


def run_realism(
    photos: Path,
    regions_path: Path | None = None,
    options: Options = Options(),
    out: Path | None = None,
    sheet: Path | None = None,
    say: Callable[[str], None] = lambda text: None,
) -> tuple[dict, Path]:
    """Measures the photos in `photos` (SOURCES.csv, realism.read_sources) and the renders of
    `options`, compares them, writes the JSON record (default bench/results/realism-<machine>.json)
    and the side-by-side sheet (default realism-sheet.png beside it). Returns (record, path)."""
    start = time.perf_counter()
    load_before = os.getloadavg()[0]
    sources = realism.read_sources(photos)
    if not sources:
        raise ValueError(f"{photos}/SOURCES.csv lists no photos")
    regions = realism.read_regions(regions_path or DEFAULT_REGIONS)
    ppd = options.px_per_deg
    photo_records, photo_measured = [], []
    for source in sources:
        region = regions.get(source.path.name, UNLISTED_PHOTO_REGION)
        rgb8 = read_photo(source.path)
        try:
            measured = realism.measure(rgb8, HASSELBLAD_HFOV_DEG, ppd, region, options.tile_px)
        except ValueError as e:
            raise ValueError(f"{source.path}: {e}") from None
        photo_measured.append((source, measured))
        photo_records.append(
            {
                "file": source.path.name,
                "sun_elevation_deg": [source.sun_low_deg, source.sun_high_deg],
                "region": dataclasses.asdict(region),
                "listed_region": source.path.name in regions,
                "reseau_px": int(measured.ground.reseau.sum()),
                "stats": measured.stats,
            }
        )
    say(f"{len(sources)} photos measured")

    elevations = sorted({s.sun_mid_deg for s in sources})
    plans = render_plans(elevations, options)
    renders = render_all(plans, options, say)
    render_measured = [(r, realism.measure(r.rgb8, options.hfov_deg, ppd, tile_px=options.tile_px)) for r in renders]

    compared_photos = {s.path.name: compared_statistics(m.stats) for s, m in photo_measured}
    render_records = []
    for r, m in render_measured:
        band = [s for s, _ in photo_measured if s.sun_low_deg <= r.plan.elevation_deg <= s.sun_high_deg]
        values = compared_statistics(m.stats)
        in_band = {}
        for key, value in values.items():
            span = band_range([compared_photos[s.path.name].get(key, float("nan")) for s in band])
            in_band[key] = {"value": value, **span, "inside": bool(span["n"] and span["min"] <= value <= span["max"])}
        render_records.append(
            {
                "name": r.plan.name,
                **dataclasses.asdict(r.plan),
                "ev100": r.ev100,
                "render": {k: r.stats[k] for k in ("camera_rays", "shadow_rays", "bounce_rays", "core_seconds")},
                "band_photos": [s.path.name for s in band],
                "stats": m.stats,
                "against_band": in_band,
            }
        )

    bands = {}
    for elevation in elevations:
        band = [s.path.name for s in sources if s.sun_low_deg <= elevation <= s.sun_high_deg]
        keys = sorted(set().union(*(compared_photos[name] for name in band)))
        bands[f"{elevation:g}"] = {
            "photos": band,
            "range": {key: band_range([compared_photos[name].get(key, float("nan")) for name in band]) for key in keys},
        }

    main_renders = [(r, m) for r, m in render_measured if r.plan.seed != options.noise_seed]
    keys = sorted(set().union(*compared_photos.values()))
    ranking = {
        key: separation(
            [v.get(key, float("nan")) for v in compared_photos.values()],
            [compared_statistics(m.stats).get(key, float("nan")) for _, m in main_renders],
        )
        for key in keys
    }
    noise_pair = [m for r, m in render_measured if r.plan.name in (plans[0].name, plans[-1].name)]
    noise = noise_record(noise_pair[0], noise_pair[1], options.tile_px)

    def patches(measured: list, tone_free: bool) -> np.ndarray:
        def luma(m: realism.Measured) -> np.ndarray:
            return m.tone_free_luma if tone_free else m.luma

        return np.vstack([realism.patch_features(luma(m), m.ground.mask, options.patch_px) for _, m in measured])

    def classify(tone_free: bool) -> dict:
        photo_patches, render_patches = patches(photo_measured, tone_free), patches(main_renders, tone_free)
        try:
            classifier = realism.two_sample_accuracy(render_patches, photo_patches)
        except ValueError as e:
            return {"error": str(e)}
        classifier["features"] = list(realism.PATCH_FEATURES)
        classifier["render_patches"], classifier["photo_patches"] = len(render_patches), len(photo_patches)
        return classifier

    record = {
        "schema_version": SCHEMA_VERSION,
        "machine": machine(),
        "options": {**dataclasses.asdict(options), "px_per_deg": ppd, "photo_hfov_deg": HASSELBLAD_HFOV_DEG},
        "photos_dir_name": Path(photos).name,
        "regions_file": str(Path(regions_path or DEFAULT_REGIONS).name),
        "definitions": "moonbot/benchmark/realism.py; comparison: moonbot/benchmark/realism_bench.py",
        "photos": photo_records,
        "sun_bands": bands,
        "renders": render_records,
        "separation": dict(sorted(ranking.items(), key=lambda kv: -_finite_or(kv[1]["score"], -1.0))),
        "monte_carlo_noise": {"renders": [plans[0].name, plans[-1].name], **noise},
        "patch_classifier": classify(tone_free=False),
        "patch_classifier_tone_free": classify(tone_free=True),
    }
    record["seconds_total"] = time.perf_counter() - start
    # Other processes inflate every time here (provisional on a shared machine); ray counts do not.
    record["load_average_1min"] = {"before": load_before, "after": os.getloadavg()[0]}
    path = Path(out) if out else RESULTS_DIR / f"realism-{machine_slug(record['machine'])}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    write_sheet(Path(sheet) if sheet else path.parent / "realism-sheet.png", main_renders, photo_measured, ppd)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(record, indent=2, default=_json_default) + "\n")
    tmp.replace(path)
    return record, path


def _finite_or(x: float, fallback: float) -> float:
    return x if math.isfinite(x) else (1e9 if x == math.inf else fallback)


def _json_default(value):
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    return str(value)


SHEET_ROW_PX = 240  # each image's height on the sheet
SHEET_CROP_PX = 128  # the ground crops at the analysis scale (8.2° at 768 px over 49.25°)


def matched_crops(a: realism.Measured, b: realism.Measured, largest: int = SHEET_CROP_PX) -> tuple[np.ndarray, ...]:
    """Square luma crops of the ground of `a` and of `b` at the analysis scale, of one size (the
    same angular size): the largest of `largest`, ¾, ½, ⅜ and ¼ of it at which both grounds hold
    a tile wholly inside their mask (realism.ground_tiles; the middle one of each). Empty (0, 0)
    arrays when even the smallest does not fit."""
    for size in (largest, largest * 3 // 4, largest // 2, largest * 3 // 8, largest // 4):
        tiles = [realism.ground_tiles(m.luma, m.ground.mask, size) for m in (a, b)]
        if all(len(t) for t in tiles):
            return tuple(t[len(t) // 2] for t in tiles)
    return np.zeros((0, 0)), np.zeros((0, 0))


def write_sheet(path: Path, renders: list, photos: list, px_per_deg: float) -> None:
    """A PNG of rows render | photo | their ground crops at the analysis scale (the same angular
    size, grey luma as measured: matched_crops) | the same crops tone-free (realism.tone_free, its
    log shown over ±3σ: only the arrangement of light and dark, whatever each image's tone
    curve), by Sun elevation, each render beside a photo of its band (taken in turn), the ground
    masks' boundaries drawn in cyan; saved as 256-colour PNG to stay small. Written to a
    temporary file, then renamed."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot as plt
    from PIL import Image

    rows = sorted(renders, key=lambda rm: (rm[0].plan.elevation_deg, rm[0].plan.location != "flat", rm[0].plan.name))
    used: dict[float, int] = {}
    size = ((2 * 4 / 3 + 4) * SHEET_ROW_PX / 100, len(rows) * SHEET_ROW_PX / 100 + 0.3)
    fig, axes = plt.subplots(
        len(rows), 6, figsize=size, dpi=100, squeeze=False, gridspec_kw={"width_ratios": [4 / 3, 4 / 3, 1, 1, 1, 1]}
    )
    spread = 3.0 * realism.TONE_FREE_SIGMA

    def tone_free(m: realism.Measured) -> realism.Measured:
        return dataclasses.replace(m, luma=m.tone_free_luma)

    for row, (r, m) in enumerate(rows):
        band = [(s, pm) for s, pm in photos if s.sun_low_deg <= r.plan.elevation_deg <= s.sun_high_deg]
        axes[row, 0].imshow(r.rgb8)
        axes[row, 0].contour(
            m.ground.mask, levels=[0.5], colors="cyan", linewidths=0.4, extent=(0, r.rgb8.shape[1], 0, r.rgb8.shape[0])
        )
        axes[row, 0].set_title(
            f"render {r.plan.name} (shadow {m.stats['shadow_fraction']:.2f}, "
            f"blobs {m.stats['blobs_per_deg2']:.2f}/deg²)",
            fontsize=5,
        )
        if band:
            k = used.get(r.plan.elevation_deg, 0)
            used[r.plan.elevation_deg] = k + 1
            s, pm = band[k % len(band)]
            image = read_photo(s.path)
            axes[row, 1].imshow(image)
            axes[row, 1].contour(
                pm.ground.mask,
                levels=[0.5],
                colors="cyan",
                linewidths=0.4,
                extent=(0, image.shape[1], 0, image.shape[0]),
            )
            axes[row, 1].set_title(
                f"photo {s.path.stem} (Sun {s.sun_low_deg:g}-{s.sun_high_deg:g}°; shadow "
                f"{pm.stats['shadow_fraction']:.2f}, blobs {pm.stats['blobs_per_deg2']:.2f}/deg²)",
                fontsize=5,
            )
            for column, crop, what in zip((2, 3), matched_crops(m, pm), ("render", "photo")):
                if crop.size:
                    axes[row, column].imshow(crop, cmap="gray", vmin=0, vmax=1, interpolation="nearest")
                    axes[row, column].set_title(
                        f"{what} ground, {crop.shape[1] / px_per_deg:.1f}° at the analysis scale", fontsize=5
                    )
            for column, crop, what in zip((4, 5), matched_crops(tone_free(m), tone_free(pm)), ("render", "photo")):
                if crop.size:
                    axes[row, column].imshow(
                        np.log(crop), cmap="gray", vmin=-spread, vmax=spread, interpolation="nearest"
                    )
                    axes[row, column].set_title(f"{what} ground, tone-free", fontsize=5)
        for ax in axes[row]:
            ax.set_axis_off()
    fig.tight_layout(pad=0.2)
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=100)
    plt.close(fig)
    buffer.seek(0)
    with Image.open(buffer) as image:
        small = image.convert("RGB").quantize(colors=256)
        tmp = path.with_name(path.name + ".tmp.png")
        small.save(tmp, format="PNG", optimize=True)
    tmp.replace(path)


def format_summary(record: dict) -> str:
    """A text table: per statistic the photos' min / median / max (all photos), the renders'
    median, how many renders fall inside their Sun band's photo range, and the separation score
    (largest first); then the Monte-Carlo noise and the patch classifiers (luma and tone-free)."""
    renders = [r for r in record["renders"] if r["seed"] != record["options"]["noise_seed"]]
    lines = [f"{'statistic':<54} {'photos min':>10} {'median':>8} {'max':>8} {'renders':>8} {'in band':>8} {'sep':>6}"]
    for key, sep in record["separation"].items():
        photos = [p for p in (realism.flatten(ph["stats"]).get(key) for ph in record["photos"]) if p is not None]
        photos = [p for p in photos if math.isfinite(p)]
        inside = sum(1 for r in renders if r["against_band"].get(key, {}).get("inside"))
        lo, hi = (min(photos), max(photos)) if photos else (float("nan"),) * 2
        lines.append(
            f"{key:<54} {lo:>10.3g} {sep.get('photos_median', float('nan')):>8.3g} {hi:>8.3g} "
            f"{sep.get('renders_median', float('nan')):>8.3g} {inside:>4}/{len(renders):<3} "
            f"{sep['score']:>6.2f}"
        )
    noise = record["monte_carlo_noise"]
    lines.append(
        f"\nMonte-Carlo noise ({noise['renders'][0]} vs seed {record['options']['noise_seed']}): "
        f"pixel RMS {noise['pixel_noise_over_mean']:.4f} of the mean luma"
    )
    for band, n in noise["noise_octave_rms_contrast"].items():
        lines.append(f"  {band:<28} noise {n:.4f}  render {noise['render_octave_rms_contrast'][band]:.4f}")
    for key, title in (("patch_classifier", "patch classifier"), ("patch_classifier_tone_free", "tone-free")):
        c = record.get(key)
        if c is None:  # records written before the tone-free statistics
            continue
        if "accuracy" in c:
            lines.append(
                f"\n{title} (renders vs photos, {c['patches_per_class']} patches each, "
                f"{c['folds']}-fold): accuracy {c['accuracy']:.3f}"
            )
            for name, w, a in zip(c["features"], c["weights"], c["single_feature_accuracy"]):
                lines.append(f"  {name:<20} weight {w:>7.2f}  alone {a:.3f}")
        else:
            lines.append(f"\n{title}: {c['error']}")
    return "\n".join(lines)
