"""Small craters: the size-frequency distribution within Poisson sampling error, the profile's
stated shape, its diffusion (against the heat equation's exact answer for a Gaussian), the
equilibrium population's mean d/D, and heights that add up each crater's profile within its
reach only."""

from __future__ import annotations

import math

import numpy as np
import pytest

from moonbot.terrain.craters import (
    DEPTH_RATIO,
    DIFFUSION_MAX,
    EJECTA_CUTOFF,
    RIM_RATIO,
    CraterField,
    crater_profile,
    crater_reach,
    depth_ratio,
    diffuse_radial,
    expected_count,
    fresh_profile,
    sample_degradation,
)

pytestmark = pytest.mark.unit


def test_sizes_follow_the_cumulative_power_law_within_sampling_error():
    half, density = 200.0, 0.05
    field = CraterField.sample(seed=4, half_size_m=half, density=density, d_min=0.5, d_max=50.0)
    assert field.diameters.min() >= 0.5 and field.diameters.max() <= 50.0
    assert (np.abs(field.centres) <= half).all()
    edges = [0.5, 0.7, 1.0, 2.0, 4.0, 50.0]
    for lo, hi in zip(edges[:-1], edges[1:]):
        n = int(((field.diameters >= lo) & (field.diameters < hi)).sum())
        mean = expected_count(half, density, lo, hi)
        assert abs(n - mean) <= 4.0 * np.sqrt(mean), (lo, hi, n, mean)  # Poisson: 4 sigma
    again = CraterField.sample(seed=4, half_size_m=half, density=density)
    np.testing.assert_array_equal(field.diameters, again.diameters)
    np.testing.assert_array_equal(field.centres, again.centres)
    other = CraterField.sample(seed=5, half_size_m=half, density=density)
    assert not np.array_equal(other.centres[:10], field.centres[:10])


def test_profile_shape():
    D = 10.0
    floor = RIM_RATIO * D * EJECTA_CUTOFF**-3
    assert crater_profile(0.0, D) == pytest.approx(RIM_RATIO * D - floor - DEPTH_RATIO * D)
    assert crater_profile(1.0, D) == pytest.approx(RIM_RATIO * D - floor)
    assert crater_profile(1.0 - 1e-12, D) == pytest.approx(crater_profile(1.0 + 1e-12, D), abs=1e-9)
    assert crater_profile(EJECTA_CUTOFF, D) == pytest.approx(0.0, abs=1e-15)
    assert crater_profile(7.0, D) == 0.0
    np.testing.assert_array_equal(crater_profile(np.linspace(0, 3, 7), D), D * fresh_profile(np.linspace(0, 3, 7)))


def test_radial_diffusion_of_a_gaussian_is_the_analytic_wider_gaussian():
    # A 2-D Gaussian bump of width a convolved with a Gaussian of sigma is a Gaussian of width
    # sqrt(a² + σ²) and peak a²/(a² + σ²): the heat equation's exact solution.
    a, sigma = 0.4, 0.3
    radii = np.linspace(0.0, 4.0, 4001)
    out = np.array([0.0, 0.2, 0.5, 1.0, 1.5])
    got = diffuse_radial(np.exp(-(radii**2) / (2 * a * a)), radii, out, sigma)
    w2 = a * a + sigma * sigma
    np.testing.assert_allclose(got, a * a / w2 * np.exp(-(out**2) / (2 * w2)), atol=1e-6)


def test_diffusion_rounds_the_rim_and_shallows_the_bowl():
    D = 2.0
    s = np.linspace(0.0, 5.0, 1001)
    fresh_ratio, *ratios = depth_ratio([0.0, 0.1, 0.3, 0.65])
    assert fresh_ratio == pytest.approx(DEPTH_RATIO)
    assert fresh_ratio > ratios[0] > ratios[1] > ratios[2] > 0.02
    for sigma in (0.1, 0.3, 0.65):
        h = crater_profile(s, D, sigma)
        assert h[s >= crater_reach(sigma)].max() == 0.0 and h[s >= crater_reach(sigma)].min() == 0.0
        # Diffusion never steepens: the steepest wall is below the fresh one's 2·2·DEPTH_RATIO.
        assert np.abs(np.diff(h) / np.diff(s * D / 2)).max() < 4 * DEPTH_RATIO
    # A barely diffused crater is the fresh one but for its rim kink.
    assert np.abs(crater_profile(s, D, 0.01) - crater_profile(s, D)).max() < 0.01 * D
    with pytest.raises(ValueError, match="^degradation: "):
        crater_profile(s, D, DIFFUSION_MAX + 0.1)


def test_equilibrium_population_mean_depth_ratio_is_the_measured_one():
    # sigma² uniform (uniform ages, κt ∝ age); mean rim-to-floor d/D 0.061 (Wu et al. 2021).
    sigma = sample_degradation(np.random.default_rng(3), 4000)
    ratios = depth_ratio(sigma)
    assert ratios.mean() == pytest.approx(0.061, abs=0.002)
    assert ratios.max() <= DEPTH_RATIO + 1e-12
    # Craters able to hold a shadow under a 12.5° Sun: a wall steeper than 12.5°.
    s = np.linspace(0.0, 1.5, 301)
    steepest = np.abs(np.diff(crater_profile(s[None, :], 2.0, sigma[:400, None]), axis=1)).max(axis=1) / (s[1] - s[0])
    assert 0.15 < np.mean(steepest > math.tan(math.radians(12.5))) < 0.27


def test_height_adds_profiles_within_reach():
    field = CraterField(
        centres=np.array([[0.0, 0.0], [3.0, 0.0]]), diameters=np.array([2.0, 1.0]), degradation=np.array([0.0, 0.5])
    )
    x = np.array([0.0, 0.5, 2.0, 3.0, 10.0])
    y = np.zeros_like(x)
    expected = crater_profile(np.abs(x) / 1.0, 2.0, 0.0) + crater_profile(np.abs(x - 3.0) / 0.5, 1.0, 0.5)
    np.testing.assert_allclose(field.height(x, y), expected, atol=1e-15)
    assert field.height(10.0, 0.0) == 0.0
    empty = CraterField(np.zeros((0, 2)), np.zeros(0), np.zeros(0))
    assert (empty.height(x, y) == 0).all()


def test_bad_parameters_name_the_field():
    with pytest.raises(ValueError, match="^d_min: "):
        CraterField.sample(seed=0, half_size_m=1.0, d_min=5.0, d_max=1.0)
    with pytest.raises(ValueError, match="^density: "):
        CraterField.sample(seed=0, half_size_m=1.0, density=-1.0)
