"""How regolith's albedo varies over a site (docs/physics.md): by about ±20 % at
low spatial frequency (mature and immature soil, mare and highland material mixing), and by
+50–100 % on the fresh ejecta of a young crater.

The variation is a factor on `terrain.albedo` per terrain mesh vertex, which the core
interpolates across triangles: (1 + albedo_variation · n(x, y)) · (1 + ejecta_brightening · b),
with n a band-limited value noise in [−1, 1] (wavelengths 50–400 m, so nothing flickers at the
bags' scale) and b = 1 inside the crater location's crater, (r/R)⁻³ on its ejecta out to 2.5 R
(the same falloff as the ejecta's thickness) and 0 beyond. Deterministic from `terrain.seed`.
"""

from __future__ import annotations

import math

import numpy as np

from moonbot.config.schema import TerrainConfig
from moonbot.terrain.craters import EJECTA_CUTOFF
from moonbot.terrain.location import main_crater
from moonbot.terrain.roughness import value_noise

WAVELENGTHS_M = (400.0, 200.0, 100.0, 50.0)
_SEED_OFFSET = 0xA1BED0  # the albedo's noise is independent of the relief's


def albedo_factor(config: TerrainConfig, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The factor on the regolith albedo at world (x, y) metres (any shape): float32, > 0."""
    x, y = np.asarray(x, dtype=np.float64).ravel(), np.asarray(y, dtype=np.float64).ravel()
    n = np.zeros_like(x)
    weights = np.sqrt(np.asarray(WAVELENGTHS_M))  # more of the variation at long wavelengths
    for k, (lam, w) in enumerate(zip(WAVELENGTHS_M, weights)):
        angle = 1.1 + 2.399963229728653 * k  # rotated octaves: no lattice direction shows
        c, s = math.cos(angle), math.sin(angle)
        n += w * value_noise(config.seed + _SEED_OFFSET, k, (c * x + s * y) / lam, (-s * x + c * y) / lam)
    factor = 1.0 + config.albedo_variation * n / weights.sum()
    crater = main_crater(config)
    if crater is not None and config.ejecta_brightening > 0:
        centre, diameter = crater
        r = np.hypot(x - centre[0], y - centre[1]) / (diameter / 2.0)
        bright = np.where(r <= 1.0, 1.0, np.where(r <= EJECTA_CUTOFF, np.maximum(r, 1.0) ** -3.0, 0.0))
        factor *= 1.0 + config.ejecta_brightening * bright
    return factor.astype(np.float32)
