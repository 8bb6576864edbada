"""The renderer's geometry against analytic answers: projection, mask boundaries, depth of
tilted planes, mask areas, hard cases (camera straight above, grazing Sun, kilometre
coordinates) and thread-count independence."""

from __future__ import annotations

import numpy as np
import pytest

from moonbot import _core
from moonbot.scene.orbit import CameraPose, orbit_pose

from scenes import K_for, camera, ground_and_box, pixel_directions, plane, rotation_x, translation

pytestmark = pytest.mark.unit

W, H = 96, 72


def test_camera_project_matches_K_R_t():
    """`Camera.project` is x ~ K (R X + t), with pixel centres at +0.5 and z-depth as third value."""
    K = K_for(W, H, 80.0)
    pose = orbit_pose(np.array([0.1, -0.2, 0.05]), 1.3, 0.7, 33.0)
    points = np.array([[0.1, -0.2, 0.05], [0.5, 0.4, 0.0], [-0.3, 0.2, 0.3]])
    cam = (pose.R @ points.T).T + pose.t
    expected = np.column_stack(
        [K[0, 0] * cam[:, 0] / cam[:, 2] + K[0, 2], K[1, 1] * cam[:, 1] / cam[:, 2] + K[1, 2], cam[:, 2]]
    )
    got = camera(K, W, H, pose).project(points)
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-12)
    # The orbit target projects onto the image centre.
    np.testing.assert_allclose(got[0, :2], [W / 2, H / 2], atol=1e-9)


def test_mask_boundary_sits_where_K_predicts():
    """Looking straight down on a box top, a pixel is labelled exactly when its centre's ray
    falls inside the top face's projection (K, pixel centres at +0.5)."""
    scene, box_world = ground_and_box(box_size=(0.4, 0.3, 0.2))
    K = K_for(W, H, 100.0)
    pose = orbit_pose(np.zeros(3), 0.0, 2.0, 0.0)  # straight above, 2 m over the ground
    out = _core.render(scene, camera(K, W, H, pose), _core.DirectionalLight(0, 60), passes=["instance", "depth"])
    # Intersect each pixel-centre ray with the top plane z = 0.2 and test the face bounds.
    d = pixel_directions(K, pose, W, H)
    c = pose.center
    t = (0.2 - c[2]) / d[..., 2]
    p = c + t[..., None] * d
    inside = (np.abs(p[..., 0]) < 0.2) & (np.abs(p[..., 1]) < 0.15)
    # Pixels whose centre lies within 1e-6 m of an edge are ambiguous; there are none here.
    margin = np.minimum(np.abs(np.abs(p[..., 0]) - 0.2), np.abs(np.abs(p[..., 1]) - 0.15))
    assert margin.min() > 1e-6
    np.testing.assert_array_equal(out["instance"] == 1, inside)
    np.testing.assert_allclose(out["depth"][inside], 1.8, rtol=1e-6)


@pytest.mark.parametrize("tilt_deg", [0.0, 25.0, 60.0, 85.0], ids=lambda a: f"tilt{a:g}")
def test_tilted_plane_depth_is_analytic_z_depth(tilt_deg):
    """A plane tilted about x at a known distance: every hit pixel's depth equals the analytic
    z-depth n·(p0 − c) / n·d (d with camera-z 1) to 1e-5 relative."""
    scene = _core.Scene()
    m = scene.add_mesh(*plane(500.0))
    world = translation(0.0, 3.0, 0.0) @ rotation_x(tilt_deg)
    scene.add_background(m, world, (0.2, 0.2, 0.2))
    scene.commit()
    K = K_for(W, H, 60.0)
    pose = orbit_pose(np.array([0.0, 3.0, 0.0]), 2.5, 1.5, 200.0)
    out = _core.render(scene, camera(K, W, H, pose), _core.DirectionalLight(0, 45), passes=["depth"])
    n = world[:3, :3] @ np.array([0.0, 0.0, 1.0])
    d = pixel_directions(K, pose, W, H)
    t = (n @ (world[:3, 3] - pose.center)) / (d @ n)
    hit = out["depth"] > 0
    assert hit.sum() > 0.5 * W * H
    np.testing.assert_allclose(out["depth"][hit], t[hit], rtol=1e-5)
    assert np.all((t[~hit] <= 0) | (t[~hit] > 400))  # misses only beyond the plane's edge


def test_box_seen_head_on_has_its_projected_area():
    """A box face perpendicular to the optical axis covers (f·w/Z)·(f·h/Z) pixels, up to the
    pixels its one-pixel border cuts."""
    size = (0.3, 0.2, 0.4)
    scene, _ = ground_and_box(box_size=size)
    K = K_for(W, H, 90.0)
    # Camera level with the box centre, 1.5 m south of its south face, looking north.
    R = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])
    eye = np.array([0.0, -0.1 - 1.5, 0.2])
    pose = CameraPose(R=R, t=-R @ eye)
    out = _core.render(scene, camera(K, W, H, pose), _core.DirectionalLight(0, 60), passes=["instance"])
    z = 1.5
    w_px, h_px = K[0, 0] * size[0] / z, K[1, 1] * size[2] / z
    border = 2 * (w_px + h_px) + 4
    assert abs((out["instance"] == 1).sum() - w_px * h_px) <= border


def test_outputs_identical_for_one_and_two_threads():
    """Counter-based sampling: rgb, depth and labels are bit-identical whatever the thread count."""
    scene, _ = ground_and_box()
    K = K_for(W, H, 70.0)
    cam = camera(K, W, H, orbit_pose(np.array([0, 0, 0.2]), 1.0, 0.5, 40.0))
    runs = [
        _core.render(scene, cam, _core.DirectionalLight(120, 12), _core.RenderSettings(spp=8, seed=5, threads=n))
        for n in (1, 2)
    ]
    for name in ("rgb", "depth", "instance"):
        assert runs[0][name].tobytes() == runs[1][name].tobytes(), name


def test_only_requested_passes_cost_rays():
    """A scene runs only what it calls for: a depth/instance-only render traces one camera ray per pixel and no shadow
    ray; the RGB pass adds spp camera rays and at most one shadow ray per sample; rendering
    never rebuilds a BVH."""
    scene, _ = ground_and_box()
    builds = scene.bvh_builds
    cam = camera(K_for(W, H, 70.0), W, H, orbit_pose(np.array([0, 0, 0.2]), 1.0, 0.5, 40.0))
    geometry = _core.render(
        scene, cam, _core.DirectionalLight(120, 12), _core.RenderSettings(spp=4), passes=["depth", "instance"]
    )
    assert set(geometry) >= {"depth", "instance"} and "rgb" not in geometry
    assert geometry["camera_rays"] == W * H and geometry["shadow_rays"] == 0
    full = _core.render(scene, cam, _core.DirectionalLight(120, 12), _core.RenderSettings(spp=4))
    assert full["camera_rays"] == W * H * (1 + 4)
    assert 0 < full["shadow_rays"] <= W * H * 4
    # Sun below the horizon: the ground faces away (no ray), the box's vertical faces still face
    # it and trace a shadow ray, which the ground blocks. The image is black.
    night = _core.render(scene, cam, _core.DirectionalLight(120, -5), _core.RenderSettings(spp=4))
    assert night["shadow_rays"] < full["shadow_rays"] / 4 and not night["rgb"].any()
    assert scene.bvh_builds == builds


def test_geometry_passes_render_without_a_light():
    """sun=None renders depth and instance alone, the same as with a light; the passes a light
    shades (rgb, and what lights it: earth, medium, light_cache) refuse it, naming the argument."""
    scene, _ = ground_and_box()
    cam = camera(K_for(W, H, 70.0), W, H, orbit_pose(np.array([0, 0, 0.2]), 1.0, 0.5, 40.0))
    lit = _core.render(scene, cam, _core.DirectionalLight(120, 12), passes=["depth", "instance"])
    unlit = _core.render(scene, cam, None, passes=["depth", "instance"])
    assert unlit["depth"].tobytes() == lit["depth"].tobytes()
    assert unlit["instance"].tobytes() == lit["instance"].tobytes()
    assert unlit["shadow_rays"] == 0 and unlit["camera_rays"] == lit["camera_rays"]
    with pytest.raises(ValueError, match="^sun: is None"):
        _core.render(scene, cam, None)
    with pytest.raises(ValueError, match="^sun: is None"):
        _core.render(scene, cam, None, passes=["depth"], earth=_core.DirectionalLight(0, 30, 1.0))


def test_camera_straight_above_is_stable():
    """Hard case: the orbit at radius 0 (camera straight above the target) gives an exact
    rotation and a finite image with the target under the principal point."""
    scene, _ = ground_and_box()
    K = K_for(W, H, 70.0)
    for azimuth in (0.0, 90.0, 271.0):
        pose = orbit_pose(np.array([0.0, 0.0, 0.2]), 0.0, 1.0, azimuth)
        np.testing.assert_allclose(pose.R @ pose.R.T, np.eye(3), atol=1e-15)
        assert np.linalg.det(pose.R) == pytest.approx(1.0, abs=1e-15)
        out = _core.render(scene, camera(K, W, H, pose), _core.DirectionalLight(120, 12), _core.RenderSettings(spp=2))
        assert np.isfinite(out["rgb"]).all()
        assert out["instance"][H // 2, W // 2] == 1
        assert out["depth"][H // 2, W // 2] == pytest.approx(1.0 - 0.2, rel=1e-6)


@pytest.mark.parametrize("elevation", [0.5, 1.0, 5.0])
def test_grazing_sun_on_a_plane_has_no_acne(elevation):
    """Hard case: at grazing Sun every pixel of an open plane has the same radiance
    albedo/π · E · sin(el): no self-shadowing speckle."""
    scene = _core.Scene()
    scene.add_background(scene.add_mesh(*plane(1000.0)), np.eye(4), (0.12, 0.12, 0.12))
    scene.commit()
    K = K_for(W, H, 70.0)
    pose = orbit_pose(np.zeros(3), 3.0, 1.0, 10.0)
    out = _core.render(
        scene, camera(K, W, H, pose), _core.DirectionalLight(190, elevation), _core.RenderSettings(spp=4)
    )
    hit = out["depth"] > 0
    expected = 0.12 / np.pi * 1361 * np.sin(np.radians(elevation))
    np.testing.assert_allclose(out["rgb"][hit], expected, rtol=1e-5)


def test_kilometre_coordinates_render_like_the_origin():
    """Hard case: the same scene 2 km from the origin gives the same depth (to float32 rounding
    of the result) and labels; the double-precision hit refinement removes the float32
    intersection error that grows with the coordinates."""
    K = K_for(W, H, 70.0)
    results = []
    for offset in (np.zeros(3), np.array([2000.0, -1500.0, 30.0])):
        shift = translation(*offset)
        scene, _ = ground_and_box(box_world=shift @ translation(0, 0, 0.2), ground_world=shift)
        pose = orbit_pose(offset + np.array([0, 0, 0.2]), 1.0, 0.5, 40.0)
        results.append(
            _core.render(scene, camera(K, W, H, pose), _core.DirectionalLight(120, 30), passes=["depth", "instance"])
        )
    a, b = results
    same = a["instance"] == b["instance"]
    assert same.mean() > 0.995  # edge pixels may flip where a ray grazes a triangle edge
    hit = (a["depth"] > 0) & (b["depth"] > 0) & same
    np.testing.assert_allclose(b["depth"][hit], a["depth"][hit], rtol=2e-6)


def test_identical_bags_share_one_bvh():
    """Eleven bags of one mesh are eleven instances of one prototype: BVH builds are one per
    mesh plus one per commit, however many instances there are, and each keeps its own label."""
    from moonbot.scene.bag_mesh import filled_cuboid

    scene = _core.Scene()
    ground = scene.add_mesh(*plane(20.0))
    bag = scene.add_mesh(*filled_cuboid())
    scene.add_background(ground, np.eye(4), (0.12, 0.12, 0.12))
    for i in range(11):
        scene.add_instance(bag, translation(-2.0 + 0.4 * i, 0.0, 0.068), i + 1, (0.5, 0.4, 0.3))
    scene.commit()
    assert scene.bvh_builds == 2 + 1
    assert scene.instance_count == 12
    K = K_for(W, H, 30.0)
    pose = orbit_pose(np.zeros(3), 0.0, 3.0, 0.0)
    out = _core.render(scene, camera(K, W, H, pose), _core.DirectionalLight(0, 60), passes=["instance"])
    assert set(np.unique(out["instance"])) == set(range(12))


@pytest.mark.parametrize("offset", [0.0, 2000.0, 10000.0], ids=lambda o: f"{o:g}m")
def test_exact_depth_holds_far_from_the_origin(offset):
    """Hard case: with exact_depth the z-depth of a tilted plane matches the analytic value to
    float32 rounding (< 1e-7 relative) however far the scene is from the origin; Embree's own
    float32 distance (exact_depth=False) stays within 2e-4 (its error grows with the offset, and
    is larger in the kernels without FMA: 1.2e-4 at 10 km with SSE and AVX, under 1e-4 with AVX2
    and AVX-512)."""
    scene = _core.Scene()
    world = translation(offset, offset, 0.0) @ rotation_x(10.0)
    scene.add_background(scene.add_mesh(*plane(50.0)), world, (0.1, 0.1, 0.1))
    scene.commit()
    K = K_for(W, H, 120.0)
    pose = orbit_pose(np.array([offset, offset, 0.0]), 1.0, 0.6, 30.0)
    n = world[:3, :3] @ np.array([0.0, 0.0, 1.0])
    d = pixel_directions(K, pose, W, H)
    t = (n @ (world[:3, 3] - pose.center)) / (d @ n)
    errors = {}
    for exact in (True, False):
        out = _core.render(
            scene,
            camera(K, W, H, pose),
            _core.DirectionalLight(0, 45),
            _core.RenderSettings(exact_depth=exact),
            passes=["depth"],
        )
        hit = out["depth"] > 0
        assert hit.mean() > 0.9
        errors[exact] = np.max(np.abs(out["depth"][hit] - t[hit]) / t[hit])
    assert errors[True] < 1e-7
    assert errors[False] < 2e-4


def test_embree_limit_probe_traces_the_renderers_rays():
    """The yardstick is fair: `measure_embree_limit` traces exactly as many camera and shadow
    rays as a spp = 1 render of the same view, one first-bounce ray from every camera hit as the
    renderer does, a second generation from those that hit again, and reports positive times."""
    scene, _ = ground_and_box()
    cam = camera(K_for(W, H, 70.0), W, H, orbit_pose(np.array([0, 0, 0.2]), 1.0, 0.5, 40.0))
    sun = _core.DirectionalLight(120, 12)
    rendered = _core.render(scene, cam, sun)
    limit = _core.measure_embree_limit(scene, cam, sun, threads=1, repeats=1, bounces=2)
    assert limit["camera_rays"] == rendered["camera_rays"] == W * H
    assert limit["shadow_rays"] == rendered["shadow_rays"] > 0
    first, second = limit["bounce_rays"]
    bounced = _core.render(scene, cam, sun, _core.RenderSettings(bounces=1))
    assert first == bounced["bounce_rays"] == np.count_nonzero(bounced["depth"] > 0)
    # The bounce vertices' shadow rays are told apart from the camera hits'.
    assert rendered["bounce_shadow_rays"] == 0
    assert bounced["bounce_shadow_rays"] == bounced["shadow_rays"] - rendered["shadow_rays"] > 0
    assert 0 < limit["bounce_shadow_rays"][0] < first
    assert 0 < second < first  # bounces that leave for the black sky end there
    assert all(
        limit[f"{query}_{kind}_s"] > 0
        for query in ("intersect", "occluded")
        for kind in ("single", "packet8", "packet16", "stream", "stream_from_memory")
    )
    assert all(s > 0 for s in limit["bounce_stream_s"] + limit["bounce_single_s"] + limit["bounce_shadow_stream_s"])
    assert _core.measure_embree_limit(scene, cam, sun, threads=1, repeats=1)["bounce_rays"] == []
    with pytest.raises(ValueError, match="bounces"):
        _core.measure_embree_limit(scene, cam, sun, bounces=17)
    assert limit["threads"] == 1 and limit["timer_overhead_s"] >= 0  # timings are for bench/, not tests
    with pytest.raises(ValueError, match="repeats"):
        _core.measure_embree_limit(scene, cam, sun, repeats=0)


def test_view_inputs_place_the_orbit_camera_and_the_lights():
    """view_inputs: orbit view v sits at azimuth start + v × step, orbit.radius_m from the target
    and above it by at least orbit.height_m (more where the ground rises), looking at the target;
    the camera has the config's image size and projects the target to the image centre; the Sun
    comes from the config, and the Earth only with earthshine."""
    from moonbot.config import load_config
    from moonbot.render.view import view_inputs
    from moonbot.scene import compose_scene

    config = load_config(
        None,
        {
            "terrain.location": "plane",
            "bags.settle.enabled": False,
            "camera.width": 64,
            "camera.height": 48,
            "sun.earthshine": False,
        },
    )
    spec = compose_scene(config)
    o = config.orbit
    for v in (0, 3):
        view = view_inputs(config, spec, v)
        azimuth = np.radians(o.start_azimuth_deg + v * o.step_deg)
        offset = view.pose.center - spec.target
        assert np.hypot(offset[0], offset[1]) == pytest.approx(o.radius_m, abs=1e-9)
        # Azimuth clockwise from North: east = sin, north = cos.
        assert np.arctan2(offset[0], offset[1]) % (2 * np.pi) == pytest.approx(azimuth % (2 * np.pi), abs=1e-9)
        assert offset[2] >= o.height_m - 1e-9
        assert (view.camera.width, view.camera.height) == (64, 48)
        assert view.camera.project(spec.target[None, :])[0, :2] == pytest.approx([32.0, 24.0], abs=1e-6)
        np.testing.assert_allclose(view.camera.center, view.pose.center, atol=1e-9)
        assert view.sun.irradiance == config.sun.irradiance_w_m2 and view.earth is None
    with_earth = load_config(None, {"terrain.location": "plane", "bags.settle.enabled": False, "sun.earthshine": True})
    assert view_inputs(with_earth, compose_scene(with_earth), 0).earth is not None
