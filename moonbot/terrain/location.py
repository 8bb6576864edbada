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
- `dem`: a real site: a `LocalDem` (`moonbot terrain import`) around `dem_site_m`, interpolated
  smoothly (`DemRelief`) and refined below its pixel by the plain's roughness and the small
  craters the DEM cannot resolve, so the near field shows no DEM facets.

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
from moonbot.terrain.dem import LocalDem
from moonbot.terrain.ground import GridGround, graded_axis
from moonbot.terrain.roughness import Roughness

LOCATIONS = ("flat", "hilly", "crater", "dem")
LUNAR_RADIUS_M = float(_core.LUNAR_RADIUS)
CRATER_CELLS = 6  # a crater is kept where its diameter spans at least this many grid cells
CRATER_REACH = 60.0  # craters of diameter D are sampled within 60·D (~10 pixels across there)
HILLS_BASELINE_M = 25.0  # the baseline of hills_rms_slope_deg (LOLA's shortest slope maps)
# A DEM resolves wavelengths down to about two pixels (Nyquist) and craters down to about five
# pixels across; the dem location adds roughness and craters below those.
DEM_ROUGHNESS_PIXELS = 2.0
DEM_CRATER_PIXELS = 5.0


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


class DemRelief:
    """A `LocalDem` as a smooth height function around a work site (metres, world East-North-Up
    with its origin at the site).

    The site is `site_m` (east, north of the DEM's origin) snapped to the nearest DEM node, so a
    world point's DEM index is that node's integer index plus x/spacing: the same world offset
    from any site does exactly the same arithmetic, and the float64 coordinates near the bags
    stay small whatever the site's distance from the DEM's origin.

    Heights are the DEM's with the Moon's curvature about the DEM's origin taken back out (a
    curved import lies d²/2R below its tangent plane); the location then applies curvature about
    the site, so `terrain.curvature` means the same for every location. Interpolation is
    Catmull-Rom bicubic: C1 (no creases at pixel edges for the Sun to pick out), equal to the DEM
    at its nodes, exact for planes and quadratics.
    """

    def __init__(self, dem: LocalDem, site_m: tuple[float, float], name: str = "DEM") -> None:
        self.name = name
        self.spacing = dem.spacing_m
        heights = dem.heights
        if dem.curvature:
            east, north = np.meshgrid(dem.east_m, dem.north_m, indexing="xy")
            distance, up = np.hypot(east, north), heights
            # The import's up is (h − h0) − drop(d, R + h) for a surface point at height h: solve
            # for h − h0 by fixed point; each step shrinks the error by drop/R (2 steps: < 1e-9 m
            # at 10 km).
            for _ in range(2):
                heights = up + curvature_drop(distance, LUNAR_RADIUS_M + dem.h0_m + heights)
        self.heights = heights
        ny, nx = heights.shape
        self.i0 = int(round(site_m[0] / self.spacing + (nx - 1) / 2))
        self.j0 = int(round(site_m[1] / self.spacing + (ny - 1) / 2))
        self.site_m = ((self.i0 - (nx - 1) / 2) * self.spacing, (self.j0 - (ny - 1) / 2) * self.spacing)
        # A bicubic read needs one node beyond its cell on each side.
        self.reach_m = {"west": (self.i0 - 1) * self.spacing, "east": (nx - 2 - self.i0) * self.spacing,
                        "south": (self.j0 - 1) * self.spacing, "north": (ny - 2 - self.j0) * self.spacing}

    def require_covers(self, half_width_m: float) -> None:
        """Raises ValueError naming terrain.extent_m if the square of `half_width_m` metres
        around the site leaves the DEM."""
        short = {side: reach for side, reach in self.reach_m.items() if reach < half_width_m}
        if short:
            sides = ", ".join(f"{reach:.1f} m {side}" for side, reach in short.items())
            raise ValueError(
                f"terrain.extent_m: the terrain reaches {half_width_m:g} m around the site "
                f"({self.site_m[0]:g} m E, {self.site_m[1]:g} m N of the DEM's origin) but {self.name} "
                f"reaches only {sides} of it; import a larger --size-m or lower terrain.extent_m")

    def height(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """DEM height (metres, float64, shaped like x) at world (x, y) metres from the site."""
        tx, ty = np.asarray(x, dtype=np.float64) / self.spacing, np.asarray(y, dtype=np.float64) / self.spacing
        kx, ky = np.floor(tx), np.floor(ty)
        wx, wy = _catmull_rom(tx - kx), _catmull_rom(ty - ky)
        i = self.i0 + kx.astype(np.int64)
        j = self.j0 + ky.astype(np.int64)
        z = np.zeros(np.broadcast(tx, ty).shape)
        for b in range(4):
            row = np.zeros_like(z)
            for a in range(4):
                row += wx[a] * self.heights[j + (b - 1), i + (a - 1)]
            z += wy[b] * row
        return z


def _catmull_rom(f: np.ndarray) -> tuple[np.ndarray, ...]:
    """The four Catmull-Rom weights of nodes −1, 0, 1, 2 at fraction f ∈ [0, 1) of a cell."""
    f2, f3 = f * f, f * f * f
    return ((-f3 + 2 * f2 - f) / 2, (3 * f3 - 5 * f2 + 2) / 2, (-3 * f3 + 4 * f2 + f) / 2, (f3 - f2) / 2)


class Location:
    """The height function of one location (metres, world East-North-Up, origin at the target),
    deterministic from `config.seed` (and, for `dem`, the DEM). `surface(x, y, cell)` is the
    relief before curvature, band-limited for a mesh of node spacing `cell`."""

    def __init__(self, config: TerrainConfig, axis: np.ndarray, dem: LocalDem | None = None) -> None:
        if config.location not in LOCATIONS:
            raise ValueError(f"terrain.location: {config.location!r} is not a procedural location {LOCATIONS}")
        if (config.location == "dem") != (dem is not None):
            raise ValueError("terrain.location: a DEM is given exactly when the location is dem")
        self.config = config
        seed = config.seed
        r = config.roughness
        c = config.craters
        max_wavelength, max_crater = r.max_wavelength_m, c.max_diameter_m
        self.dem = None
        if dem is not None:
            self.dem = DemRelief(dem, config.dem_site_m, name=config.dem_file)
            self.dem.require_covers(float(np.max(np.abs(axis))))
            # Detail only below what the DEM resolves: the DEM carries everything larger.
            max_wavelength = min(max_wavelength, DEM_ROUGHNESS_PIXELS * dem.spacing_m)
            max_crater = min(max_crater, DEM_CRATER_PIXELS * dem.spacing_m)
        self.roughness = None
        if max_wavelength > r.min_wavelength_m:
            self.roughness = Roughness(seed=seed, rms_slope_deg=r.rms_slope_deg, hurst_fine=r.hurst_fine,
                                       hurst_coarse=r.hurst_coarse, min_wavelength_m=r.min_wavelength_m,
                                       max_wavelength_m=max_wavelength)
        self.hills = None
        if config.location == "hilly":
            self.hills = Roughness(seed=seed + 1, rms_slope_deg=config.hills_rms_slope_deg, hurst_fine=0.95,
                                   hurst_coarse=0.95, min_wavelength_m=4.0,
                                   max_wavelength_m=config.hills_wavelength_m, slope_baseline_m=HILLS_BASELINE_M)
        # Sampled over squares that do not depend on the grid (so changing the grid's knobs
        # changes how the same craters are drawn, not which craters exist), then thinned to the
        # ones the grid can draw where they lie.
        craters = CraterField.sample_graded(
            seed, density=c.density, d_min=c.min_diameter_m, d_max=max_crater,  # none if d_max <= d_min
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
        z = self.craters.height(x, y)
        if self.roughness is not None:
            z += self.roughness.height(x, y, cell)
        if self.dem is not None:
            z += self.dem.height(x, y)
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


def build_location(config: TerrainConfig, dem: LocalDem | None = None) -> GridGround:
    """Samples the location on its graded grid: a `GridGround` whose mesh is what the renderer
    draws and whose heights placement and physics read. The ground at the origin is shifted to
    z = 0 so the target stands near the frame's origin whatever the relief. `dem` is the
    location's DEM (location `dem` only)."""
    axis = location_axis(config)
    location = Location(config, axis, dem)
    X, Y = np.meshgrid(axis, axis, indexing="xy")
    spacing = node_spacing(axis)
    cell = np.maximum(spacing[None, :], spacing[:, None])
    z = location.surface(X, Y, cell)
    z -= location.surface(np.zeros(1), np.zeros(1), np.full(1, config.detail_m))[0]
    if config.curvature:
        z -= curvature_drop(np.hypot(X, Y))
    return GridGround(axis, axis, z)
