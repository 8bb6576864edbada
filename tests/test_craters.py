"""Small craters: the size-frequency distribution within Poisson sampling error, the profile's
stated shape, and heights that add up each crater's profile within its reach only."""

from __future__ import annotations

import numpy as np
import pytest

from moonbot.terrain.craters import (DEPTH_RATIO, EJECTA_CUTOFF, RIM_RATIO, CraterField, crater_profile,
                                   expected_count)


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
    floor = RIM_RATIO * D * EJECTA_CUTOFF ** -3
    assert crater_profile(0.0, D) == pytest.approx(RIM_RATIO * D - floor - DEPTH_RATIO * D)
    assert crater_profile(1.0, D) == pytest.approx(RIM_RATIO * D - floor)
    assert crater_profile(1.0 - 1e-12, D) == pytest.approx(crater_profile(1.0 + 1e-12, D), abs=1e-9)
    assert crater_profile(EJECTA_CUTOFF, D) == pytest.approx(0.0, abs=1e-15)
    assert crater_profile(7.0, D) == 0.0
    assert crater_profile(0.5, D, degradation=0.3) == pytest.approx(0.3 * crater_profile(0.5, D))


def test_height_adds_profiles_within_reach():
    field = CraterField(centres=np.array([[0.0, 0.0], [3.0, 0.0]]), diameters=np.array([2.0, 1.0]),
                        degradation=np.array([1.0, 0.5]))
    x = np.array([0.0, 0.5, 2.0, 3.0, 10.0])
    y = np.zeros_like(x)
    expected = (crater_profile(np.abs(x) / 1.0, 2.0, 1.0) + crater_profile(np.abs(x - 3.0) / 0.5, 1.0, 0.5))
    np.testing.assert_allclose(field.height(x, y), expected, atol=1e-15)
    assert field.height(10.0, 0.0) == 0.0
    empty = CraterField(np.zeros((0, 2)), np.zeros(0), np.zeros(0))
    assert (empty.height(x, y) == 0).all()


def test_bad_parameters_name_the_field():
    with pytest.raises(ValueError, match="^d_min: "):
        CraterField.sample(seed=0, half_size_m=1.0, d_min=5.0, d_max=1.0)
    with pytest.raises(ValueError, match="^density: "):
        CraterField.sample(seed=0, half_size_m=1.0, density=-1.0)
