"""Regolith relief from millimetres to hundreds of metres: a law of RMS slope against baseline
(`SlopeLaw`), the fractal height field that realises it on a mesh (`Roughness`), and the split of
the law between what a mesh resolves and what the photometric function's roughness θ̄ must carry.

**The law.** Roughness is reported scale by scale (Shepard et al. 2001, JGR 106:32777): the RMS
height difference ν(Δx) between points Δx apart grows as Δx^H (the deviogram), and the 1-D RMS
slope over that baseline is tan s(Δx) = ν(Δx)/Δx = tan s0·(Δx/x0)^(H−1). `SlopeLaw` is that power
law with one break: exponent `hurst_coarse` above `break_m`, `hurst_fine` below, anchored at
`rms_slope_deg` over `baseline_m`. The defaults (moonbot/config/default.yaml) take the anchor
from LOLA over the maria, a median bidirectional slope of 2.0° at 17 m (Rosenburg et al. 2011,
JGR 116, E02001, Table 2), i.e. 3.0° RMS for Gaussian slopes (median |tan| = 0.6745 RMS); the
fine exponent 0.65 from Apollo close-up stereo of undisturbed regolith, H = 0.54–0.7 at
sub-millimetre to centimetre scales (Helfenstein & Shepard 1999, Icarus 141:107, as reported by
Shepard et al. 2001); and the coarse exponent 0.9, between LOLA's maria (0.76) and highlands
(0.95) medians, where no measurement reaches (LOLA fits 57 m–2.7 km): it is set by the Apollo
surface photographs, which show ~5 % of the ground in shadow at a 7–18° Sun, and Smith's (1967)
shadowing function for a Gaussian surface, which allows a resolved RMS slope of only ~7° at 12°.
The law then gives 3.0° at 17 m, 4.0° at 1 m, 6.3° at 1 cm, and 29° at 0.1 mm, the scale
that sets Hapke's θ̄ (Hapke 2012, §12.2.4): θ̄ = 23.8° there, against the 23.4° fitted to LROC
WAC photometry (Sato et al. 2014, JGR Planets 119:1775).

**The field.** A sum of octaves of smooth value noise (quintic interpolation of hashed lattice
values), each octave a factor 2 finer than the last and rotated by its own angle so no lattice
direction shows. Octave k of wavelength λ_k and amplitude a_k adds a_k²·g(Δx/λ_k) to ν(Δx)²,
where g is value noise's own structure function (`value_noise_structure`, measured once). The
amplitudes are the non-negative least-squares fit of Σ a_k²·g(Δx/λ_k) to the law's ν(Δx)² at
baselines from the shortest octave to the longest, three per octave, in relative error: the
field follows the law itself rather than a λ^H guess, which value noise bends by ±0.1 in H.

**Band limiting.** Where a mesh samples the field with cells of size c, octaves shorter than 2c
cannot be represented and would alias; `height(..., cell=c)` fades them out between 4c and 2c.
The same point therefore has the same height in every mesh fine enough to hold all its octaves.

**Resolved and unresolved.** Slopes at well separated scales add in tan²: the law's total slope
at its smallest scale (`smallest_m`, ~0.1 mm) is the mesh's facet slope ⊕ the slope the mesh
cannot hold, and the latter is what Hapke's θ̄ must describe (`unresolved_theta_bar_deg`). Hapke's
slope distribution has a 1-D RMS slope of √(π/2)·tan θ̄ (Hapke 2012, §12.4).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache, cached_property

import numpy as np
from scipy.optimize import nnls

_GOLDEN = 0x9E3779B97F4A7C15
_MASK = (1 << 64) - 1
HAPKE_RMS_PER_TAN = math.sqrt(math.pi / 2.0)  # 1-D RMS slope of Hapke's distribution over tan θ̄
BASELINES_PER_OCTAVE = 3  # law points the octave amplitudes are fitted to
SMOOTHING = 0.3  # weight of the fit's penalty on neighbouring octaves' relative amplitudes
OCTAVE_TURN = 2.399963229728653  # octave k's lattice is turned k times the golden angle: lattices never line up


def _mix(h: np.ndarray) -> np.ndarray:
    """SplitMix64 finaliser on uint64 arrays: a bijective, well-mixed integer hash."""
    h = h ^ (h >> np.uint64(30))
    h = h * np.uint64(0xBF58476D1CE4E5B9)
    h = h ^ (h >> np.uint64(27))
    h = h * np.uint64(0x94D049BB133111EB)
    return h ^ (h >> np.uint64(31))


def lattice_key(seed: int, octave: int) -> int:
    """The 64-bit key of one octave's lattice values (the core's SubgridRelief takes it too)."""
    return (seed * _GOLDEN + (octave + 1) * 0xD1B54A32D192ED03) & _MASK


def _lattice(seed: int, octave: int, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Value in [-1, 1) at integer lattice points (i, j) of one octave (float64)."""
    key = np.uint64(lattice_key(seed, octave))
    h = _mix(key ^ _mix(i.astype(np.int64).view(np.uint64) * np.uint64(_GOLDEN) ^ j.astype(np.int64).view(np.uint64)))
    return (h >> np.uint64(11)).astype(np.float64) * (2.0 / 2.0**53) - 1.0


def value_noise(seed: int, octave: int, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Smooth value noise of unit lattice spacing at (u, v) (float64), C2 (quintic fade)."""
    i, j = np.floor(u), np.floor(v)
    fu, fv = u - i, v - j
    su = fu * fu * fu * (fu * (fu * 6 - 15) + 10)
    sv = fv * fv * fv * (fv * (fv * 6 - 15) + 10)
    i, j = i.astype(np.int64), j.astype(np.int64)
    a, b = _lattice(seed, octave, i, j), _lattice(seed, octave, i + 1, j)
    c, d = _lattice(seed, octave, i, j + 1), _lattice(seed, octave, i + 1, j + 1)
    return (a + su * (b - a)) + sv * ((c + su * (d - c)) - (a + su * (b - a)))


@dataclass(frozen=True)
class SlopeLaw:
    """1-D RMS slope against baseline: tan s(Δx) = tan s_b·(Δx/break_m)^(H−1), H = `hurst_coarse`
    for Δx ≥ `break_m` and `hurst_fine` below, continuous at the break and equal to
    `rms_slope_deg` at `baseline_m` (metres, degrees)."""

    rms_slope_deg: float
    baseline_m: float
    hurst_coarse: float
    hurst_fine: float
    break_m: float

    def __post_init__(self) -> None:
        if not 0 <= self.rms_slope_deg < 90:
            raise ValueError(f"rms_slope_deg: must be in [0, 90), got {self.rms_slope_deg}")
        for name in ("baseline_m", "break_m"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name}: must be > 0, got {getattr(self, name)}")
        for name in ("hurst_fine", "hurst_coarse"):
            if not 0 < getattr(self, name) < 1:
                raise ValueError(f"{name}: must be in (0, 1), got {getattr(self, name)}")

    def _exponent(self, baseline: np.ndarray) -> np.ndarray:
        return np.where(baseline >= self.break_m, self.hurst_coarse, self.hurst_fine) - 1.0

    def tan_slope(self, baseline: np.ndarray | float) -> np.ndarray:
        """tan of the 1-D RMS slope over `baseline` metres (float64, shaped like baseline)."""
        b = np.asarray(baseline, dtype=np.float64)
        anchor = np.float64(self.baseline_m)
        at_break = math.tan(math.radians(self.rms_slope_deg)) / (anchor / self.break_m) ** self._exponent(anchor)
        return at_break * (b / self.break_m) ** self._exponent(b)

    def slope_deg(self, baseline: np.ndarray | float) -> np.ndarray:
        """The 1-D RMS slope over `baseline` metres, degrees."""
        return np.degrees(np.arctan(self.tan_slope(baseline)))

    def deviation(self, baseline: np.ndarray | float) -> np.ndarray:
        """ν(Δx): RMS height difference (metres) between points `baseline` metres apart."""
        return self.tan_slope(baseline) * np.asarray(baseline, dtype=np.float64)


def slope_law(config) -> SlopeLaw:
    """The law of a `RoughnessConfig` (moonbot.config.schema)."""
    return SlopeLaw(
        rms_slope_deg=config.rms_slope_deg,
        baseline_m=config.baseline_m,
        hurst_coarse=config.hurst_coarse,
        hurst_fine=config.hurst_fine,
        break_m=config.break_m,
    )


def theta_bar_deg(tan_rms_slope: float) -> float:
    """Hapke's mean slope θ̄ (degrees) of a surface whose 1-D RMS slope has tangent `tan_rms_slope`."""
    return math.degrees(math.atan(tan_rms_slope / HAPKE_RMS_PER_TAN))


def unresolved_theta_bar_deg(law: SlopeLaw, smallest_m: float, resolved_tan: float) -> float:
    """θ̄ (degrees) of the relief a mesh leaves out: the law's total tan² at its smallest scale
    `smallest_m` less the mesh's resolved facet tan² (`resolved_tan`, tangent of the mesh's 1-D RMS
    facet slope). Raises ValueError if the mesh is rougher than the law's total."""
    total = float(law.tan_slope(smallest_m)) ** 2
    left = total - resolved_tan**2
    if left < 0:
        raise ValueError(
            f"roughness: the mesh's RMS slope {math.degrees(math.atan(resolved_tan)):.1f}° exceeds "
            f"the law's total {float(law.slope_deg(smallest_m)):.1f}° at {smallest_m} m"
        )
    return theta_bar_deg(math.sqrt(left))


@cache
def value_noise_structure() -> tuple[np.ndarray, np.ndarray]:
    """(lags u (K,), g(u) (K,)): the mean squared difference of unit `value_noise` between
    points u lattice spacings apart in a random direction, at u = 2^(i/3) for i = −15…6, measured
    once on 40 000 fixed point pairs (deterministic). Below u = 1/32 g grows as u² (the noise is
    smooth), above u = 4 it is flat (the lattice values are independent)."""
    rng = np.random.default_rng(20260101)
    p = rng.uniform(0.0, 1000.0, size=(40000, 2))
    phi = rng.uniform(0.0, 2.0 * math.pi, size=40000)
    direction = np.column_stack([np.cos(phi), np.sin(phi)])
    lags = 2.0 ** (np.arange(-15, 7) / 3.0)
    base = value_noise(0, 0, p[:, 0], p[:, 1])
    g = np.array([np.mean((value_noise(0, 0, *(p + u * direction).T) - base) ** 2) for u in lags])
    return lags, g


def _structure_at(u: np.ndarray) -> np.ndarray:
    """g(u) of `value_noise_structure` at any lags u > 0 (log-log interpolation, u² below the
    table, flat above)."""
    lags, g = value_noise_structure()
    u = np.asarray(u, dtype=np.float64)
    inside = np.exp(np.interp(np.log(u), np.log(lags), np.log(g)))
    return np.where(u < lags[0], g[0] * (u / lags[0]) ** 2, inside)


@dataclass(frozen=True)
class Roughness:
    """Band-limited fractal heights following `law` with octaves from `max_wavelength_m` down
    to `min_wavelength_m` (metres). Octaves longer than `longest_drawn_m` are fitted but left
    out of the heights: a DEM carries that relief itself."""

    seed: int
    law: SlopeLaw
    min_wavelength_m: float = 0.02
    max_wavelength_m: float = 512.0
    longest_drawn_m: float = math.inf

    def __post_init__(self) -> None:
        if not 0 < self.min_wavelength_m < self.max_wavelength_m:
            raise ValueError(f"min_wavelength_m: must be in (0, max_wavelength_m), got {self.min_wavelength_m}")

    @cached_property
    def wavelengths(self) -> np.ndarray:
        """Octave wavelengths (metres, float64), longest first, halving down to the minimum."""
        n = int(math.floor(math.log2(self.max_wavelength_m / self.min_wavelength_m))) + 1
        return self.max_wavelength_m / 2.0 ** np.arange(n)

    @cached_property
    def offsets(self) -> np.ndarray:
        """Each octave's lattice offset (K, 2) in lattice units, uniform in [0, 1)² from the seed.
        Value noise is not stationary (flat at its lattice nodes, steepest between them): a seeded
        offset puts the target at a random place in every octave's cell, so over seeds the near
        field sees the law itself."""
        return np.random.default_rng([self.seed, 0x0FF5E7]).random((len(self.wavelengths), 2))

    @cached_property
    def fit_baselines(self) -> np.ndarray:
        """The baselines (metres) the amplitudes are fitted at: from the shortest octave's
        wavelength to an eighth of the longest's, `BASELINES_PER_OCTAVE` per octave (longer
        baselines are not fitted: the octaves that would carry them are missing)."""
        n = len(self.wavelengths)
        b = self.wavelengths[-1] * 2.0 ** (np.arange(BASELINES_PER_OCTAVE * (n - 1) + 1) / BASELINES_PER_OCTAVE)
        return b[b <= max(self.wavelengths[0] / 8.0, self.wavelengths[-1])]

    @cached_property
    def amplitudes(self) -> np.ndarray:
        """Octave amplitudes (metres, like `wavelengths`): a_k² = c_k·ν(λ_k)², with c_k ≥ 0 the
        least-squares fit of the octaves' summed structure function to the law's ν² at
        `fit_baselines` in relative error, plus a penalty `SMOOTHING` on c_k − c_(k+1) (without it
        the fit trades neighbouring octaves against each other, leaving some empty)."""
        if self.law.rms_slope_deg == 0:
            return np.zeros(len(self.wavelengths))
        b = self.fit_baselines
        target = self.law.deviation(b) ** 2
        own = self.law.deviation(self.wavelengths) ** 2  # relative unknowns keep the system well scaled
        design = _structure_at(b[:, None] / self.wavelengths[None, :]) * own[None, :] / target[:, None]
        n = len(own)
        smooth = SMOOTHING * (np.eye(n - 1, n) - np.eye(n - 1, n, k=1))
        relative, _ = nnls(
            np.vstack([design, smooth]), np.concatenate([np.ones(len(b)), np.zeros(n - 1)]), maxiter=50 * n
        )
        return np.sqrt(relative * own)

    def structure(self, baseline: np.ndarray | float) -> np.ndarray:
        """ν(Δx) of the unlimited field (metres), from the octaves' amplitudes and g."""
        b = np.atleast_1d(np.asarray(baseline, dtype=np.float64))
        return np.sqrt(_structure_at(b[:, None] / self.wavelengths[None, :]) @ self.amplitudes**2).reshape(
            np.shape(baseline)
        )

    def _sum(self, x: np.ndarray, y: np.ndarray, cell: np.ndarray | None) -> np.ndarray:
        z = np.zeros(np.broadcast(x, y).shape)
        for k, (lam, amp) in enumerate(zip(self.wavelengths, self.amplitudes)):
            if amp == 0.0 or lam > self.longest_drawn_m:
                continue
            if cell is None:
                at, weight = slice(None), 1.0
            else:
                # Only the points whose mesh can hold this octave: on a graded mesh the fine
                # octaves touch a small near field, which keeps a horizon-wide build cheap.
                weight = np.clip(lam / (2.0 * cell) - 1.0, 0.0, 1.0)
                at = np.flatnonzero(weight > 0.0)
                if len(at) == 0:
                    continue
                weight = weight[at]
            angle = OCTAVE_TURN * k
            c, s = math.cos(angle), math.sin(angle)
            u = (c * x[at] + s * y[at]) / lam + self.offsets[k, 0]
            v = (-s * x[at] + c * y[at]) / lam + self.offsets[k, 1]
            z[at] += weight * amp * value_noise(self.seed, k, u, v)
        return z

    def drawn_octaves(self) -> dict[str, np.ndarray]:
        """The octaves `height` draws (a non-zero amplitude, no longer than `longest_drawn_m`),
        longest first, as the core's SubgridRelief takes them: wavelengths and amplitudes (K,)
        metres, angles (K,) radians, lattice offsets (K, 2), lattice keys (K,) uint64."""
        k = np.flatnonzero((self.amplitudes > 0.0) & (self.wavelengths <= self.longest_drawn_m))
        return {
            "wavelengths": self.wavelengths[k],
            "amplitudes": self.amplitudes[k],
            "angles": OCTAVE_TURN * k.astype(np.float64),
            "offsets": self.offsets[k],
            "keys": np.array([lattice_key(self.seed, int(i)) for i in k], dtype=np.uint64),
        }

    def height(self, x: np.ndarray, y: np.ndarray, cell: np.ndarray | float | None = None) -> np.ndarray:
        """Roughness height (metres, float64) at world (x, y); `cell` (metres, scalar or per
        point) band-limits it for a mesh of that spacing (None: every octave)."""
        x, y = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
        if cell is not None:
            cell = np.broadcast_to(np.asarray(cell, dtype=np.float64), x.shape).ravel()
        # Flat 1-D arrays: the hash's wrapping uint64 arithmetic is silent on arrays only.
        return self._sum(x.ravel(), y.ravel(), cell).reshape(x.shape)
