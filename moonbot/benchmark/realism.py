"""Realism statistics: one code path that measures a lunar photograph and a render alike.

Every statistic is computed on the *luma* of an 8-bit sRGB image, Y' = 0.2126 R' + 0.7152 G' +
0.0722 B' on the code values / 255 (so in [0, 1], gamma-encoded, no linearisation), resampled to
a common *analysis scale* in pixels per degree of field (photos and renders are compared at the
same angular resolution, so a pebble of a given angular size covers as many pixels in both), and
restricted to a *ground mask*: inside a region of interest (a frame fraction, see
`RegionOfInterest`), minus the sky (black above the horizon), a band below the horizon, and
reseau crosses. Renders go through the project's own exposure and tone map to 8-bit sRGB first,
so both sides pass through one display curve.

Statistics (all dimensionless unless stated):

* shadow_fraction: fraction of ground pixels with Y' below `SHADOW_LEVEL` (5 %) of the ground's
  99th percentile.
* shadow_fraction_black_corrected: the same with luma and the 99th percentile measured above
  the frame's black level (its 0.5th percentile, sky and rebate included): scans whose black
  is lifted (by the scanner or the film's fog) otherwise read as shadowless.
* luma_percentiles: the ground's 5th, 25th, 75th, 95th and 99th percentiles of Y', each over the
  median (p50): the shape of the brightness distribution without its exposure.
* spectrum_slope: the exponent s of the ground's radially averaged power spectrum P(f) ∝ f^s,
  least squares in log-log over `SPECTRUM_BAND` (0.04-0.25 cycles per analysis pixel). P is the
  mean periodogram of square tiles wholly inside the ground mask, each less its fitted plane,
  divided by the ground's mean luma (contrast) and Hann-windowed. A 1/f^β image gives s = −β;
  natural images ≈ −2.
* octave_rms_contrast: RMS contrast (std / mean of luma) in octave bands of radial spatial
  frequency, from the same periodograms (Parseval): band k spans [0.5·2^-(k+1), 0.5·2^-k)
  cycles per pixel, k = 0 the finest. Also as cycles per degree.
* fine_to_coarse_contrast (granularity): the two finest octaves' RMS contrast over the two
  coarsest octaves'.
* laplacian_contrast: RMS of the 5-point Laplacian of Y' over ground pixels whose four
  neighbours are ground, over the mean Y': edge and grain energy at the finest scale.
* dark blobs (granularity): pixels darker than `BLOB_DARKNESS` × their local background (a
  masked Gaussian mean of σ = `BLOB_BACKGROUND_SIGMA_DEG`) form 8-connected blobs — the cast
  shadows and dark sides of pebbles and rocks. Blobs touching the mask's edge (size unknown),
  single pixels (noise) and blobs wider than `BLOB_MAX_DIAMETER_DEG` (a crater's or the
  photographer's shadow, not a pebble's) are dropped. Reported: blobs per square degree of
  ground, their area-equivalent diameters (degrees; quantiles and counts per octave of size) and
  the fraction of ground they cover.
* tone_free (the same spatial statistics, tone curve taken out): spectrum slope, octave
  contrasts, fine/coarse, Laplacian and dark blobs of `tone_free(y)`, the luma with every ground
  pixel replaced by exp(σ·z), z its normal score (rank → Φ⁻¹), σ = `TONE_FREE_SIGMA` for every
  image. Any strictly increasing curve applied to the luma gives the same image, so a photo's
  unknown film and scan curve and the renders' tone map drop out, and what is compared is how
  brightness is arranged: granular, pebble-strewn ground against smooth ground. Two ways a curve
  still acts: the film's curve came before the resampling to the analysis scale, which averages
  ~2.6 × 2.6 scan pixels (a second-order effect), and codes that a curve merges become ties
  (ties share their mean rank).

Caveats. The photos are film scans re-exported through an unknown tone curve (Lightroom): every
statistic that depends on the curve (shadow fraction, percentiles, blob darkness) carries its
uncertainty; the spectrum slope and octave contrasts depend on it through the local slope of the
curve, the tone_free statistics hardly at all. JPEG's 8×8 blocks and film grain sit at the scan's
finest scales; resampling a 2000-pixel scan down to the analysis scale (≈2.6×) averages most of
them away. Reseau crosses (thin crosses on a 10 mm grid exposed on every frame; bold on the
Apollo 12 black-and-white scans, faint on the colour ones) are masked by `reseau_cross_mask`;
the faintest Apollo 11 ones fall below its contrast and stay (lines about a pixel wide). The film rebate and hardware in
frame are kept out by each photo's region of interest. The scans' width is taken as the
Hasselblad's 49.25° field; the visible rebate strips (2-3 % a side) mean the image area is
somewhat narrower, so photos are analysed at a scale a few per cent finer than renders.
Renders must be converged: Monte-Carlo noise adds fine-scale energy that a photo's ground
texture would otherwise be credited with (the benchmark measures it with a second seed).

numpy and scipy.ndimage (filters, connected-component labels) only: no image library.

Arrays: images are (H, W) float64 luma or (H, W, 3) uint8 sRGB; masks (H, W) bool, True = use.
"""

from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import ndimage
from scipy.special import ndtri
from scipy.stats import rankdata

LUMA_WEIGHTS = (0.2126, 0.7152, 0.0722)  # ITU-R BT.709, applied to gamma-encoded codes (luma)
SHADOW_LEVEL = 0.05  # a shadow pixel is below this fraction of the ground's 99th percentile
SHADOW_REFERENCE_PERCENTILE = 99.0
PERCENTILES = (5, 25, 75, 95, 99)
# Cycles per analysis pixel: from the third bin of a 64-px tile (the first two hold the window's
# leakage) to a quarter of the sampling rate (a tenth of the scans' own, below JPEG's blocks).
SPECTRUM_BAND = (0.04, 0.25)
TILE_PX = 64  # square tiles for the spectrum; f = 1/64 cycles/px is the lowest frequency resolved
OCTAVES = 5  # finest band [0.25, 0.5) down to [1/64, 1/32) cycles/px
SKY_LEVEL = 0.16  # luma below this, in a run from the top of a column, is sky (black) or rebate
SKY_SMOOTH_PX = 3  # box smoothing before the sky test, so a single bright speck does not end the run
HORIZON_MARGIN_PX = 3  # ground rows kept out below the sky: the limb's blend of sky and ground
BLOB_DARKNESS = 0.5  # blob pixels are below half their local background
# The local background: wider than the widest blob kept, so a large shadow is dark throughout
# (narrower, its core matches its own dark surroundings and only its rim is found).
BLOB_BACKGROUND_SIGMA_DEG = 1.5
BLOB_MIN_AREA_PX = 2
BLOB_MAX_DIAMETER_DEG = 1.0  # beyond ≈ 1° a dark patch is a crater's, rock's or hardware's shadow
RESEAU_ARM_DEG = 0.3  # a cross's arm from its centre (the Apollo 12 scans' crosses reach ≈ 0.35°)
RESEAU_CONTRAST = 0.06  # a line pixel differs from the pixels two beside it by this fraction of its luma
RESEAU_AGREEMENT = 0.75  # of the pixels along each of a cross's four arms lie on a line
RESEAU_GRID_DEG = math.degrees(math.atan(10.0 / 60.0))  # 10 mm reseau pitch behind the 60 mm lens: 9.46°
RESEAU_GRID_TOLERANCE = 0.15  # the scans' scale (rebate included or cropped) is known to ±15 %


def luma(rgb8: np.ndarray) -> np.ndarray:
    """Y' in [0, 1] (H, W) float64 of an 8-bit sRGB image (H, W, 3) or (H, W) (already grey);
    an alpha channel is ignored."""
    rgb8 = np.asarray(rgb8)
    if rgb8.dtype != np.uint8:
        raise ValueError(f"luma: expected 8-bit codes (uint8), got {rgb8.dtype}")
    if rgb8.ndim == 2:
        return rgb8.astype(np.float64) / 255.0
    if rgb8.ndim != 3 or rgb8.shape[2] not in (1, 3, 4):
        raise ValueError(f"luma: expected (H, W), (H, W, 1), (H, W, 3) or (H, W, 4), got {rgb8.shape}")
    if rgb8.shape[2] == 1:
        return rgb8[..., 0].astype(np.float64) / 255.0
    return rgb8[..., :3].astype(np.float64) @ np.array(LUMA_WEIGHTS) / 255.0


def _resample_axis(a: np.ndarray, n_out: int, axis: int) -> np.ndarray:
    """Box-filter resampling along `axis` to `n_out` samples: output sample j is the exact mean
    of the input over [j·n/n_out, (j+1)·n/n_out) (input pixel i spans [i, i+1)), from the
    linearly interpolated cumulative sum. Conserves the mean."""
    a = np.moveaxis(a, axis, 0)
    n = a.shape[0]
    cumulative = np.concatenate([np.zeros((1,) + a.shape[1:]), np.cumsum(a, axis=0)])
    edges = np.linspace(0.0, n, n_out + 1)
    lower = np.minimum(np.floor(edges).astype(int), n - 1)
    frac = (edges - lower)[(...,) + (None,) * (a.ndim - 1)]
    at_edges = cumulative[lower] + frac * (cumulative[lower + 1] - cumulative[lower])
    out = (at_edges[1:] - at_edges[:-1]) / (n / n_out)
    return np.moveaxis(out, 0, axis)


def area_resample(image: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """`image` (H, W) float resampled to `shape` (h, w) by exact box filtering (area averaging),
    separably; for downsampling, the anti-aliased mean over each output pixel's footprint."""
    h, w = shape
    if h < 1 or w < 1:
        raise ValueError(f"area_resample: output shape must be positive, got {shape}")
    return _resample_axis(_resample_axis(np.asarray(image, dtype=np.float64), h, 0), w, 1)


def to_analysis_scale(image: np.ndarray, hfov_deg: float, px_per_deg: float) -> np.ndarray:
    """`image` (H, W) whose width spans `hfov_deg` resampled to `px_per_deg` pixels per degree
    (square pixels, the same factor both ways). Small-angle: the factor is taken at the centre."""
    h, w = image.shape
    factor = px_per_deg * hfov_deg / w
    return area_resample(image, (max(1, round(h * factor)), max(1, round(w * factor))))


@dataclass(frozen=True)
class RegionOfInterest:
    """A rectangle of the frame as fractions of width (x) and height (y), origin top left:
    x0 < x1 and y0 < y1 in [0, 1]. The whole frame is (0, 0, 1, 1)."""

    x0: float = 0.0
    y0: float = 0.0
    x1: float = 1.0
    y1: float = 1.0

    def __post_init__(self):
        if not (0.0 <= self.x0 < self.x1 <= 1.0 and 0.0 <= self.y0 < self.y1 <= 1.0):
            raise ValueError(f"region of interest: need 0 <= x0 < x1 <= 1 and 0 <= y0 < y1 <= 1, got {self}")

    def mask(self, shape: tuple[int, int]) -> np.ndarray:
        """(H, W) bool, True inside the rectangle (pixel centres)."""
        h, w = shape
        ys = (np.arange(h) + 0.5) / h
        xs = (np.arange(w) + 0.5) / w
        return ((ys >= self.y0) & (ys < self.y1))[:, None] & ((xs >= self.x0) & (xs < self.x1))[None, :]


def sky_mask(y: np.ndarray, level: float = SKY_LEVEL, smooth_px: int = SKY_SMOOTH_PX) -> np.ndarray:
    """(H, W) bool: the sky, i.e. in each column the unbroken run of dark pixels (box-smoothed
    luma below `level`) from the top row down. Ground shadows are dark too but start below
    lit ground, so they are not sky unless they touch the horizon, or the frame's top edge where
    no sky is in view (hilly renders looking up-slope, photos of near ground): luma alone cannot
    tell those from sky, and they are left out. The same run catches a film rebate along the top."""
    smoothed = ndimage.uniform_filter(y, size=smooth_px, mode="nearest") if smooth_px > 1 else y
    return np.cumprod(smoothed < level, axis=0).astype(bool)


def below_horizon_margin(sky: np.ndarray, margin_px: int = HORIZON_MARGIN_PX) -> np.ndarray:
    """(H, W) bool: the sky and the `margin_px` rows under it in each column."""
    if margin_px <= 0:
        return sky.copy()
    shifted = [sky] + [np.concatenate([np.zeros((k, sky.shape[1]), bool), sky[:-k]]) for k in range(1, margin_px + 1)]
    return np.logical_or.reduce(shifted)


def _fraction_along(indicator: np.ndarray, axis: int, start: int, stop: int) -> np.ndarray:
    """Per pixel, the mean of bool `indicator` at offsets start..stop (inclusive, may be
    negative) along `axis`; beyond the image counts as False."""
    count = stop - start + 1
    pad = max(abs(start), abs(stop))
    padded = np.pad(indicator.astype(np.float64), [(pad, pad) if a == axis else (0, 0) for a in range(2)])
    cumulative = np.concatenate(
        [np.zeros_like(np.take(padded, [0], axis=axis)), np.cumsum(padded, axis=axis)], axis=axis
    )
    n = indicator.shape[axis]
    index = np.arange(n) + pad
    upper = np.take(cumulative, index + stop + 1, axis=axis)
    lower = np.take(cumulative, index + start, axis=axis)
    return (upper - lower) / count


def reseau_cross_mask(
    y: np.ndarray,
    px_per_deg: float,
    arm_deg: float = RESEAU_ARM_DEG,
    contrast: float = RESEAU_CONTRAST,
    agreement: float = RESEAU_AGREEMENT,
    grid_deg: float = RESEAU_GRID_DEG,
    grid_tolerance: float = RESEAU_GRID_TOLERANCE,
) -> np.ndarray:
    """(H, W) bool: squares of half-width 1.5 × the arm around detected reseau crosses.

    A cross is a thin horizontal line and a thin vertical line crossing, each reaching an arm's
    length (`arm_deg`) to both sides. A pixel lies on a thin dark horizontal line when it is
    darker than both the pixels two rows above and below by `contrast` × its luma (vertical:
    columns left and right; bright lines alike, brighter). A pixel is a cross's centre when, on
    each of its four arms (offsets 2 .. arm), at least `agreement` of the pixels lie on such a
    line of the arm's direction. Texture darkens random pixels and fails the agreement on some
    arm; a straight shadow edge or a staff is a line in one direction only. Last, only
    candidates with another a grid step (`grid_deg` ± `grid_tolerance` of it) away along a row
    or column are kept: the reseau is a grid, texture that passes by chance is not."""
    arm = max(3, round(arm_deg * px_per_deg))
    padded = np.pad(y, 2, mode="edge")
    centre = padded[2:-2, 2:-2]
    up, down = padded[:-4, 2:-2], padded[4:, 2:-2]
    left, right = padded[2:-2, :-4], padded[2:-2, 4:]
    # Deep shadow is noise over a near-black level: no cross is found there (none is visible).
    scale = np.maximum(centre, 0.1)
    level = contrast * scale
    dark = (np.minimum(up, down) - centre > level, np.minimum(left, right) - centre > level)
    bright = (centre - np.maximum(up, down) > level, centre - np.maximum(left, right) > level)
    found = np.zeros(y.shape, bool)
    for on_horizontal, on_vertical in (dark, bright):
        centre_ok = np.ones(y.shape, bool)
        for start, stop in ((-arm, -2), (2, arm)):
            centre_ok &= _fraction_along(on_horizontal, 1, start, stop) >= agreement
            centre_ok &= _fraction_along(on_vertical, 0, start, stop) >= agreement
        found |= centre_ok
    labels, count = ndimage.label(found, structure=np.ones((3, 3), bool))
    mask = np.zeros(y.shape, bool)
    if count < 2:
        return mask
    centres = np.array(ndimage.center_of_mass(found, labels, np.arange(1, count + 1)))
    # Crosses sit on a grid: keep a candidate only with another one a grid step away along a
    # row or a column. Texture that happens to pass the arm test does not line up like that.
    step = grid_deg * px_per_deg
    dy = np.abs(centres[:, None, 0] - centres[None, :, 0])
    dx = np.abs(centres[:, None, 1] - centres[None, :, 1])
    low, high = (1 - grid_tolerance) * step, (1 + grid_tolerance) * step
    aligned = ((dx >= low) & (dx <= high) & (dy <= 2.0)) | ((dy >= low) & (dy <= high) & (dx <= 2.0))
    half = round(1.5 * arm)
    for r, c in centres[aligned.any(axis=1)]:
        r, c = int(round(r)), int(round(c))
        mask[max(0, r - half) : r + half + 1, max(0, c - half) : c + half + 1] = True
    return mask


@dataclass(frozen=True)
class GroundMask:
    """The ground pixels to measure (`mask`, (H, W) bool) and the parts removed: `sky` (with the
    margin below the horizon) and `reseau` (crosses)."""

    mask: np.ndarray
    sky: np.ndarray
    reseau: np.ndarray


def ground_mask(
    y: np.ndarray, px_per_deg: float, roi: RegionOfInterest = RegionOfInterest(), detect_reseau: bool = True
) -> GroundMask:
    """The ground of luma `y` at the analysis scale: inside `roi`, not sky, not within
    HORIZON_MARGIN_PX below it, not on a reseau cross."""
    sky = below_horizon_margin(sky_mask(y))
    reseau = reseau_cross_mask(y, px_per_deg) if detect_reseau else np.zeros(y.shape, bool)
    return GroundMask(mask=roi.mask(y.shape) & ~sky & ~reseau, sky=sky, reseau=reseau)


def shadow_fraction(
    y: np.ndarray,
    mask: np.ndarray,
    level: float = SHADOW_LEVEL,
    reference_percentile: float = SHADOW_REFERENCE_PERCENTILE,
    black: float = 0.0,
) -> float:
    """Fraction of masked pixels with luma below `level` × the masked pixels'
    `reference_percentile`, both measured above `black` (a black level: 0, or the frame's own,
    see black_level)."""
    values = y[mask]
    if values.size == 0:
        raise ValueError("shadow_fraction: the mask is empty")
    return float(np.mean(values - black < level * (np.percentile(values, reference_percentile) - black)))


BLACK_PERCENTILE = 0.5


def black_level(y: np.ndarray) -> float:
    """The frame's black: its BLACK_PERCENTILE-th percentile luma over the whole frame (sky, film
    rebate and deepest shadow included). Scans differ in it (0 on the Apollo 11 colour
    re-exports, 0.03-0.05 on the Apollo 12 colour ones) while a photographed shadow is as black
    as the frame gets."""
    return float(np.percentile(y, BLACK_PERCENTILE))


def luma_percentiles(y: np.ndarray, mask: np.ndarray, percentiles=PERCENTILES) -> dict[str, float]:
    """{"p5": p5 / p50, ...}: masked luma percentiles over the masked median (NaN if it is 0)."""
    values = y[mask]
    if values.size == 0:
        raise ValueError("luma_percentiles: the mask is empty")
    median = float(np.median(values))
    ps = np.percentile(values, percentiles)
    return {f"p{p}": (float(v) / median if median > 0 else float("nan")) for p, v in zip(percentiles, ps)}


def ground_tiles(y: np.ndarray, mask: np.ndarray, tile: int = TILE_PX) -> np.ndarray:
    """(n, tile, tile) float64: the non-overlapping tiles of a regular grid (anchored at the
    mask's bounding box) that lie wholly inside `mask`."""
    rows, cols = np.nonzero(mask)
    if rows.size == 0:
        return np.zeros((0, tile, tile))
    out = []
    for r in range(rows.min(), rows.max() - tile + 2, tile):
        for c in range(cols.min(), cols.max() - tile + 2, tile):
            if mask[r : r + tile, c : c + tile].all():
                out.append(y[r : r + tile, c : c + tile])
    return np.array(out).reshape(-1, tile, tile)


def remove_planes(tiles: np.ndarray) -> np.ndarray:
    """(n, t, t) tiles less each one's least-squares plane a + b·row + c·col. A steep spectrum's
    strongest, lowest frequencies leak through the window into the lowest bins and steepen the
    fitted slope (−3.15 for β = 3 over 0.02-0.2 cycles/px with the mean alone removed); the
    plane carries most of them."""
    n, t, _ = tiles.shape
    rows, cols = np.mgrid[:t, :t]
    design = np.stack([np.ones(t * t), rows.ravel() - (t - 1) / 2, cols.ravel() - (t - 1) / 2], axis=1)
    flat = tiles.reshape(n, t * t).T
    coefficients = np.linalg.lstsq(design, flat, rcond=None)[0]
    return (flat - design @ coefficients).T.reshape(n, t, t)


def contrast_periodogram(tiles: np.ndarray, reference_mean: float) -> np.ndarray:
    """(n, t, t) → (t, t) mean periodogram of the tiles' luma contrast, (y − the tile's plane,
    see remove_planes) / `reference_mean` (the whole ground's mean, not the tile's: a tile in deep shadow has a mean
    near 0 and would blow its own contrast up), Hann-windowed and normalised so that its sum is
    the contrast variance (Parseval, window power divided out). Frequencies as
    np.fft.fftfreq(t). No tiles or a reference mean ≤ 0 give an all-NaN array."""
    n, t, _ = tiles.shape
    if n == 0 or not reference_mean > 0:
        return np.full((t, t), np.nan)
    window = np.outer(np.hanning(t), np.hanning(t))
    contrast = remove_planes(tiles) / reference_mean
    spectra = np.abs(np.fft.fft2(contrast * window)) ** 2
    return spectra.mean(axis=0) / (t**4 * np.mean(window**2))


def radial_frequency(t: int) -> np.ndarray:
    """(t, t) |f| in cycles per pixel of a t × t FFT."""
    f = np.fft.fftfreq(t)
    return np.hypot(f[:, None], f[None, :])


def radial_power(periodogram: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Radially averaged periodogram: (f, P) with f = k / t cycles per pixel for k = 1 .. t/2 and
    P the mean over the annulus |f| ∈ [(k − ½)/t, (k + ½)/t)."""
    t = periodogram.shape[0]
    ring = np.rint(radial_frequency(t) * t).astype(int)
    ks = np.arange(1, t // 2 + 1)
    power = np.array([periodogram[ring == k].mean() for k in ks])
    return ks / t, power


def spectrum_slope(periodogram: np.ndarray, band: tuple[float, float] = SPECTRUM_BAND) -> float:
    """The exponent s of P(f) ∝ f^s fitted by least squares to log P against log f over the
    radial bins with f in `band` (cycles per pixel); NaN without two positive bins."""
    f, p = radial_power(periodogram)
    keep = (f >= band[0]) & (f <= band[1]) & (p > 0) & np.isfinite(p)
    if keep.sum() < 2:
        return float("nan")
    return float(np.polyfit(np.log(f[keep]), np.log(p[keep]), 1)[0])


def octave_bands(octaves: int = OCTAVES) -> list[tuple[float, float]]:
    """[(low, high)] cycles per pixel, finest first: [0.25, 0.5), [0.125, 0.25), ..."""
    return [(0.5 / 2 ** (k + 1), 0.5 / 2**k) for k in range(octaves)]


def octave_rms_contrast(periodogram: np.ndarray, octaves: int = OCTAVES) -> list[float]:
    """RMS luma contrast in each octave band of `octave_bands` (finest first): the square root
    of the periodogram's sum over |f| in the band (the finest band ends at 0.5 inclusive, so
    the axes' Nyquist bins count; the corners beyond do not)."""
    radius = radial_frequency(periodogram.shape[0])
    out = []
    for k, (low, high) in enumerate(octave_bands(octaves)):
        inside = (radius >= low) & ((radius <= high) if k == 0 else (radius < high))
        out.append(float(np.sqrt(periodogram[inside].sum())))
    return out


def fine_to_coarse(octaves: list[float]) -> float:
    """Granularity: the RMS contrast of the two finest octaves over that of the two coarsest
    (quadrature sums; NaN without coarse contrast). Grainy, pebble-strewn ground is high; smooth
    dunes with broad shading are low."""
    fine = math.hypot(octaves[0], octaves[1])
    coarse = math.hypot(octaves[-2], octaves[-1])
    return fine / coarse if coarse > 0 else float("nan")


def laplacian_contrast(y: np.ndarray, mask: np.ndarray) -> float:
    """RMS of the 5-point Laplacian of `y` over masked pixels whose four neighbours are masked,
    divided by the mean of `y` over the same pixels (NaN when none or the mean is 0)."""
    core = mask.copy()
    core[0, :] = core[-1, :] = core[:, 0] = core[:, -1] = False
    core[1:-1, 1:-1] &= mask[:-2, 1:-1] & mask[2:, 1:-1] & mask[1:-1, :-2] & mask[1:-1, 2:]
    if not core.any():
        return float("nan")
    lap = np.zeros_like(y)
    lap[1:-1, 1:-1] = y[:-2, 1:-1] + y[2:, 1:-1] + y[1:-1, :-2] + y[1:-1, 2:] - 4.0 * y[1:-1, 1:-1]
    mean = float(y[core].mean())
    return float(np.sqrt(np.mean(lap[core] ** 2)) / mean) if mean > 0 else float("nan")


@dataclass(frozen=True)
class Blobs:
    """Small dark connected blobs in a ground mask at the analysis scale: `diameters_px` (n,)
    float64 area-equivalent diameters 2·sqrt(area/π) in analysis pixels, `ground_px` the mask's
    pixel count, `covered_px` the pixels of the kept blobs."""

    diameters_px: np.ndarray
    ground_px: int
    covered_px: int


def masked_gaussian(y: np.ndarray, mask: np.ndarray, sigma_px: float) -> np.ndarray:
    """Gaussian mean of `y` over masked pixels only (normalised convolution); NaN far from any."""
    weight = ndimage.gaussian_filter(mask.astype(np.float64), sigma_px, mode="constant")
    total = ndimage.gaussian_filter(np.where(mask, y, 0.0), sigma_px, mode="constant")
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(weight > 1e-6, total / weight, np.nan)


def dark_blobs(
    y: np.ndarray,
    mask: np.ndarray,
    px_per_deg: float,
    darkness: float = BLOB_DARKNESS,
    background_sigma_deg: float = BLOB_BACKGROUND_SIGMA_DEG,
    min_area_px: int = BLOB_MIN_AREA_PX,
    max_diameter_deg: float = BLOB_MAX_DIAMETER_DEG,
) -> Blobs:
    """The dark blobs of `y` in `mask` (see the module's definition): 8-connected pixels below
    `darkness` × their local background, kept if not touching the mask's edge or the image's,
    at least `min_area_px`, and at most `max_diameter_deg` across (area-equivalent)."""
    background = masked_gaussian(y, mask, background_sigma_deg * px_per_deg)
    dark = mask & (y < darkness * np.nan_to_num(background, nan=0.0))
    labels, count = ndimage.label(dark, structure=np.ones((3, 3), bool))
    if count == 0:
        return Blobs(np.zeros(0), int(mask.sum()), 0)
    areas = np.bincount(labels.ravel(), minlength=count + 1)
    # A blob touching outside the mask (or the image border) is cut: its size is unknown.
    outside = np.pad(~mask, 1, constant_values=True)
    touching_outside = ndimage.binary_dilation(outside, structure=np.ones((3, 3), bool))[1:-1, 1:-1]
    cut = np.zeros(count + 1, bool)
    cut[np.unique(labels[touching_outside & dark])] = True
    diameters = 2.0 * np.sqrt(areas / math.pi)
    keep = (~cut) & (areas >= min_area_px) & (diameters <= max_diameter_deg * px_per_deg)
    keep[0] = False
    return Blobs(diameters[keep].astype(np.float64), int(mask.sum()), int(areas[keep].sum()))


BLOB_SIZE_EDGES_DEG = (0.1, 0.2, 0.4, 0.8)  # octaves of blob diameter for the size distribution


def blob_statistics(blobs: Blobs, px_per_deg: float) -> dict:
    """Blobs per square degree of ground, the fraction of ground they cover, quantiles of their
    diameters (degrees) and their count per square degree in diameter octaves (degrees)."""
    ground_deg2 = blobs.ground_px / px_per_deg**2
    d = blobs.diameters_px / px_per_deg
    quantiles = {f"d{q}_deg": (float(np.percentile(d, q)) if d.size else float("nan")) for q in (25, 50, 75, 90)}
    edges = (0.0,) + BLOB_SIZE_EDGES_DEG + (math.inf,)
    per_octave = {
        f"{lo:g}-{hi:g}_deg": float(((d >= lo) & (d < hi)).sum() / ground_deg2) for lo, hi in zip(edges[:-1], edges[1:])
    }
    return {
        "blobs_per_deg2": float(d.size / ground_deg2),
        "blob_cover_fraction": blobs.covered_px / blobs.ground_px,
        **quantiles,
        "blobs_per_deg2_by_diameter": per_octave,
    }


@dataclass(frozen=True)
class Measured:
    """One image's statistics (`stats`, see image_statistics) and the arrays behind them: `luma`
    (H, W) at the analysis scale, `ground` its mask, `tone_free_luma` (H, W) tone_free(luma,
    ground.mask), which the tone-free statistics, patches and sheet crops all read."""

    stats: dict
    luma: np.ndarray
    ground: GroundMask
    tone_free_luma: np.ndarray


def measure(
    rgb8: np.ndarray,
    hfov_deg: float,
    px_per_deg: float,
    roi: RegionOfInterest = RegionOfInterest(),
    tile_px: int = TILE_PX,
) -> Measured:
    """The one code path for photos and renders: 8-bit sRGB (H, W, 3) whose width spans
    `hfov_deg` → luma at `px_per_deg` → ground mask in `roi` → every statistic. Raises
    ValueError when the ground mask is empty."""
    y = to_analysis_scale(luma(rgb8), hfov_deg, px_per_deg)
    ground = ground_mask(y, px_per_deg, roi)
    if not ground.mask.any():
        raise ValueError("no ground pixels: the region of interest is all sky, horizon or reseau")
    free = tone_free(y, ground.mask)
    stats = image_statistics(y, ground.mask, px_per_deg, tile_px, black_level(y), free)
    return Measured(stats, y, ground, free)


def image_statistics(
    y: np.ndarray,
    mask: np.ndarray,
    px_per_deg: float,
    tile_px: int = TILE_PX,
    black: float = 0.0,
    free: np.ndarray | None = None,
) -> dict:
    """Every statistic of the module's list for luma `y` (H, W) at `px_per_deg` over `mask`;
    `black` is the frame's black level (shadow_fraction_black_corrected). `tone_free` holds the
    spatial statistics again, of `free`: tone_free(y, mask), computed here when None."""
    if free is None:
        free = tone_free(y, mask)
    return {
        "ground_px": int(mask.sum()),
        "ground_deg2": float(mask.sum() / px_per_deg**2),
        "shadow_fraction": shadow_fraction(y, mask),
        "black_level": black,
        "shadow_fraction_black_corrected": shadow_fraction(y, mask, black=black),
        "luma_median": float(np.median(y[mask])),
        "luma_percentiles_over_median": luma_percentiles(y, mask),
        **spatial_statistics(y, mask, px_per_deg, tile_px),
        "tone_free": spatial_statistics(free, mask, px_per_deg, tile_px),
    }


def spatial_statistics(y: np.ndarray, mask: np.ndarray, px_per_deg: float, tile_px: int = TILE_PX) -> dict:
    """The statistics of how luma `y` (H, W) at `px_per_deg` is arranged over `mask`: the count
    of spectrum tiles, spectrum slope, octave contrasts, fine/coarse, Laplacian and dark blobs."""
    tiles = ground_tiles(y, mask, tile_px)
    periodogram = contrast_periodogram(tiles, float(y[mask].mean()))
    octaves = octave_rms_contrast(periodogram)
    return {
        "tiles": int(len(tiles)),
        "spectrum_slope": spectrum_slope(periodogram),
        "octave_rms_contrast": {
            f"{lo * px_per_deg:.3g}-{hi * px_per_deg:.3g}_cyc_per_deg": v
            for (lo, hi), v in zip(octave_bands(), octaves)
        },
        "fine_to_coarse_contrast": fine_to_coarse(octaves),
        "laplacian_contrast": laplacian_contrast(y, mask),
        **blob_statistics(dark_blobs(y, mask, px_per_deg), px_per_deg),
    }


TONE_FREE_SIGMA = 0.35  # log-luma spread of a tone-free image: between the renders' (≈0.25) and the photos' (≈0.45)


def tone_free(y: np.ndarray, mask: np.ndarray, sigma: float = TONE_FREE_SIGMA) -> np.ndarray:
    """Luma `y` (H, W) with its tone curve taken out: each pixel of `mask` becomes exp(σ·z),
    z = Φ⁻¹((r − ½)/n) its normal score (r its rank among the n ground pixels, tied pixels sharing
    their mean rank); off the mask 1, the ground's median. Every strictly increasing curve applied
    to `y` gives the same result, so statistics of it compare only how brightness is arranged, not
    the film's or the tone map's curve. σ fixes the spread alike for every image."""
    out = np.ones_like(y, dtype=np.float64)
    ranks = rankdata(y[mask])
    out[mask] = np.exp(sigma * ndtri((ranks - 0.5) / ranks.size))
    return out


def flatten(stats: dict, prefix: str = "") -> dict[str, float]:
    """{"a.b": value} for the numeric leaves of nested `stats` (comparison tables and tests)."""
    out = {}
    for key, value in stats.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(flatten(value, name + "."))
        elif isinstance(value, (int, float)) and not isinstance(value, bool):
            out[name] = float(value)
    return out


# ----------------------------------------------------------------------------------------------
# Patches and a classifier two-sample test

PATCH_PX = 32
PATCH_MIN_MEDIAN = 0.02  # luma; patches darker than this (≈ code 5) are skipped
PATCH_FEATURES = (
    "log_contrast",
    "p10_over_median",
    "p90_over_median",
    "dark_fraction",
    "log_laplacian",
    "log_fine_octave",
    "log_mid_octave",
    "log_coarse_octave",
)


def patch_features(y: np.ndarray, mask: np.ndarray, patch_px: int = PATCH_PX) -> np.ndarray:
    """(n, len(PATCH_FEATURES)) float64, one row per `ground_tiles` patch of `patch_px` whose
    median luma is at least PATCH_MIN_MEDIAN: log(std/mean), p10/p50, p90/p50, the fraction below half the median,
    log(Laplacian RMS/mean), and the log RMS contrast of the patch's three finest octaves."""
    patches = ground_tiles(y, mask, patch_px)
    rows = []
    window = np.outer(np.hanning(patch_px), np.hanning(patch_px))
    radius = radial_frequency(patch_px)
    bands = octave_bands(3)
    tiny = 1e-6
    for p in patches:
        mean = p.mean()
        median = np.median(p)
        if median < PATCH_MIN_MEDIAN:  # near-black: crushed shadow has no measurable texture
            continue
        q10, q90 = np.percentile(p, (10, 90))
        lap = p[:-2, 1:-1] + p[2:, 1:-1] + p[1:-1, :-2] + p[1:-1, 2:] - 4.0 * p[1:-1, 1:-1]
        spectrum = np.abs(np.fft.fft2((p - mean) / mean * window)) ** 2 / (patch_px**4 * np.mean(window**2))
        octave = [
            np.sqrt(spectrum[(radius >= lo) & (radius <= hi if k == 0 else radius < hi)].sum())
            for k, (lo, hi) in enumerate(bands)
        ]
        rows.append(
            [
                np.log(p.std() / mean + tiny),
                q10 / median,
                q90 / median,
                np.mean(p < 0.5 * median),
                np.log(np.sqrt(np.mean(lap**2)) / mean + tiny),
            ]
            + [np.log(o + tiny) for o in octave]
        )
    return np.array(rows, dtype=np.float64).reshape(-1, len(PATCH_FEATURES))


def fit_logistic(x: np.ndarray, labels: np.ndarray, l2: float = 1e-2, iterations: int = 50) -> np.ndarray:
    """Weights (k + 1,) (bias last) of L2-regularised logistic regression by Newton's method on
    standardised features `x` (n, k) and 0/1 `labels` (n,)."""
    design = np.hstack([x, np.ones((len(x), 1))])
    w = np.zeros(design.shape[1])
    penalty = l2 * np.eye(design.shape[1])
    penalty[-1, -1] = 0.0
    for _ in range(iterations):
        p = 1.0 / (1.0 + np.exp(-design @ w))
        gradient = design.T @ (p - labels) + penalty @ w
        hessian = design.T @ (design * (p * (1 - p))[:, None]) + penalty
        step = np.linalg.solve(hessian + 1e-9 * np.eye(len(w)), gradient)
        w -= step
        if np.max(np.abs(step)) < 1e-10:
            break
    return w


def two_sample_accuracy(a: np.ndarray, b: np.ndarray, folds: int = 5, seed: int = 0, max_per_class: int = 2000) -> dict:
    """How well logistic regression tells rows of `a` (n_a, k) from rows of `b` (n_b, k):
    classes balanced by drawing min(n_a, n_b, max_per_class) rows of each (seeded), `folds`-fold
    cross-validated accuracy (0.5 = indistinguishable, 1 = fully separated) on features
    standardised by the training folds; the standardised weights of a fit on all rows; and each
    feature's own cross-validated accuracy."""
    rng = np.random.default_rng(seed)
    n = min(len(a), len(b), max_per_class)
    if n < folds:
        raise ValueError(f"two-sample test: need at least {folds} rows in each class, got {len(a)} and {len(b)}")
    x = np.vstack([a[rng.choice(len(a), n, replace=False)], b[rng.choice(len(b), n, replace=False)]])
    labels = np.concatenate([np.zeros(n), np.ones(n)])
    fold_of = np.concatenate([rng.permutation(n) % folds, rng.permutation(n) % folds])

    def cross_validated(columns: list[int]) -> float:
        correct = 0
        for k in range(folds):
            train, test = fold_of != k, fold_of == k
            mu, sd = x[train][:, columns].mean(axis=0), x[train][:, columns].std(axis=0) + 1e-12
            w = fit_logistic((x[train][:, columns] - mu) / sd, labels[train])
            z = np.hstack([(x[test][:, columns] - mu) / sd, np.ones((test.sum(), 1))]) @ w
            correct += int(np.sum((z > 0) == (labels[test] > 0.5)))
        return correct / len(labels)

    mu, sd = x.mean(axis=0), x.std(axis=0) + 1e-12
    weights = fit_logistic((x - mu) / sd, labels)
    k = x.shape[1]
    return {
        "patches_per_class": n,
        "folds": folds,
        "accuracy": cross_validated(list(range(k))),
        "weights": weights[:-1].tolist(),
        "single_feature_accuracy": [cross_validated([j]) for j in range(k)],
    }


# ----------------------------------------------------------------------------------------------
# The reference photos' table

SOURCES_COLUMNS = ("file", "approx_sun_elevation_deg")
_ELEVATION = re.compile(r"^\s*~?\s*(\d+(?:\.\d+)?)\s*(?:-\s*(\d+(?:\.\d+)?))?")


def parse_elevation_range(text: str) -> tuple[float, float]:
    """(low, high) degrees from a field starting "~a-b" or "~a" (anything after is a note)."""
    m = _ELEVATION.match(text)
    if not m:
        raise ValueError(f"expected a Sun elevation like '~14-15' or '~12', got {text!r}")
    low = float(m.group(1))
    high = float(m.group(2)) if m.group(2) else low
    if high < low:
        raise ValueError(f"Sun elevation range {text!r}: the high end is below the low end")
    return low, high


@dataclass(frozen=True)
class PhotoSource:
    """One reference photo: its `path`, its Sun elevation (`sun_low_deg`, `sun_high_deg`), what
    SOURCES.csv says it shows (`what`)."""

    path: Path
    sun_low_deg: float
    sun_high_deg: float
    what: str

    @property
    def sun_mid_deg(self) -> float:
        return 0.5 * (self.sun_low_deg + self.sun_high_deg)


def read_sources(directory: Path) -> list[PhotoSource]:
    """The photos listed in `directory`/SOURCES.csv (columns `file` and
    `approx_sun_elevation_deg`, optionally `what_it_shows`; a header row first), in file order.
    Errors name the file and line: a missing column, an unparsable elevation, a missing photo."""
    path = Path(directory) / "SOURCES.csv"
    if not path.is_file():
        raise ValueError(f"{path}: not found (the photo directory needs a SOURCES.csv)")
    with path.open(newline="", encoding="utf-8") as f:
        rows = list(csv.reader(f))
    if not rows:
        raise ValueError(f"{path}: empty")
    header = [h.strip() for h in rows[0]]
    missing = [c for c in SOURCES_COLUMNS if c not in header]
    if missing:
        raise ValueError(f"{path}: line 1: missing column(s) {', '.join(missing)}")
    file_col, sun_col = header.index("file"), header.index("approx_sun_elevation_deg")
    what_col = header.index("what_it_shows") if "what_it_shows" in header else None
    out = []
    for line, row in enumerate(rows[1:], start=2):
        if not any(cell.strip() for cell in row):
            continue
        if len(row) <= max(file_col, sun_col):
            raise ValueError(f"{path}: line {line}: too few fields")
        photo = Path(directory) / row[file_col].strip()
        if not photo.is_file():
            raise ValueError(f"{path}: line {line}: photo {photo.name} not found in {directory}")
        try:
            low, high = parse_elevation_range(row[sun_col])
        except ValueError as e:
            raise ValueError(f"{path}: line {line}: approx_sun_elevation_deg: {e}") from None
        what = row[what_col].strip() if what_col is not None and what_col < len(row) else ""
        out.append(PhotoSource(photo, low, high, what))
    return out


def read_regions(path: Path) -> dict[str, RegionOfInterest]:
    """{photo file name: region} from a CSV with columns file, x0, y0, x1, y1 (fractions of the
    frame; lines starting with # are comments). Errors name the file and line."""
    regions = {}
    lines = Path(path).read_text(encoding="utf-8").splitlines()
    rows = [(n, line) for n, line in enumerate(lines, start=1) if line.strip() and not line.lstrip().startswith("#")]
    if not rows or [c.strip() for c in rows[0][1].split(",")][:5] != ["file", "x0", "y0", "x1", "y1"]:
        raise ValueError(f"{path}: expected a header 'file,x0,y0,x1,y1'")
    for n, line in rows[1:]:
        cells = [c.strip() for c in line.split(",")]
        if len(cells) < 5:
            raise ValueError(f"{path}: line {n}: expected file,x0,y0,x1,y1")
        try:
            regions[cells[0]] = RegionOfInterest(*(float(c) for c in cells[1:5]))
        except ValueError as e:
            raise ValueError(f"{path}: line {n}: {e}") from None
    return regions
