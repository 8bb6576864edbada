"""The procedural lunar locations (paper 3.1, 4.2.1): height functions composed from the
terrain's parts, meshed on one graded grid that is 1 cm fine around the bags and reaches the
horizon, with the Moon's curvature.

- `flat`, a mare plain: fractal regolith roughness (`Roughness`: H 0.6 below 1 m, 0.9 above,
  20° RMS slope at 1 cm) and small craters from the equilibrium size-frequency distribution.
- `hilly`: the plain on rolling hills, a second fBm of highland character (H 0.95, Rosenburg
  et al. 2011) with `hills_rms_slope_deg` over a 25 m baseline, so the ground under the bags
  slopes and the skyline changes as the camera orbits.
- `crater`: the plain beside a fresh simple crater (`craters.crater_profile`, its ejecta cut off
  at 2.5 R) whose centre lies `crater_distance_m` from the target; rocks cluster toward it
  (`rocks.py`).

**One graded grid, horizon to bags.** A single tensor grid (`graded_axis`) is uniform at
`detail_m` within ±`detail_extent_m` and its spacing then grows by `growth` per cell out to
±`extent_m`; the spacing at distance r is ≈ (growth − 1)·r, which tracks the footprint of a
pixel on ground seen at grazing angles. One grid has no seams and no T-junctions between
rings, and every feature is sampled consistently: each roughness octave and each crater is
kept only where the grid can hold it (octaves shorter than two cells fade out; craters are
kept where their diameter spans at least `CRATER_CELLS` cells, out of those sampled within
`CRATER_REACH`·D), so coarse far terrain never aliases. The price is long thin cells along the axes through the fine tile (1 cm × metres),
which are harmless to a height field and to the double-precision hit resolve.

**Curvature.** With `curvature: true` every node is lowered by the sphere's drop
R − √(R² − d²) (d its distance from the origin, R = 1737.4 km; the same expression as the core's
`curvature_drop`): 1.15 m at 2 km, which is what puts the horizon at ~1.9 km for a camera 1 m up.
"""

from __future__ import annotations

import math

import numpy as np

from moonbot import _core
from moonbot.config.schema import TerrainConfig
from moonbot.terrain.craters import CraterField, crater_profile
from moonbot.terrain.ground import GridGround, graded_axis
from moonbot.terrain.roughness import Roughness

LOCATIONS = ("flat", "hilly", "crater")
LUNAR_RADIUS_M = float(_core.LUNAR_RADIUS)
CRATER_CELLS = 6  # a crater is kept where its diameter spans at least this many grid cells
CRATER_REACH = 60.0  # craters of diameter D are sampled within 60·D (~10 pixels across there)
HILLS_BASELINE_M = 25.0  # the baseline of hills_rms_slope_deg (LOLA's shortest slope maps)


def curvature_drop(distance: np.ndarray, radius: float = LUNAR_RADIUS_M) -> np.ndarray:
    """R − √(R² − d²) in metres for horizontal distances d (metres, any shape, |d| ≤ R),
    written d² / (R + √(R² − d²)) so it keeps full relative precision at metre distances."""
    d = np.abs(np.asarray(distance, dtype=np.float64))
    return d * d / (radius + np.sqrt((radius - d) * (radius + d)))


def node_spacing(axis: np.ndarray) -> np.ndarray:
    """The coarser of the two cells beside each node of a sorted axis (metres, like axis)."""
    gaps = np.diff(axis)
    return np.maximum(np.concatenate([gaps[:1], gaps]), np.concatenate([gaps, gaps[-1:]]))


def drawable(axis: np.ndarray, centres: np.ndarray, diameters: np.ndarray) -> np.ndarray:
    """Which craters (centres (K, 2), diameters (K,) metres) span at least CRATER_CELLS cells
    of the grid `axis` at their centre: a boolean mask (K,)."""
    spacing = node_spacing(axis)
    cell = np.maximum(np.interp(centres[:, 0], axis, spacing), np.interp(centres[:, 1], axis, spacing))
    return diameters >= CRATER_CELLS * cell


class Location:
    """The height function of one procedural location (metres, world East-North-Up, origin at
    the target), deterministic from `config.seed`. `surface(x, y, cell)` is the relief before
    curvature, band-limited for a mesh of node spacing `cell`."""

    def __init__(self, config: TerrainConfig, axis: np.ndarray) -> None:
        if config.location not in LOCATIONS:
            raise ValueError(f"terrain.location: {config.location!r} is not a procedural location {LOCATIONS}")
        self.config = config
        seed = config.seed
        r = config.roughness
        self.roughness = Roughness(seed=seed, rms_slope_deg=r.rms_slope_deg, hurst_fine=r.hurst_fine,
                                   hurst_coarse=r.hurst_coarse, min_wavelength_m=r.min_wavelength_m,
                                   max_wavelength_m=r.max_wavelength_m)
        self.hills = None
        if config.location == "hilly":
            self.hills = Roughness(seed=seed + 1, rms_slope_deg=config.hills_rms_slope_deg, hurst_fine=0.95,
                                   hurst_coarse=0.95, min_wavelength_m=4.0,
                                   max_wavelength_m=config.hills_wavelength_m, slope_baseline_m=HILLS_BASELINE_M)
        c = config.craters
        # Sampled over squares that do not depend on the grid (so changing the grid's knobs
        # changes how the same craters are drawn, not which craters exist), then thinned to the
        # ones the grid can draw where they lie.
        craters = CraterField.sample_graded(
            seed, density=c.density, d_min=c.min_diameter_m, d_max=c.max_diameter_m,
            half_size=lambda d: min(CRATER_REACH * d, config.extent_m))
        craters = craters.subset(drawable(axis, craters.centres, craters.diameters))
        # A work site is chosen outside large craters: drop those whose bowl reaches the fine
        # tile (otherwise a low Sun can leave the whole site in a crater wall's shadow).
        reach = craters.diameters / 2.0 + config.detail_extent_m
        self.craters = craters.subset((craters.diameters <= c.site_max_diameter_m)
                                      | (np.hypot(*craters.centres.T) > reach))
        self.main_crater = main_crater(config)

    def surface(self, x: np.ndarray, y: np.ndarray, cell: np.ndarray) -> np.ndarray:
        """Relief z (metres, float64, shaped like x) at world (x, y), without curvature."""
        z = self.roughness.height(x, y, cell) + self.craters.height(x, y)
        if self.hills is not None:
            z += self.hills.height(x, y, cell)
        if self.main_crater is not None:
            centre, diameter = self.main_crater
            s = np.hypot(x - centre[0], y - centre[1]) / (diameter / 2.0)
            z += crater_profile(s, diameter)
        return z


def main_crater(config: TerrainConfig) -> tuple[np.ndarray, float] | None:
    """The crater location's crater: (centre (2,) world metres, rim diameter metres); None
    elsewhere."""
    if config.location != "crater":
        return None
    az = math.radians(config.crater_azimuth_deg)
    return config.crater_distance_m * np.array([math.sin(az), math.cos(az)]), config.crater_diameter_m


def location_axis(config: TerrainConfig) -> np.ndarray:
    """The grid coordinates (metres, float64) along x and along y of a location's mesh."""
    return graded_axis(config.extent_m, config.detail_extent_m, config.detail_m, config.growth)


def build_location(config: TerrainConfig) -> GridGround:
    """Samples the location on its graded grid: a `GridGround` whose mesh is what the renderer
    draws and whose heights placement and physics read. The ground at the origin is shifted to
    z = 0 so the target stands near the frame's origin whatever the relief."""
    axis = location_axis(config)
    location = Location(config, axis)
    X, Y = np.meshgrid(axis, axis, indexing="xy")
    spacing = node_spacing(axis)
    cell = np.maximum(spacing[None, :], spacing[:, None])
    z = location.surface(X, Y, cell)
    z -= location.surface(np.zeros(1), np.zeros(1), np.full(1, config.detail_m))[0]
    if config.curvature:
        z -= curvature_drop(np.hypot(X, Y))
    return GridGround(axis, axis, z)
