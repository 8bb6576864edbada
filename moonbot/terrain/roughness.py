"""Fractal regolith roughness: band-limited fractional Brownian motion as a continuous height
function z = f(x, y) (metres, world East-North-Up), deterministic from a seed.

A sum of octaves of smooth value noise (quintic interpolation of hashed lattice values), each
octave a factor 2 finer than the last and rotated by its own angle so no lattice direction shows.
An octave of wavelength λ has an amplitude ∝ λ^H, which gives a structure function
⟨(Δz)²⟩^½ ∝ baseline^H: the Hurst exponent H. Following lunar-physics.md §4.4, H is 0.9 above
1 m (LOLA, Rosenburg et al. 2011) and 0.6 below (Helfenstein & Shepard 1999), and the amplitude
is set so that the RMS slope over a `slope_baseline_m` baseline (1 cm by default) is
`rms_slope_deg` (~20° at 1 cm for lunar regolith).

Band limiting: where a mesh samples the field with cells of size c, octaves shorter than 2c
cannot be represented and would alias; `height(..., cell=c)` fades them out between 4c and 2c.
The same point therefore has the same height in every mesh fine enough to hold all its octaves.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

_GOLDEN = 0x9E3779B97F4A7C15
_MASK = (1 << 64) - 1


def _mix(h: np.ndarray) -> np.ndarray:
    """SplitMix64 finaliser on uint64 arrays: a bijective, well-mixed integer hash."""
    h = h ^ (h >> np.uint64(30))
    h = h * np.uint64(0xBF58476D1CE4E5B9)
    h = h ^ (h >> np.uint64(27))
    h = h * np.uint64(0x94D049BB133111EB)
    return h ^ (h >> np.uint64(31))


def _lattice(seed: int, octave: int, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Value in [-1, 1) at integer lattice points (i, j) of one octave (float64)."""
    key = np.uint64((seed * _GOLDEN + (octave + 1) * 0xD1B54A32D192ED03) & _MASK)
    h = _mix(key ^ _mix(i.astype(np.int64).view(np.uint64) * np.uint64(_GOLDEN)
                        ^ j.astype(np.int64).view(np.uint64)))
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
class Roughness:
    """Band-limited fBm heights. `max_wavelength_m` and `min_wavelength_m` bound the octaves;
    `break_m` is where the Hurst exponent changes from `hurst_fine` to `hurst_coarse`; the
    amplitude gives an RMS slope of `rms_slope_deg` over `slope_baseline_m`."""

    seed: int
    rms_slope_deg: float = 20.0
    hurst_fine: float = 0.6
    hurst_coarse: float = 0.9
    break_m: float = 1.0
    min_wavelength_m: float = 0.02
    max_wavelength_m: float = 512.0
    slope_baseline_m: float = 0.01

    def __post_init__(self) -> None:
        if not 0 < self.min_wavelength_m < self.max_wavelength_m:
            raise ValueError(f"min_wavelength_m: must be in (0, max_wavelength_m), got {self.min_wavelength_m}")
        if not self.slope_baseline_m > 0:
            raise ValueError(f"slope_baseline_m: must be > 0, got {self.slope_baseline_m}")
        if not 0 <= self.rms_slope_deg < 90:
            raise ValueError(f"rms_slope_deg: must be in [0, 90), got {self.rms_slope_deg}")
        for name in ("hurst_fine", "hurst_coarse"):
            if not 0 < getattr(self, name) < 1:
                raise ValueError(f"{name}: must be in (0, 1), got {getattr(self, name)}")

    @cached_property
    def wavelengths(self) -> np.ndarray:
        """Octave wavelengths (metres, float64), longest first, halving down to the minimum."""
        n = int(math.floor(math.log2(self.max_wavelength_m / self.min_wavelength_m))) + 1
        return self.max_wavelength_m / 2.0 ** np.arange(n)

    def _shape(self, wavelength: np.ndarray) -> np.ndarray:
        """Relative amplitude λ^H, continuous at the break."""
        lam = np.asarray(wavelength) / self.break_m
        return np.where(lam < 1.0, lam ** self.hurst_fine, lam ** self.hurst_coarse)

    def _raw(self, x: np.ndarray, y: np.ndarray, cell: np.ndarray | float | None) -> np.ndarray:
        z = np.zeros(np.broadcast(x, y).shape)
        for k, (lam, amp) in enumerate(zip(self.wavelengths, self._shape(self.wavelengths))):
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
            angle = 2.399963229728653 * k  # the golden angle: octave lattices never line up
            c, s = math.cos(angle), math.sin(angle)
            u = (c * x[at] + s * y[at]) / lam + 0.5 * k
            v = (-s * x[at] + c * y[at]) / lam + 0.25 * k
            z[at] += weight * amp * value_noise(self.seed, k, u, v)
        return z

    @cached_property
    def scale(self) -> float:
        """Metres per unit of the raw octave sum, so that the RMS slope over `slope_baseline_m`
        is `rms_slope_deg`; measured once on 20 000 fixed point pairs (the same for every seed's
        statistics, so deterministic)."""
        if self.rms_slope_deg == 0:
            return 0.0
        rng = np.random.default_rng(20260101)
        p = rng.uniform(-self.max_wavelength_m, self.max_wavelength_m, size=(20000, 2))
        phi = rng.uniform(0.0, 2 * math.pi, size=20000)
        base = self.slope_baseline_m
        q = p + base * np.column_stack([np.cos(phi), np.sin(phi)])
        dz = self._raw(q[:, 0], q[:, 1], None) - self._raw(p[:, 0], p[:, 1], None)
        return math.tan(math.radians(self.rms_slope_deg)) * base / float(np.sqrt(np.mean(dz * dz)))

    def height(self, x: np.ndarray, y: np.ndarray, cell: np.ndarray | float | None = None) -> np.ndarray:
        """Roughness height (metres, float64) at world (x, y); `cell` (metres, scalar or per
        point) band-limits it for a mesh of that spacing (None: every octave)."""
        x, y = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
        if cell is not None:
            cell = np.broadcast_to(np.asarray(cell, dtype=np.float64), x.shape).ravel()
        # Flat 1-D arrays: the hash's wrapping uint64 arithmetic is silent on arrays only.
        return (self.scale * self._raw(x.ravel(), y.ravel(), cell)).reshape(x.shape)
