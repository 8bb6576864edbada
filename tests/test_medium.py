"""The dust as a medium and as moving geometry (moonbot/medium.h, moonbot/dust.h): the
baked grid's transmittance matches the puffs' closed-form integrals, scattering follows the
phase function, a strided march matches the full one, a puff-free medium is no medium
(bit-identical, nothing traced), renders are the
same on 1 and 2 threads, hard cases (grazing Sun, camera inside the dust, kilometre
coordinates) stay finite; the cloud's puffs are a pure function of time; the ejecta's mesh is
closed, outward and inside each fragment's diameter, and moving it rebuilds that mesh alone."""

from __future__ import annotations

import numpy as np
import pytest

from moonbot import _core

pytestmark = pytest.mark.unit

W, H = 48, 36


def wall_scene(offset=(0.0, 0.0, 0.0)) -> _core.Scene:
    """A white Lambertian ground square 20 m wide at z = 0 (shifted by `offset`)."""
    scene = _core.Scene()
    o = np.asarray(offset, float)
    v = np.array([[-10, -10, 0], [10, -10, 0], [10, 10, 0], [-10, 10, 0]], float) + o
    scene.add_background(scene.add_mesh(v, np.array([[0, 1, 2], [0, 2, 3]])), np.eye(4), (1.0, 1.0, 1.0))
    scene.commit()
    return scene


def down_camera(offset=(0.0, 0.0, 0.0), height=2.0) -> _core.Camera:
    """Looking straight down from `height` m above the origin (OpenCV axes: x east, y south)."""
    R = np.diag([1.0, -1.0, -1.0])  # camera-from-world
    centre = np.asarray(offset, float) + [0.0, 0.0, height]
    return _core.Camera(40.0, 40.0, W / 2, H / 2, W, H, R, -R @ centre)


def test_transmittance_matches_the_closed_form_through_one_puff():
    # No scattering (albedo 0): the ground's radiance is attenuated by the dust toward the camera
    # and toward the Sun, each exp(-optical depth) of the puff along that ray.
    scene, camera = wall_scene(), down_camera()
    centre, sigma, peak = np.array([0.05, -0.03, 0.9]), 0.2, 3.0
    sun = _core.DirectionalLight(30.0, 60.0, 1000.0, 0.0)
    clear = _core.render(scene, camera, sun)
    medium = _core.Medium([[*centre, sigma, peak]], albedo=(0, 0, 0), voxel_m=0.005)
    dusty = _core.render(scene, camera, sun, medium=medium)
    np.testing.assert_array_equal(dusty["depth"], clear["depth"])  # the medium leaves depth alone
    ratio = dusty["rgb"][..., 0] / clear["rgb"][..., 0]
    K_inv = np.linalg.inv(np.array([[40.0, 0, W / 2], [0, 40.0, H / 2], [0, 0, 1]]))
    az, el = np.radians(30.0), np.radians(60.0)
    to_sun = np.array([np.sin(az) * np.cos(el), np.cos(az) * np.cos(el), np.sin(el)])
    worst = 0.0
    for y in range(0, H, 5):
        for x in range(0, W, 5):
            d_cam = K_inv @ [x + 0.5, y + 0.5, 1.0]
            d = np.diag([1.0, -1.0, -1.0]) @ d_cam  # world-from-camera
            hit = np.array([0, 0, 2.0]) + d * 2.0 / -d[2]
            tau_cam = _core.puff_optical_depth(centre, sigma, peak, [0, 0, 2.0], d, np.linalg.norm(hit - [0, 0, 2.0]))
            tau_sun = _core.puff_optical_depth(centre, sigma, peak, hit, to_sun)
            worst = max(worst, abs(ratio[y, x] - np.exp(-tau_cam - tau_sun)))
    assert worst < 2e-3, worst


def test_single_scattering_against_the_sky_matches_the_integral():
    # A thin puff seen against the black sky, lit by a Sun behind the camera's side: its radiance
    # is ω·E·p_HG(θ)·∫k ds (optically thin: T ≈ 1 everywhere), ∫k ds the closed-form depth.
    scene = wall_scene(offset=(0, 0, -100.0))  # far below: the rays above the horizon see sky
    R = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])  # looking east, level
    camera = _core.Camera(40.0, 40.0, W / 2, H / 2, W, H, R, -R @ np.zeros(3))
    centre, sigma, peak = np.array([3.0, 0.0, 0.0]), 0.3, 1e-3
    sun = _core.DirectionalLight(135.0, 20.0, 1000.0, 0.0)  # behind and to the right: scattering at ~118°
    medium = _core.Medium([[*centre, sigma, peak]], albedo=(0.5, 0.5, 0.5), asymmetry=0.6, voxel_m=0.01)
    out = _core.render(scene, camera, sun, medium=medium)
    d = R.T @ (np.linalg.inv(np.array([[40.0, 0, W / 2], [0, 40.0, H / 2], [0, 0, 1]])) @ [W / 2 + 0.5, H / 2 + 0.5, 1])
    d /= np.linalg.norm(d)
    az, el = np.radians(135.0), np.radians(20.0)
    to_sun = np.array([np.sin(az) * np.cos(el), np.cos(az) * np.cos(el), np.sin(el)])
    tau = _core.puff_optical_depth(centre, sigma, peak, [0, 0, 0], d)
    expected = 0.5 * 1000.0 * _core.henyey_greenstein(float(to_sun @ d), 0.6) * tau
    # 5e-3: the thin-medium formula leaves out T ≈ 1 − 1e-3 toward camera and Sun, and the grid
    # interpolates the puff's profile at 1 cm.
    assert out["rgb"][H // 2, W // 2, 0] == pytest.approx(expected, rel=5e-3)
    assert out["depth"][H // 2, W // 2] == 0.0  # still sky in depth


def test_a_strided_march_matches_the_closed_form_and_the_full_march():
    # Transmittance only (albedo 0), as in the closed-form test, but at the default camera's pixel
    # size (f = 554 px, 640×480 at 60°): every 4th pixel's ray marches, the others interpolate
    # the four around them at their own hit distance. A ground hit 2 m away, a puff of σ 0.2 m.
    f, w, h = 554.0, 64, 48
    R = np.diag([1.0, -1.0, -1.0])
    camera = _core.Camera(f, f, w / 2, h / 2, w, h, R, -R @ np.array([0.0, 0.0, 2.0]))
    scene = wall_scene()
    centre, sigma, peak = np.array([0.01, -0.02, 0.9]), 0.2, 3.0
    sun = _core.DirectionalLight(30.0, 60.0, 1000.0, 0.0)
    clear = _core.render(scene, camera, sun)["rgb"][..., 0]
    out = {}
    for stride in (1, 4):
        medium = _core.Medium([[*centre, sigma, peak]], albedo=(0, 0, 0), voxel_m=0.005, march_stride_px=stride)
        out[stride] = (
            _core.render(scene, camera, sun, _core.RenderSettings(threads=2), medium=medium)["rgb"][..., 0] / clear
        )
    K_inv = np.linalg.inv(np.array([[f, 0, w / 2], [0, f, h / 2], [0, 0, 1]]))
    az, el = np.radians(30.0), np.radians(60.0)
    to_sun = np.array([np.sin(az) * np.cos(el), np.cos(az) * np.cos(el), np.sin(el)])
    worst = 0.0
    for y in range(0, h, 3):
        for x in range(0, w, 3):
            d = R.T @ (K_inv @ [x + 0.5, y + 0.5, 1.0])
            hit = np.array([0, 0, 2.0]) + d * 2.0 / -d[2]
            tau_cam = _core.puff_optical_depth(centre, sigma, peak, [0, 0, 2.0], d, np.linalg.norm(hit - [0, 0, 2.0]))
            tau_sun = _core.puff_optical_depth(centre, sigma, peak, hit, to_sun)
            worst = max(worst, abs(out[4][y, x] - np.exp(-tau_cam - tau_sun)))
    assert worst < 2e-3, worst
    # The marched rays' own pixels agree with the full march to rounding; the rest to 0.1 %.
    np.testing.assert_allclose(out[4][::4, ::4], out[1][::4, ::4], rtol=1e-6)
    np.testing.assert_allclose(out[4], out[1], rtol=1e-3)


def test_a_medium_without_puffs_is_no_medium():
    scene, camera = wall_scene(), down_camera()
    sun = _core.DirectionalLight(30.0, 40.0, 1000.0, 0.533)
    settings = _core.RenderSettings(spp=2, seed=3, light_samples=2, bounces=1)
    plain = _core.render(scene, camera, sun, settings)
    empty = _core.render(scene, camera, sun, settings, medium=_core.Medium(np.zeros((0, 5))))
    for key in ("rgb", "depth", "instance"):
        assert plain[key].tobytes() == empty[key].tobytes()
    assert plain["medium_rays"] == empty["medium_rays"] == 0
    assert empty["camera_rays"] == plain["camera_rays"]


def test_dust_renders_the_same_on_one_and_two_threads_and_stays_finite_in_hard_cases():
    puffs = _core.cloud_puffs(_core.CloudParams(origin=(0.3, 0.2, 0.0), vertical_offset_m=0.0), 5, 6.0)
    for offset, elevation in (((0, 0, 0), 30.0), ((0, 0, 0), 0.5), ((3000.0, -2000.0, 500.0), 8.0)):
        shifted = puffs.copy()
        shifted[:, :3] += offset
        scene, camera = wall_scene(offset), down_camera(offset, height=0.4)  # camera inside the cloud
        sun = _core.DirectionalLight(120.0, elevation, 1361.0, 0.533)
        for stride in (1, 4):
            medium = _core.Medium(shifted, voxel_m=0.1, floor_z=offset[2] - 0.5, march_stride_px=stride)
            one = _core.render(scene, camera, sun, _core.RenderSettings(spp=2, seed=9, threads=1), medium=medium)
            two = _core.render(scene, camera, sun, _core.RenderSettings(spp=2, seed=9, threads=2), medium=medium)
            assert one["rgb"].tobytes() == two["rgb"].tobytes()
            assert np.isfinite(one["rgb"]).all() and (one["rgb"] >= 0).all()
            assert one["medium_rays"] > 0


def test_dust_under_a_roof_is_dark_and_each_grid_line_takes_one_sun_ray():
    # A thin puff seen against the sky from its side (camera at the origin looking east), the Sun
    # 70° up in the south, and a roof over y >= 0 facing down, at z = 1 m (above the dust) or
    # z = 0 (through its middle): dust at height z under it is shaded where
    # y > (roof - z)·cot 70°. The grid's lines run along the Sun's direction, so a line with dust
    # takes one Sun ray, and one more past each surface it meets with dust beyond.
    f, w, h = 100.0, 48, 36
    centre, sigma, peak, voxel = np.array([3.0, 0.0, 0.0]), 0.3, 1e-3, 0.02
    R = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])  # camera x = -world y, y = -world z
    camera = _core.Camera(f, f, w / 2, h / 2, w, h, R, -R @ np.zeros(3))
    sun = _core.DirectionalLight(180.0, 70.0, 1000.0, 0.0)
    medium = _core.Medium([[*centre, sigma, peak]], albedo=(0.5, 0.5, 0.5), voxel_m=voxel)
    out = {}
    for roof in (None, 1.0, 0.0):
        scene = wall_scene(offset=(0, 0, -100.0))  # far below: the rays toward the dust see sky behind it
        if roof is not None:  # wound clockwise seen from above: its front faces down, toward the dust
            v = np.array([[2, 0, roof], [8, 0, roof], [8, 5, roof], [2, 5, roof]], float)
            scene.add_background(scene.add_mesh(v, np.array([[0, 2, 1], [0, 3, 2]])), np.eye(4), (1.0, 1.0, 1.0))
            scene.commit()
        out[roof] = _core.render(scene, camera, sun, medium=medium)
    open_sky, above, through = (out[k]["rgb"][..., 0] for k in (None, 1.0, 0.0))
    middle = slice(h // 2 - 3, h // 2 + 3)  # lines of sight within 10 cm of the puff's centre height
    high, low = slice(h // 2 - 8, h // 2 - 3), slice(h // 2 + 3, h // 2 + 8)  # 10-25 cm above, below
    # Columns 0-6 (x_cam < -17 px): lines of sight whose dust lies at y > 0.39 m wherever they
    # cross the puff's reach (x >= 2.36 m), in the roof's shadow. They are dark, the rim of the
    # reach too: every node that shares a cell with a dusty one traces its own visibility. When
    # an empty node counted as lit, a dusty node in shadow blended with it there, and the rim kept
    # up to 0.5-0.9 % of the open sky's light.
    assert open_sky[middle, :7].min() > 0.0
    assert above[middle, :7].max() <= 1e-6 * open_sky[middle, :7].max()
    assert through[low, :7].max() <= 1e-6 * open_sky[low, :7].max()
    # The dust above the roof through its middle, and at y < -0.1 m, is lit as under the open sky.
    np.testing.assert_allclose(through[high, :8], open_sky[high, :8], rtol=1e-6)
    np.testing.assert_allclose(above[middle, 28:], open_sky[middle, 28:], rtol=1e-6)
    # The grid spans the puff's reach on each side: one Sun ray a line with dust or beside it (the
    # + 2: a line each side), not one a node (about (2 reach / voxel)³ · π/6 ≈ 1.4e5 of those).
    # The roof above the dust adds none; the roof through it one for each line it stops with dust
    # beyond it.
    lines = (2 * sigma * np.sqrt(2 * np.log(peak / 1e-4)) / voxel + 2) ** 2
    assert 0 < out[None]["medium_rays"] == out[1.0]["medium_rays"] <= lines
    assert out[None]["medium_rays"] < out[0.0]["medium_rays"] <= 2 * lines


def test_medium_arguments_name_the_field():
    with pytest.raises(ValueError, match="puffs"):
        _core.Medium(np.zeros((2, 4)))
    with pytest.raises(ValueError, match="sigma_m"):
        _core.Medium([[0, 0, 0, -1.0, 1.0]])
    with pytest.raises(ValueError, match="voxel_m"):
        _core.Medium([[0, 0, 0, 1.0, 1.0]], voxel_m=0.0)
    with pytest.raises(ValueError, match="asymmetry"):
        _core.Medium([[0, 0, 0, 1.0, 1.0]], asymmetry=1.0)
    with pytest.raises(ValueError, match="albedo"):
        _core.Medium([[0, 0, 0, 1.0, 1.0]], albedo=(0.5, 2.0, 0.5))
    for stride in (0, 3, 16):
        with pytest.raises(ValueError, match="march_stride_px"):
            _core.Medium([[0, 0, 0, 1.0, 1.0]], march_stride_px=stride)


def test_cloud_puffs_are_a_pure_function_of_time():
    a = _core.cloud_puffs(_core.CloudParams(), 11, 7.0)
    assert a.shape[0] == pytest.approx(40 * 5, abs=2)  # rate × lifetime alive
    np.testing.assert_array_equal(a, _core.cloud_puffs(_core.CloudParams(), 11, 7.0))
    assert not np.array_equal(a, _core.cloud_puffs(_core.CloudParams(), 12, 7.0))
    # Without gravity each puff drifts in a straight line: 0.1 s later, the puffs still alive
    # moved by at most 0.1 s × 0.7 m/s, and grew by 0.1 s × 0.08 m/s.
    b = _core.cloud_puffs(_core.CloudParams(), 11, 7.1)
    common = min(len(a), len(b)) - 8
    moved = np.linalg.norm(b[:common, :3] - a[4 : 4 + common, :3], axis=1)
    assert moved.max() <= 0.07 + 1e-12
    np.testing.assert_allclose(b[:common, 3] - a[4 : 4 + common, 3], 0.008, atol=1e-12)
    # Opacity rises then falls: the peak optical depth through a centre stays ≤ the configured one.
    through = a[:, 4] * a[:, 3] * np.sqrt(2 * np.pi)
    assert through.max() <= 0.25 + 1e-12
    # The first puff, at birth, is transparent: left out.
    assert len(_core.cloud_puffs(_core.CloudParams(), 11, 0.0)) == 0
    with pytest.raises(ValueError, match="lifetime_s"):
        _core.cloud_puffs(_core.CloudParams(lifetime_s=0.0), 1, 1.0)
    with pytest.raises(ValueError, match="time_s"):
        _core.cloud_puffs(_core.CloudParams(), 1, -1.0)


def test_fragment_mesh_is_closed_outward_and_inside_each_fragment():
    scene = wall_scene()
    state = _core.simulate_ejecta(scene, _core.EjectaParams(count=30), seed=2, time_s=0.3)
    v, t = state["vertices"].astype(float), state["triangles"]
    assert v.shape == (30 * 12, 3) and t.shape == (30 * 20, 3)
    for f in range(30):
        tri = t[20 * f : 20 * f + 20]
        assert tri.min() == 12 * f and tri.max() == 12 * f + 11
        p = v[tri]
        volume = np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6
        assert volume > 0  # outward winding
        edges = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
        _, counts = np.unique(edges, axis=0, return_counts=True)
        assert np.all(counts == 2)  # closed: every edge shared by two faces
        r = np.linalg.norm(v[12 * f : 12 * f + 12] - state["position"][f], axis=1)
        assert r.max() <= state["diameter"][f] / 2 * (1 + 1e-6)
        assert r.min() >= 0.6 * state["diameter"][f] / 2 * (1 - 1e-6)


def test_moving_a_mesh_rebuilds_it_alone():
    scene = wall_scene()
    state = _core.simulate_ejecta(scene, _core.EjectaParams(count=10), seed=2, time_s=0.2)
    mesh = scene.add_mesh(state["vertices"], state["triangles"])
    scene.add_background(mesh, np.eye(4), (0.1, 0.1, 0.1))
    scene.commit()
    before = scene.bvh_builds
    # (It collides with the old mesh too.)
    later = _core.simulate_ejecta(scene, _core.EjectaParams(count=10), seed=2, time_s=0.4)
    scene.update_mesh(mesh, later["vertices"])
    assert not scene.committed
    scene.commit()
    assert scene.bvh_builds == before + 2  # this mesh's BVH and the top level, nothing else
    with pytest.raises(ValueError, match="vertices"):
        scene.update_mesh(mesh, later["vertices"][:-1])
    with pytest.raises(ValueError, match="mesh"):
        scene.update_mesh(99, later["vertices"])
    bad = later["vertices"].copy()
    bad[3, 1] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        scene.update_mesh(mesh, bad)
