"""Input checking at the Python boundary of `moonbot._core`, as properties.

The contract (issue: "input checking in the bindings"): whatever a caller passes, a binding either
succeeds or raises ValueError, TypeError or OSError, and never takes the interpreter down; a
well-formed call with one specific defect raises ValueError whose message starts with the name of
the argument as the caller spells it ("vertices: ...", "fx: ...").

Four groups:

* fuzz      hypothesis throws arbitrary shapes, dtypes (bool, every integer width, float16 to
            longdouble, complex, str, bytes, datetime, object, structured, byte-swapped) and
            values (NaN, ±inf, extremes, negatives) at every binding; only the three allowed
            exception types may escape, and a rejected call leaves the scene as it was.
* defects   hypothesis builds a valid call, injects exactly one defect and checks the ValueError
            names the argument.
* tables    one readable parametrized case per bad input the issue lists.
* isolated  inputs that used to crash the interpreter (fixed in 07b277f), or that need gigabytes
            of address space, run in a child interpreter: a regression fails one test instead of
            killing the session.

All hypothesis runs are derandomized and keep no example database, so every run tests the same
examples; the tests write only below pytest's tmp_path (hypothesis itself still caches source
constants in the git-ignored .hypothesis/). Renders stay at most 16x16 pixels.
"""

from __future__ import annotations

import itertools
import json
import math
import pickle
import re
import signal
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from moonbot import _core

pytestmark = pytest.mark.unit

ALLOWED = (ValueError, TypeError, OSError)
MAX_SIDE = 32768  # the camera's largest accepted image side (cpp/src/camera.cpp)
MAX_SPP = 65536  # render's largest accepted sample count (cpp/src/render.cpp)
INT_MIN, INT_MAX = -(2**31), 2**31 - 1

# Generating random arrays is slow by hypothesis' standards, and large random arrays are the point
# of these tests, so those two health checks would only complain about the design.
_SLOW_DATA = [HealthCheck.too_slow, HealthCheck.data_too_large]
FUZZ = settings(max_examples=120, deadline=None, derandomize=True, database=None, suppress_health_check=_SLOW_DATA)
DEFECT = settings(max_examples=60, deadline=None, derandomize=True, database=None, suppress_health_check=_SLOW_DATA)
# The image tests write below pytest's tmp_path, which hypothesis does not reset between examples;
# each example writes into a fresh sub-directory of its own, so sharing tmp_path is harmless.
FUZZ_FILES = settings(FUZZ, max_examples=80, suppress_health_check=[*_SLOW_DATA, HealthCheck.function_scoped_fixture])

_subdirs = itertools.count()


def fresh_dir(tmp_path):
    """A new, empty directory under tmp_path for one hypothesis example."""
    d = tmp_path / f"example{next(_subdirs)}"
    d.mkdir()
    return d


def attempt(fn, *args, **kwargs):
    """Call a binding and return (result, None), or (None, error) for an allowed error type.

    Any other exception propagates and fails the test. numpy's floating-point error reporting is
    silenced for the call, so a huge float64 narrowed to float32 reaches the core's own checks as
    inf. (With the reporting on, pytest's `filterwarnings = error` makes numpy refuse the
    conversion; that path used to crash the interpreter and is checked in a child interpreter by
    test_overflowing_conversion_is_not_fatal, so a regression cannot take this session down.)"""
    name = getattr(fn, "__name__", "call")
    with np.errstate(over="ignore", under="ignore"):
        try:
            result = fn(*args, **kwargs)
        except ALLOWED as error:
            event(f"{name}: {type(error).__name__}")  # see --hypothesis-show-statistics
            return None, error
    event(f"{name}: returned")
    return result, None


def expect_named(name, fn, *args, **kwargs):
    """Assert the call raises ValueError whose message starts with "<name>: "; return the message."""
    with np.errstate(over="ignore", under="ignore"):
        with pytest.raises(ValueError, match=rf"^{re.escape(name)}: ") as info:
            fn(*args, **kwargs)
    return str(info.value)


# --- fixtures of known-good input ---------------------------------------------------------------

QUAD_V = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float32)
QUAD_T = np.array([[0, 1, 2], [0, 2, 3]], np.int32)
GREY = (0.2, 0.2, 0.2)
LOOK_DOWN = np.diag([1.0, -1.0, -1.0])  # camera x = east, y = south, z = down (det +1)


def translation(x, y, z):
    m = np.eye(4)
    m[:3, 3] = (x, y, z)
    return m


def ground_scene(label=None, commit=True):
    """A 20 m ground quad (label 0), optionally a labelled 1 m quad above it, committed."""
    scene = _core.Scene()
    mesh = scene.add_mesh(QUAD_V, QUAD_T)
    scene.add_background(mesh, np.diag([10.0, 10.0, 1.0, 1.0]), GREY)
    if label is not None:
        scene.add_instance(mesh, translation(0, 0, 0.5), label, (0.6, 0.5, 0.4))
    if commit:
        scene.commit()
    return scene


def down_camera(width=8, height=6, f=6.0, altitude=3.0):
    """A camera `altitude` metres above the origin, looking straight down."""
    return _core.Camera(
        f, f, width / 2, height / 2, width, height, LOOK_DOWN, -LOOK_DOWN @ np.array([0.0, 0.0, altitude])
    )


def rotation_from(q):
    """The rotation of quaternion q (any non-zero 4-vector), as a (3, 3) float64 array."""
    w, x, y, z = np.asarray(q, np.float64) / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


# --- strategies ---------------------------------------------------------------------------------

NUMERIC_DTYPES = [
    np.bool_,
    np.int8,
    np.uint8,
    np.int16,
    np.uint16,
    np.int32,
    np.uint32,
    np.int64,
    np.uint64,
    np.float16,
    np.float32,
    np.float64,
    np.longdouble,
]
OTHER_DTYPES = [
    np.complex64,
    np.complex128,
    "U3",
    "S2",
    "M8[s]",
    "m8[ms]",
    "O",
    [("x", "<f4"), ("n", "<i2")],
    ">f8",
    ">i4",
    ">u2",
]
ANY_DTYPE = st.sampled_from([np.dtype(d) for d in NUMERIC_DTYPES + OTHER_DTYPES])
FLOAT_DTYPES = [np.dtype(d) for d in (np.float16, np.float32, np.float64, np.longdouble)]
INT_DTYPES = [np.dtype(d) for d in (np.int8, np.uint8, np.int16, np.uint16, np.int32, np.uint32, np.int64, np.uint64)]
NOT_FLOAT_DTYPES = [np.dtype(d) for d in (np.bool_, np.int32, np.uint8, np.complex128, "U4", "O")]
NOT_NUMBER_DTYPES = [np.dtype(d) for d in (np.complex64, "U4", "S3", "O", "M8[s]")]
PIXEL_DTYPES = [np.dtype(d) for d in (np.uint8, np.uint16, np.float32)]
NON_FINITE = [math.nan, math.inf, -math.inf]


def shapes(*typical):
    """Any shape of 0-4 dimensions with sides 0-6, or one of the `typical` near-misses."""
    return st.one_of(hnp.array_shapes(min_dims=0, max_dims=4, min_side=0, max_side=6), st.sampled_from(typical))


def arrays_of(dtypes, shape_strategy):
    """Arrays of a dtype from `dtypes` and a shape from `shape_strategy`, any values."""
    return st.tuples(dtypes, shape_strategy).flatmap(lambda ds: hnp.arrays(ds[0], ds[1]))


# No integers here: an unbounded integer can be a valid but huge spp or thread count.
JUNK = st.one_of(
    st.none(),
    st.booleans(),
    st.floats(),
    st.complex_numbers(),
    st.text(max_size=4),
    st.binary(max_size=4),
    st.recursive(
        st.one_of(st.floats(), st.integers(-10, 10), st.text(max_size=1)),
        lambda inner: st.lists(inner, max_size=4),
        max_leaves=12,
    ),  # ragged, mixed
    st.builds(object),
)


def anything(*typical):
    """Whatever a caller might pass where an array is expected: arrays of any dtype, any shape
    (including the `typical` near-misses) and any values; rectangular lists; scalars; junk."""
    return st.one_of(
        arrays_of(ANY_DTYPE, shapes(*typical)),
        st.sampled_from(typical).flatmap(  # nested lists of the right-looking shape
            lambda s: hnp.arrays(np.float64, s).map(lambda a: a.tolist())
        ),
        JUNK,
    )


def numpy_scalars():
    """A numpy scalar of any dtype (0-d array element): np.float16(nan), np.uint64(2**64-1), ..."""
    return ANY_DTYPE.flatmap(lambda d: hnp.arrays(d, ())).map(lambda a: a[()])


ANY_FLOAT = st.one_of(st.floats(), st.integers(), numpy_scalars(), JUNK)
ANY_INT = st.one_of(st.integers(-3, 300), st.integers(), numpy_scalars(), JUNK)

VERTEX_SHAPES = ((0, 3), (1, 3), (5, 3), (4, 2), (4, 4), (12,), (3,), (2, 4, 3), (3, 1))
TRIANGLE_SHAPES = ((0, 3), (1, 3), (2, 3), (2, 2), (2, 4), (6,), (1, 2, 3))
MATRIX4_SHAPES = ((4, 4), (3, 4), (4, 3), (3, 3), (16,), (1, 4, 4), (0, 4))
MATRIX3_SHAPES = ((3, 3), (3, 4), (4, 4), (9,), (2, 3), (1, 3, 3))
VECTOR3_SHAPES = ((3,), (2,), (4,), (1, 3), (3, 1), (0,), ())
IMAGE_SHAPES = ((2, 3), (2, 3, 1), (2, 3, 3), (2, 3, 4), (2, 3, 5), (0, 3, 3), (3, 0), (4,), (1, 2, 3, 1), (16, 16, 3))


@st.composite
def layouts(draw, array, lists=True, byteswap=True):
    """The values of `array` in another memory layout or container: as is, Fortran order, a
    strided view, read-only, byte-swapped or as nested lists. A binding must not care."""
    a = np.asarray(array)
    kind = draw(st.sampled_from(["as-is", "fortran", "strided", "read-only", "byteswapped", "list"]))
    if kind == "fortran":
        return np.asfortranarray(a)
    if kind == "strided" and a.ndim and a.shape[0]:
        return np.repeat(a, 2, axis=0)[::2]
    if kind == "read-only":
        a = a.copy()
        a.flags.writeable = False
        return a
    if kind == "byteswapped" and byteswap and a.dtype.byteorder != "|":
        return a.astype(a.dtype.newbyteorder())
    if kind == "list" and lists:
        return a.tolist()
    return a


@st.composite
def calls(draw, valid, wild):
    """Keyword arguments for one call: every argument drawn from `valid`, except at most two
    drawn from `wild`. Mostly-valid calls reach the checks behind the first argument (and the
    success path), which all-random calls almost never do."""
    spoiled = draw(st.sets(st.sampled_from(sorted(wild)), max_size=2))
    return {name: draw(wild[name] if name in spoiled else strategy) for name, strategy in valid.items()}


@st.composite
def rotations(draw, dtype=np.float64):
    """A proper rotation matrix (orthonormal to ~1e-16, det +1)."""
    q = draw(hnp.arrays(np.float64, 4, elements=st.floats(-1, 1)))
    if np.linalg.norm(q) < 0.1:
        q = np.array([1.0, 0.0, 0.0, 0.0])
    return rotation_from(q).astype(dtype)


@st.composite
def transforms(draw):
    """A valid world_from_object: rotation times a per-axis scale in [0.1, 10], plus a shift."""
    m = np.eye(4)
    scale = draw(hnp.arrays(np.float64, 3, elements=st.floats(0.1, 10)))
    m[:3, :3] = draw(rotations()) * scale
    m[:3, 3] = draw(hnp.arrays(np.float64, 3, elements=st.floats(-1e4, 1e4)))
    return m


@st.composite
def meshes(draw):
    """A valid mesh: 1-6 finite vertices of a float dtype, 1-4 triangles of an int dtype."""
    n = draw(st.integers(1, 6))
    vertices = draw(hnp.arrays(st.sampled_from(FLOAT_DTYPES), (n, 3), elements=st.floats(-1e3, 1e3, width=16)))
    m = draw(st.integers(1, 4))
    triangles = draw(hnp.arrays(st.sampled_from(INT_DTYPES), (m, 3), elements=st.integers(0, n - 1)))
    return vertices, triangles


def sized_arrays(dtypes, shape, **kwargs):
    """Arrays of the given shape and a dtype drawn from `dtypes`."""
    return hnp.arrays(st.sampled_from(dtypes), shape, **kwargs)


ALBEDOS = st.one_of(
    st.tuples(st.floats(0, 1), st.floats(0, 1), st.floats(0, 1)),
    sized_arrays(FLOAT_DTYPES, 3, elements=st.floats(0, 1, width=16)).flatmap(layouts),
    hnp.arrays(bool, 3).flatmap(layouts),
)
CAMERA_FIELDS = dict(
    fx=st.floats(1e-3, 1e6),
    fy=st.floats(1e-3, 1e6),
    cx=st.floats(-1e6, 1e6),
    cy=st.floats(-1e6, 1e6),
    width=st.integers(1, MAX_SIDE),
    height=st.integers(1, MAX_SIDE),
    R=st.one_of(rotations(), rotations(np.float32)).flatmap(layouts),
    t=hnp.arrays(np.float64, 3, elements=st.floats(-1e6, 1e6)).flatmap(layouts),
)
SUN_FIELDS = dict(
    azimuth_deg=st.floats(allow_nan=False, allow_infinity=False),
    elevation_deg=st.floats(-90, 90),
    irradiance=st.floats(0, 1e7),
)


# --- fuzz: anything in, only ValueError / TypeError / OSError out --------------------------------

VALID_MESH = dict(
    vertices=st.integers(4, 8)
    .flatmap(lambda n: sized_arrays(FLOAT_DTYPES, (n, 3), elements=st.floats(-1e3, 1e3, width=16)))
    .flatmap(layouts),
    triangles=st.integers(1, 4)
    .flatmap(lambda m: sized_arrays(INT_DTYPES, (m, 3), elements=st.integers(0, 3)))
    .flatmap(layouts),
)
WILD_MESH = dict(vertices=anything(*VERTEX_SHAPES), triangles=anything(*TRIANGLE_SHAPES))


@FUZZ
@given(kwargs=calls(VALID_MESH, WILD_MESH))
def test_add_mesh_survives_anything(kwargs):
    """add_mesh never crashes and raises only the allowed types; a rejected mesh leaves the scene
    untouched (no mesh, no BVH build, still committed), an accepted one gets the next index."""
    scene = ground_scene()
    meshes_before, builds_before = scene.mesh_count, scene.bvh_builds
    index, error = attempt(scene.add_mesh, **kwargs)
    if error is None:
        assert index == meshes_before
        assert (scene.mesh_count, scene.bvh_builds) == (meshes_before + 1, builds_before + 1)
    else:
        assert (scene.mesh_count, scene.bvh_builds) == (meshes_before, builds_before)
    assert scene.committed  # a new prototype does not touch the committed top level


VALID_INSTANCE = dict(
    mesh=st.sampled_from([0, 1, np.uint32(1), np.int64(0)]),
    world_from_object=transforms().flatmap(layouts),
    instance_id=st.integers(1, 255),
    albedo=ALBEDOS,
)
WILD_INSTANCE = dict(
    mesh=ANY_INT, world_from_object=anything(*MATRIX4_SHAPES), instance_id=ANY_INT, albedo=anything(*VECTOR3_SHAPES)
)


@FUZZ
@given(kwargs=calls(VALID_INSTANCE, WILD_INSTANCE), background=st.booleans())
def test_add_instance_survives_anything(kwargs, background):
    """add_instance / add_background never crash and raise only the allowed types. A rejected call
    leaves no trace: the instance count and the committed flag are unchanged and a valid label is
    still free. Whatever was accepted, the scene still commits and renders."""
    scene = ground_scene()
    scene.add_mesh(QUAD_V * 0.1, QUAD_T)  # mesh 1
    before = scene.instance_count
    if background:
        _, error = attempt(scene.add_background, **{k: v for k, v in kwargs.items() if k != "instance_id"})
    else:
        _, error = attempt(scene.add_instance, **kwargs)
    if error is None:
        assert scene.instance_count == before + 1 and not scene.committed
    else:
        assert scene.instance_count == before and scene.committed
        label = kwargs.get("instance_id")
        if isinstance(label, int) and 1 <= label <= 255:
            scene.add_instance(0, np.eye(4), label, GREY)  # the label was not consumed
    scene.commit()
    out = _core.render(scene, down_camera(4, 4), _core.DirectionalLight(30, 60), _core.RenderSettings(threads=1))
    assert out["depth"].shape == (4, 4)


WILD_CAMERA = dict(
    fx=ANY_FLOAT,
    fy=ANY_FLOAT,
    cx=ANY_FLOAT,
    cy=ANY_FLOAT,
    width=ANY_INT,
    height=ANY_INT,
    R=anything(*MATRIX3_SHAPES),
    t=anything(*VECTOR3_SHAPES),
)


@FUZZ
@given(kwargs=calls(CAMERA_FIELDS, WILD_CAMERA))
def test_camera_survives_anything(kwargs):
    """Camera(...) never crashes and raises only the allowed types; an accepted camera reports the
    image size it was given and a centre -R^T t."""
    camera, error = attempt(_core.Camera, **kwargs)
    if error is None:
        assert (camera.width, camera.height) == (int(kwargs["width"]), int(kwargs["height"]))
        R, t = np.asarray(kwargs["R"], np.float64), np.asarray(kwargs["t"], np.float64)
        np.testing.assert_allclose(camera.center, -R.T @ t, rtol=1e-6, atol=1e-6)


@FUZZ
@given(
    points=st.one_of(
        st.integers(0, 8).flatmap(lambda n: sized_arrays(NUMERIC_DTYPES, (n, 3))).flatmap(layouts),
        anything((0, 3), (1, 3), (7, 3), (3,), (2, 2), (2, 3, 3)),
    )
)
def test_project_survives_anything(points):
    """Camera.project never crashes and raises only the allowed types; on success it returns one
    float64 (u, v, z) row per input point, whatever the values (NaN, inf, z = 0 included)."""
    uvz, error = attempt(down_camera().project, points)
    if error is None:
        assert uvz.dtype == np.float64 and uvz.shape == (len(points), 3)


@FUZZ
@given(kwargs=calls(dict(SUN_FIELDS, irradiance=st.floats(0, 1e300)), dict.fromkeys(SUN_FIELDS, ANY_FLOAT)))
def test_sun_survives_anything(kwargs):
    """Sun(...) never crashes and raises only the allowed types; an accepted Sun has a unit
    direction and the irradiance it was given."""
    sun, error = attempt(_core.DirectionalLight, **kwargs)
    if error is None:
        assert np.isclose(np.linalg.norm(sun.direction), 1.0)
        assert sun.irradiance == float(kwargs["irradiance"])


def _stale_scene():
    scene = ground_scene()
    scene.add_instance(0, translation(0, 0, 1), 9, GREY)  # after the commit
    return scene


def _empty_scene():
    scene = _core.Scene()
    scene.commit()
    return scene


SCENES = {  # the scene states render must refuse
    "uncommitted": lambda label: ground_scene(label, commit=False),
    "stale": lambda label: _stale_scene(),
    "empty": lambda label: _empty_scene(),
}
LABEL = 7  # the labelled instance in the fuzzed scenes


@st.composite
def small_cameras(draw, max_side=16):
    """A valid downward camera of at most max_side x max_side pixels."""
    w, h = draw(st.integers(1, max_side)), draw(st.integers(1, max_side))
    f = draw(st.floats(0.5, 50))
    altitude = draw(st.floats(0.6, 50))
    R = LOOK_DOWN @ draw(rotations()) if draw(st.booleans()) else LOOK_DOWN
    return _core.Camera(
        f, f, draw(st.floats(0, w)), draw(st.floats(0, h)), w, h, R, -R @ np.array([0.0, 0.0, altitude])
    )


PASSES = ["rgb", "depth", "instance"]
PASS_NAMES = st.one_of(
    st.sampled_from(PASSES), st.sampled_from(["", "RGB", "normal", "rgb ", "depth\0"]), st.text(max_size=6)
)
BAD_SCENES = st.one_of(
    st.sampled_from(["uncommitted", "stale", "empty"]).map(lambda k: SCENES[k](LABEL)),
    st.sampled_from([None, "scene", 0]),
)
VALID_RENDER = dict(
    scene=st.builds(ground_scene, st.just(LABEL)),
    camera=small_cameras(),
    sun=st.builds(_core.DirectionalLight, **SUN_FIELDS),
    spp=st.integers(1, 4),
    seed=st.integers(0, 2**64 - 1),
    threads=st.integers(0, 2),
    passes=st.one_of(
        st.lists(st.sampled_from(PASSES), min_size=1, max_size=4),
        st.lists(st.sampled_from(PASSES), min_size=1, max_size=3).map(tuple),
    ),
)
WILD_RENDER = dict(
    scene=BAD_SCENES,
    camera=st.one_of(st.sampled_from([None, "camera", 0]), st.builds(_core.DirectionalLight, st.just(0), st.just(0))),
    sun=st.one_of(st.none(), st.builds(down_camera)),
    spp=st.one_of(
        st.integers(max_value=0),
        st.integers(MAX_SPP + 1, 2**70),
        numpy_scalars().filter(lambda s: not (isinstance(s, np.integer) and 4 < s <= MAX_SPP)),
        JUNK,
    ),
    seed=st.one_of(st.integers(max_value=-1), st.integers(min_value=2**64), JUNK),
    threads=st.one_of(st.integers(max_value=-1), JUNK),
    passes=st.one_of(st.lists(PASS_NAMES, max_size=4), st.sampled_from(["rgb", b"rgb", None, {"rgb"}]), JUNK),
)


@FUZZ
@given(kwargs=calls(VALID_RENDER, WILD_RENDER))
def test_render_survives_anything(kwargs):
    """render never crashes and raises only the allowed types, whatever the scene state, objects
    and settings; a successful render returns exactly the requested passes, of the camera's size
    and documented dtypes, with finite non-negative radiance and depth and only the labels in the
    scene. (Thread counts above the cap of 1024 are left to the table and isolated tests: above
    65536 they used to crash inside TBB.)"""
    out, error = attempt(_core.render, **kwargs)
    if error is not None:
        return
    h, w = kwargs["camera"].height, kwargs["camera"].width
    wanted = set(kwargs["passes"])
    assert {"rgb", "depth", "instance"} & set(out) == wanted
    if "rgb" in wanted:
        assert out["rgb"].dtype == np.float32 and out["rgb"].shape == (h, w, 3)
        assert np.isfinite(out["rgb"]).all() and (out["rgb"] >= 0).all()
    if "depth" in wanted:
        assert out["depth"].dtype == np.float32 and out["depth"].shape == (h, w)
        assert np.isfinite(out["depth"]).all() and (out["depth"] >= 0).all()
    if "instance" in wanted:
        assert out["instance"].dtype == np.uint8 and out["instance"].shape == (h, w)
        assert set(np.unique(out["instance"]).tolist()) <= {0, LABEL}


VALID_TONEMAP = dict(
    rgb=st.tuples(st.integers(0, 16), st.integers(0, 16))
    .flatmap(lambda hw: sized_arrays(FLOAT_DTYPES, (*hw, 3)))
    .flatmap(layouts),
    exposure=st.floats(1e-30, 1e30),
)


@FUZZ
@given(kwargs=calls(VALID_TONEMAP, dict(rgb=anything(*IMAGE_SHAPES), exposure=ANY_FLOAT)))
def test_tonemap_survives_anything(kwargs):
    """tonemap_reinhard never crashes and raises only the allowed types; on success it returns a
    uint8 (H, W, 3) image in which every channel whose scaled input is NaN or not positive is 0,
    and the number of pixels whose input has a NaN, infinite or negative channel -- NaN and Inf
    never reach an image."""
    result, error = attempt(_core.tonemap_reinhard, **kwargs)
    if error is not None:
        return
    out, invalid = result
    with np.errstate(over="ignore", invalid="ignore"):
        rgb = np.asarray(kwargs["rgb"]).astype(np.float32)
        scaled = rgb * np.float32(kwargs["exposure"])
    assert out.dtype == np.uint8 and out.shape == scaled.shape
    assert (out[~(scaled > 0)] == 0).all()
    assert invalid == int(np.count_nonzero((~(rgb >= 0) | np.isinf(rgb)).any(axis=-1)))


# The extensions the docstring promises, one that is refused, and none at all. (Every other
# extension is refused with OSError: OIIO's rarer plugins aborted; see test_image_plugins_are_not_fatal.)
EXTENSIONS = [".png", ".exr", ".tif", ".tiff", ".unknown", ""]


def leftovers(directory):
    """Hidden temporaries the atomic writer may have left behind."""
    return sorted(p.name for p in directory.iterdir() if p.name.startswith("."))


VALID_WRITE = dict(
    pixels=st.tuples(st.integers(1, 16), st.integers(1, 16), st.sampled_from([(), (1,), (2,), (3,), (4,)]))
    .flatmap(lambda s: sized_arrays(PIXEL_DTYPES, (s[0], s[1], *s[2])))
    .flatmap(lambda a: layouts(a, lists=False)),  # a list would become int64 / float64
    png_compression=st.integers(0, 9),
)
WILD_WRITE = dict(pixels=anything(*IMAGE_SHAPES), png_compression=st.one_of(st.integers(), JUNK))


@FUZZ_FILES
@given(kwargs=calls(VALID_WRITE, WILD_WRITE), ext=st.sampled_from(EXTENSIONS))
def test_write_image_survives_anything(tmp_path, kwargs, ext):
    """write_image never crashes and raises only the allowed types, and is atomic either way: on
    success the file is there (and reads back at the same size), on failure it is not, and no
    temporary is left behind."""
    directory = fresh_dir(tmp_path)
    target = directory / f"image{ext}"
    _, error = attempt(_core.write_image, str(target), **kwargs)
    assert target.exists() == (error is None)
    assert leftovers(directory) == []
    if error is None:
        shape = np.shape(kwargs["pixels"])
        assert _core.read_image(str(target)).shape == (shape[:2] if shape[2:] == (1,) else shape)


@FUZZ_FILES
@given(
    ext=st.sampled_from([".png", ".exr", ".tif"]),
    cut=st.floats(0, 1),
    flips=st.lists(st.tuples(st.floats(0, 1), st.integers(0, 255)), max_size=8),
    noise=st.one_of(st.none(), st.binary(max_size=200)),
)
def test_read_image_survives_damaged_files(tmp_path, ext, cut, flips, noise):
    """read_image on a truncated, bit-flipped or random file of a supported format never crashes:
    it returns an array or raises OSError."""
    directory = fresh_dir(tmp_path)
    path = directory / f"damaged{ext}"
    pixels = np.arange(4 * 5 * 3, dtype=np.uint8).reshape(4, 5, 3)
    _core.write_image(str(path), pixels.astype(np.float32) if ext == ".exr" else pixels)
    data = bytearray(path.read_bytes()) if noise is None else bytearray(noise)
    data = data[: max(1, int(len(data) * cut))] if data else data
    for where, value in flips:
        if data:
            data[int(where * (len(data) - 1))] = value
    path.write_bytes(bytes(data))
    image, error = attempt(_core.read_image, str(path))
    assert error is None or isinstance(error, OSError)
    if error is None:
        assert isinstance(image, np.ndarray) and image.ndim in (2, 3)


def _wild(fields):
    return dict.fromkeys(fields, ANY_FLOAT)


FRAME_FIELDS = dict(
    lat0_deg=st.floats(-90, 90), lon0_deg=st.floats(-1e4, 1e4), h0=st.floats(-1e5, 1e5), radius=st.floats(1.0, 1e9)
)
TO_ENU_FIELDS = dict(lat_deg=st.floats(-90, 90), lon_deg=st.floats(-1e4, 1e4), h=st.floats(-1e5, 1e5))
TO_GEODETIC_FIELDS = dict(east=st.floats(-1e6, 1e6), north=st.floats(-1e6, 1e6), up=st.floats(-1e6, 1e6))
CURVATURE_FIELDS = dict(distance=st.floats(-1e6, 1e6), radius=st.floats(1.0, 1e9))


@FUZZ
@given(
    frame=calls(FRAME_FIELDS, _wild(FRAME_FIELDS)),
    enu=calls(TO_ENU_FIELDS, _wild(TO_ENU_FIELDS)),
    geo=calls(TO_GEODETIC_FIELDS, _wild(TO_GEODETIC_FIELDS)),
    drop=calls(CURVATURE_FIELDS, _wild(CURVATURE_FIELDS)),
)
def test_geodesy_survives_anything(frame, enu, geo, drop):
    """LunarFrame, its to_enu / to_geodetic and curvature_drop never crash and raise only the
    allowed types; successful calls return three floats (one for curvature_drop)."""
    lunar, error = attempt(_core.LunarFrame, **frame)
    if error is None:
        for method, kwargs in ((lunar.to_enu, enu), (lunar.to_geodetic, geo)):
            out, _ = attempt(method, **kwargs)
            assert out is None or (len(out) == 3 and all(isinstance(x, float) for x in out))
    value, _ = attempt(_core.curvature_drop, **drop)
    assert value is None or isinstance(value, float)


@settings(FUZZ, max_examples=30)
@given(
    kwargs=calls(
        dict(
            scene=st.builds(ground_scene, st.just(LABEL)),
            camera=small_cameras(4),
            sun=st.builds(_core.DirectionalLight, **SUN_FIELDS),
            threads=st.integers(0, 2),
            repeats=st.integers(1, 2),
            bounces=st.integers(0, 2),
        ),
        dict(
            scene=BAD_SCENES,
            threads=st.one_of(st.integers(max_value=-1), JUNK),
            repeats=st.one_of(st.integers(max_value=0), JUNK),
            bounces=st.one_of(st.integers(max_value=-1), st.integers(min_value=17), JUNK),
        ),
    )
)
def test_embree_limit_survives_anything(kwargs):
    """measure_embree_limit (a benchmark binding) never crashes on bad settings or scene state and
    raises only the allowed types; on success it traced one camera ray per pixel."""
    out, error = attempt(_core.measure_embree_limit, **kwargs)
    if error is None:
        assert out["camera_rays"] == kwargs["camera"].width * kwargs["camera"].height
        assert len(out["bounce_rays"]) == kwargs.get("bounces", 0)


# --- defects: one defect in an otherwise valid call names its argument ---------------------------


@st.composite
def bad_vertices(draw, n):
    """(n, 3)-ish vertices with exactly one defect: non-finite, wrong dtype, wrong shape, empty."""
    kind = draw(st.sampled_from(["non-finite", "dtype", "shape", "empty"]))
    if kind == "non-finite":
        v = draw(hnp.arrays(st.sampled_from(FLOAT_DTYPES), (n, 3), elements=st.floats(-10, 10, width=16)))
        v[draw(st.integers(0, n - 1)), draw(st.integers(0, 2))] = draw(st.sampled_from(NON_FINITE))
        return v
    if kind == "dtype":
        return draw(hnp.arrays(st.sampled_from(NOT_FLOAT_DTYPES), (n, 3)))
    if kind == "shape":
        shape = draw(st.sampled_from([(n, 2), (n, 4), (3 * n,), (1, n, 3), (n, 3, 1), ()]))
        return draw(hnp.arrays(np.float32, shape, elements=st.floats(-10, 10, width=32)))
    return np.zeros((0, 3), draw(st.sampled_from(FLOAT_DTYPES)))


@DEFECT
@given(mesh=meshes(), data=st.data())
def test_vertex_defects_name_vertices(mesh, data):
    """A mesh whose vertices are non-finite, not floating point, not (N, 3) or empty is refused
    with ValueError("vertices: ..."), and the scene gains nothing."""
    vertices, triangles = mesh
    scene = _core.Scene()
    expect_named("vertices", scene.add_mesh, data.draw(bad_vertices(len(vertices))), triangles)
    assert scene.mesh_count == 0


@st.composite
def bad_triangles(draw, n):
    """(M, 3)-ish indices into n vertices with exactly one defect."""
    kind = draw(st.sampled_from(["too-large", "negative", "dtype", "shape", "empty"]))
    m = draw(st.integers(1, 4))
    if kind in ("too-large", "negative"):
        dtype = draw(st.sampled_from([d for d in INT_DTYPES if kind == "too-large" or d.kind == "i"]))
        t = draw(hnp.arrays(dtype, (m, 3), elements=st.integers(0, n - 1)))
        info = np.iinfo(dtype)
        bad = st.integers(n, int(info.max)) if kind == "too-large" else st.integers(int(info.min), -1)
        t[draw(st.integers(0, m - 1)), draw(st.integers(0, 2))] = draw(bad)
        return t
    if kind == "dtype":
        return draw(
            hnp.arrays(
                st.sampled_from([np.dtype(np.float32), np.dtype(np.float64), np.dtype(np.bool_), np.dtype("U2")]),
                (m, 3),
            )
        )
    if kind == "shape":
        shape = draw(st.sampled_from([(m, 2), (m, 4), (3 * m,), (1, m, 3)]))
        return draw(hnp.arrays(np.int32, shape, elements=st.integers(0, n - 1)))
    return np.zeros((0, 3), draw(st.sampled_from(INT_DTYPES)))


@DEFECT
@given(mesh=meshes(), data=st.data())
def test_triangle_defects_name_triangles(mesh, data):
    """Triangles with an index >= the vertex count or negative (in any integer dtype, uint64
    included), of a non-integer dtype, not (M, 3), or none at all are refused with
    ValueError("triangles: ...")."""
    vertices, _ = mesh
    scene = _core.Scene()
    expect_named("triangles", scene.add_mesh, vertices, data.draw(bad_triangles(len(vertices))))
    assert scene.mesh_count == 0


@st.composite
def bad_transforms(draw):
    """A valid transform with one defect: non-finite entry, bottom row, singular, shape, dtype."""
    kind = draw(st.sampled_from(["non-finite", "bottom-row", "singular", "shape", "dtype"]))
    m = draw(transforms())
    if kind == "non-finite":
        m[draw(st.integers(0, 3)), draw(st.integers(0, 3))] = draw(st.sampled_from(NON_FINITE))
    elif kind == "bottom-row":
        column = draw(st.integers(0, 3))
        m[3, column] = draw(st.floats(-1e3, 1e3).filter(lambda x: x != (1.0 if column == 3 else 0.0)))
    elif kind == "singular":
        m[:3, draw(st.integers(0, 2))] = 0.0
    elif kind == "shape":
        if draw(st.booleans()):
            m = m[: draw(st.integers(0, 3))]
        else:
            m = m.reshape(draw(st.sampled_from([(16,), (2, 8), (1, 4, 4)])))
    else:
        m = m.astype(draw(st.sampled_from(NOT_NUMBER_DTYPES)))
    return m


@DEFECT
@given(world=bad_transforms(), background=st.booleans())
def test_transform_defects_name_world_from_object(world, background):
    """A world_from_object that is not finite, not affine (bottom row), singular, not (4, 4) or
    not numeric is refused with ValueError("world_from_object: ...") by add_instance and
    add_background alike."""
    scene = ground_scene()
    if background:
        expect_named("world_from_object", scene.add_background, 0, world, GREY)
    else:
        expect_named("world_from_object", scene.add_instance, 0, world, 5, GREY)
    assert scene.instance_count == 1


@DEFECT
@given(
    albedo=st.one_of(
        st.tuples(
            st.floats(0, 1),
            st.floats(0, 1),
            st.one_of(st.floats(max_value=-1e-6), st.floats(min_value=1.0001), st.sampled_from(NON_FINITE)),
        ).flatmap(lambda a: st.permutations(a)),
        hnp.arrays(np.float64, st.sampled_from([(2,), (4,), (1, 3), (3, 1), ()]), elements=st.floats(0, 1)),
        hnp.arrays(st.sampled_from(NOT_NUMBER_DTYPES), 3),
    ),
    background=st.booleans(),
)
def test_albedo_defects_name_albedo(albedo, background):
    """An albedo with a channel outside [0, 1] or non-finite, not (3,) or not numeric is refused
    with ValueError("albedo: ...")."""
    scene = ground_scene()
    if background:
        expect_named("albedo", scene.add_background, 0, np.eye(4), albedo)
    else:
        expect_named("albedo", scene.add_instance, 0, np.eye(4), 5, albedo)


@DEFECT
@given(
    instance_id=st.one_of(st.integers(INT_MIN, 0), st.integers(256, INT_MAX)),
    used=st.integers(1, 255),
    mesh=st.integers(1, 2**32 - 1),
)
def test_instance_id_and_mesh_defects_are_named(instance_id, used, mesh):
    """An instance_id outside 1..255 (anywhere in the C int range) or one already used raises
    ValueError("instance_id: ..."); a mesh index past the scene's meshes raises
    ValueError("mesh: ...")."""
    scene = ground_scene()
    expect_named("instance_id", scene.add_instance, 0, np.eye(4), instance_id, GREY)
    scene.add_instance(0, np.eye(4), used, GREY)
    message = expect_named("instance_id", scene.add_instance, 0, np.eye(4), used, GREY)
    assert str(used) in message
    expect_named("mesh", scene.add_instance, mesh, np.eye(4), 1 + used % 255, GREY)
    expect_named("mesh", scene.add_background, mesh, np.eye(4), GREY)


NOT_POSITIVE = st.one_of(st.floats(max_value=0.0), st.sampled_from(NON_FINITE))
CAMERA_DEFECTS = {
    "fx": NOT_POSITIVE,
    "fy": NOT_POSITIVE,
    "cx": st.sampled_from(NON_FINITE),
    "cy": st.sampled_from(NON_FINITE),
    "width": st.one_of(st.integers(INT_MIN, 0), st.integers(MAX_SIDE + 1, INT_MAX)),
    "height": st.one_of(st.integers(INT_MIN, 0), st.integers(MAX_SIDE + 1, INT_MAX)),
}


@st.composite
def bad_rotations(draw):
    """A rotation with one defect: scaled, reflected, non-finite, wrong shape or dtype."""
    R = draw(rotations())
    kind = draw(st.sampled_from(["scaled", "reflected", "non-finite", "shape", "dtype"]))
    if kind == "scaled":
        return R * draw(st.one_of(st.floats(0.01, 0.999), st.floats(1.001, 100)))
    if kind == "reflected":
        R[draw(st.integers(0, 2))] *= -1.0
        return R
    if kind == "non-finite":
        R[draw(st.integers(0, 2)), draw(st.integers(0, 2))] = draw(st.sampled_from(NON_FINITE))
        return R
    if kind == "shape":
        return np.resize(R, draw(st.sampled_from([(3,), (9,), (3, 4), (4, 4), (1, 3, 3)])))
    return R.astype(draw(st.sampled_from(NOT_NUMBER_DTYPES)))


@DEFECT
@given(args=st.fixed_dictionaries(CAMERA_FIELDS), field=st.sampled_from([*CAMERA_DEFECTS, "R", "t"]), data=st.data())
def test_camera_defects_name_the_field(args, field, data):
    """A camera with one bad field -- focal length zero, negative or non-finite; principal point
    non-finite; image side outside 1..32768; R scaled, reflected, non-finite, not (3, 3) or not
    numeric; t non-finite or not (3,) -- is refused with ValueError("<field>: ...")."""
    _core.Camera(**args)  # the base call is valid
    if field == "R":
        bad = data.draw(bad_rotations())
    elif field == "t":
        bad = args["t"].copy()
        if data.draw(st.booleans()):
            bad[data.draw(st.integers(0, 2))] = data.draw(st.sampled_from(NON_FINITE))
        else:
            bad = np.resize(bad, data.draw(st.sampled_from([(2,), (4,), (1, 3), (3, 3)])))
    else:
        bad = data.draw(CAMERA_DEFECTS[field])
    expect_named(field, _core.Camera, **{**args, field: bad})


@DEFECT
@given(
    args=st.tuples(st.floats(-1e6, 1e6), st.floats(-90, 90), st.floats(0, 1e6)),
    field=st.sampled_from(["azimuth_deg", "elevation_deg", "irradiance"]),
    data=st.data(),
)
def test_sun_defects_name_the_field(args, field, data):
    """A Sun with a non-finite azimuth, an elevation outside [-90, 90] (or NaN), or a negative or
    non-finite irradiance is refused with ValueError("<field>: ...")."""
    bad = {
        "azimuth_deg": st.sampled_from(NON_FINITE),
        "elevation_deg": st.one_of(
            st.floats(min_value=90, exclude_min=True), st.floats(max_value=-90, exclude_max=True), st.just(math.nan)
        ),
        "irradiance": st.one_of(
            st.floats(max_value=0, exclude_max=True),
            st.sampled_from(NON_FINITE),
            st.floats(min_value=1e7, exclude_min=True, allow_infinity=False),
        ),
    }[field]
    values = dict(zip(["azimuth_deg", "elevation_deg", "irradiance"], args))
    _core.DirectionalLight(**values)  # the base call is valid
    expect_named(field, _core.DirectionalLight, **{**values, field: data.draw(bad)})


@DEFECT
@given(setting=st.sampled_from(["spp", "threads", "passes", "scene"]), data=st.data())
def test_render_defects_name_the_setting(setting, data):
    """render refuses spp outside 1..65536, a negative thread count, an unknown or empty pass
    list, and an uncommitted or instance-less scene, each with ValueError naming it."""
    settings = dict(spp=1, seed=0, threads=1)
    passes = ["rgb", "depth", "instance"]
    scene = ground_scene(3)
    if setting == "spp":
        settings["spp"] = data.draw(st.one_of(st.integers(INT_MIN, 0), st.integers(MAX_SPP + 1, INT_MAX)))
    elif setting == "threads":
        settings["threads"] = data.draw(st.integers(INT_MIN, -1))
    elif setting == "passes":
        good = data.draw(st.lists(st.sampled_from(["rgb", "depth", "instance"]), max_size=3))
        unknown = data.draw(
            st.text(st.characters(exclude_categories=["Cs"]), max_size=6).filter(
                lambda p: p not in ("rgb", "depth", "instance")
            )
        )
        passes = data.draw(st.permutations([*good, unknown])) if data.draw(st.booleans()) else []
    else:
        scene = data.draw(st.sampled_from([lambda: ground_scene(3, commit=False), _stale_scene, _empty_scene]))()

    def call():
        # A setting out of range is refused where the RenderSettings is made (or, written after, by render).
        _core.render(
            scene, down_camera(4, 4), _core.DirectionalLight(0, 45), _core.RenderSettings(**settings), passes=passes
        )

    expect_named(setting, call)


@DEFECT
@given(
    rgb=st.one_of(
        hnp.arrays(st.sampled_from(NOT_FLOAT_DTYPES), st.tuples(st.integers(1, 16), st.integers(1, 16), st.just(3))),
        hnp.arrays(
            st.sampled_from(FLOAT_DTYPES), st.sampled_from([(4, 4), (4, 4, 1), (4, 4, 4), (3,), (1, 4, 4, 3), ()])
        ),
    ),
    exposure=st.one_of(st.floats(max_value=0.0), st.sampled_from(NON_FINITE)),
)
def test_tonemap_defects_name_the_argument(rgb, exposure):
    """tonemap_reinhard refuses rgb that is not floating point or not (H, W, 3) with
    ValueError("rgb: ..."), and a zero, negative or non-finite exposure with
    ValueError("exposure: ...")."""
    expect_named("rgb", _core.tonemap_reinhard, rgb, 1.0)
    expect_named("exposure", _core.tonemap_reinhard, np.ones((2, 3, 3), np.float32), exposure)


@st.composite
def bad_pixels(draw):
    """Pixels with one defect: dtype outside uint8/uint16/float32, 1-D or 4-D, 0 or >4 channels,
    zero height or width."""
    kind = draw(st.sampled_from(["dtype", "ndim", "channels", "empty"]))
    if kind == "dtype":
        # uint8, uint16 and float32 in either byte order are pixels; everything else is not.
        others = [
            d
            for d in map(np.dtype, NUMERIC_DTYPES + OTHER_DTYPES)
            if (d.kind, d.itemsize) not in {("u", 1), ("u", 2), ("f", 4)}
        ]
        return draw(hnp.arrays(st.sampled_from(others), st.sampled_from([(2, 3), (2, 3, 3)])))
    dtype = draw(st.sampled_from(PIXEL_DTYPES))
    shape = {
        "ndim": st.sampled_from([(), (5,), (1, 2, 3, 1)]),
        "channels": st.tuples(st.integers(1, 4), st.integers(1, 4), st.sampled_from([0, 5, 8])),
        "empty": st.sampled_from([(0, 3), (3, 0), (0, 0, 3), (2, 0, 1)]),
    }[kind]
    return draw(hnp.arrays(dtype, shape))


@settings(DEFECT, suppress_health_check=[*_SLOW_DATA, HealthCheck.function_scoped_fixture])
@given(
    pixels=bad_pixels(),
    level=st.one_of(st.integers(INT_MIN, -1), st.integers(10, INT_MAX)),
    ext=st.sampled_from([".png", ".exr", ".tif"]),
)
def test_write_image_defects_name_the_argument(tmp_path, pixels, level, ext):
    """write_image refuses bad pixels with ValueError("pixels: ...") and a PNG compression level
    outside 0..9 with ValueError("png_compression: ..."), writing nothing."""
    directory = fresh_dir(tmp_path)
    expect_named("pixels", _core.write_image, str(directory / f"a{ext}"), pixels)
    expect_named("png_compression", _core.write_image, str(directory / f"b{ext}"), np.zeros((2, 2), np.uint8), level)
    assert list(directory.iterdir()) == []


# --- tables: each bad input the issue lists, with a readable id ----------------------------------


def _with(array, index, value):
    out = np.array(array, copy=True)
    out[index] = value
    return out


BAD_MESHES = {
    "vertices-dtype-int32": (QUAD_V.astype(np.int32), QUAD_T, "vertices"),
    "vertices-dtype-bool": (QUAD_V.astype(bool), QUAD_T, "vertices"),
    "vertices-dtype-complex": (QUAD_V.astype(np.complex64), QUAD_T, "vertices"),
    "vertices-dtype-str": (QUAD_V.astype("U6"), QUAD_T, "vertices"),
    "vertices-dtype-object": (QUAD_V.astype(object), QUAD_T, "vertices"),
    "vertices-ragged-list": ([[0, 0, 0], [1, 0], [0, 1, 0]], [[0, 1, 2]], "vertices"),
    "vertices-shape-(4,2)": (QUAD_V[:, :2], QUAD_T, "vertices"),
    "vertices-shape-(4,4)": (np.hstack([QUAD_V, QUAD_V[:, :1]]), QUAD_T, "vertices"),
    "vertices-shape-(12,)": (QUAD_V.ravel(), QUAD_T, "vertices"),
    "vertices-shape-(1,4,3)": (QUAD_V[None], QUAD_T, "vertices"),
    "vertices-nan": (_with(QUAD_V, (2, 1), np.nan), QUAD_T, "vertices"),
    "vertices-+inf": (_with(QUAD_V, (0, 0), np.inf), QUAD_T, "vertices"),
    "vertices--inf-float16": (_with(QUAD_V.astype(np.float16), (3, 2), -np.inf), QUAD_T, "vertices"),
    "vertices-nan-float64": (_with(QUAD_V.astype(np.float64), (1, 0), np.nan), QUAD_T, "vertices"),
    "empty-mesh": (np.zeros((0, 3), np.float32), np.zeros((0, 3), np.int32), "vertices"),
    "empty-vertices": (np.zeros((0, 3), np.float32), QUAD_T, "vertices"),
    "empty-triangles": (QUAD_V, np.zeros((0, 3), np.int32), "triangles"),
    "triangles-dtype-float": (QUAD_V, QUAD_T.astype(np.float64), "triangles"),
    "triangles-dtype-bool": (QUAD_V, QUAD_T.astype(bool), "triangles"),
    "triangles-dtype-str": (QUAD_V, QUAD_T.astype("U2"), "triangles"),
    "triangles-shape-(2,2)": (QUAD_V, QUAD_T[:, :2], "triangles"),
    "triangles-shape-(6,)": (QUAD_V, QUAD_T.ravel(), "triangles"),
    "triangles-index-equals-count": (QUAD_V, _with(QUAD_T, (1, 2), 4), "triangles"),
    "triangles-index-2**32": (QUAD_V, _with(QUAD_T.astype(np.int64), (0, 0), 2**32), "triangles"),
    "triangles-index-uint32-max": (QUAD_V, _with(QUAD_T.astype(np.uint32), (0, 1), 2**32 - 1), "triangles"),
    "triangles-index-uint64-2**63+1": (QUAD_V, _with(QUAD_T.astype(np.uint64), (0, 1), 2**63 + 1), "triangles"),
    "triangles-negative": (QUAD_V, _with(QUAD_T, (0, 2), -1), "triangles"),
    "triangles-negative-int8": (QUAD_V, _with(QUAD_T.astype(np.int8), (1, 0), -128), "triangles"),
}


@pytest.mark.parametrize(("vertices", "triangles", "name"), BAD_MESHES.values(), ids=BAD_MESHES.keys())
def test_bad_mesh_is_named(vertices, triangles, name):
    """Each listed bad mesh raises ValueError naming vertices or triangles; no mesh is added."""
    scene = _core.Scene()
    expect_named(name, scene.add_mesh, vertices, triangles)
    assert scene.mesh_count == 0 and scene.bvh_builds == 0


def _skewed_bottom_row():
    m = np.eye(4)
    m[3, 0] = 0.5
    return m


BAD_INSTANCES = {
    "instance_id-0": (dict(instance_id=0), "instance_id"),
    "instance_id-256": (dict(instance_id=256), "instance_id"),
    "instance_id--1": (dict(instance_id=-1), "instance_id"),
    "instance_id-duplicate": (dict(instance_id=1), "instance_id"),  # the scene already uses 1
    "mesh-out-of-range": (dict(mesh=1), "mesh"),
    "world_from_object-shape-(3,3)": (dict(world_from_object=np.eye(3)), "world_from_object"),
    "world_from_object-nan": (dict(world_from_object=_with(np.eye(4), (0, 3), np.nan)), "world_from_object"),
    "world_from_object-inf": (dict(world_from_object=_with(np.eye(4), (1, 1), np.inf)), "world_from_object"),
    "world_from_object-bottom-row": (dict(world_from_object=_skewed_bottom_row()), "world_from_object"),
    "world_from_object-singular": (dict(world_from_object=np.diag([1.0, 0.0, 1.0, 1.0])), "world_from_object"),
    "world_from_object-str": (dict(world_from_object="identity"), "world_from_object"),
    "albedo-above-1": (dict(albedo=(0.5, 1.5, 0.5)), "albedo"),
    "albedo-negative": (dict(albedo=(-0.1, 0.5, 0.5)), "albedo"),
    "albedo-nan": (dict(albedo=(0.5, 0.5, np.nan)), "albedo"),
    "albedo-shape-(4,)": (dict(albedo=(0.5, 0.5, 0.5, 1.0)), "albedo"),
    "albedo-complex": (dict(albedo=np.full(3, 0.5 + 0j)), "albedo"),
}


@pytest.mark.parametrize(("change", "name"), BAD_INSTANCES.values(), ids=BAD_INSTANCES.keys())
def test_bad_instance_is_named(change, name):
    """Each listed bad instance raises ValueError naming the argument; the scene keeps its one
    instance and stays committed."""
    scene = _core.Scene()
    scene.add_instance(scene.add_mesh(QUAD_V, QUAD_T), np.eye(4), 1, GREY)
    scene.commit()
    args = dict(mesh=0, world_from_object=np.eye(4), instance_id=2, albedo=GREY)
    expect_named(name, scene.add_instance, **{**args, **change})
    assert scene.instance_count == 1 and scene.committed


GOOD_CAMERA = dict(fx=6.0, fy=6.0, cx=4.0, cy=3.0, width=8, height=6, R=LOOK_DOWN, t=np.array([0.0, 0.0, 3.0]))
BAD_CAMERAS = {
    "fx-zero": ("fx", 0.0),
    "fx-negative": ("fx", -6.0),
    "fx-nan": ("fx", math.nan),
    "fx-inf": ("fx", math.inf),
    "fy-zero": ("fy", 0.0),
    "fy-negative": ("fy", -1e-9),
    "cx-nan": ("cx", math.nan),
    "cy--inf": ("cy", -math.inf),
    "width-zero": ("width", 0),
    "width-negative": ("width", -8),
    "width-32769": ("width", MAX_SIDE + 1),
    "height-zero": ("height", 0),
    "height-negative": ("height", -1),
    "R-not-orthonormal-scaled": ("R", 2.0 * LOOK_DOWN),
    "R-not-orthonormal-sheared": ("R", _with(np.eye(3), (0, 1), 0.1)),
    "R-reflection": ("R", np.diag([1.0, 1.0, -1.0])),
    "R-point-reflection": ("R", -np.eye(3)),
    "R-nan": ("R", _with(LOOK_DOWN, (2, 2), np.nan)),
    "R-shape-(4,4)": ("R", np.eye(4)),
    "R-dtype-str": ("R", LOOK_DOWN.astype("U4")),
    "t-shape-(2,)": ("t", np.zeros(2)),
    "t-inf": ("t", np.array([0.0, np.inf, 3.0])),
}


@pytest.mark.parametrize(("field", "value"), BAD_CAMERAS.values(), ids=BAD_CAMERAS.keys())
def test_bad_camera_is_named(field, value):
    """Each listed bad camera argument raises ValueError naming it."""
    expect_named(field, _core.Camera, **{**GOOD_CAMERA, field: value})


def _render_call(scene=None, passes=("rgb", "depth", "instance"), **settings_):
    return lambda: _core.render(
        scene() if scene else ground_scene(4),
        down_camera(4, 4),
        _core.DirectionalLight(0, 45),
        _core.RenderSettings(**settings_),
        passes=list(passes),
    )


BAD_RENDERS = {
    "before-commit": (_render_call(lambda: ground_scene(4, commit=False)), "scene"),
    "instance-added-after-commit": (_render_call(_stale_scene), "scene"),
    "no-instances": (_render_call(_empty_scene), "scene"),
    "spp-0": (_render_call(spp=0), "spp"),
    "spp--1": (_render_call(spp=-1), "spp"),
    "spp-65537": (_render_call(spp=MAX_SPP + 1), "spp"),
    "threads--1": (_render_call(threads=-1), "threads"),
    "threads-1025": (_render_call(threads=1025), "threads"),
    "measure_embree_limit-threads-1025": (
        lambda: _core.measure_embree_limit(
            ground_scene(4), down_camera(4, 4), _core.DirectionalLight(0, 45), threads=1025
        ),
        "threads",
    ),
    "measure_embree_limit-repeats-0": (
        lambda: _core.measure_embree_limit(
            ground_scene(4), down_camera(4, 4), _core.DirectionalLight(0, 45), repeats=0
        ),
        "repeats",
    ),
    "measure_embree_limit-bounces-17": (
        lambda: _core.measure_embree_limit(
            ground_scene(4), down_camera(4, 4), _core.DirectionalLight(0, 45), bounces=17
        ),
        "bounces",
    ),
    "passes-unknown": (_render_call(passes=["rgb", "normals"]), "passes"),
    "passes-empty-name": (_render_call(passes=[""]), "passes"),
    "passes-empty": (_render_call(passes=[]), "passes"),
}


@pytest.mark.parametrize(("call", "name"), BAD_RENDERS.values(), ids=BAD_RENDERS.keys())
def test_bad_render_is_named(call, name):
    """Each listed bad render raises ValueError naming the scene or the setting."""
    expect_named(name, call)


BAD_SUNS = {
    "elevation_deg-above-90": ((0.0, 90.000001), "elevation_deg"),
    "elevation_deg-below--90": ((0.0, -91.0), "elevation_deg"),
    "elevation_deg-nan": ((0.0, math.nan), "elevation_deg"),
    "irradiance-negative": ((0.0, 30.0, -1.0), "irradiance"),
    "irradiance-inf": ((0.0, 30.0, math.inf), "irradiance"),
    "irradiance-beyond-1e7": ((0.0, 30.0, 1e8), "irradiance"),
    "azimuth_deg-inf": ((math.inf, 30.0), "azimuth_deg"),
}


@pytest.mark.parametrize(("args", "name"), BAD_SUNS.values(), ids=BAD_SUNS.keys())
def test_bad_sun_is_named(args, name):
    """Each listed bad Sun raises ValueError naming the argument."""
    expect_named(name, _core.DirectionalLight, *args)


BAD_TONEMAPS = {
    "rgb-dtype-uint8": ((np.zeros((2, 2, 3), np.uint8), 1.0), "rgb"),
    "rgb-shape-(H,W)": ((np.zeros((2, 2), np.float32), 1.0), "rgb"),
    "rgb-shape-(H,W,4)": ((np.zeros((2, 2, 4), np.float32), 1.0), "rgb"),
    "rgb-none": ((None, 1.0), "rgb"),
    "rgb-side-32769": ((np.zeros((MAX_SIDE + 1, 1, 3), np.float32), 1.0), "rgb"),
    "exposure-zero": ((np.zeros((2, 2, 3), np.float32), 0.0), "exposure"),
    "exposure-negative": ((np.zeros((2, 2, 3), np.float32), -1.0), "exposure"),
    "exposure-nan": ((np.zeros((2, 2, 3), np.float32), math.nan), "exposure"),
    "veiling_glare-negative": ((np.zeros((2, 2, 3), np.float32), 1.0, -0.02), "veiling_glare"),
    "veiling_glare-inf": ((np.zeros((2, 2, 3), np.float32), 1.0, math.inf), "veiling_glare"),
}


@pytest.mark.parametrize(("args", "name"), BAD_TONEMAPS.values(), ids=BAD_TONEMAPS.keys())
def test_bad_tonemap_is_named(args, name):
    """Each listed bad tone-mapping call raises ValueError naming the argument."""
    expect_named(name, _core.tonemap_reinhard, *args)


BAD_WRITES = {
    "pixels-dtype-int32": (np.zeros((2, 2), np.int32), 1, "pixels"),
    "pixels-dtype-float64": (np.zeros((2, 2, 3)), 1, "pixels"),
    "pixels-dtype-float16": (np.zeros((2, 2), np.float16), 1, "pixels"),
    "pixels-dtype-bool": (np.zeros((2, 2), bool), 1, "pixels"),
    "pixels-1d": (np.zeros(4, np.uint8), 1, "pixels"),
    "pixels-4d": (np.zeros((1, 2, 2, 1), np.uint8), 1, "pixels"),
    "pixels-0-channels": (np.zeros((2, 2, 0), np.uint8), 1, "pixels"),
    "pixels-5-channels": (np.zeros((2, 2, 5), np.uint8), 1, "pixels"),
    "pixels-zero-height": (np.zeros((0, 2), np.uint8), 1, "pixels"),
    "pixels-side-32769": (np.zeros((1, MAX_SIDE + 1), np.uint8), 1, "pixels"),
    "png_compression--1": (np.zeros((2, 2), np.uint8), -1, "png_compression"),
    "png_compression-10": (np.zeros((2, 2), np.uint8), 10, "png_compression"),
}


@pytest.mark.parametrize(("pixels", "level", "name"), BAD_WRITES.values(), ids=BAD_WRITES.keys())
def test_bad_write_is_named(tmp_path, pixels, level, name):
    """Each listed bad image raises ValueError naming the argument and writes nothing."""
    expect_named(name, _core.write_image, str(tmp_path / "x.png"), pixels, level)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "where",
    [
        "missing-directory",
        "missing-parent",
        "no-writer-for-extension",
        "unsupported-extension-.jpg",
        "target-is-a-directory",
    ],
)
def test_unwritable_path_raises_oserror_naming_it(tmp_path, where):
    """An image that cannot be written raises OSError whose message names the path, and leaves
    nothing behind."""
    target = {
        "missing-directory": tmp_path / "absent" / "x.png",
        "missing-parent": tmp_path / "a" / "b" / "c" / "x.png",
        "no-writer-for-extension": tmp_path / "x.notaformat",
        "unsupported-extension-.jpg": tmp_path / "x.jpg",
        "target-is-a-directory": tmp_path / "taken.png",
    }[where]
    if where == "target-is-a-directory":
        target.mkdir()
    with pytest.raises(OSError) as info:
        _core.write_image(str(target), np.zeros((2, 2), np.uint8))
    assert str(target) in str(info.value)
    assert leftovers(tmp_path) == []


BAD_GEODESY = {
    "LunarFrame-lat0_deg-91": (lambda: _core.LunarFrame(91.0, 0.0), "lat0_deg"),
    "LunarFrame-lat0_deg-nan": (lambda: _core.LunarFrame(math.nan, 0.0), "lat0_deg"),
    "LunarFrame-lon0_deg-inf": (lambda: _core.LunarFrame(0.0, math.inf), "lon0_deg"),
    "LunarFrame-h0-nan": (lambda: _core.LunarFrame(0.0, 0.0, math.nan), "h0"),
    "LunarFrame-radius-zero": (lambda: _core.LunarFrame(0.0, 0.0, 0.0, 0.0), "radius"),
    "LunarFrame-radius-inf": (lambda: _core.LunarFrame(0.0, 0.0, 0.0, math.inf), "radius"),
    "curvature_drop-radius-negative": (lambda: _core.curvature_drop(1.0, -1.0), "radius"),
    "curvature_drop-distance-beyond-radius": (lambda: _core.curvature_drop(2.0, 1.0), "distance"),
}


@pytest.mark.parametrize(("call", "name"), BAD_GEODESY.values(), ids=BAD_GEODESY.keys())
def test_bad_geodesy_is_named(call, name):
    """Each listed bad geodesy argument raises ValueError naming it as the caller spells it
    (the keyword: lat0_deg, not "latitude")."""
    expect_named(name, call)


# --- regressions: inputs that crashed or misbehaved before the bindings were hardened ------------

CHILD_PRELUDE = """
import json, sys
import numpy as np
from moonbot import _core
LOOK_DOWN = np.diag([1.0, -1.0, -1.0])
def ground_scene():
    s = _core.Scene()
    v = np.array([[-5, -5, 0], [5, -5, 0], [5, 5, 0], [-5, 5, 0]], np.float32)
    s.add_background(s.add_mesh(v, [[0, 1, 2], [0, 2, 3]]), np.eye(4), (0.2, 0.2, 0.2))
    s.commit()
    return s
def small_camera():
    return _core.Camera(4.0, 4.0, 2.0, 2.0, 4, 4, LOOK_DOWN, -LOOK_DOWN @ [0.0, 0.0, 2.0])
"""


def run_isolated(tmp_path, body, *python_flags):
    """Run `body` in a child interpreter (cwd = tmp_path); return [outcome, message], where
    outcome is "returned" or the name of the exception raised. Fails the test, rather than the
    whole session, if the child dies of a signal; skips it if the child prints ["skip", why]."""
    code = "\n".join(
        [
            CHILD_PRELUDE,
            "try:",
            textwrap.indent(textwrap.dedent(body).strip("\n"), "    "),
            "    outcome = ['returned', '']",
            "except Exception as error:",
            "    outcome = [type(error).__name__, str(error)]",
            "print(json.dumps(outcome))",
        ]
    )
    proc = subprocess.run(
        [sys.executable, *python_flags, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=120
    )
    if proc.returncode < 0:
        pytest.fail(
            f"the interpreter died of {signal.Signals(-proc.returncode).name}; stderr: {proc.stderr.strip()[-300:]!r}"
        )
    assert proc.returncode == 0, proc.stderr
    outcome = json.loads(proc.stdout.strip().splitlines()[-1])
    if outcome[0] == "skip":
        pytest.skip(outcome[1])
    return outcome


def assert_allowed(outcome, name=None, may_return=True):
    """The child returned (if allowed), or raised an allowed type -- a ValueError naming `name`
    when a name is given."""
    kind, message = outcome
    if kind == "returned" and may_return:
        return
    assert kind in {"ValueError", "TypeError", "OSError"}, f"{kind}: {message}"
    if name is not None:
        assert kind == "ValueError" and message.startswith(f"{name}: "), f"{kind}: {message}"


WARNINGS_AS_ERRORS = ("-W", "error")
OVERFLOWING_CONVERSIONS = {
    # pybind11's array_t::ensure returns a null array when numpy refuses the conversion (the
    # overflow reported as an error); the bindings used to dereference it (SIGSEGV).
    "rgb-float64-1e39": ("_core.tonemap_reinhard(np.full((2, 2, 3), 1e39), 1.0)", "rgb", WARNINGS_AS_ERRORS),
    "rgb-float64-1e-50-seterr-raise": (
        "np.seterr(all='raise')\n_core.tonemap_reinhard(np.full((2, 2, 3), 1e-50), 1.0)",
        "rgb",
        (),
    ),
    "vertices-float64-1e39": (
        "_core.Scene().add_mesh(np.full((3, 3), 1e39), [[0, 1, 2]])",
        "vertices",
        WARNINGS_AS_ERRORS,
    ),
    "R-longdouble-1e400": (
        "_core.Camera(1, 1, 0, 0, 1, 1, np.full((3, 3), np.longdouble('1e400')), np.zeros(3))",
        "R",
        WARNINGS_AS_ERRORS,
    ),
    "t-longdouble-1e400": (
        "_core.Camera(1, 1, 0, 0, 1, 1, np.eye(3), np.full(3, np.longdouble('1e400')))",
        "t",
        WARNINGS_AS_ERRORS,
    ),
    "world_from_object-longdouble-1e400": (
        "ground_scene().add_background(\n    0, np.full((4, 4), np.longdouble('1e400')), (0, 0, 0))",
        "world_from_object",
        WARNINGS_AS_ERRORS,
    ),
    "albedo-longdouble-1e400": (
        "ground_scene().add_background(0, np.eye(4), np.full(3, np.longdouble('1e400')))",
        "albedo",
        WARNINGS_AS_ERRORS,
    ),
    "points-longdouble-1e400": (
        "small_camera().project(np.full((1, 3), np.longdouble('1e400')))",
        "points",
        WARNINGS_AS_ERRORS,
    ),
}


@pytest.mark.parametrize(
    ("body", "name", "flags"), OVERFLOWING_CONVERSIONS.values(), ids=OVERFLOWING_CONVERSIONS.keys()
)
def test_overflowing_conversion_is_not_fatal(tmp_path, body, name, flags):
    """A value that overflows (or underflows) while the binding narrows it -- float64 to float32,
    longdouble to float64 -- must not crash the interpreter when numpy's floating-point errors are
    raised (pytest's `filterwarnings = error`, `python -W error`, `np.seterr(all="raise")`): the
    call returns (tone mapping and projection are defined for any value) or raises ValueError
    naming the argument."""
    assert_allowed(run_isolated(tmp_path, body, *flags), name)


HUGE_THREAD_COUNTS = {
    "render-threads-65537": "_core.render(ground_scene(), small_camera(), _core.DirectionalLight(0, 45), "
    "_core.RenderSettings(threads=65537))",
    "render-threads-10**8": "_core.render(ground_scene(), small_camera(), _core.DirectionalLight(0, 45), "
    "_core.RenderSettings(threads=10**8))",
    "render-threads-int-max": "_core.render(ground_scene(), small_camera(), _core.DirectionalLight(0, 45), "
    "_core.RenderSettings(threads=2**31 - 1))",
    "measure_embree_limit-threads-65537": "_core.measure_embree_limit(ground_scene(), small_camera(), "
    "_core.DirectionalLight(0, 45), threads=65537, repeats=1)",
}


@pytest.mark.parametrize("body", HUGE_THREAD_COUNTS.values(), ids=HUGE_THREAD_COUNTS.keys())
def test_huge_thread_count_is_not_fatal(tmp_path, body):
    """Any int thread count either renders (capped to the machine) or raises ValueError naming
    threads -- never a crash, never MemoryError."""
    assert_allowed(run_isolated(tmp_path, body), "threads")


IMAGE_PLUGINS = {
    # OpenImageIO picks the plugin from the extension; before only .png/.exr/.tif(f) were let
    # through, the DPX writer asserted (SIGABRT) and the ICO reader double-freed (SIGABRT).
    "write-dpx-2-channels": "_core.write_image('x.dpx', np.zeros((2, 2, 2), np.uint8))",
    "read-back-ico": "_core.write_image('x.ico', np.zeros((1, 1), np.uint8))\n_core.read_image('x.ico')",
}


@pytest.mark.parametrize("body", IMAGE_PLUGINS.values(), ids=IMAGE_PLUGINS.keys())
def test_image_plugins_are_not_fatal(tmp_path, body):
    """Writing or reading an image under any extension returns or raises OSError / ValueError; it
    never aborts the interpreter."""
    assert_allowed(run_isolated(tmp_path, body))


SIDES_BEYOND_INT = {
    # np.zeros takes the memory lazily (calloc): gigabytes of address space, a page of RAM.
    "channels-2**32+3": (1, 1, 2**32 + 3),
    "width-2**32+2": (1, 2**32 + 2),
    "height-2**31": (2**31, 1),
}


@pytest.mark.parametrize("shape", SIDES_BEYOND_INT.values(), ids=SIDES_BEYOND_INT.keys())
def test_image_sides_beyond_int_are_refused(tmp_path, shape):
    """An image side that does not fit the core's int is refused with ValueError("pixels: ..."),
    not truncated into a different, valid-looking image."""
    body = f"""
    try:
        pixels = np.zeros({shape!r}, np.uint8)
    except MemoryError:
        print(json.dumps(["skip", "cannot reserve the address space for {shape!r}"]))
        sys.exit(0)
    _core.write_image('x.png', pixels)
    """
    assert_allowed(run_isolated(tmp_path, body), "pixels", may_return=False)


EQUAL_DTYPES = {
    "unpickled-uint8": (lambda a: pickle.loads(pickle.dumps(a.astype(np.uint8))), ".png"),
    "unpickled-uint16": (lambda a: pickle.loads(pickle.dumps(a.astype(np.uint16))), ".png"),
    "unpickled-float32": (lambda a: pickle.loads(pickle.dumps(a.astype(np.float32))), ".exr"),
    "big-endian-uint16": (lambda a: a.astype(">u2"), ".png"),
    "big-endian-float32": (lambda a: a.astype(">f4"), ".tif"),
}


@pytest.mark.parametrize(("make", "ext"), EQUAL_DTYPES.values(), ids=EQUAL_DTYPES.keys())
def test_write_image_accepts_equal_dtypes(tmp_path, make, ext):
    """Pixels whose dtype is uint8, uint16 or float32 by kind and size are accepted whatever the
    dtype object: one from a pickle (multiprocessing, a cache) is equal but not identical, and a
    byte-swapped one is the same numbers. The file reads back as the same values."""
    pixels = make(np.arange(12).reshape(3, 4))
    _core.write_image(str(tmp_path / f"x{ext}"), pixels)
    np.testing.assert_array_equal(_core.read_image(str(tmp_path / f"x{ext}")), pixels)


@pytest.mark.parametrize("path", ["", "x\0y.png"], ids=["empty", "nul"])
def test_bad_path_is_named(tmp_path, path):
    """An empty path, or one with an embedded NUL, raises ValueError("path: ...") from write_image
    and read_image alike."""
    expect_named("path", _core.write_image, path, np.zeros((2, 2), np.uint8))
    expect_named("path", _core.read_image, path)


def test_read_image_refuses_other_formats_naming_the_path(tmp_path):
    """read_image opens only .png/.exr/.tif(f): anything else raises OSError naming the path,
    before any OpenImageIO plugin sees the file."""
    path = tmp_path / "x.ico"
    path.write_bytes(b"\0\0\1\0\1\0" + b"\xff" * 64)
    with pytest.raises(OSError, match=re.escape(str(path))):
        _core.read_image(str(path))


def test_write_image_refuses_a_nul_in_the_path(tmp_path):
    """A path with an embedded NUL is refused (as Python's open() does) instead of silently writing
    to the path truncated at the NUL."""
    with pytest.raises((ValueError, OSError)):
        _core.write_image(str(tmp_path / "x\0y.png"), np.zeros((2, 2), np.uint8))
    assert list(tmp_path.iterdir()) == []


def test_scene_cannot_change_while_rendering():
    """A render with the GIL released holds the scene: a concurrent modification from another
    Python thread raises instead of racing Embree's traversal."""
    import threading

    scene = _core.Scene()
    ground = np.array([[-10, -10, 0], [10, -10, 0], [10, 10, 0], [-10, 10, 0]], np.float32)
    triangles = np.array([[0, 1, 2], [0, 2, 3]])
    scene.add_background(scene.add_mesh(ground, triangles), np.eye(4), (0.1, 0.1, 0.1))
    scene.commit()
    look_down = np.diag([1.0, -1.0, -1.0])
    cam = _core.Camera(500.0, 500.0, 512.0, 512.0, 1024, 1024, look_down, -look_down @ [0, 0, 2.0])
    errors, done = [], threading.Event()

    def render():
        try:
            for _ in range(5):
                _core.render(scene, cam, _core.DirectionalLight(0, 30), _core.RenderSettings(spp=2))
        finally:
            done.set()

    thread = threading.Thread(target=render)
    thread.start()
    while not done.is_set():
        try:
            scene.add_mesh(ground, triangles)
        except RuntimeError as e:  # std::logic_error → RuntimeError
            errors.append(str(e))
    thread.join()
    assert errors and all("while a render is using it" in e for e in errors)
