"""The terrain's subgrid relief (cpp/include/moonbot/subgrid_relief.h): the roughness octaves the
graded mesh faded out, given back to the shading. Checked against the Python field the mesh is
sampled from (moonbot/terrain/roughness.py), against its own finite differences and closed-form
slope variance, through the config, and in rendered images."""

from __future__ import annotations

import math

import numpy as np
import pytest

from moonbot import _core
from moonbot.config import load_config
from moonbot.render import build_scene, render_view
from moonbot.render.view import regolith_grain
from moonbot.scene import compose_scene, intrinsics, orbit_pose
from moonbot.terrain import get_terrain
from moonbot.terrain.location import location_axis, node_spacing, roughness_fields, subgrid_relief

pytestmark = pytest.mark.unit


def relief_of(location: str, **overrides) -> tuple[_core.SubgridRelief, object]:
    terrain = load_config(None, {"terrain.location": location, **overrides}).terrain
    return _core.SubgridRelief(**vars(subgrid_relief(terrain))), terrain


@pytest.mark.parametrize("location", ["flat", "hilly"])
def test_mesh_plus_subgrid_is_the_whole_field(location):
    """What the mesh draws at its cell plus what the relief gives back is the unlimited field."""
    core, terrain = relief_of(location)
    rng = np.random.default_rng(7)
    # Near the fine tile, across the graded band, and out where cells are metres wide.
    p = np.concatenate([rng.uniform(-3, 3, (300, 2)), rng.uniform(-40, 40, (300, 2)), rng.uniform(-900, 900, (300, 2))])
    axis = location_axis(terrain)
    spacing = node_spacing(axis)
    cell = core.cell(p)
    np.testing.assert_array_equal(
        cell, np.maximum(np.interp(p[:, 0], axis, spacing), np.interp(p[:, 1], axis, spacing))
    )
    fields = [f for f in roughness_fields(terrain) if f is not None]
    whole = sum(f.height(p[:, 0], p[:, 1]) for f in fields)
    meshed = sum(f.height(p[:, 0], p[:, 1], cell) for f in fields)
    np.testing.assert_allclose(meshed + core.height(p, cell), whole, rtol=0, atol=1e-12)
    # Where the mesh holds everything (a cell far below the shortest octave) nothing is given back.
    assert np.all(core.height(p, np.full(len(p), 1e-4)) == 0.0)


def test_gradient_is_the_heights_derivative():
    core, _ = relief_of("flat")
    p = np.random.default_rng(3).uniform(-20, 20, (200, 2))
    cell = core.cell(p)
    gradient, spread = core.eval(np.column_stack([p, np.zeros(len(p))]), 0.0)
    h = 1e-6
    for axis in range(2):
        step = np.zeros(2)
        step[axis] = h
        slope = (core.height(p + step, cell) - core.height(p - step, cell)) / (2 * h)
        np.testing.assert_allclose(gradient[:, axis], slope, rtol=0, atol=1e-7)
    assert np.all(gradient[:, 2] == 0.0)
    assert np.all(spread == 0.0)  # an unfiltered read: no spread within the pixel


def one_octave(wavelength=0.1, amplitude=0.01):
    return _core.SubgridRelief(
        [wavelength], [amplitude], [0.3], [[0.25, 0.5]], np.array([12345], dtype=np.uint64), [-1e3, 1e3], [1.0, 1.0]
    )


def test_one_octaves_slope_variance_is_the_closed_form():
    """Unit quintic value noise has a 1-D slope variance ⅓·2·(10/7)·(181/231) per unit spacing,
    along x and along y alike; prefiltered, the box's mean slope keeps w⁴ of it and the spread
    about it w²(1 − w²)."""
    wavelength, amplitude = 0.1, 0.01
    relief = one_octave(wavelength, amplitude)
    v = (1 / 3) * 2 * (10 / 7) * (181 / 231) * (amplitude / wavelength) ** 2
    points = np.column_stack([np.random.default_rng(5).uniform(-300, 300, (200_000, 2)), np.zeros(200_000)])
    gradient, _ = relief.eval(points, 0.0)
    for axis in range(2):
        assert np.mean(gradient[:, axis] ** 2) == pytest.approx(v, rel=0.02)
    footprint = 0.06
    x = math.pi * footprint / (2 * wavelength)
    w = (math.exp(-0.5 * x * x) - 0.01) / 0.99
    gradient, spread = relief.eval(points, footprint)
    assert np.mean(gradient[:, 0] ** 2) == pytest.approx(w**4 * v, rel=0.02)
    np.testing.assert_allclose(spread, w * w * (1 - w * w) * v, rtol=1e-12)
    # A footprint of 1.94 lattice spacings keeps under 1 % of the octave: nothing is read.
    gradient, spread = relief.eval(points[:10], 1.95 * wavelength)
    assert np.all(gradient == 0.0) and np.all(spread == 0.0)


def test_the_relief_restores_the_laws_slope_where_the_mesh_is_coarse():
    """At 20 m the mesh's cells are ~40 cm wide: the relief gives back the slopes of the octaves
    below them, which the roughness law says are several degrees."""
    core, terrain = relief_of("flat")
    angle = np.random.default_rng(2).uniform(0, 2 * np.pi, 20_000)
    points = np.column_stack([20 * np.cos(angle), 20 * np.sin(angle), np.zeros(len(angle))])
    gradient, _ = core.eval(points, 0.0)
    slope_deg = math.degrees(math.atan(math.sqrt(np.mean(gradient[:, 0] ** 2))))
    assert 3.0 < slope_deg < 8.0
    near, _ = core.eval(np.column_stack([np.random.default_rng(4).uniform(-1, 1, (2000, 2)), np.zeros(2000)]), 0.0)
    # In the 1 cm tile the mesh holds all but the 2 cm octave.
    assert math.degrees(math.atan(math.sqrt(np.mean(near[:, 0] ** 2)))) < slope_deg


def test_bad_input_names_the_argument():
    good = {
        "wavelengths": [0.1],
        "amplitudes": [0.01],
        "angles": [0.0],
        "offsets": [[0.0, 0.0]],
        "keys": np.array([1], dtype=np.uint64),
        "axis": [0.0, 1.0],
        "spacing": [1.0, 1.0],
    }
    cases = [
        ({"wavelengths": [0.0]}, r"octave 0\.wavelength_m"),
        ({"amplitudes": [-1.0]}, r"octave 0\.amplitude_m"),
        ({"amplitudes": [0.1, 0.2]}, r"amplitudes: must have shape \(1,\)"),
        ({"offsets": [[0.0, 0.0, 0.0]]}, r"offsets: must have shape \(N, 2\)"),
        ({"keys": np.array([1], dtype=np.int64)}, r"keys: must be a uint64 array"),
        ({"axis": [1.0, 0.0]}, r"axis: must be finite and strictly ascending"),
        ({"axis": [0.0]}, r"axis: needs at least 2 nodes"),
        ({"spacing": [1.0, 0.0]}, r"spacing: must be finite and > 0"),
        ({"spacing": [1.0]}, r"spacing: must have one value per axis node"),
        ({"wavelengths": [float("nan")]}, r"octave 0\.wavelength_m"),
    ]
    for change, message in cases:
        with pytest.raises(ValueError, match=message):
            _core.SubgridRelief(**{**good, **change})
    with pytest.raises(ValueError, match="footprint_m"):
        one_octave().eval(np.zeros((1, 3)), -1.0)


def test_off_builds_nothing_and_the_analytic_grounds_have_none():
    off = load_config(None, {"terrain.roughness.subgrid_shading": False}).terrain
    assert subgrid_relief(off) is None
    terrain, _ = get_terrain(off)
    assert terrain.subgrid is None
    plane = load_config(None, {"terrain.location": "plane"}).terrain
    assert get_terrain(plane)[0].subgrid is None
    # Grain off and no subgrid relief: no texture object at all, so no texture code runs.
    grain_off = load_config(
        None, {"terrain.photometry.grain.albedo_rms": 0.0, "terrain.photometry.grain.slope_rms_deg": 0.0}
    ).terrain.photometry.grain
    assert regolith_grain(grain_off) is None
    # Grain off, subgrid relief on: the texture holds the relief alone.
    texture = regolith_grain(grain_off, subgrid_relief(load_config(None, {}).terrain))
    assert texture is not None and texture.octaves == 0 and math.isinf(texture.flat_footprint_m)


def ground_view(subgrid: bool):
    """A 320×240 view of the flat location's ground from 1.5 m up and 6 m out, looking at the
    target, the grain off so that only the mesh and the subgrid relief shape the ground."""
    config = load_config(
        None,
        {
            "terrain.roughness.subgrid_shading": subgrid,
            "terrain.photometry.grain.albedo_rms": 0.0,
            "terrain.photometry.grain.slope_rms_deg": 0.0,
            "sun.elevation_deg": 12.0,
            "camera.width": 320,
            "camera.height": 240,
        },
    )
    spec = compose_scene(config)
    pose = orbit_pose(spec.target, 6.0, 1.5, 90.0)
    return render_view(build_scene(spec), config, intrinsics(config.camera), pose, seed=1)


def test_the_distant_ground_gets_fine_contrast_and_keeps_its_mean():
    on, off = ground_view(True), ground_view(False)
    np.testing.assert_array_equal(on.depth, off.depth)  # the geometry is the mesh's alone
    np.testing.assert_array_equal(on.instance, off.instance)
    # The upper half of the image: ground beyond the fine tile, where the mesh's cells grow.
    far = (on.instance[:120] == 0) & (on.depth[:120] > 4.0)
    assert far.sum() > 10_000

    def fine_contrast(rgb):
        """Median |Laplacian| of the far ground's luminance over its mean (robust to rock edges)."""
        y = rgb[:120, :, 1].astype(np.float64)
        lap = 4 * y[1:-1, 1:-1] - y[:-2, 1:-1] - y[2:, 1:-1] - y[1:-1, :-2] - y[1:-1, 2:]
        inside = far[1:-1, 1:-1] & far[:-2, 1:-1] & far[2:, 1:-1] & far[1:-1, :-2] & far[1:-1, 2:]
        return np.median(np.abs(lap[inside])) / np.mean(y[far])

    assert fine_contrast(on.rgb) > 1.3 * fine_contrast(off.rgb)
    # A bump of symmetric slopes moves the mean brightness little.
    assert np.mean(on.rgb[:120][far]) == pytest.approx(np.mean(off.rgb[:120][far]), rel=0.02)
