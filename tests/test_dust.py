"""Granular ejecta (moonbot/dust.h): free flight is the exact parabola at any time step,
bounces never add energy, fragments come to rest on a plane in finite time without sinking,
nothing tunnels through a zero-thickness surface at the largest step, and the state is the same
on 1 and 2 threads."""

from __future__ import annotations

import numpy as np
import pytest

from moonbot import _core

pytestmark = pytest.mark.unit

G = 1.62


def plane_scene(z: float = 0.0, half: float = 50.0) -> _core.Scene:
    """A zero-thickness square at height z."""
    scene = _core.Scene()
    v = np.array([[-half, -half, z], [half, -half, z], [half, half, z], [-half, half, z]], np.float32)
    scene.add_background(scene.add_mesh(v, np.array([[0, 1, 2], [0, 2, 3]])), np.eye(4), (0.1,) * 3)
    scene.commit()
    return scene


@pytest.mark.parametrize("dt", [0.1, 0.01, 0.001])
def test_free_flight_is_the_parabola_at_any_step(dt):
    scene = plane_scene(z=-1000.0)
    launch = _core.simulate_ejecta(scene, _core.EjectaParams(count=50), seed=4, time_s=0.0)
    assert np.all(launch["age"] == 0) and np.all(launch["velocity"][:, 2] > 0)
    for t in (0.37, 1.3, 1.999):
        state = _core.simulate_ejecta(scene, _core.EjectaParams(count=50), seed=4, time_s=t, dt_s=dt)
        expected = launch["position"] + launch["velocity"] * t + 0.5 * np.array([0, 0, -G]) * t * t
        np.testing.assert_allclose(state["position"], expected, rtol=0, atol=1e-12)
        np.testing.assert_allclose(state["velocity"], launch["velocity"] + np.array([0, 0, -G]) * t, atol=1e-12)
        assert np.all(state["bounces"] == 0)


def test_bursts_repeat_every_period_with_new_fragments():
    scene = plane_scene(z=-1000.0)
    a = _core.simulate_ejecta(scene, _core.EjectaParams(count=20), seed=4, time_s=0.5)
    b = _core.simulate_ejecta(scene, _core.EjectaParams(count=20), seed=4, time_s=2.5)
    assert np.all(b["age"] == pytest.approx(0.5))
    assert not np.allclose(a["velocity"], b["velocity"])  # burst 1 is another throw
    many = _core.EjectaParams(count=2000)
    speeds = np.linalg.norm(_core.simulate_ejecta(scene, many, seed=4, time_s=0.0)["velocity"], axis=1)
    assert 0.25 <= speeds.min() and speeds.max() <= 0.75  # uniform in [0.5, 1.5] × 0.5 m/s
    launch = _core.simulate_ejecta(scene, many, seed=4, time_s=0.0)["velocity"]
    cos = launch[:, 2] / np.linalg.norm(launch, axis=1)
    assert cos.min() >= np.cos(np.radians(45.0)) - 1e-12  # inside the 45° cone


def test_energy_never_increases_and_fragments_come_to_rest_on_a_plane():
    scene = plane_scene()
    times = np.arange(0.0, 1.999, 0.01)
    states = [_core.simulate_ejecta(scene, _core.EjectaParams(count=100), seed=9, time_s=t, dt_s=0.01) for t in times]
    energy = np.array([0.5 * (s["velocity"] ** 2).sum(axis=1) + G * s["position"][:, 2] for s in states])
    assert np.all(np.diff(energy, axis=0) <= 1e-9)
    last = states[-1]
    assert last["resting"].all()
    assert np.all(last["velocity"] == 0) and last["bounces"].max() < 50
    radius = last["diameter"] / 2
    for s in states:  # never below the surface: the centre stays a radius above it
        assert np.all(s["position"][:, 2] >= s["diameter"] / 2 - 1e-6)
    np.testing.assert_allclose(last["position"][:, 2], radius, atol=1e-5)  # resting on it


def test_nothing_tunnels_through_a_thin_surface_at_the_largest_step():
    """Fast fragments (5 m/s mean, 1 s flights) stepping 0.1 s — longer than it takes to cross
    a zero-thickness surface many times over — never end up below it."""
    scene = plane_scene()
    for t in np.arange(0.0, 2.0, 0.05):
        s = _core.simulate_ejecta(
            scene, _core.EjectaParams(count=200, mean_speed_m_s=5.0), seed=2, time_s=t, dt_s=_core.MAX_DUST_STEP
        )
        assert np.all(s["position"][:, 2] >= s["diameter"] / 2 - 1e-6)


def test_same_state_on_one_and_two_threads():
    scene = plane_scene()
    one = _core.simulate_ejecta(scene, _core.EjectaParams(count=300), seed=5, time_s=1.234, threads=1)
    two = _core.simulate_ejecta(scene, _core.EjectaParams(count=300), seed=5, time_s=1.234, threads=2)
    for key in one:
        assert one[key].tobytes() == two[key].tobytes(), key
    other = _core.simulate_ejecta(scene, _core.EjectaParams(count=300), seed=6, time_s=1.234)
    assert other["position"].tobytes() != one["position"].tobytes()


def test_bad_arguments_name_the_field():
    scene = plane_scene()
    with pytest.raises(ValueError, match="dt_s: must be in"):
        _core.simulate_ejecta(scene, _core.EjectaParams(), seed=0, time_s=1.0, dt_s=0.5)
    with pytest.raises(ValueError, match="restitution: must be in"):
        _core.simulate_ejecta(scene, _core.EjectaParams(restitution=1.0), seed=0, time_s=1.0)
    with pytest.raises(ValueError, match="time_s: must be finite"):
        _core.simulate_ejecta(scene, _core.EjectaParams(), seed=0, time_s=-1.0)
    with pytest.raises(ValueError, match="scene: not committed"):
        _core.simulate_ejecta(_core.Scene(), _core.EjectaParams(), seed=0, time_s=1.0)


def test_puff_transmittance_matches_its_integral():
    """Beer–Lambert through one Gaussian puff: the closed-form optical depth equals a fine
    quadrature of the extinction along the ray, on rays through, beside, starting inside and
    ending inside the puff; through the centre to infinity it is peak·σ·√(2π)."""
    from scipy.integrate import quad

    rng = np.random.default_rng(8)
    centre, sigma, peak = np.array([0.3, -0.2, 0.5]), 0.25, 3.0
    for _ in range(40):
        origin = centre + rng.normal(0.0, 0.6, 3)
        direction = rng.normal(size=3)
        direction /= np.linalg.norm(direction)
        t_max = float(rng.uniform(0.05, 2.0))
        k = lambda t: peak * np.exp(-np.sum((origin + t * direction - centre) ** 2) / (2 * sigma**2))  # noqa: E731
        expected, _ = quad(k, 0.0, t_max, epsabs=1e-13, epsrel=1e-11, points=[max(0.0, -(origin - centre) @ direction)])
        tau = _core.puff_optical_depth(centre, sigma, peak, origin, direction, t_max)
        assert tau == pytest.approx(expected, rel=1e-9, abs=1e-13)
    through = _core.puff_optical_depth(centre, sigma, peak, centre - [5.0, 0, 0], [1.0, 0, 0])
    assert through == pytest.approx(peak * sigma * np.sqrt(2 * np.pi), rel=1e-12)
    assert np.exp(-through) == pytest.approx(np.exp(-peak * sigma * np.sqrt(2 * np.pi)), rel=1e-12)
    assert _core.puff_optical_depth(centre, sigma, 0.0, centre, [0, 0, 1.0]) == 0.0
    with pytest.raises(ValueError, match="sigma_m: must be positive"):
        _core.puff_optical_depth(centre, 0.0, peak, centre, [0, 0, 1.0])
