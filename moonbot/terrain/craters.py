"""Small craters for the procedural locations: a size-frequency distribution, and the height
they add to the ground (metres, world East-North-Up), deterministic from a seed.

Sizes follow the empirical equilibrium of small lunar craters, a cumulative density
N(≥D) = C·D^-2 per m² with D in metres and C = 0.079, Trask 1966's standard equilibrium
(docs/physics.md; fits range from 0.0336 on an Apollo 15 mare to ~0.08: Minton et al. 2019,
Xiao & Werner 2015). The D^-2 steady state holds from metres down to the 13 cm craters counted
at Surveyor 7, which follow the same standard curve (Shoemaker et al. 1969, JGR 74:6081; Moore,
Boyce & Hahn 1980 find it for 1–100 m, the production population being steeper, D^-2.8), so the
locations continue it down to 5 cm, the smallest crater five cells of the 1 cm tile can draw.
Centres are uniform (a Poisson process; craters may overlap, as on the saturated real surface).
Each crater has the simple-crater profile of `terrain.CraterGround` (depth 0.13·D, rim 0.036·D,
ejecta as (r/R)^-3, cut off at 2.5 R) when fresh, worn down by diffusion as below; a crater
changes nothing beyond its reach.

**Degradation.** Small lunar craters are worn down by topographic diffusion, ∂h/∂t = κ∇²h
(Soderblom 1970, JGR 75:2655; Fassett & Thomson 2014, JGR Planets 119:2255; Minton et al. 2019,
Icarus 326:63 find it is what sets the D^-2 equilibrium). Its solution is the fresh profile
convolved with a 2-D Gaussian of standard deviation σ = √(2κt): the rim rounds off first, the
walls flatten, the bowl fills, and the depth falls as the rim's short wavelengths decay before
the bowl's. Each crater's `degradation` is that diffusion length in crater radii, σ/R (0 =
fresh), and `crater_profile` is the fresh profile diffused by it (`diffuse_radial`, tabulated
once). In equilibrium the ages of the craters still visible are uniform up to the age at which
diffusion erases them, and κt grows linearly with age, so σ² is uniform on [0, `DIFFUSION_MAX`²]
(the erasing age is where the fit below puts it). DIFFUSION_MAX = 0.65 makes the population's mean rim-to-floor d/D 0.061,
the mean of the small craters measured in the Chang'E-4 1 cm Pancam DEM (Wu et al. 2021, EPSL
553:116666): a few fresh bowls (d/D 0.13, walls 27°), most shallow dimples — a fifth have a
wall steeper than 12.5° (σ/R < 0.3) and can hold a shadow under a 12.5° Sun.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cache

import numpy as np
from scipy.spatial import cKDTree

# Fresh simple crater proportions (docs/physics.md): depth and rim height over diameter,
# and the ejecta thickness law's exponent; `terrain.CraterGround` uses the same.
DEPTH_RATIO = 0.13
RIM_RATIO = 0.036
EJECTA_EXPONENT = 3.0
EJECTA_CUTOFF = 2.5  # in crater radii
DIFFUSION_MAX = 0.65  # largest diffusion length σ/R of the equilibrium population (see above)
RING_STREAM = 0x5B6C1D  # keys sample_graded_ring's random stream apart from sample_graded's
# The table `crater_profile` interpolates: source radii (crater radii) over the fresh profile's
# support, diffusion lengths from 0 to DIFFUSION_MAX, and output radii out to the largest reach.
_SOURCE_STEP = EJECTA_CUTOFF / 1000
_DIFFUSION_GRID = np.concatenate([[0.0], np.geomspace(0.01, DIFFUSION_MAX, 32)])
REACH_SIGMAS = 3.0  # a diffused crater's heights are cut off at EJECTA_CUTOFF + 3σ radii
_OUTPUT_STEP = 0.01
_OUTPUT_RADII = np.arange(0.0, EJECTA_CUTOFF + REACH_SIGMAS * DIFFUSION_MAX + 2 * _OUTPUT_STEP, _OUTPUT_STEP)


def fresh_profile(s: np.ndarray) -> np.ndarray:
    """Height over diameter at radial distance s = r/R of a fresh crater: a parabolic bowl of
    depth DEPTH_RATIO to the rim crest at s = 1 (RIM_RATIO high), ejecta (r/R)^-3 outside, shifted
    so it reaches exactly 0 at the cut-off EJECTA_CUTOFF and stays 0 beyond."""
    s = np.asarray(s, dtype=np.float64)
    floor = RIM_RATIO * EJECTA_CUTOFF**-EJECTA_EXPONENT  # ejecta height at the cut-off, removed
    inside = RIM_RATIO - floor - DEPTH_RATIO * (1.0 - s * s)
    outside = np.where(s < EJECTA_CUTOFF, RIM_RATIO * np.clip(s, 1.0, EJECTA_CUTOFF) ** -EJECTA_EXPONENT - floor, 0.0)
    return np.where(s < 1.0, inside, outside)


def diffuse_radial(values: np.ndarray, radii: np.ndarray, out_radii: np.ndarray, sigma: float) -> np.ndarray:
    """A radially symmetric field sampled at evenly spaced `radii` (from 0, zero beyond the last)
    convolved with a 2-D Gaussian of standard deviation `sigma` (same unit), at `out_radii`:
    h(r) = ∫ h0(r') (r'/σ²) exp(−(r²+r'²)/2σ²) I0(r r'/σ²) dr', the angular integral of the
    Gaussian done in closed form (trapezoidal rule in r'; i0e keeps it finite)."""
    from scipy.special import i0e

    weights = np.full(radii.size, radii[1] - radii[0])
    weights[[0, -1]] *= 0.5
    r, q = out_radii[:, None], radii[None, :]
    kernel = (q / sigma**2) * np.exp(-((r - q) ** 2) / (2.0 * sigma**2)) * i0e(r * q / sigma**2)
    return kernel @ (values * weights)


@cache
def _profile_table() -> np.ndarray:
    """(len(_DIFFUSION_GRID), len(_OUTPUT_RADII)) heights over diameter of the fresh profile
    diffused by each tabulated σ/R, each row shifted to 0 at its reach and 0 beyond it."""
    source = np.arange(0.0, EJECTA_CUTOFF + _SOURCE_STEP / 2, _SOURCE_STEP)
    fresh = fresh_profile(source)
    rows = []
    for sigma in _DIFFUSION_GRID:
        row = fresh_profile(_OUTPUT_RADII) if sigma == 0.0 else diffuse_radial(fresh, source, _OUTPUT_RADII, sigma)
        reach = EJECTA_CUTOFF + REACH_SIGMAS * sigma
        row = np.where(_OUTPUT_RADII < reach, row - np.interp(reach, _OUTPUT_RADII, row), 0.0)
        rows.append(row)
    table = np.array(rows)
    table.flags.writeable = False
    return table


def profile_table() -> dict:
    """`crater_profile`'s table as the core's SubgridCraters takes it: the diffusion lengths σ/R
    of its rows `table_degradation` (from 0), the step of its radii `radius_step` (crater radii,
    from 0), its heights over diameter `table` (rows × radii) and each row's reach `table_reach`
    (crater radii). Fresh craters (σ/R = 0) read row 0, the fresh profile sampled every
    radius_step, where `crater_profile` takes the exact parabola."""
    return {
        "table_degradation": _DIFFUSION_GRID,
        "radius_step": _OUTPUT_STEP,
        "table": _profile_table(),
        "table_reach": crater_reach(_DIFFUSION_GRID),
    }


def crater_reach(degradation: float | np.ndarray) -> float | np.ndarray:
    """Radius (in crater radii) beyond which a crater diffused by σ/R = `degradation` adds nothing."""
    return EJECTA_CUTOFF + REACH_SIGMAS * np.asarray(degradation, dtype=np.float64)


def crater_profile(s: np.ndarray, diameter: float | np.ndarray, degradation: float | np.ndarray = 0.0) -> np.ndarray:
    """Height (metres) at radial distance s = r/R from a crater's centre: the fresh profile
    (`fresh_profile` × diameter) diffused by σ/R = `degradation` in [0, DIFFUSION_MAX] (0 = fresh,
    exact), interpolated in the tabulated profiles (linear in σ and in s); 0 from the reach
    EJECTA_CUTOFF + 3σ on. Arguments broadcast."""
    s, diameter, degradation = np.broadcast_arrays(
        np.asarray(s, dtype=np.float64),
        np.asarray(diameter, dtype=np.float64),
        np.asarray(degradation, dtype=np.float64),
    )
    if np.any((degradation < 0.0) | (degradation > DIFFUSION_MAX)):
        raise ValueError(f"degradation: must be in [0, {DIFFUSION_MAX}], got {degradation.min()}..{degradation.max()}")
    if np.all(degradation == 0.0):
        return diameter * fresh_profile(s)
    table = _profile_table()
    row = np.clip(np.searchsorted(_DIFFUSION_GRID, degradation, side="right") - 1, 0, len(_DIFFUSION_GRID) - 2)
    w_row = (degradation - _DIFFUSION_GRID[row]) / (_DIFFUSION_GRID[row + 1] - _DIFFUSION_GRID[row])
    position = np.clip(s, 0.0, _OUTPUT_RADII[-1]) / _OUTPUT_STEP
    col = np.minimum(position.astype(np.int64), len(_OUTPUT_RADII) - 2)
    w_col = position - col
    low = table[row, col] * (1.0 - w_col) + table[row, col + 1] * w_col
    high = table[row + 1, col] * (1.0 - w_col) + table[row + 1, col + 1] * w_col
    height = low * (1.0 - w_row) + high * w_row
    return np.where(s < crater_reach(degradation), diameter * height, 0.0)


def depth_ratio(degradation: float | np.ndarray) -> np.ndarray:
    """Rim-crest-to-floor depth over diameter of craters diffused by σ/R = `degradation`
    (DEPTH_RATIO for a fresh one)."""
    degradation = np.atleast_1d(np.asarray(degradation, dtype=np.float64))
    s = _OUTPUT_RADII[None, :]
    heights = crater_profile(s, 1.0, degradation[:, None])
    return heights.max(axis=1) - heights[:, 0]


def sample_degradation(rng: np.random.Generator, count: int) -> np.ndarray:
    """σ/R of `count` craters of an equilibrium population: ages uniform, κt ∝ age, so σ² is
    uniform on [0, DIFFUSION_MAX²]."""
    return DIFFUSION_MAX * np.sqrt(rng.random(count))


def expected_count(half_size_m: float, density: float, lo: float, hi: float) -> float:
    """The mean number of craters with lo ≤ D < hi in the square ±half_size_m under
    N(≥D) = density·D^-2 per m²."""
    return density * (2.0 * half_size_m) ** 2 * (lo**-2.0 - hi**-2.0)


@dataclass(frozen=True)
class CraterField:
    """Craters with centres (K, 2) metres, diameters (K,) metres and degradation (K,) in
    σ/R in [0, DIFFUSION_MAX] (`crater_profile`); `height` adds up their profiles."""

    centres: np.ndarray
    diameters: np.ndarray
    degradation: np.ndarray

    @staticmethod
    def sample(
        seed: int | list[int], half_size_m: float, density: float = 0.079, d_min: float = 0.5, d_max: float = 50.0
    ) -> CraterField:
        """A Poisson sample over the square ±half_size_m with N(≥D) = density·D^-2 per m²,
        D in [d_min, d_max] (inverse-CDF sampling of the truncated power law)."""
        if not 0 < d_min < d_max:
            raise ValueError(f"d_min: must be in (0, d_max), got {d_min}")
        if not density >= 0:
            raise ValueError(f"density: must be >= 0, got {density}")
        rng = np.random.default_rng([*np.atleast_1d(seed).tolist(), 0xC7A7E5])
        area = (2.0 * half_size_m) ** 2
        a, b = d_min**-2.0, d_max**-2.0
        count = rng.poisson(density * area * (a - b))
        u = rng.random(count)
        diameters = (a - u * (a - b)) ** -0.5
        centres = rng.uniform(-half_size_m, half_size_m, size=(count, 2))
        degradation = sample_degradation(rng, count)
        return CraterField(centres, diameters, degradation)

    def subset(self, keep: np.ndarray) -> CraterField:
        """The craters selected by a boolean mask or index array."""
        return CraterField(self.centres[keep], self.diameters[keep], self.degradation[keep])

    @staticmethod
    def sample_graded(
        seed: int, half_size: Callable[[float], float], density: float = 0.079, d_min: float = 0.5, d_max: float = 200.0
    ) -> CraterField:
        """Craters for a mesh that coarsens away from the origin: diameters in octave bands
        [d, 2d) from d_min up to d_max, each band a Poisson sample (`sample`) over the square
        ±half_size(d) in which the mesh can still draw a crater of the band's smallest size.
        Within its square each band follows N(≥D) = density·D^-2 exactly; beyond it, craters too
        small for the mesh are left out rather than aliased."""
        parts = []
        lo, band = d_min, 0
        while lo < d_max:
            hi = min(2.0 * lo, d_max)
            half = half_size(lo)
            if half > 0.0:
                parts.append(CraterField.sample([seed, band], half, density, lo, hi))
            lo, band = hi, band + 1
        return CraterField.union(parts)

    @staticmethod
    def sample_graded_ring(
        seed: int,
        inner: Callable[[float], float],
        outer: Callable[[float], float],
        density: float = 0.079,
        d_min: float = 0.5,
        d_max: float = 200.0,
    ) -> CraterField:
        """The craters `sample_graded` with half_size `inner` leaves out, out to `outer`: for each
        of its octave bands [d, 2d), a Poisson sample over the square ±outer(d) (a stream of its
        own) less the craters inside the square ±inner(d). With `sample_graded`'s the union
        follows N(≥D) = density·D^-2 exactly over each band's outer square, as one Poisson
        process restricted to two disjoint regions."""
        parts = []
        lo, band = d_min, 0
        while lo < d_max:
            hi = min(2.0 * lo, d_max)
            near, far = inner(lo), outer(lo)
            if far > near:
                ring = CraterField.sample([seed, band, RING_STREAM], far, density, lo, hi)
                parts.append(ring.subset(np.max(np.abs(ring.centres), axis=1) > near))
            lo, band = hi, band + 1
        return CraterField.union(parts)

    @staticmethod
    def union(parts: list[CraterField]) -> CraterField:
        """The craters of every field in `parts`, in order."""
        if not parts:
            return CraterField(np.zeros((0, 2)), np.zeros(0), np.zeros(0))
        return CraterField(
            np.concatenate([p.centres for p in parts]),
            np.concatenate([p.diameters for p in parts]),
            np.concatenate([p.degradation for p in parts]),
        )

    def height(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Sum of all craters' profiles at world (x, y) (metres, float64, shaped like x)."""
        x, y = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
        points = np.column_stack([x.ravel(), y.ravel()])
        z = np.zeros(len(points))
        if len(self.diameters) == 0 or len(points) == 0:
            return z.reshape(x.shape)
        tree = cKDTree(points)
        reach = crater_reach(self.degradation) * self.diameters / 2.0
        for centre, diameter, degradation, r in zip(self.centres, self.diameters, self.degradation, reach):
            near = np.asarray(tree.query_ball_point(centre, r), dtype=np.int64)
            if len(near):
                s = np.linalg.norm(points[near] - centre, axis=1) / (diameter / 2.0)
                z[near] += crater_profile(s, diameter, degradation)
        return z.reshape(x.shape)
