"""Lighting against closed forms: a plane under the Sun gives E·f·sin(e) at every
pixel for Lambert and Lunar-Lambert; grazing Suns leave no acne and no leaks; a Sun below the
horizon gives a black, finite image; the photometric functions are reciprocal and conserve
energy; inter-reflection inside an integrating sphere converges bounce by bounce to the
analytic geometric series; noise falls as 1/√spp; and soft shadows come from the Sun's disk."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

from moonbot import _core

pytestmark = pytest.mark.unit

E = 1361.0


def look_at(centre, target, width=64, height=48, f=60.0):
    """A _core.Camera at `centre` looking at `target` (world ENU, z up), and its K."""
    centre, target = np.asarray(centre, float), np.asarray(target, float)
    z = target - centre
    z /= np.linalg.norm(z)
    x = np.cross(z, [0.0, 0.0, 1.0])
    if np.linalg.norm(x) < 1e-9:
        x = np.array([1.0, 0.0, 0.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.stack([x, y, z])  # world → camera rows (OpenCV: x right, y down, z forward)
    t = -R @ centre
    K = np.array([[f, 0, width / 2], [0, f, height / 2], [0, 0, 1]])
    return _core.Camera(f, f, width / 2, height / 2, width, height, R, t), K, R


def pixel_rays(K, R, width, height):
    """Unit world directions (H, W, 3) of the pixel-centre rays."""
    u, v = np.meshgrid(np.arange(width) + 0.5, np.arange(height) + 0.5)
    d = np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones_like(u)], -1) @ R
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def plane_scene(albedo, photometry=None):
    scene = _core.Scene()
    s = 1000.0
    mesh = scene.add_mesh(
        np.array([[-s, -s, 0], [s, -s, 0], [s, s, 0], [-s, s, 0]], np.float32), np.array([[0, 1, 2], [0, 2, 3]])
    )
    scene.add_background(mesh, np.eye(4), (albedo,) * 3, photometry or _core.Photometry())
    scene.commit()
    return scene


def lunar_lambert_shape(mu_i, mu_o, cos_g, b0=1.8, h=0.07):
    """McEwen's Lunar-Lambert with L(g) = exp(−g/60°) and the SHOE surge, written out here
    independently of the core."""
    g = np.degrees(np.arccos(np.clip(cos_g, -1, 1)))
    L = np.exp(-g / 60.0)
    surge = 1.0 + b0 / (1.0 + np.tan(np.radians(g) / 2) / h)
    return (2 * L / (mu_i + mu_o) + 1 - L) * surge


def sun_vector(az, el):
    a, e = math.radians(az), math.radians(el)
    return np.array([math.sin(a) * math.cos(e), math.cos(a) * math.cos(e), math.sin(e)])


@pytest.mark.parametrize("model", ["lambert", "lunar-lambert"])
@pytest.mark.parametrize("elevation", [0.5, 1.0, 5.0, 22.0, 60.0])
def test_plane_under_the_sun_is_E_f_sin_e_at_every_pixel(model, elevation):
    """Every pixel of an open plane sees the whole Sun disk: radiance E·(A/π)·shape·sin(e), with
    the disk sampled, inter-reflection on (a plane never sees itself) and Earthshine off. Grazing
    Suns included: no shadow acne (every pixel lit), nothing leaks."""
    albedo = 0.12
    photometry = _core.Photometry(
        model=model, surge_amplitude=1.8 if model == "lunar-lambert" else 0.0, surge_width=0.07
    )
    scene = plane_scene(albedo, photometry)
    camera, K, R = look_at([1.2, -1.6, 3.0], [0.0, 0.0, 0.0])
    sun = _core.DirectionalLight(200.0, elevation, E, 0.533)
    out = _core.render(scene, camera, sun, _core.RenderSettings(spp=1, light_samples=4, bounces=2))
    d = pixel_rays(K, R, 64, 48)
    s = sun_vector(200.0, elevation)
    mu_i = s[2]
    mu_o = -d[..., 2]
    shape = 1.0 if model == "lambert" else lunar_lambert_shape(mu_i, mu_o, -(d @ s))
    expected = E * albedo / math.pi * shape * mu_i
    assert (out["depth"] > 0).all()
    np.testing.assert_allclose(out["rgb"][..., 0], expected, rtol=1e-3)
    assert out["bounce_rays"] > 0  # the bounces were traced, and found only sky


@pytest.mark.parametrize("elevation", [-0.3, -1.0, -30.0, -90.0])
def test_sun_below_the_horizon_is_a_black_finite_image(elevation):
    scene = plane_scene(0.12, _core.Photometry(model="lunar-lambert", surge_amplitude=1.8, surge_width=0.07))
    camera, _, _ = look_at([3.0, -4.0, 1.5], [0.0, 0.0, 0.0])
    out = _core.render(
        scene,
        camera,
        _core.DirectionalLight(10.0, elevation, E, 0.533),
        _core.RenderSettings(spp=4, light_samples=4, bounces=3),
    )
    assert np.isfinite(out["rgb"]).all() and (out["rgb"] == 0).all()
    assert out["shadow_rays"] == 0


def test_photometry_is_reciprocal_and_conserves_energy():
    rng = np.random.default_rng(3)
    models = [
        _core.Photometry(model="lunar-lambert", phase=phase, surge_amplitude=b0, surge_width=0.07)
        for phase in ("exponential", "mcewen")
        for b0 in (0.0, 1.8)
    ]
    for p in models:
        for _ in range(200):
            a, b = rng.normal(size=3), rng.normal(size=3)
            a[2], b[2] = abs(a[2]), abs(b[2])
            a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
            assert p.shape(a[2], b[2], a @ b) == pytest.approx(p.shape(b[2], a[2], b @ a), rel=1e-14)
        assert p.shape(0.0, 0.5, 0.3) == 0.0 and p.shape(0.5, -0.1, 0.3) == 0.0
    # Directional-hemispherical reflectance of the default regolith (normal albedo 0.12, so
    # A = 0.12 / 2.8) at incidences up to grazing, by quadrature over the outgoing hemisphere.
    default = models[1]
    A = 0.12 / default.shape(1.0, 1.0, 1.0)
    assert default.shape(1.0, 1.0, 1.0) == pytest.approx(2.8)
    n = 120
    theta = (np.arange(n) + 0.5) / n * math.pi / 2
    phi = (np.arange(2 * n) + 0.5) / (2 * n) * 2 * math.pi
    T, P = np.meshgrid(theta, phi, indexing="ij")
    out = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1)
    dw = (math.pi / 2 / n) * (math.pi / n) * np.sin(T)
    shape = np.vectorize(default.shape)
    for incidence in (0.0, 45.0, 80.0, 89.5):
        s = np.array([math.sin(math.radians(incidence)), 0.0, math.cos(math.radians(incidence))])
        albedo = float((A / math.pi * shape(s[2], out[..., 2], out @ s) * out[..., 2] * dw).sum())
        assert 0.0 < albedo < 1.0
    # At normal albedo 1 (the config's upper bound) too: A = 1/2.8, shape integrates to < 2.3.
    s = np.array([math.sin(math.radians(89.5)), 0.0, math.cos(math.radians(89.5))])
    assert float((shape(s[2], out[..., 2], out @ s) * out[..., 2] * dw).sum()) / math.pi / 2.8 < 1.0


def integrating_sphere(hole_deg=40.0, subdivisions=5):
    """A unit icosphere open at the top (triangles whose centroid is above cos(hole)); returns
    the mesh arrays, the hole's projected area (what a vertical beam brings in) and the share of
    the sphere's area that is open."""
    sphere = trimesh.creation.icosphere(subdivisions=subdivisions)
    centroids = sphere.triangles_center
    hole = centroids[:, 2] > math.cos(math.radians(hole_deg))
    areas = sphere.area_faces
    projected = float((np.abs(sphere.face_normals[hole, 2]) * areas[hole]).sum())
    return (
        sphere.vertices.astype(np.float32),
        sphere.faces[~hole].astype(np.int64),
        projected,
        float(areas[hole].sum() / areas.sum()),
        float(areas.sum()),
    )


@pytest.mark.parametrize("bounces", [1, 2, 3])
def test_integrating_sphere_converges_to_the_geometric_series(bounces):
    """Light enters a Lambertian sphere (albedo ρ) through a hole at its top and falls on its
    floor. Inside a sphere a Lambertian emitter irradiates every point equally, so after the
    first reflection the wall's irradiance is E₁ = ρ·P₀/A and each further reflection multiplies
    it by ρ(1 − f), f the hole's share of the area A. A wall the Sun cannot see directly then
    has radiance ρ/π·E₁·Σ_{k<N} (ρ(1 − f))^k with N bounces."""
    rho = 0.5
    vertices, faces, projected, f, area = integrating_sphere()
    scene = _core.Scene()
    mesh = scene.add_mesh(vertices, faces)
    scene.add_background(mesh, np.eye(4), (rho,) * 3)
    scene.commit()
    camera, _, _ = look_at([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], width=64, height=16, f=60.0)
    out = _core.render(
        scene, camera, _core.DirectionalLight(0.0, 90.0, E), _core.RenderSettings(spp=256, bounces=bounces, seed=11)
    )
    e1 = rho * E * projected / area
    expected = rho / math.pi * e1 * sum((rho * (1 - f)) ** k for k in range(bounces))
    measured = float(out["rgb"][..., 1].mean())
    assert measured == pytest.approx(expected, rel=0.02)
    # Bounce by bounce the series' next term is visible: more bounces, brighter walls.
    if bounces > 1:
        fewer = _core.render(
            scene,
            camera,
            _core.DirectionalLight(0.0, 90.0, E),
            _core.RenderSettings(spp=256, bounces=bounces - 1, seed=11),
        )
        assert measured > float(fewer["rgb"][..., 1].mean())


def test_noise_falls_faster_than_one_over_root_spp():
    """Inside the integrating sphere, where every pixel's value is a Monte Carlo estimate of the
    same radiance: the RMS deviation from a high-sample reference falls by more than the half per
    4× samples that independent random numbers give (1/sqrt(spp)): the sampler's stratified
    points (sampler.h) make it about 9× from 4 to 64 spp, against 4×."""
    vertices, faces, *_ = integrating_sphere()
    scene = _core.Scene()
    scene.add_background(scene.add_mesh(vertices, faces), np.eye(4), (0.5,) * 3)
    scene.commit()
    camera, _, _ = look_at([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], width=32, height=16, f=60.0)
    sun = _core.DirectionalLight(0.0, 90.0, E)
    reference = _core.render(scene, camera, sun, _core.RenderSettings(spp=4096, bounces=1, seed=1))["rgb"][..., 1]
    rmse = {
        spp: float(
            np.sqrt(
                np.mean(
                    (
                        _core.render(scene, camera, sun, _core.RenderSettings(spp=spp, bounces=1, seed=2))["rgb"][
                            ..., 1
                        ]
                        - reference
                    )
                    ** 2
                )
            )
        )
        for spp in (4, 16, 64)
    }
    assert rmse[4] / rmse[16] > 2.0 and rmse[16] / rmse[64] > 2.0
    assert rmse[4] / rmse[64] > 6.0


def test_soft_shadow_edge_has_the_penumbra_of_the_sun_disk():
    """A wall's shadow on the plane: with a point Sun the edge is a step; with the 0.533° disk the
    lit fraction ramps over the penumbra H·θ/sin²(e) (H the wall's height, θ the disk in radians:
    the shadow's edge moves by H·dcot(e) = H·de/sin²(e) across the disk) and is one half on the
    geometric edge."""
    scene = _core.Scene()
    s = 50.0
    plane = scene.add_mesh(
        np.array([[-s, -s, 0], [s, -s, 0], [s, s, 0], [-s, s, 0]], np.float32), np.array([[0, 1, 2], [0, 2, 3]])
    )
    scene.add_background(plane, np.eye(4), (0.5,) * 3)
    # A thin wall along x at y = 0, 1 m high: the Sun in the north (az 0) casts its shadow south.
    wall = scene.add_mesh(
        np.array([[-20, 0, 0], [20, 0, 0], [20, 0, 1], [-20, 0, 1]], np.float32), np.array([[0, 1, 2], [0, 2, 3]])
    )
    scene.add_background(wall, np.eye(4), (0.5,) * 3)
    scene.commit()
    elevation = 20.0
    edge = -1.0 / math.tan(math.radians(elevation))  # where the top of the wall's shadow falls
    penumbra = 1.0 * math.radians(0.533) / math.sin(math.radians(elevation)) ** 2  # H·θ/sin²(e)
    # Looking straight down on the shadow's edge: pixel rows run along y.
    camera, K, R = look_at([0.0, edge, 2.0], [0.0, edge + 1e-9, 0.0], width=16, height=200, f=2000.0)
    lit = E * 0.5 / math.pi * math.sin(math.radians(elevation))
    hard = (
        _core.render(scene, camera, _core.DirectionalLight(0.0, elevation, E, 0.0), _core.RenderSettings(spp=1))["rgb"][
            ..., 0
        ]
        / lit
    )
    soft = (
        _core.render(
            scene,
            camera,
            _core.DirectionalLight(0.0, elevation, E, 0.533),
            _core.RenderSettings(spp=16, light_samples=64, seed=5),
        )["rgb"][..., 0]
        / lit
    )
    d = pixel_rays(K, R, 16, 200)
    y = (edge + 2.0 * d[..., 1] / -d[..., 2])[:, 8]  # ground y of each row (centre column)
    assert np.all((np.abs(hard) < 1e-6) | (np.abs(hard - 1.0) < 1e-6))
    assert np.array_equal(hard[:, 8] > 0.5, y < edge)  # the hard edge is the geometric one
    # Between the wall (y = 0) and the edge is shadow; beyond the edge (y < edge), sunlight.
    profile = soft.mean(axis=1)
    inside = np.abs(y - edge) < 0.1 * penumbra
    assert np.all(np.abs(profile[inside] - 0.5) < 0.15)
    assert profile[y < edge - penumbra / 2].min() > 0.97 and profile[y > edge + penumbra / 2].max() < 0.03
    ramp = (y > edge - penumbra / 2) & (y < edge + penumbra / 2)
    assert np.all(np.diff(profile[ramp][np.argsort(y[ramp])]) < 0.05)  # falls monotonically (to noise)


def test_vertex_albedo_scales_radiance_and_varies_over_a_site():
    """A per-vertex albedo factor multiplies the radiance where it is (interpolated across each
    triangle); the procedural sites vary by at most ±albedo_variation, brighter on the crater's
    fresh ejecta."""
    from moonbot.config import load_config
    from moonbot.terrain.albedo import albedo_factor

    s = 100.0
    vertices = np.array([[-s, -s, 0], [s, -s, 0], [s, s, 0], [-s, s, 0]], np.float32)
    camera, _, _ = look_at([1.2, -1.6, 3.0], [0.0, 0.0, 0.0])
    sun = _core.DirectionalLight(200.0, 30.0, E, 0.533)
    images = []
    for factor in (None, np.full(4, 0.5, np.float32)):
        scene = _core.Scene()
        mesh = scene.add_mesh(vertices, np.array([[0, 1, 2], [0, 2, 3]]), vertex_albedo=factor)
        scene.add_background(mesh, np.eye(4), (0.2,) * 3)
        scene.commit()
        images.append(_core.render(scene, camera, sun, _core.RenderSettings(light_samples=4))["rgb"])
    np.testing.assert_allclose(images[1], 0.5 * images[0], rtol=1e-6)
    with pytest.raises(ValueError, match="vertex_albedo: must be finite and >= 0"):
        _core.Scene().add_mesh(vertices, np.array([[0, 1, 2]]), vertex_albedo=np.array([1, 1, -1, 1], np.float32))

    x, y = np.meshgrid(np.linspace(-1000, 1000, 201), np.linspace(-1000, 1000, 201))
    flat = albedo_factor(load_config(None, {"terrain.location": "flat"}).terrain, x, y)
    assert flat.dtype == np.float32 and 0.8 <= flat.min() and flat.max() <= 1.2
    assert abs(float(flat.mean()) - 1.0) < 0.05 and flat.std() > 0.01
    crater = load_config(None, {"terrain.location": "crater", "terrain.albedo_variation": 0.0}).terrain
    rim = albedo_factor(crater, np.array([12.0 + 10.0, 12.0 + 25.0, 12.0 + 100.0]), np.zeros(3))
    np.testing.assert_allclose(rim, [1.5, 1.0 + 0.5 * 2.5**-3, 1.0], rtol=1e-6)


def test_effects_not_asked_for_trace_no_rays():
    """A scene runs only what it calls for: no bounce ray without bounces, no shadow ray toward an Earth that is not
    there, and one shadow ray a hit toward a point Sun however many disk samples are asked."""
    scene = plane_scene(0.12)
    camera, _, _ = look_at([1.2, -1.6, 3.0], [0.0, 0.0, 0.0])
    hits = 64 * 48
    direct = _core.render(
        scene, camera, _core.DirectionalLight(200.0, 30.0, E, 0.533), _core.RenderSettings(light_samples=3, bounces=0)
    )
    assert direct["bounce_rays"] == 0 and direct["shadow_rays"] == 3 * hits
    point = _core.render(
        scene, camera, _core.DirectionalLight(200.0, 30.0, E, 0.0), _core.RenderSettings(light_samples=3)
    )
    assert point["shadow_rays"] == hits
    earth = _core.DirectionalLight(20.0, 40.0, 0.1, 1.9, (0.85, 0.95, 1.2))
    with_earth = _core.render(
        scene, camera, _core.DirectionalLight(200.0, 30.0, E, 0.533), _core.RenderSettings(light_samples=3), earth=earth
    )
    assert with_earth["shadow_rays"] == 4 * hits  # the Earth's one a hit on top of the Sun's three
    assert (with_earth["rgb"] > direct["rgb"]).all()
    dark = _core.render(
        scene, camera, _core.DirectionalLight(200.0, 30.0, 0.0, 0.533), _core.RenderSettings(light_samples=3, bounces=2)
    )
    assert dark["shadow_rays"] == 0 and dark["bounce_rays"] == 0 and (dark["rgb"] == 0).all()


def test_vertex_normals_shade_a_tessellated_sphere_as_a_sphere():
    """A coarse icosphere (320 facets) lit by a point Sun: with its vertex normals the shading
    follows the true sphere's cosine, E·a/π·max(0, n·s) at each hit, several times closer than
    flat facets do; the silhouette and shadows still follow the triangles."""
    sphere = trimesh.creation.icosphere(subdivisions=2)
    vertices = sphere.vertices.astype(np.float32)
    camera, K, R = look_at([0.0, -4.0, 0.0], [0.0, 0.0, 0.0], width=96, height=96, f=120.0)
    sun = _core.DirectionalLight(60.0, 35.0, E)
    s = sun_vector(60.0, 35.0)
    errors = {}
    for smooth in (False, True):
        scene = _core.Scene()
        mesh = scene.add_mesh(vertices, sphere.faces, vertex_normals=vertices if smooth else None)
        scene.add_background(mesh, np.eye(4), (0.5,) * 3)
        scene.commit()
        out = _core.render(scene, camera, sun)
        hit = out["depth"] > 0
        d = pixel_rays(K, R, 96, 96)
        # Depth is camera z; the hit point is the camera centre + depth × (ray with camera-z 1).
        points = np.array([0.0, -4.0, 0.0]) + (out["depth"][..., None] / (d @ R[2])[..., None]) * d
        normal = points / np.linalg.norm(points, axis=-1, keepdims=True)
        expected = E * 0.5 / math.pi * np.maximum(0.0, normal @ s)
        lit = hit & (expected > 0.2 * expected.max())  # away from the terminator
        errors[smooth] = float(np.abs(out["rgb"][..., 0] - expected)[lit].mean() / expected[lit].mean())
    assert errors[True] < 0.25 * errors[False]
    assert errors[True] < 0.01


@pytest.mark.parametrize("incidence", [70.0, 87.0])
@pytest.mark.parametrize("slope_deg", [15.0, 30.0, 60.0])
def test_lit_slope_is_uniform(slope_deg, incidence):
    """A Lambertian slope 4 km across in two triangles (the `slope` location's extent) under a Sun
    20° or 3° above it shines E·(A/π)·cos i at every pixel: no shadow acne, however large its
    triangles."""
    from moonbot.terrain.ground import SlopedGround

    ground = SlopedGround(slope_deg, downhill_azimuth_deg=90.0, size_m=4000.0)
    h = 2000.0
    corners = np.array([[-h, -h], [h, -h], [h, h], [-h, h]])
    scene = _core.Scene()
    mesh = scene.add_mesh(
        np.column_stack([corners, ground.height(corners[:, 0], corners[:, 1])]).astype(np.float32),
        np.array([[0, 1, 2], [0, 2, 3]]),
    )
    albedo = 0.12
    scene.add_background(mesh, np.eye(4), (albedo,) * 3)
    scene.commit()
    # The slope falls toward +x, so its normal leans toward +x by slope_deg from the zenith. A Sun
    # whose zenith angle, signed toward +x, is slope_deg − incidence meets it at that incidence.
    tilt = slope_deg - incidence
    elevation, azimuth = 90.0 - abs(tilt), (90.0 if tilt >= 0 else 270.0)
    sun = _core.DirectionalLight(azimuth, elevation, E)
    n = ground.plane()[1]
    cos_i = float(np.dot(n, sun.direction))
    assert cos_i == pytest.approx(math.cos(math.radians(incidence)), abs=1e-9)
    # Downhill of the origin, 2.5 m above the slope, looking uphill: the slope fills the view.
    camera, _, _ = look_at(
        (2.0, -1.5, 2.5 + ground.height(2.0, -1.5)),
        (-0.5, 0.5, ground.height(-0.5, 0.5)),
        width=160,
        height=120,
        f=120.0,
    )
    out = _core.render(
        scene, camera, sun, _core.RenderSettings(spp=1, seed=0, threads=2, bounces=0), passes=["rgb", "depth"]
    )
    ground = out["depth"] > 0  # the rest is sky past the steepest slope's contour
    assert ground.mean() > 0.6
    radiance = out["rgb"][ground][:, 0]
    expected = E * albedo / math.pi * cos_i
    assert np.abs(radiance / expected - 1).max() < 1e-3, np.mean(radiance < 0.8 * expected)
