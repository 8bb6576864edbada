"""Photometry through the bindings and the config: Hapke's model (photometry.h) as a reference
option, its normalisation to the normal albedo, and Lambert/Lunar-Lambert left as they were.
The physics checks in depth are in cpp/tests/test_photometry.cpp."""

from __future__ import annotations

import math

import numpy as np
import pytest

from moonbot import _core
from moonbot.config import ConfigError, load_config
from moonbot.render.view import regolith

pytestmark = pytest.mark.unit


def random_geometries(n: int, seed: int = 5) -> np.ndarray:
    """(n, 3) rows of (cos i, cos e, cos g) for two random upper-hemisphere directions."""
    rng = np.random.default_rng(seed)
    mu_i, mu_o = rng.uniform(1e-6, 1.0, n), rng.uniform(1e-6, 1.0, n)
    psi = rng.uniform(0.0, 2.0 * math.pi, n)
    cos_g = mu_i * mu_o + np.sqrt((1 - mu_i**2) * (1 - mu_o**2)) * np.cos(psi)
    return np.stack([mu_i, mu_o, cos_g], axis=1)


def h_2002(w: float, x: float) -> float:
    """Hapke 2002 (Icarus 157:523) eq. 13, written out independently of the C++."""
    gamma = math.sqrt(1.0 - w)
    r0 = (1.0 - gamma) / (1.0 + gamma)
    return 1.0 / (1.0 - w * x * (r0 + (1.0 - 2.0 * r0 * x) / 2.0 * math.log((1.0 + x) / x)))


def test_hapke_defaults_are_the_lunar_set_normalised_to_one():
    p = _core.Photometry(model="hapke", surge_amplitude=1.8, surge_width=0.07)
    assert p.model == "hapke"
    assert p.shape(1.0, 1.0, 1.0) == pytest.approx(1.0, abs=1e-15)
    assert p.porosity_factor == pytest.approx(1.4405, abs=1e-4)
    # A_N = K·w/8·[p(0)·(1 + B_S0) + H(χ/K)² − 1] for the Sato et al. 2014 set.
    assert p.hapke_normal_albedo == pytest.approx(0.2663, abs=1e-4)
    assert p.hapke_reflectance(1.0, 1.0, 1.0) * math.pi == pytest.approx(p.hapke_normal_albedo, rel=1e-14)
    assert _core.Photometry(model="lunar-lambert").hapke_normal_albedo is None


def test_hapke_reciprocal_and_finite():
    p = _core.Photometry(model="hapke", surge_amplitude=1.8, surge_width=0.07, cboe_amplitude=0.5, cboe_width=0.05)
    for mu_i, mu_o, cos_g in random_geometries(5000):
        a, b = p.shape(mu_i, mu_o, cos_g), p.shape(mu_o, mu_i, cos_g)
        assert a == b and math.isfinite(a) and a >= 0.0
    for mu in (0.0, -0.2):
        assert p.shape(mu, 0.5, 0.3) == 0.0 and p.shape(0.5, mu, 0.3) == 0.0
    for cos_g in (-1.0, 1.0):
        assert math.isfinite(p.shape(1e-12, 1e-12, cos_g))


def test_hapke_smooth_isotropic_is_the_chandrasekhar_form():
    """θ̄ = 0, no surges, b = 0, φ = 0 (K = 1): r = w/(4π)·μ0/(μ0 + μ)·H(μ0)·H(μ)."""
    for w in (0.1, 0.5, 0.99):
        p = _core.Photometry(model="hapke", w=w, b=0.0, roughness_deg=0.0, filling_factor=0.0)
        assert p.porosity_factor == 1.0
        for mu_i, mu_o, cos_g in random_geometries(500, seed=9):
            want = w / (4 * math.pi) * mu_i / (mu_i + mu_o) * h_2002(w, mu_i) * h_2002(w, mu_o)
            assert p.hapke_reflectance(mu_i, mu_o, cos_g) == pytest.approx(want, rel=1e-12)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"model": "hapk"}, "model"),
        ({"w": 1.2}, "w"),
        ({"w": float("nan")}, "w"),
        ({"b": 1.0}, "b"),
        ({"c": -1.5}, "c"),
        ({"roughness_deg": 61.0}, "roughness_deg"),
        ({"filling_factor": 0.8}, "filling_factor"),
        ({"cboe_amplitude": 2.0}, "cboe_amplitude"),
        ({"cboe_width": 0.0}, "cboe_width"),
        ({"surge_width": 0.0}, "surge_width"),
    ],
)
def test_binding_errors_name_the_field(kwargs, field):
    kwargs = {"model": "hapke", **kwargs}
    with pytest.raises(ValueError, match=f"^{field}: "):
        _core.Photometry(**kwargs)


def test_regolith_albedo_is_normal_albedo_over_shape_at_zero():
    base = load_config().terrain.photometry
    # Lunar-Lambert and Lambert: exactly the old arithmetic, A = normal / (1 + B0) and A = normal.
    photometry, albedo = regolith(base, 0.12)
    assert photometry.model == "lunar-lambert" and albedo == (0.12 / (1.0 + 1.8),) * 3
    off = load_config(None, {"terrain.photometry.surge_amplitude": 0.0}).terrain.photometry
    assert regolith(off, 0.12)[1] == (0.12,) * 3
    lam = load_config(None, {"terrain.photometry.model": "lambert"}).terrain.photometry
    assert regolith(lam, 0.12)[1] == (0.12,) * 3
    # Hapke: normalised by its own normal albedo, so A is the normal albedo.
    hapke = load_config(None, {"terrain.photometry.model": "hapke"}).terrain.photometry
    photometry, albedo = regolith(hapke, 0.12)
    assert photometry.model == "hapke" and albedo[0] == pytest.approx(0.12, rel=1e-15)
    # The config's Hapke fields reach the core.
    rough0 = load_config(
        None, {"terrain.photometry.model": "hapke", "terrain.photometry.roughness_deg": 0.0}
    ).terrain.photometry
    assert regolith(rough0, 0.12)[0].shape(0.3, 0.9, 0.5) != photometry.shape(0.3, 0.9, 0.5)


@pytest.mark.parametrize(
    ("override", "message"),
    [
        ({"terrain.photometry.model": "hapke2"}, "terrain.photometry.model: must be one of"),
        ({"terrain.photometry.w": 1.5}, "terrain.photometry.w: must be <= 1.0"),
        ({"terrain.photometry.c": -2}, "terrain.photometry.c: must be >= -1.0"),
        ({"terrain.photometry.roughness_deg": 70}, "terrain.photometry.roughness_deg: must be <= 60.0"),
        ({"terrain.photometry.filling_factor": 0.9}, "terrain.photometry.filling_factor: must be <= 0.75"),
        ({"terrain.photometry.cboe_width": 0}, "terrain.photometry.cboe_width: must be > 0"),
    ],
)
def test_config_errors_name_the_field(override, message):
    with pytest.raises(ConfigError) as caught:
        load_config(None, override)
    assert message in str(caught.value)
