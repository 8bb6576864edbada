"""The procedural lunar locations (paper 3.1, 4.2.1): height functions composed from the
terrain's parts, meshed on one graded grid that is 1 cm fine around the bags and reaches the
horizon, with the Moon's curvature.

- `flat`, a mare plain: fractal regolith relief following a measured law of RMS slope against
  baseline (`roughness.py`: 3.0° at 17 m, 4.0° at 1 m, 6.3° at 1 cm), small craters from the
  equilibrium size-frequency distribution down to 5 cm, and rocks down to 1 cm (`rocks.py`).
- `hilly`: the plain on rolling hills, a second fBm of highland character (H 0.95, Rosenburg
  et al. 2011) with `hills_rms_slope_deg` over a 25 m baseline, so the ground under the bags
  slopes and the skyline changes as the camera orbits.
- `crater`: the plain beside a fresh simple crater (`craters.crater_profile`, its ejecta cut off
  at 2.5 R) whose centre lies `crater_distance_m` from the target; rocks cluster toward it
  (`rocks.py`).
- `dem`: a real site: a `LocalDem` (`moonbot terrain import`) around `dem_site_m`, seen in the
  site's own East-North-Up frame (`DemRelief`: its true north, its up; recorded as a `DemSite`),
  interpolated smoothly and refined below its pixel by the plain's roughness and the small
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
from dataclasses import dataclass

import numpy as np

from moonbot import _core
from moonbot.config.schema import LOCATIONS, TerrainConfig
from moonbot.terrain.craters import CraterField, crater_profile, profile_table
from moonbot.terrain.dem import LocalDem
from moonbot.terrain.ground import GridGround, graded_axis
from moonbot.terrain.roughness import Roughness, SlopeLaw, slope_law

LUNAR_RADIUS_M = float(_core.LUNAR_RADIUS)
CRATER_CELLS = 5  # a crater is kept where its diameter spans at least this many grid cells
CRATER_REACH = 60.0  # craters of diameter D are sampled within 60·D (~10 pixels across there)
# The craters the mesh cannot draw are shaded out to 200·D, where one spans about 4 pixels of the
# default 640-pixel camera (its shadow 1–2): further out it is the photometry's unresolved roughness.
SUBGRID_CRATER_REACH = 200.0
HILLS_BASELINE_M = 25.0  # the baseline of hills_rms_slope_deg (LOLA's shortest slope maps)
HILLS_HURST = 0.95  # LOLA highlands median (Rosenburg et al. 2011)
# A DEM resolves wavelengths down to about two pixels (Nyquist) and craters down to about five
# pixels across; the dem location adds roughness and craters below those.
DEM_ROUGHNESS_PIXELS = 2.0
DEM_CRATER_PIXELS = 5.0
# The world height of a DEM surface point is found by fixed-point iteration (DemRelief.world_up):
# it stops once no height moves by more than this many metres, and gives up after so many steps.
DEM_CONVERGED_M = 1e-9
DEM_MAX_STEPS = 30


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


def enu_axes(lat_deg: float, lon_deg: float) -> np.ndarray:
    """(3, 3) float64 whose rows are the unit East, North and Up vectors at (lat, lon) in the
    Moon's body-fixed frame (x toward 0° N 0° E, z toward the north pole): on a sphere, the axes
    of GeographicLib's LocalCartesian and so of `_core.LunarFrame`. At a pole, North points along
    the meridian `lon_deg` (GeographicLib's convention there)."""
    p, q = math.radians(lat_deg), math.radians(lon_deg)
    return np.array(
        [
            [-math.sin(q), math.cos(q), 0.0],
            [-math.sin(p) * math.cos(q), -math.sin(p) * math.sin(q), math.cos(p)],
            [math.cos(p) * math.cos(q), math.cos(p) * math.sin(q), math.sin(p)],
        ]
    )


@dataclass(frozen=True)
class DemSite:
    """Where a `dem` location's world frame lies on the Moon: its origin is the DEM's surface at
    (lat_deg, lon_deg), height_m above the 1737.4 km sphere, and its axes are that point's own
    East, North and Up, so every azimuth (the Sun's, the Earth's, the orbit's) is measured from
    the site's true north. north_in_dem_deg is the direction of that north in the DEM's grid,
    degrees clockwise from the grid's north (the DEM origin's North): the turn about the
    vertical between the DEM's axes and the world's, which the meridians' convergence makes
    −58.8° for a site 5 km east of a DEM origin at 89.9° N and 0 on the origin's meridian."""

    lat_deg: float
    lon_deg: float
    height_m: float
    north_in_dem_deg: float

    def as_json(self) -> dict[str, float]:
        """The record gt.json and the BOP scene files carry (JSON numbers, degrees and metres)."""
        return {
            "lat_deg": self.lat_deg,
            "lon_deg": self.lon_deg,
            "height_m": self.height_m,
            "north_in_dem_deg": self.north_in_dem_deg,
        }


class DemRelief:
    """A `LocalDem` as a smooth height function in a work site's own frame (metres).

    The site is `site_m` (east, north of the DEM's origin, in the DEM's grid) snapped to the
    nearest DEM node. The world frame is the site's East-North-Up with its origin on the DEM's
    surface there (`site`). The DEM's grid is the ENU frame of the DEM's origin, which a site
    kilometres away sees turned about the vertical (the meridians converge: −58.8° at 89.9° N
    5 km out, 0.012° at 10° N 2 km east) and tilted by d/R. Both are Cartesian frames of the same
    body, so one rigid motion maps DEM points to the world (`rotation` turns DEM-frame vectors
    into world vectors; the site's surface point is the world origin). The world height at
    (x, y) is the world up of the DEM surface point whose world east and north are (x, y), found
    by fixed-point iteration: each step shrinks the error by about (terrain slope) × d/R.

    A node's surface point: curved import (the default) east, north and up as stored; flat
    import (`curvature=False`) h0 + the stored height above the sphere on the radial through the
    tangent-plane point (east, north, 0). Between nodes the DEM is interpolated Catmull-Rom
    bicubic in its grid (`grid_height`): C1 (no creases at pixel edges for the Sun to pick out),
    equal to the DEM at its nodes, exact for planes and quadratics. The float64 arithmetic stays
    relative to the site node, so it is as precise kilometres out as at the origin.
    """

    def __init__(self, dem: LocalDem, site_m: tuple[float, float], name: str = "DEM") -> None:
        self.name = name
        self.spacing = dem.spacing_m
        self.heights = dem.heights
        self.curvature = dem.curvature
        self.dem_radius = LUNAR_RADIUS_M + dem.h0_m  # the DEM origin's distance from the Moon's centre
        ny, nx = self.heights.shape
        self.i0 = int(round(site_m[0] / self.spacing + (nx - 1) / 2))
        self.j0 = int(round(site_m[1] / self.spacing + (ny - 1) / 2))
        if not (1 <= self.i0 <= nx - 3 and 1 <= self.j0 <= ny - 3):
            raise ValueError(
                f"terrain.dem_site_m: ({site_m[0]:g}, {site_m[1]:g}) m lies outside {name}, which reaches "
                f"±{(nx - 1) / 2 * self.spacing:g} m east and ±{(ny - 1) / 2 * self.spacing:g} m north of its origin"
            )
        self.site_m = ((self.i0 - (nx - 1) / 2) * self.spacing, (self.j0 - (ny - 1) / 2) * self.spacing)
        self.site_height = float(self.heights[self.j0, self.i0])
        # A bicubic read needs one node beyond its cell on each side.
        self.reach_m = {
            "west": (self.i0 - 1) * self.spacing,
            "east": (nx - 2 - self.i0) * self.spacing,
            "south": (self.j0 - 1) * self.spacing,
            "north": (ny - 2 - self.j0) * self.spacing,
        }
        # The site's surface point in the DEM frame (metres from the DEM origin), and where it is.
        self.origin = self._surface_point(np.zeros(1), np.zeros(1), np.full(1, self.site_height))[:, 0]
        lat, lon, h = _core.LunarFrame(dem.lat_deg, dem.lon_deg, dem.h0_m).to_geodetic(*self.origin)
        self.rotation = enu_axes(lat, lon) @ enu_axes(dem.lat_deg, dem.lon_deg).T
        north = self.rotation[1]  # the site's North in DEM-frame components
        self.site = DemSite(
            lat_deg=lat, lon_deg=lon, height_m=h, north_in_dem_deg=math.degrees(math.atan2(north[0], north[1]))
        )
        self.site_radius = LUNAR_RADIUS_M + h

    def _surface_point(self, u: np.ndarray, v: np.ndarray, h: np.ndarray) -> np.ndarray:
        """(3, N) DEM-frame positions (metres from the DEM origin) of the surface where the grid,
        at offsets (u, v) metres from the site node, holds height h."""
        e, n = self.site_m[0] + u, self.site_m[1] + v
        if self.curvature:
            return np.stack([e, n, h])
        rho = self.dem_radius
        w = np.sqrt(e * e + n * n + rho * rho)
        # (ρ + h)·(e, n, ρ)/w − (0, 0, ρ), its up written without cancellation: ρ·(h − (w − ρ))/w.
        return np.stack([e * (rho + h) / w, n * (rho + h) / w, rho * (h - (e * e + n * n) / (w + rho)) / w])

    def _offset_from_site(self, u: np.ndarray, v: np.ndarray, h: np.ndarray) -> np.ndarray:
        """(3, N) DEM-frame vectors from the site's surface point to the surface point of grid
        offsets (u, v) holding height h; kept small where the import allows (curved: exactly)."""
        if self.curvature:
            return np.stack([u, v, h - self.site_height])
        return self._surface_point(u, v, h) - self.origin[:, None]

    def _grid_offsets(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Grid offsets (u, v) metres from the site node of the DEM node position under the
        DEM-frame points `p` ((3, N), metres from the site's surface point): straight down the
        DEM's up (curved import) or along the radial (flat import)."""
        if self.curvature:
            return p[0], p[1]
        x, y, z = (p[k] + self.origin[k] for k in range(3))
        scale = self.dem_radius / (z + self.dem_radius)
        return x * scale - self.site_m[0], y * scale - self.site_m[1]

    def grid_height(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """The DEM's stored height (metres, float64, shaped like u) interpolated at grid offsets
        (u, v) metres east and north of the site node, in the DEM's own grid."""
        tu, tv = np.asarray(u, dtype=np.float64) / self.spacing, np.asarray(v, dtype=np.float64) / self.spacing
        ku, kv = np.floor(tu), np.floor(tv)
        wu, wv = _catmull_rom(tu - ku), _catmull_rom(tv - kv)
        i = self.i0 + ku.astype(np.int64)
        j = self.j0 + kv.astype(np.int64)
        ny, nx = self.heights.shape
        if i.size and (i.min() < 1 or i.max() > nx - 3 or j.min() < 1 or j.max() > ny - 3):
            raise ValueError(
                f"terrain.extent_m: the terrain needs {self.name} beyond its edge; import a larger "
                "--size-m or lower terrain.extent_m"
            )
        z = np.zeros(np.broadcast(tu, tv).shape)
        for b in range(4):
            row = np.zeros_like(z)
            for a in range(4):
                row += wu[a] * self.heights[j + (b - 1), i + (a - 1)]
            z += wv[b] * row
        return z

    def world_up(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """World up (metres, float64, shaped like x) of the DEM surface at world (x, y): the
        site's true ENU, curvature and all."""
        x, y = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
        shape, x, y = x.shape, x.ravel(), y.ravel()
        to_dem = self.rotation.T
        # Start on the sphere through the site: then only the relief is left to converge. Each
        # step works on the points that moved by more than the tolerance in the one before.
        z = -curvature_drop(np.hypot(x, y), self.site_radius)
        active = np.arange(z.size)
        for _ in range(DEM_MAX_STEPS):
            if active.size == 0:
                return z.reshape(shape)
            xa, ya = x[active], y[active]
            u, v = self._grid_offsets(to_dem @ np.stack([xa, ya, z[active]]))
            q = self.rotation[2] @ self._offset_from_site(u, v, self.grid_height(u, v))
            moved = np.abs(q - z[active]) > DEM_CONVERGED_M
            z[active] = q
            active = active[moved]
        raise ValueError(
            f"{self.name}: the surface under the terrain was not found in {DEM_MAX_STEPS} steps "
            "(a near-vertical cliff?)"
        )

    def height(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Relief (metres, float64, shaped like x) at world (x, y) before curvature, as `Location`
        composes it: the world up plus the sphere's drop about the site, which `build_location`
        takes off again when terrain.curvature is on."""
        x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
        return self.world_up(x, y) + curvature_drop(np.hypot(x, y))

    def require_covers(self, half_width_m: float) -> None:
        """Raises ValueError naming terrain.extent_m if the world square of `half_width_m` metres
        around the site needs DEM beyond its edges."""
        a = half_width_m
        x = np.array([-a, 0.0, a, -a, a, -a, 0.0, a])
        y = np.array([-a, -a, -a, 0.0, 0.0, a, a, a])
        u, v = self._grid_offsets(self.rotation.T @ np.stack([x, y, -curvature_drop(np.hypot(x, y), self.site_radius)]))
        # The relief moves a point along the site's up, which the DEM's grid sees tilted.
        tilt = math.hypot(self.rotation[2, 0], self.rotation[2, 1])
        slack = tilt * (float(np.ptp(self.heights)) + curvature_drop(np.array([a * math.sqrt(2)]))[0]) + 1e-6 * a
        need = {"west": -u.min() + slack, "east": u.max() + slack, "south": -v.min() + slack, "north": v.max() + slack}
        short = [side for side, reach in self.reach_m.items() if reach < need[side]]
        if short:
            sides = ", ".join(f"{self.reach_m[side]:.1f} m {side}" for side in short)
            needed = ", ".join(f"{need[side]:.1f} m" for side in short)
            raise ValueError(
                f"terrain.extent_m: the terrain reaches {half_width_m:g} m around the site "
                f"({self.site_m[0]:g} m E, {self.site_m[1]:g} m N of the DEM's origin) but {self.name} "
                f"reaches only {sides} of it, where the terrain needs {needed}; import a larger --size-m or "
                "lower terrain.extent_m"
            )


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
        self.dem = None
        if dem is not None:
            self.dem = DemRelief(dem, config.dem_site_m, name=config.dem_file)
            self.dem.require_covers(float(np.max(np.abs(axis))))
        self.roughness, self.hills = roughness_fields(config, dem)
        # Thinned to the craters the grid can draw where they lie.
        craters = crater_population(config, dem)
        self.craters = outside_site(config, craters.subset(drawable(axis, craters.centres, craters.diameters)))
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


def crater_population(config: TerrainConfig, dem: LocalDem | None = None) -> CraterField:
    """Every small crater a location samples, before its mesh keeps the ones it can draw: the
    equilibrium law over octave bands of diameter, band [d, 2d) over the square ±CRATER_REACH·d
    (at most the terrain's extent). The squares do not depend on the grid, so changing the grid's
    knobs changes how the same craters are drawn, not which craters exist. Under a DEM only
    craters below what it resolves: the DEM carries everything larger."""
    c = config.craters
    return CraterField.sample_graded(
        config.seed,
        density=c.density,
        d_min=c.min_diameter_m,
        d_max=largest_crater(config, dem),  # none if d_max <= d_min
        half_size=lambda d: min(CRATER_REACH * d, config.extent_m),
    )


def largest_crater(config: TerrainConfig, dem: LocalDem | None = None) -> float:
    """The largest small crater's diameter, metres: terrain.craters.max_diameter_m, and under a
    DEM no larger than DEM_CRATER_PIXELS of its pixels."""
    if dem is None:
        return config.craters.max_diameter_m
    return min(config.craters.max_diameter_m, DEM_CRATER_PIXELS * dem.spacing_m)


def outside_site(config: TerrainConfig, craters: CraterField) -> CraterField:
    """`craters` less those larger than terrain.craters.site_max_diameter_m whose bowl reaches
    the fine tile: a work site is chosen outside large craters (otherwise a low Sun can leave the
    whole site in a crater wall's shadow)."""
    reach = craters.diameters / 2.0 + config.detail_extent_m
    return craters.subset(
        (craters.diameters <= config.craters.site_max_diameter_m) | (np.hypot(*craters.centres.T) > reach)
    )


def roughness_fields(config: TerrainConfig, dem: LocalDem | None = None) -> tuple[Roughness | None, Roughness | None]:
    """The location's fractal fields: the regolith's roughness (None where a DEM resolves all of
    it) and, on `hilly`, the hills (else None)."""
    r = config.roughness
    roughness = hills = None
    # A DEM's location draws only the octaves below what the DEM resolves, the DEM being the rest;
    # they still follow the whole law (fitted up to max_wavelength_m).
    longest = math.inf if dem is None else DEM_ROUGHNESS_PIXELS * dem.spacing_m
    if longest > r.min_wavelength_m:
        roughness = Roughness(
            seed=config.seed,
            law=slope_law(r),
            min_wavelength_m=r.min_wavelength_m,
            max_wavelength_m=r.max_wavelength_m,
            longest_drawn_m=longest,
        )
    if config.location == "hilly":
        law = SlopeLaw(
            rms_slope_deg=config.hills_rms_slope_deg,
            baseline_m=HILLS_BASELINE_M,
            hurst_coarse=HILLS_HURST,
            hurst_fine=HILLS_HURST,
            break_m=HILLS_BASELINE_M,
        )
        hills = Roughness(
            seed=config.seed + 1, law=law, min_wavelength_m=4.0, max_wavelength_m=config.hills_wavelength_m
        )
    return roughness, hills


@dataclass(frozen=True)
class SubgridRelief:
    """The roughness octaves of a location's fields (both, on `hilly`), with the graded grid its
    mesh was sampled on: the core's SubgridRelief (moonbot/subgrid_relief.h) shades, where a pixel
    reads it, the share of each octave that the mesh's local cell faded out (`Roughness.height`'s
    band limit). Octaves as `Roughness.drawn_octaves` gives them: wavelengths and amplitudes (K,)
    metres, angles (K,) radians, offsets (K, 2) lattice units, keys (K,) uint64; the grid's `axis`
    (n,) metres (along x and along y) and each node's cell `spacing` (n,) metres."""

    wavelengths: np.ndarray
    amplitudes: np.ndarray
    angles: np.ndarray
    offsets: np.ndarray
    keys: np.ndarray
    axis: np.ndarray
    spacing: np.ndarray


def subgrid_relief(config: TerrainConfig, dem: LocalDem | None = None) -> SubgridRelief | None:
    """What a procedural location's mesh leaves of its roughness for the shading; None where
    `terrain.roughness.subgrid_shading` is off or the location has no roughness field."""
    if not config.roughness.subgrid_shading:
        return None
    fields = [f for f in roughness_fields(config, dem) if f is not None]
    octaves = [f.drawn_octaves() for f in fields]
    if not octaves or not sum(len(o["wavelengths"]) for o in octaves):
        return None
    axis = location_axis(config)
    return SubgridRelief(
        **{name: np.concatenate([o[name] for o in octaves]) for name in octaves[0]},
        axis=axis,
        spacing=node_spacing(axis),
    )


@dataclass(frozen=True)
class SubgridCraters:
    """The small craters of a location that its mesh did not draw, for the core's SubgridCraters
    (moonbot/subgrid_craters.h), which shades their slopes and their walls' shadows: `centres`
    (K, 2) world metres, `diameters` (K,) metres, `degradation` (K,) σ/R, and craters.py's profile
    table (`craters.profile_table`)."""

    centres: np.ndarray
    diameters: np.ndarray
    degradation: np.ndarray
    table_degradation: np.ndarray
    radius_step: float
    table: np.ndarray
    table_reach: np.ndarray


def subgrid_craters(config: TerrainConfig, dem: LocalDem | None = None) -> SubgridCraters | None:
    """The craters a procedural location's graded mesh leaves out, for the shading: those of its
    population (`crater_population`) it cannot draw where they lie, and the same law's craters
    beyond its squares out to ±SUBGRID_CRATER_REACH·d (`CraterField.sample_graded_ring`), each a
    few pixels across there; those reaching the site are left out as the mesh leaves them.
    None where `terrain.craters.subgrid_shading` is off or none is left."""
    c = config.craters
    if not c.subgrid_shading:
        return None
    population = crater_population(config, dem)
    axis = location_axis(config)
    undrawn = population.subset(~drawable(axis, population.centres, population.diameters))
    beyond = CraterField.sample_graded_ring(
        config.seed,
        inner=lambda d: min(CRATER_REACH * d, config.extent_m),
        outer=lambda d: min(SUBGRID_CRATER_REACH * d, config.extent_m),
        density=c.density,
        d_min=c.min_diameter_m,
        d_max=largest_crater(config, dem),
    )
    craters = outside_site(config, CraterField.union([undrawn, beyond]))
    if not len(craters.diameters):
        return None
    return SubgridCraters(craters.centres, craters.diameters, craters.degradation, **profile_table())


def main_crater(config: TerrainConfig) -> tuple[np.ndarray, float] | None:
    """The crater location's crater: (centre (2,) world metres, rim diameter metres); None
    elsewhere."""
    if config.location != "crater":
        return None
    az = math.radians(config.crater_azimuth_deg)
    return config.crater_distance_m * np.array([math.sin(az), math.cos(az)]), config.crater_diameter_m


def dem_site(config: TerrainConfig, dem: LocalDem) -> DemSite:
    """Where the `dem` location of `config` puts its world frame on the Moon."""
    return DemRelief(dem, config.dem_site_m, name=config.dem_file).site


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
