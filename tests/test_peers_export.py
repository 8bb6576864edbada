"""bench/peers/export_scene.py: the scene handed to the peer renderers (Mitsuba, Cycles) is
moonbot's own, in world metres, and scene.json says what the peers need with units. Only the
export runs here: the peers are optional and never installed in CI."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh
from scipy import ndimage

pytestmark = pytest.mark.unit

PEERS = Path(__file__).resolve().parents[1] / "bench" / "peers"
sys.path.insert(0, str(PEERS))

from moonbot.render.view import orbit_view  # noqa: E402
from moonbot.scene.compose import TERRAIN_MESH  # noqa: E402

from export_scene import PARITY_OVERRIDES, export_scene, parity_config, parity_spec  # noqa: E402
from ply import read_ply, write_ply  # noqa: E402


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    # The default scene on a smaller terrain (the 2 km one is 3 M triangles): same code path.
    config = parity_config(64, 48, {"terrain.extent_m": 60.0})
    spec = parity_spec(config)
    out = tmp_path_factory.mktemp("peers-scene")
    scene = export_scene(out, config, spec)
    return config, spec, out, scene


def world_vertices(pose, vertices):
    return np.asarray(vertices, np.float64) @ np.asarray(pose)[:3, :3].T + np.asarray(pose)[:3, 3]


def test_parity_settings_reach_moonbot(exported):
    config, spec, _, scene = exported
    assert config.terrain.photometry.model == "lambert"
    assert config.render.bounces == 1 and config.render.light_samples == 1
    assert config.sun.angular_diameter_deg == 0.0
    assert config.bags.fabric.relief_m == 0.0 and config.bags.fabric.contrast == 0.0
    assert config.bags.fabric.sheen == 0.0
    assert not config.terrain.photometry.grain.enabled  # no micro-texture: the peers have none
    assert spec.terrain_subgrid is None  # nor the bump of the relief the mesh does not hold
    assert spec.terrain_craters is None  # nor the craters it does not draw
    assert spec.terrain_normals is None  # flat shading, as the peers are given it
    assert scene["config_overrides"].items() >= PARITY_OVERRIDES.items()


def test_flat_bags_change_only_bag_pixels(exported):
    # build_scene(smooth_bags=False): the bags shaded by their facets, as the peers shade them;
    # the ground and rocks, and every pixel's depth and label, stay as they were. Direct light
    # only, uniform samples: light bounced off a bag, or a refinement a bag's edge starts, would
    # carry the bag's shading farther than the pixels its samples reach (its own and the ring of
    # edge pixels whose centre misses it).
    from moonbot.render import build_scene
    from moonbot.render.view import render_view, view_inputs

    config, spec, _, _ = exported
    overrides = {"terrain.extent_m": 60.0, "render.threads": 1, "render.bounces": 0, "render.adaptive_spp": 0}
    config = parity_config(64, 48, overrides)
    view = view_inputs(config, spec, 0)
    smooth, flat = (
        render_view(build_scene(spec, smooth_bags=s), config, view.K, view.pose, config.seed) for s in (True, False)
    )
    assert np.array_equal(smooth.depth, flat.depth) and np.array_equal(smooth.instance, flat.instance)
    bag = smooth.instance > 0
    assert bag.any()
    changed = np.any(smooth.rgb != flat.rgb, axis=-1)
    reach = ndimage.binary_dilation(bag, structure=np.ones((3, 3), bool))
    assert changed[bag].any() and not changed[~reach].any()


def test_meshes_read_back_as_moonbots_scene(exported):
    _, spec, out, scene = exported
    by_kind = {m["kind"]: m for m in scene["meshes"]}
    assert set(by_kind) == ({"terrain", "rocks", "bag"} if spec.rocks else {"terrain", "bag"})

    # Terrain: the very vertices and triangles moonbot renders, and its albedo per vertex.
    v, t, extra = read_ply(out / "terrain.ply")
    mv, mt = spec.meshes[TERRAIN_MESH]
    assert np.array_equal(v, mv) and np.array_equal(t, mt)
    assert by_kind["terrain"]["triangles"] == len(mt)
    np.testing.assert_allclose(extra["albedo_r"], 0.12 * spec.terrain_albedo_scale, rtol=1e-6)
    np.testing.assert_allclose(by_kind["terrain"]["bounds_m"], [mv.min(0), mv.max(0)], rtol=0, atol=0)

    # Bags: each instance in world metres, as its pose places moonbot's model.
    for bag in spec.bags:
        v, t, _ = read_ply(out / f"bag_{bag.instance_id:03d}.ply")
        mv, mt = spec.meshes[bag.obj_id]
        expected = world_vertices(bag.world_from_model, mv)
        assert np.array_equal(t, mt)
        np.testing.assert_allclose(v, expected, atol=1e-6)
        np.testing.assert_allclose(np.array(by_kind["bag"]["bounds_m"]), [expected.min(0), expected.max(0)], atol=1e-6)

    # Rocks: every instance, merged.
    if spec.rocks:
        v, t, _ = read_ply(out / "rocks.ply")
        assert len(t) == sum(len(spec.meshes[key][1]) for key, _ in spec.rocks) == by_kind["rocks"]["triangles"]
        expected = np.concatenate([world_vertices(pose, spec.meshes[key][0]) for key, pose in spec.rocks])
        np.testing.assert_allclose([v.min(0), v.max(0)], [expected.min(0), expected.max(0)], atol=1e-5)

    total = (
        len(spec.meshes[TERRAIN_MESH][1])
        + sum(len(spec.meshes[k][1]) for k, _ in spec.rocks)
        + sum(len(spec.meshes[b.obj_id][1]) for b in spec.bags)
    )
    assert scene["triangles_total"] == total


def test_an_independent_reader_agrees(exported):
    _, _, out, scene = exported
    for m in scene["meshes"]:
        mesh = trimesh.load(out / m["file"], process=False)
        assert len(mesh.faces) == m["triangles"] and len(mesh.vertices) == m["vertices"]
        np.testing.assert_allclose(mesh.bounds, m["bounds_m"], atol=1e-6)


def test_scene_json_has_camera_sun_and_units(exported):
    config, spec, out, scene = exported
    assert json.loads((out / "scene.json").read_text()) == scene
    units = scene["units"]
    assert units["length"] == "m" and units["irradiance"] == "W/m^2" and units["radiance"] == "W/(m^2 sr)"
    cam = scene["camera"]
    assert (cam["width"], cam["height"]) == (64, 48)
    K, pose = orbit_view(config, spec, 0)
    np.testing.assert_allclose(cam["K"], K)
    assert cam["hfov_deg"] == pytest.approx(config.camera.hfov_deg)
    R, t, c = np.array(cam["R_world_to_cam"]), np.array(cam["t_world_to_cam_m"]), np.array(cam["position_m"])
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(R @ c + t, 0, atol=1e-12)
    # The orbit camera looks at the target bag: it projects to the principal point.
    p = K @ (R @ np.array(cam["look_at_m"]) + t)
    np.testing.assert_allclose(p[:2] / p[2], [cam["cx"], cam["cy"]], atol=1e-6)
    np.testing.assert_allclose(cam["forward"], R[2])
    np.testing.assert_allclose(cam["up"], -R[1])
    sun = scene["sun"]
    assert sun["type"] == "directional" and sun["irradiance_w_m2"] == config.sun.irradiance_w_m2
    d = np.array(sun["direction_to_sun"])
    assert np.linalg.norm(d) == pytest.approx(1.0)
    assert math.degrees(math.asin(d[2])) == pytest.approx(config.sun.elevation_deg)
    assert scene["integrator"]["bounces"] == 1 and scene["sky"]["radiance_w_m2_sr"] == 0.0
    for m in scene["meshes"]:
        assert m["albedo"] and m["triangles"] > 0 and len(m["bounds_m"]) == 2


def test_ply_round_trip(tmp_path):
    rng = np.random.default_rng(0)
    v = rng.normal(size=(10, 3)).astype(np.float32)
    t = rng.integers(0, 10, size=(7, 3)).astype(np.int32)
    a = rng.random(10).astype(np.float32)
    write_ply(tmp_path / "x.ply", v, t, {"albedo_r": a}, comment="two\nlines")
    rv, rt, extra = read_ply(tmp_path / "x.ply")
    assert np.array_equal(rv, v) and np.array_equal(rt, t) and np.array_equal(extra["albedo_r"], a)
