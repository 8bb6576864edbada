"""Regolith relief: the slope law's cited anchor and exponents, the fractal field following the
law scale by scale, determinism, band limiting that only removes fine octaves, and Hapke's θ̄ for
the relief a mesh leaves out."""

from __future__ import annotations

import math

import numpy as np
import pytest

from moonbot.terrain.roughness import (
    HAPKE_RMS_PER_TAN,
    Roughness,
    SlopeLaw,
    theta_bar_deg,
    unresolved_theta_bar_deg,
    value_noise_structure,
)

pytestmark = pytest.mark.unit

MARE = SlopeLaw(rms_slope_deg=3.0, baseline_m=17.0, hurst_coarse=0.9, hurst_fine=0.65, break_m=0.01)
ROUGH = Roughness(seed=11, law=MARE)


def structure(r: Roughness, baseline: float, seeds=(0,), n: int = 20000, span: float = 1000.0) -> float:
    """RMS height difference (metres) between points `baseline` apart in random directions at
    random places within ±span, pooled over fields of the given seeds."""
    squares = []
    for seed in seeds:
        field = Roughness(
            seed=seed, law=r.law, min_wavelength_m=r.min_wavelength_m, max_wavelength_m=r.max_wavelength_m
        )
        rng = np.random.default_rng(99)
        p = rng.uniform(-span, span, size=(n, 2))
        phi = rng.uniform(0, 2 * math.pi, size=n)
        q = p + baseline * np.column_stack([np.cos(phi), np.sin(phi)])
        dz = field.height(q[:, 0], q[:, 1]) - field.height(p[:, 0], p[:, 1])
        squares.append(np.mean(dz * dz))
    return float(np.sqrt(np.mean(squares)))


def test_the_law_passes_its_anchor_and_follows_its_exponents():
    assert float(MARE.slope_deg(17.0)) == pytest.approx(3.0, abs=1e-12)  # LOLA maria: 2.0° median = 3.0° RMS
    assert math.tan(math.radians(2.0)) / 0.6745 == pytest.approx(math.tan(math.radians(3.0)), rel=0.02)
    for lo, hi, h in [(0.1, 10.0, 0.9), (1e-4, 1e-3, 0.65)]:
        ratio = MARE.deviation(hi) / MARE.deviation(lo)
        assert math.log(ratio) / math.log(hi / lo) == pytest.approx(h, abs=1e-12)
    below, above = MARE.tan_slope(0.01 * (1 - 1e-12)), MARE.tan_slope(0.01)
    assert below == pytest.approx(above, rel=1e-9)  # continuous at the break
    # The numbers the docs quote: 4.0° at 1 m, 6.3° at 1 cm, 29° at 0.1 mm, θ̄ 23.8° there
    # against Sato et al.'s (2014) 23.4° from orbit.
    np.testing.assert_allclose(MARE.slope_deg([1.0, 0.01, 1e-4]), [3.98, 6.29, 28.93], atol=0.01)
    assert theta_bar_deg(float(MARE.tan_slope(1e-4))) == pytest.approx(23.4, abs=0.5)


def test_same_seed_same_bytes_other_seed_other_terrain():
    x, y = np.meshgrid(np.linspace(-3, 3, 50), np.linspace(-3, 3, 50))
    a = ROUGH.height(x, y)
    np.testing.assert_array_equal(a, Roughness(seed=11, law=MARE).height(x, y))
    assert np.abs(a - Roughness(seed=12, law=MARE).height(x, y)).mean() > 0.01
    np.testing.assert_array_equal(
        ROUGH.height(np.float64(0.3), -0.2), ROUGH.height(np.array([0.3]), np.array([-0.2]))[0]
    )
    assert np.all(Roughness(seed=5, law=SlopeLaw(0.0, 1.0, 0.9, 0.9, 1.0)).height([1.0, 2.0], [3.0, 4.0]) == 0.0)


def test_the_octaves_fit_the_law_from_the_shortest_octave_to_an_eighth_of_the_longest():
    b = np.geomspace(ROUGH.min_wavelength_m, ROUGH.max_wavelength_m / 8, 40)
    np.testing.assert_allclose(ROUGH.structure(b) / MARE.deviation(b), 1.0, atol=0.03)
    lags, g = value_noise_structure()  # value noise: smooth below a cell, independent beyond two
    assert g[-1] == pytest.approx(g[-4], rel=0.02)
    assert g[1] / g[0] == pytest.approx(2.0 ** (2 / 3), rel=0.02)


@pytest.mark.parametrize("baseline", [0.04, 0.16, 1.0, 4.0, 16.0])
def test_the_field_has_the_law_s_rms_slope_at_each_baseline(baseline):
    """Measured on the field itself over ±1 km and four seeds (the law is a statement about
    the ensemble: a few metres of one field see the long octaves as one tilt)."""
    measured = structure(ROUGH, baseline, seeds=(0, 1, 2, 3))
    assert measured / float(MARE.deviation(baseline)) == pytest.approx(1.0, abs=0.08)


def test_band_limiting_removes_only_octaves_a_mesh_cannot_hold():
    x, y = np.meshgrid(np.linspace(5, 6, 40), np.linspace(-2, -1, 40))
    full = ROUGH.height(x, y)
    np.testing.assert_array_equal(ROUGH.height(x, y, cell=ROUGH.min_wavelength_m / 4), full)
    coarse = ROUGH.height(x, y, cell=1.0)  # keeps octaves of 4 m and longer
    kept = ROUGH.wavelengths >= 4.0
    by_hand = np.zeros(x.size)
    for k in np.flatnonzero(kept):
        one = Roughness(seed=11, law=MARE)
        one.__dict__["amplitudes"] = np.where(np.arange(len(kept)) == k, ROUGH.amplitudes, 0.0)
        by_hand += one.height(x.ravel(), y.ravel())
    np.testing.assert_allclose(coarse.ravel(), by_hand, atol=1e-12)
    # Leaving out the octaves a DEM carries (longer than 3 m) leaves exactly the rest.
    below_dem = Roughness(seed=11, law=MARE, longest_drawn_m=3.0).height(x, y)
    np.testing.assert_allclose(full - below_dem, coarse, atol=1e-12)
    per_point = ROUGH.height(x, y, cell=np.where(x < 5.5, 1.0, ROUGH.min_wavelength_m / 4))
    np.testing.assert_array_equal(per_point[x < 5.5], coarse[x < 5.5])
    np.testing.assert_array_equal(per_point[x >= 5.5], full[x >= 5.5])


def test_theta_bar_of_the_relief_a_mesh_leaves_out():
    # Hapke's slope distribution has a 1-D RMS slope of sqrt(pi/2)·tan θ̄: 28.5° for 23.4°.
    assert math.degrees(math.atan(HAPKE_RMS_PER_TAN * math.tan(math.radians(23.4)))) == pytest.approx(28.5, abs=0.05)
    total = float(MARE.tan_slope(1e-4))
    assert unresolved_theta_bar_deg(MARE, 1e-4, 0.0) == pytest.approx(theta_bar_deg(total), abs=1e-12)
    resolved = math.tan(math.radians(5.5))
    left = math.tan(math.radians(unresolved_theta_bar_deg(MARE, 1e-4, resolved))) * HAPKE_RMS_PER_TAN
    assert left**2 + resolved**2 == pytest.approx(total**2, rel=1e-12)  # tan² adds up
    with pytest.raises(ValueError, match="^roughness: the mesh's RMS slope"):
        unresolved_theta_bar_deg(MARE, 1e-4, 1.0)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [({"rms_slope_deg": 90.0}, "rms_slope_deg"), ({"hurst_fine": 1.0}, "hurst_fine"), ({"break_m": 0.0}, "break_m")],
)
def test_bad_parameters_name_the_field(kwargs, field):
    with pytest.raises(ValueError, match=f"^{field}: "):
        SlopeLaw(
            **{
                "rms_slope_deg": 3.0,
                "baseline_m": 17.0,
                "hurst_coarse": 0.9,
                "hurst_fine": 0.65,
                "break_m": 0.01,
                **kwargs,
            }
        )
    with pytest.raises(ValueError, match="^min_wavelength_m: "):
        Roughness(seed=0, law=MARE, min_wavelength_m=0.0)
