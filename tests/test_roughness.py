"""Fractal roughness: deterministic from the seed, the stated RMS slope at 1 cm, the stated
Hurst exponents on either side of the break, and band limiting that only removes fine octaves."""

from __future__ import annotations

import math

import numpy as np
import pytest

from moonbot.terrain.roughness import Roughness

ROUGH = Roughness(seed=11)


def structure(r: Roughness, baseline: float, n: int = 40000) -> float:
    """RMS height difference (metres) between points `baseline` apart in random directions."""
    rng = np.random.default_rng(99)
    p = rng.uniform(-300, 300, size=(n, 2))
    phi = rng.uniform(0, 2 * math.pi, size=n)
    q = p + baseline * np.column_stack([np.cos(phi), np.sin(phi)])
    dz = r.height(q[:, 0], q[:, 1]) - r.height(p[:, 0], p[:, 1])
    return float(np.sqrt(np.mean(dz * dz)))


def test_same_seed_same_bytes_other_seed_other_terrain():
    x, y = np.meshgrid(np.linspace(-3, 3, 50), np.linspace(-3, 3, 50))
    a = ROUGH.height(x, y)
    np.testing.assert_array_equal(a, Roughness(seed=11).height(x, y))
    assert np.abs(a - Roughness(seed=12).height(x, y)).mean() > 0.01
    np.testing.assert_array_equal(ROUGH.height(np.float64(0.3), -0.2), ROUGH.height(np.array([0.3]), np.array([-0.2]))[0])


def test_rms_slope_at_one_centimetre_is_the_stated_one():
    for slope in (10.0, 20.0):
        r = Roughness(seed=5, rms_slope_deg=slope)
        measured = math.degrees(math.atan(structure(r, 0.01) / 0.01))
        assert measured == pytest.approx(slope, abs=1.0)
    assert np.all(Roughness(seed=5, rms_slope_deg=0.0).height([1.0, 2.0], [3.0, 4.0]) == 0.0)


@pytest.mark.parametrize(("lo", "hi"), [(0.06, 0.25), (8.0, 32.0)])
@pytest.mark.parametrize("h", [0.5, 0.8])
def test_hurst_exponent(lo, hi, h):
    """With one exponent on both sides of the break, the structure function grows as
    baseline^H within the octaves' band (value noise: within ±0.12)."""
    r = Roughness(seed=2, hurst_fine=h, hurst_coarse=h)
    measured = math.log(structure(r, hi) / structure(r, lo)) / math.log(hi / lo)
    assert measured == pytest.approx(h, abs=0.12)


def test_the_break_makes_small_scales_rougher_relative_to_large_ones():
    """Below the break the lower exponent keeps more relief at short baselines: relative to a
    uniform H = 0.9 field of the same large-scale relief, 10 cm differences are larger."""
    broken, uniform = Roughness(seed=2), Roughness(seed=2, hurst_fine=0.9)
    ratio = lambda r: structure(r, 0.1) / structure(r, 16.0)  # noqa: E731
    assert ratio(broken) > 1.2 * ratio(uniform)  # pure power laws: 2x; long octaves blur it


def test_band_limiting_removes_only_octaves_a_mesh_cannot_hold():
    x, y = np.meshgrid(np.linspace(5, 6, 40), np.linspace(-2, -1, 40))
    full = ROUGH.height(x, y)
    np.testing.assert_array_equal(ROUGH.height(x, y, cell=ROUGH.min_wavelength_m / 4), full)
    coarse = ROUGH.height(x, y, cell=1.0)  # keeps octaves of 4 m and longer
    unlimited_fine = Roughness(seed=11, min_wavelength_m=4.0, max_wavelength_m=512.0)
    np.testing.assert_allclose(coarse, unlimited_fine._raw(x.ravel(), y.ravel(), None).reshape(x.shape) * ROUGH.scale,
                               atol=1e-12)
    per_point = ROUGH.height(x, y, cell=np.where(x < 5.5, 1.0, ROUGH.min_wavelength_m / 4))
    np.testing.assert_array_equal(per_point[x < 5.5], coarse[x < 5.5])
    np.testing.assert_array_equal(per_point[x >= 5.5], full[x >= 5.5])


@pytest.mark.parametrize(("kwargs", "field"), [({"min_wavelength_m": 0.0}, "min_wavelength_m"),
                                               ({"rms_slope_deg": 90.0}, "rms_slope_deg"),
                                               ({"hurst_fine": 1.0}, "hurst_fine")])
def test_bad_parameters_name_the_field(kwargs, field):
    with pytest.raises(ValueError, match=f"^{field}: "):
        Roughness(seed=0, **kwargs)
