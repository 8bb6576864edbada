"""Bad input at the Python boundary: every binding of `moonbot._core` either succeeds or raises
ValueError / TypeError / OSError, never crashes; each defect the core checks raises ValueError
naming the argument. Property tests (hypothesis, derandomized) throw random shapes, dtypes and
values at every binding; table tests pin the message for each listed defect."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from scenes import plane

from moonbot import _core

ALLOWED = (ValueError, TypeError, OSError)
PROPERTY = settings(max_examples=150, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

# Every numeric dtype numpy has, plus the non-numeric ones a user might pass by mistake.
DTYPES = st.sampled_from([np.bool_, np.int8, np.uint8, np.int16, np.uint16, np.int32, np.uint32,
                          np.int64, np.uint64, np.float16, np.float32, np.float64, np.complex64,
                          np.dtype("U3"), np.dtype("M8[s]")])
SHAPES = hnp.array_shapes(min_dims=0, max_dims=4, min_side=0, max_side=5)


def any_array():
    """Arrays of any dtype and shape with any values (NaN, ±inf, extremes included)."""
    return DTYPES.flatmap(lambda dt: hnp.arrays(dt, SHAPES))


def anything():
    """Arrays, scalars, None, strings, lists — whatever a caller might pass."""
    return st.one_of(any_array(), st.none(), st.text(max_size=3), st.integers(),
                     st.floats(allow_nan=True), st.lists(st.floats(), max_size=4),
                     st.lists(st.lists(st.integers(-3, 8), min_size=3, max_size=3), max_size=3))


def identity():
    return np.eye(4)


def good_scene() -> _core.Scene:
    scene = _core.Scene()
    scene.add_background(scene.add_mesh(*plane(10.0)), identity(), (0.1, 0.1, 0.1))
    scene.commit()
    return scene


def good_camera(width=8, height=6) -> _core.Camera:
    R = np.array([[1.0, 0, 0], [0, -1.0, 0], [0, 0, -1.0]])  # looking straight down
    return _core.Camera(5.0, 5.0, width / 2, height / 2, width, height, R, -R @ np.array([0, 0, 2.0]))


def call(fn, *args, **kwargs):
    """Run a binding; only ValueError, TypeError and OSError may escape."""
    try:
        fn(*args, **kwargs)
    except ALLOWED:
        pass


# --- property tests: never a crash, never another exception type -----------------------------

@PROPERTY
@given(vertices=anything(), triangles=anything())
def test_add_mesh_takes_anything(vertices, triangles):
    scene = _core.Scene()
    call(scene.add_mesh, vertices, triangles)


@PROPERTY
@given(world=anything(), albedo=anything(), label=st.integers(-300, 300), mesh=st.integers(0, 3))
def test_add_instance_takes_anything(world, albedo, label, mesh):
    scene = _core.Scene()
    scene.add_mesh(*plane(1.0))
    call(scene.add_instance, mesh, world, label, albedo)
    call(scene.add_background, mesh, world, albedo)


@PROPERTY
@given(values=st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=4, max_size=4),
       width=st.integers(-5, 40), height=st.integers(-5, 40), R=anything(), t=anything())
def test_camera_takes_anything(values, width, height, R, t):
    call(_core.Camera, *values, width, height, R, t)


@PROPERTY
@given(points=anything())
def test_project_takes_anything(points):
    call(good_camera().project, points)


@PROPERTY
@given(az=st.floats(allow_nan=True), el=st.floats(allow_nan=True), e=st.floats(allow_nan=True))
def test_sun_takes_anything(az, el, e):
    call(_core.Sun, az, el, e)


@PROPERTY
@given(spp=st.integers(-3, 5), seed=st.integers(0, 2**64 - 1), threads=st.integers(-2, 3),
       passes=st.lists(st.sampled_from(["rgb", "depth", "instance", "normal", ""]), max_size=4),
       el=st.floats(-90, 90))
def test_render_takes_any_settings(spp, seed, threads, passes, el):
    out = None
    try:
        out = _core.render(good_scene(), good_camera(), _core.Sun(10, el), spp=spp, seed=seed,
                           threads=threads, passes=passes)
    except ALLOWED:
        return
    for name in passes:  # what was asked for came back, finite and the right shape
        assert np.isfinite(out[name]).all() and out[name].shape[:2] == (6, 8)


@PROPERTY
@given(rgb=anything(), exposure=st.floats(allow_nan=True, allow_infinity=True))
def test_tonemap_takes_anything(rgb, exposure):
    call(_core.tonemap_reinhard, rgb, exposure)


@PROPERTY
@given(pixels=anything(), level=st.integers(-2, 11), ext=st.sampled_from([".png", ".exr", ".tif", ".xyz", ""]))
def test_write_image_takes_anything(tmp_path_factory, pixels, level, ext):
    path = tmp_path_factory.mktemp("img") / f"x{ext}"
    call(_core.write_image, str(path), pixels, level)


@PROPERTY
@given(name=st.text(max_size=12), content=st.binary(max_size=64))
def test_read_image_takes_any_file(tmp_path_factory, name, content):
    directory = tmp_path_factory.mktemp("read")
    path = directory / "f.png"
    path.write_bytes(content)
    call(_core.read_image, str(path))
    call(_core.read_image, str(directory / name))


@PROPERTY
@given(lat=st.floats(allow_nan=True), lon=st.floats(allow_nan=True), h=st.floats(allow_nan=True),
       r=st.floats(allow_nan=True))
def test_geo_takes_anything(lat, lon, h, r):
    call(_core.LunarFrame, lat, lon, h, r)
    call(_core.curvature_drop, h, r)


# --- each listed defect: ValueError naming the argument ----------------------------------------

V = plane(1.0)[0]
T = plane(1.0)[1]
BAD_MESHES = {
    "vertices-dtype-int": (V.astype(np.int32), T, "vertices"),
    "vertices-dtype-str": (V.astype("U8"), T, "vertices"),
    "vertices-shape-N2": (V[:, :2], T, "vertices"),
    "vertices-shape-1d": (V.ravel(), T, "vertices"),
    "vertices-nan": (np.where(np.arange(12).reshape(4, 3) == 4, np.nan, V).astype(np.float32), T, "vertices"),
    "vertices-inf": (np.where(np.arange(12).reshape(4, 3) == 0, np.inf, V), T, "vertices"),
    "vertices-empty": (np.zeros((0, 3), np.float32), np.zeros((0, 3), np.int32), "vertices"),
    "triangles-empty": (V, np.zeros((0, 3), np.int32), "triangles"),
    "triangles-dtype-float": (V, T.astype(np.float32), "triangles"),
    "triangles-shape": (V, T[:, :2], "triangles"),
    "triangles-out-of-range": (V, np.array([[0, 1, 4]]), "triangles"),
    "triangles-negative": (V, np.array([[0, -1, 2]]), "triangles"),
    "triangles-uint64-huge": (V, np.array([[0, 1, 2**63 + 5]], np.uint64), "triangles"),
}


@pytest.mark.parametrize(("vertices", "triangles", "name"), BAD_MESHES.values(), ids=BAD_MESHES.keys())
def test_bad_mesh_names_the_argument(vertices, triangles, name):
    with pytest.raises(ValueError, match=name):
        _core.Scene().add_mesh(vertices, triangles)


def test_bad_instance_names_the_argument():
    scene = _core.Scene()
    m = scene.add_mesh(*plane(1.0))
    for label in (0, 256, -1):
        with pytest.raises(ValueError, match="instance_id"):
            scene.add_instance(m, identity(), label, (0.5, 0.5, 0.5))
    scene.add_instance(m, identity(), 7, (0.5, 0.5, 0.5))
    with pytest.raises(ValueError, match="instance_id: 7 is already used"):
        scene.add_instance(m, identity(), 7, (0.5, 0.5, 0.5))
    with pytest.raises(ValueError, match="mesh"):
        scene.add_instance(m + 1, identity(), 8, (0.5, 0.5, 0.5))
    bad_worlds = [np.eye(3), np.zeros((4, 4)), np.full((4, 4), np.nan),
                  np.vstack([np.eye(4)[:3], [1, 0, 0, 1]])]
    for world in bad_worlds:
        with pytest.raises(ValueError, match="world_from_object"):
            scene.add_instance(m, world, 9, (0.5, 0.5, 0.5))
    for albedo in ((0.5, 0.5), (0.5, 0.5, 1.5), (np.nan, 0.1, 0.1), "tan"):
        with pytest.raises(ValueError, match="albedo"):
            scene.add_background(m, identity(), albedo)


CAMERA_OK = dict(fx=5.0, fy=5.0, cx=4.0, cy=3.0, width=8, height=6, R=np.eye(3), t=np.zeros(3))
BAD_CAMERAS = {
    "fx-zero": ({"fx": 0.0}, "fx"), "fx-negative": ({"fx": -1.0}, "fx"), "fy-zero": ({"fy": 0.0}, "fy"),
    "fx-nan": ({"fx": float("nan")}, "fx"), "cx-inf": ({"cx": float("inf")}, "cx"),
    "width-zero": ({"width": 0}, "width"), "height-zero": ({"height": 0}, "height"),
    "width-huge": ({"width": 10**6}, "width"),
    "R-scaled": ({"R": 2 * np.eye(3)}, "R"), "R-reflection": ({"R": np.diag([1.0, 1.0, -1.0])}, "R"),
    "R-shape": ({"R": np.eye(4)}, "R"), "R-nan": ({"R": np.full((3, 3), np.nan)}, "R"),
    "t-shape": ({"t": np.zeros(2)}, "t"), "t-inf": ({"t": np.array([0, np.inf, 0])}, "t"),
}


@pytest.mark.parametrize(("change", "name"), BAD_CAMERAS.values(), ids=BAD_CAMERAS.keys())
def test_bad_camera_names_the_argument(change, name):
    with pytest.raises(ValueError, match=f"^{name}"):
        _core.Camera(**{**CAMERA_OK, **change})


def test_bad_render_settings_name_the_argument():
    scene, cam, sun = good_scene(), good_camera(), _core.Sun(0, 30)
    for kwargs, name in (({"spp": 0}, "spp"), ({"spp": 70000}, "spp"), ({"threads": -1}, "threads"),
                         ({"passes": ["rgb", "normals"]}, "passes"), ({"passes": []}, "passes")):
        with pytest.raises(ValueError, match=name):
            _core.render(scene, cam, sun, **kwargs)
    uncommitted = _core.Scene()
    uncommitted.add_background(uncommitted.add_mesh(*plane(1.0)), identity(), (0.1, 0.1, 0.1))
    with pytest.raises(ValueError, match="scene: not committed"):
        _core.render(uncommitted, cam, sun)
    with pytest.raises(ValueError, match="scene: has no instances"):
        empty = _core.Scene()
        empty.commit()
        _core.render(empty, cam, sun)
    for args, name in (((0, 91), "elevation_deg"), ((0, 10, -1), "irradiance"), ((np.nan, 10), "azimuth_deg")):
        with pytest.raises(ValueError, match=name):
            _core.Sun(*args)


def test_bad_images_name_the_argument_or_path(tmp_path):
    for rgb in (np.zeros((4, 4), np.float32), np.zeros((4, 4, 3), np.uint8), np.zeros((2, 2, 3), "U1")):
        with pytest.raises(ValueError, match="rgb"):
            _core.tonemap_reinhard(rgb, 1.0)
    with pytest.raises(ValueError, match="exposure"):
        _core.tonemap_reinhard(np.zeros((2, 2, 3), np.float32), 0.0)
    for pixels in (np.zeros((4, 4), np.int32), np.zeros((4,), np.uint8), np.zeros((0, 4), np.uint8),
                   np.zeros((4, 4, 5), np.uint8)):
        with pytest.raises(ValueError, match="pixels"):
            _core.write_image(str(tmp_path / "x.png"), pixels)
    with pytest.raises(ValueError, match="png_compression"):
        _core.write_image(str(tmp_path / "x.png"), np.zeros((2, 2), np.uint8), 10)
    missing = tmp_path / "no" / "such" / "dir" / "x.png"
    with pytest.raises(OSError, match="no/such/dir"):
        _core.write_image(str(missing), np.zeros((2, 2), np.uint8))
    with pytest.raises(OSError, match="x.unknown"):
        _core.write_image(str(tmp_path / "x.unknown"), np.zeros((2, 2), np.uint8))
    assert not list(tmp_path.iterdir())  # nothing half-written left behind


def test_scene_cannot_change_while_rendering():
    """A render with the GIL released holds the scene: a concurrent modification from another
    Python thread raises instead of racing Embree's traversal."""
    import threading

    scene = _core.Scene()
    scene.add_background(scene.add_mesh(*plane(10.0)), identity(), (0.1, 0.1, 0.1))
    scene.commit()
    cam = good_camera(1024, 1024)
    errors, done = [], threading.Event()

    def render():
        try:
            for _ in range(5):
                _core.render(scene, cam, _core.Sun(0, 30), spp=2)
        finally:
            done.set()

    thread = threading.Thread(target=render)
    thread.start()
    while not done.is_set():
        try:
            scene.add_mesh(*plane(1.0))
        except RuntimeError as e:  # std::logic_error → RuntimeError
            errors.append(str(e))
    thread.join()
    assert errors and all("while a render is using it" in e for e in errors)
