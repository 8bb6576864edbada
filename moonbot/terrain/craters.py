"""Small craters for the procedural locations: a size-frequency distribution, and the height
they add to the ground (metres, world East-North-Up), deterministic from a seed.

Sizes follow the empirical equilibrium of small lunar craters, a cumulative density
N(≥D) = C·D^-2 per m² with D in metres and C ≈ 0.05 (lunar-physics.md §4.2: 0.0336 for an
Apollo 15 mare fit up to ~0.08; Trask 1966's standard equilibrium is 0.079; Minton et al. 2019,
Xiao & Werner 2015). The D^-2 steady state holds from metres down to the 13 cm craters counted
at Surveyor 7 (Shoemaker et al. 1969, JGR 74:6081; Moore, Boyce & Hahn 1980 find it for 1–100 m,
the production population being steeper, D^-2.8), so the locations continue it down to 5 cm,
the smallest crater five cells of the 1 cm tile can draw. Centres are uniform
(a Poisson process; craters may overlap, as on the saturated real surface). Each crater has
the simple-crater profile of `terrain.CraterGround` (depth 0.13·D, rim 0.036·D, ejecta as
(r/R)^-3), scaled by a degradation factor, and its ejecta is cut off at 2.5 R so that a crater
changes nothing beyond it.

**Degradation.** A population in equilibrium is mostly old craters: if a crater's depth decays
about exponentially with age (diffusive infill) and ages are uniform, depths are log-uniform.
The factor is log-uniform in [`DEGRADATION_MIN`, `DEGRADATION_MAX`], i.e. depth/diameter from
0.010 to 0.195: the freshest small craters at Pike's (1974) d/D ≈ 0.2, and a mean of 0.063, the
mean of the small craters measured in the Chang'E-4 1 cm Pancam DEM (0.061; Wu et al. 2021, EPSL
553:116666). Fewer than half are steep enough to hold a shadow at a 12° Sun.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

# Fresh simple crater proportions (lunar-physics.md §4.1): depth and rim height over diameter,
# and the ejecta thickness law's exponent; `terrain.CraterGround` uses the same.
DEPTH_RATIO = 0.13
RIM_RATIO = 0.036
EJECTA_EXPONENT = 3.0
EJECTA_CUTOFF = 2.5  # in crater radii
DEGRADATION_MIN, DEGRADATION_MAX = 0.08, 1.5  # log-uniform factor on the fresh profile's heights


def crater_profile(s: np.ndarray, diameter: float | np.ndarray, degradation: float | np.ndarray = 1.0) -> np.ndarray:
    """Height (metres) at radial distance s = r/R from a crater's centre: a parabolic bowl to
    the rim crest at s = 1, ejecta (r/R)^-3 outside, shifted so it reaches exactly 0 at the
    cut-off 2.5 R (and stays 0 beyond); scaled by `degradation`."""
    s = np.asarray(s, dtype=np.float64)
    depth, rim = DEPTH_RATIO * diameter, RIM_RATIO * diameter
    floor = rim * EJECTA_CUTOFF ** -EJECTA_EXPONENT  # ejecta height at the cut-off, removed
    inside = rim - floor - depth * (1.0 - s * s)
    outside = rim * np.clip(s, 1.0, EJECTA_CUTOFF) ** -EJECTA_EXPONENT - floor
    return degradation * np.where(s < 1.0, inside, outside)


def expected_count(half_size_m: float, density: float, lo: float, hi: float) -> float:
    """The mean number of craters with lo ≤ D < hi in the square ±half_size_m under
    N(≥D) = density·D^-2 per m²."""
    return density * (2.0 * half_size_m) ** 2 * (lo ** -2.0 - hi ** -2.0)


@dataclass(frozen=True)
class CraterField:
    """Craters with centres (K, 2) metres, diameters (K,) metres and degradation (K,) in
    [DEGRADATION_MIN, DEGRADATION_MAX]; `height` adds up their profiles."""

    centres: np.ndarray
    diameters: np.ndarray
    degradation: np.ndarray

    @staticmethod
    def sample(seed: int | list[int], half_size_m: float, density: float = 0.05, d_min: float = 0.5,
               d_max: float = 50.0) -> "CraterField":
        """A Poisson sample over the square ±half_size_m with N(≥D) = density·D^-2 per m²,
        D in [d_min, d_max] (inverse-CDF sampling of the truncated power law)."""
        if not 0 < d_min < d_max:
            raise ValueError(f"d_min: must be in (0, d_max), got {d_min}")
        if not density >= 0:
            raise ValueError(f"density: must be >= 0, got {density}")
        rng = np.random.default_rng([*np.atleast_1d(seed).tolist(), 0xC7A7E5])
        area = (2.0 * half_size_m) ** 2
        a, b = d_min ** -2.0, d_max ** -2.0
        count = rng.poisson(density * area * (a - b))
        u = rng.random(count)
        diameters = (a - u * (a - b)) ** -0.5
        centres = rng.uniform(-half_size_m, half_size_m, size=(count, 2))
        degradation = DEGRADATION_MIN * (DEGRADATION_MAX / DEGRADATION_MIN) ** rng.random(count)
        return CraterField(centres, diameters, degradation)

    def subset(self, keep: np.ndarray) -> "CraterField":
        """The craters selected by a boolean mask or index array."""
        return CraterField(self.centres[keep], self.diameters[keep], self.degradation[keep])

    @staticmethod
    def sample_graded(seed: int, half_size: Callable[[float], float], density: float = 0.05,
                      d_min: float = 0.5, d_max: float = 200.0) -> "CraterField":
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
        if not parts:
            return CraterField(np.zeros((0, 2)), np.zeros(0), np.zeros(0))
        return CraterField(np.concatenate([p.centres for p in parts]),
                           np.concatenate([p.diameters for p in parts]),
                           np.concatenate([p.degradation for p in parts]))

    def height(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Sum of all craters' profiles at world (x, y) (metres, float64, shaped like x)."""
        x, y = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
        points = np.column_stack([x.ravel(), y.ravel()])
        z = np.zeros(len(points))
        if len(self.diameters) == 0 or len(points) == 0:
            return z.reshape(x.shape)
        tree = cKDTree(points)
        reach = EJECTA_CUTOFF * self.diameters / 2.0
        for centre, diameter, degradation, r in zip(self.centres, self.diameters, self.degradation, reach):
            near = np.asarray(tree.query_ball_point(centre, r), dtype=np.int64)
            if len(near):
                s = np.linalg.norm(points[near] - centre, axis=1) / (diameter / 2.0)
                z[near] += crater_profile(s, diameter, degradation)
        return z.reshape(x.shape)
