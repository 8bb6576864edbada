"""sandbag-01, -02 and -03 against exact geometric properties: a closed, consistently oriented 2-manifold of
sphere topology, outward faces, the extents and volume its parameters imply, and a diameter on
the paper's ~400 mm ADD-S scale; the settled body's sag and the creases' and puckers' depths
measured from the mesh against the configured ones."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from moonbot.scene.bag_mesh import FOLDED, SEAMED, BagShape, filled_cuboid, folded_cuboid, seamed_cuboid

pytestmark = pytest.mark.unit

# The unsettled, unwrinkled pillow of the first bodies: the exact-volume tests below hold for it.
PLAIN = dict(sag_m=0.0, belly_m=0.0, belly_height=0.0, flat_bottom=False, crease_depth_m=0.0, pucker_depth_m=0.0)

SHAPES = {
    "default": BagShape(),
    "pillow": BagShape(**PLAIN),
    "sharp-box": BagShape(**PLAIN, edge_radius_m=0.0, bulge_m=0.0),
    "sharp-bulged": BagShape(**PLAIN, edge_radius_m=0.0, bulge_m=0.01),
    "round-no-bulge": BagShape(**PLAIN, edge_radius_m=0.02, bulge_m=0.0),
    "coarse": BagShape(**PLAIN, edge_length_m=0.05),
    "long-thin": BagShape(**PLAIN, size_m=(0.6, 0.1, 0.05), edge_radius_m=0.01, bulge_m=0.005),
    "long-thin-wrinkled": BagShape(size_m=(0.6, 0.1, 0.05), edge_radius_m=0.01, bulge_m=0.005),
    "seamed": SEAMED,
    "seamed-no-stitch": BagShape(seam_height_m=0.004, stitch_depth=0.0),
    "folded": FOLDED,
    "folded-deep": BagShape(fold_length_m=0.1, gather=0.5, pleats=7, pleat_depth_m=0.01),
    "deep-wrinkles": BagShape(
        crease_depth_m=0.005, creases_per_corner=4, pucker_depth_m=0.003, pucker_pitch_m=0.024, wrinkle_seed=7
    ),
    "hard-settled": BagShape(sag_m=0.03, belly_m=0.03, belly_height=0.8),
    "sharp-settled": BagShape(edge_radius_m=0.0, bulge_m=0.01),
}
WRINKLED = {k: s for k, s in SHAPES.items() if s.crease_depth_m > 0 or s.pucker_depth_m > 0}


def signed_volume(v, t):
    a, b, c = (v[t[:, i]].astype(np.float64) for i in range(3))
    return np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0


@pytest.mark.parametrize("shape", SHAPES.values(), ids=SHAPES.keys())
def test_closed_oriented_manifold_of_sphere_topology(shape):
    """Every directed edge occurs once and its reverse once (closed, consistently oriented,
    manifold); V − E + F = 2; no degenerate triangle; no unused vertex."""
    v, t = filled_cuboid(shape)
    assert v.dtype == np.float32 and t.dtype == np.int32 and np.isfinite(v).all()
    directed = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    keys = directed[:, 0].astype(np.int64) * len(v) + directed[:, 1]
    reverse = directed[:, 1].astype(np.int64) * len(v) + directed[:, 0]
    assert len(np.unique(keys)) == len(keys)
    assert np.isin(reverse, keys).all()
    assert len(v) - len(directed) // 2 + len(t) == 2
    assert len(np.unique(t)) == len(v)
    area = np.linalg.norm(np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]]), axis=1)
    assert area.min() > 0


@pytest.mark.parametrize("shape", SHAPES.values(), ids=SHAPES.keys())
def test_faces_point_outward(shape):
    """A consistently oriented closed surface (previous test) with positive signed volume faces
    outward everywhere. The plain pillow is also convex and centred on the origin, so every
    triangle's normal points away from the origin."""
    v, t = filled_cuboid(shape)
    v = v.astype(np.float64)
    assert signed_volume(v, t) > 0
    if shape.seam_height_m == 0 and shape.fold_length_m == 0 and dataclasses.replace(shape, **PLAIN) == shape:
        n = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
        centroid = v[t].mean(axis=1)
        assert (np.einsum("ij,ij->i", n, centroid) > 0).all()


@pytest.mark.parametrize("shape", WRINKLED.values(), ids=WRINKLED.keys())
def test_wrinkles_fold_nothing_through_itself(shape):
    """Every triangle of the wrinkled body faces the same way as its twin on the smooth body
    (same lattice): a crease or pucker folded through the surface would flip some."""
    smooth, t = filled_cuboid(shape, wrinkles=False)
    wrinkled, t2 = filled_cuboid(shape)
    np.testing.assert_array_equal(t, t2)

    def normals(v):
        v = v.astype(np.float64)
        return np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])

    cosine = np.einsum("ij,ij->i", normals(smooth), normals(wrinkled))
    cosine /= np.linalg.norm(normals(smooth), axis=1) * np.linalg.norm(normals(wrinkled), axis=1)
    assert cosine.min() > math.cos(math.radians(60))


@pytest.mark.parametrize(
    "shape",
    [s for s in SHAPES.values() if dataclasses.replace(s, **PLAIN) == s],
    ids=[k for k, s in SHAPES.items() if dataclasses.replace(s, **PLAIN) == s],
)
def test_extents_and_volume_follow_the_parameters(shape):
    """Half-extent = size/2 + bulge (a vertex sits at every face centre); the volume lies between
    the rounded box's (less 0.5 %: the polyhedron is inscribed in the rounding) and the bulge's
    upper bound, and equals the box's for a sharp, flat box."""
    v, t = filled_cuboid(shape)
    half = np.array(shape.size_m) / 2
    np.testing.assert_allclose(np.abs(v).max(axis=0), half + shape.bulge_m, rtol=1e-6)
    r = shape.edge_radius_m
    sx, sy, sz = shape.size_m
    # Box minus what rounding cuts: (1 − π/4) r² per unit of the 12 edges' length and
    # (1 − π/6) r³ per corner.
    rounded = sx * sy * sz - (4 - math.pi) * r**2 * (sx + sy + sz - 6 * r) - (8 - 4 * math.pi / 3) * r**3
    volume = signed_volume(v, t)
    faces = 2 * (sx * sy + sy * sz + sz * sx)
    assert volume <= rounded + faces * shape.bulge_m
    if shape.fold_length_m == 0:  # gathering the ends takes volume away
        assert volume >= rounded * 0.995
    if r == 0 and shape.bulge_m == 0:
        assert volume == pytest.approx(sx * sy * sz, rel=1e-6)


@pytest.mark.parametrize(
    "make", [filled_cuboid, seamed_cuboid, folded_cuboid], ids=["sandbag-01", "sandbag-02", "sandbag-03"]
)
def test_default_diameter_is_on_the_papers_scale(make):
    """ADD-S thresholds are 10 % and 20 % of a ~400 mm diameter: each default body's largest
    distance between surface points is 380–420 mm."""
    v, _ = make()
    v = v.astype(np.float64)
    diameter = max(np.linalg.norm(v[i : i + 512, None] - v[None], axis=2).max() for i in range(0, len(v), 512))
    assert 0.380 <= diameter <= 0.420


def test_seam_is_proud_by_its_height_and_only_on_the_edges():
    """sandbag-02 is sandbag-01 with vertices moved outward along the rounding normal on the
    edge arcs only: the largest move is the seam height (at the middle of an arc, between
    stitches), nothing on the flat faces moves, and the volume grows."""
    plain_v, plain_t = filled_cuboid(dataclasses.replace(SEAMED, seam_height_m=0.0))
    seam_v, seam_t = seamed_cuboid()
    np.testing.assert_array_equal(plain_t, seam_t)  # same lattice, same triangles
    move = np.linalg.norm(seam_v.astype(np.float64) - plain_v, axis=1)
    assert move.max() == pytest.approx(SEAMED.seam_height_m, rel=1e-3)
    inner = np.array(SEAMED.size_m) / 2 - SEAMED.edge_radius_m
    on_edge_band = (np.abs(plain_v) > inner + 1e-7).sum(axis=1) >= 2
    assert (move[~on_edge_band] == 0).all()
    assert (move[on_edge_band] > 0).mean() > 0.3
    assert signed_volume(seam_v, seam_t) > signed_volume(plain_v, plain_t)


def test_stitches_modulate_the_seam():
    """Along an edge the seam's height dips by stitch_depth once per stitch pitch."""
    v, _ = seamed_cuboid(BagShape(seam_height_m=0.004, stitch_depth=0.5, stitch_pitch_m=0.02))
    plain, _ = filled_cuboid(BagShape())
    move = np.linalg.norm(v.astype(np.float64) - plain, axis=1)
    ridge = move > 0.5 * 0.004 * 0.5
    assert move[ridge].max() == pytest.approx(0.004, rel=1e-3)
    assert move[ridge].min() < 0.004 * 0.75  # the stitch dips are sampled too


@pytest.mark.parametrize("shape", [FOLDED, SHAPES["folded-deep"]], ids=["folded", "folded-deep"])
def test_folds_do_not_fold_the_surface_through_itself(shape):
    """Every triangle of sandbag-03 still faces the same way as its twin on the unfolded body
    (a pleat folded through the surface would flip some), and x is untouched by folding."""
    plain_v, t = filled_cuboid(BagShape(**{**shape.__dict__, "fold_length_m": 0.0}), wrinkles=False)
    fold_v, _ = folded_cuboid(shape, wrinkles=False)

    def normals(v):
        v = v.astype(np.float64)
        return np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])

    assert (np.einsum("ij,ij->i", normals(plain_v), normals(fold_v)) > 0).all()
    np.testing.assert_array_equal(fold_v[:, 0], plain_v[:, 0])


def test_folded_ends_gather_the_cross_section():
    """With pleats off, every vertex's cross-section coordinates are the plain body's times
    1 − gather·s(t)², s the smoothstep of t = (|x| − start) / fold_length: exactly the gather
    law, 1 in the middle and 1 − gather at the very ends."""
    shape = BagShape(**PLAIN, fold_length_m=0.06, pleat_depth_m=0.0, gather=0.3)
    plain, _ = filled_cuboid(BagShape(**PLAIN, size_m=shape.size_m))
    folded, _ = folded_cuboid(shape)
    start = shape.size_m[0] / 2 + shape.bulge_m - shape.fold_length_m
    t = np.clip((np.abs(plain[:, 0].astype(np.float64)) - start) / shape.fold_length_m, 0, 1)
    scale = 1.0 - shape.gather * (t * t * (3 - 2 * t)) ** 2
    np.testing.assert_allclose(folded[:, 1:], plain[:, 1:] * scale[:, None], rtol=1e-6, atol=1e-9)
    assert scale.min() < 1.0 - shape.gather + 0.01 and scale.max() == 1.0


def _symmetric_under(v, R, tolerance=1e-6):
    """Fraction of vertices that the rotation R maps onto some vertex of the mesh."""

    def key(a):
        return {tuple(p) for p in np.round(a / tolerance).astype(np.int64)}

    original = key(v.astype(np.float64))
    rotated = np.round((v.astype(np.float64) @ R.T) / tolerance).astype(np.int64)
    return np.mean([tuple(p) in original for p in rotated])


def test_sag_keeps_only_the_half_turn_about_z_and_folding_breaks_it():
    """The settled, wrinkled -01 and -02 map onto themselves under the half-turn about z (their
    vertex sets are symmetric: the wrinkles' layout is repeated turned); sag breaks the
    half-turns about x and y (top and bottom differ); the folded ends, folded differently,
    break all three."""
    about_z = np.diag([-1.0, -1, 1])
    tipping = [np.diag(d) for d in ([1.0, -1, -1], [-1.0, 1, -1])]
    for mesh in (filled_cuboid(), seamed_cuboid(BagShape(seam_height_m=0.003, stitch_pitch_m=0.01))):
        assert _symmetric_under(mesh[0], about_z, tolerance=2e-6) > 0.999
        for R in tipping:
            assert _symmetric_under(mesh[0], R, tolerance=2e-6) < 0.5
    folded, _ = folded_cuboid()
    for R in [about_z] + tipping:
        assert _symmetric_under(folded, R, tolerance=2e-6) < 0.9


def test_the_pillow_keeps_the_boxs_half_turns():
    """Without sag and wrinkles the plain and seamed bodies keep all three half-turns."""
    half_turns = [np.diag(d) for d in ([1.0, -1, -1], [-1.0, 1, -1], [-1.0, -1, 1])]
    for mesh in (
        filled_cuboid(BagShape(**PLAIN)),
        seamed_cuboid(BagShape(**PLAIN, seam_height_m=0.003, stitch_pitch_m=0.01)),
    ):
        for R in half_turns:
            assert _symmetric_under(mesh[0], R, tolerance=2e-6) > 0.999


def _warp(v, belly_height):
    """The sides' vertical profile coordinate: (v − v0)/(1 − v0·v), v0 = −belly_height."""
    v0 = -belly_height
    return (v - v0) / (1.0 - v0 * v)


def test_sag_settles_the_top_bellies_the_sides_and_flattens_the_bottom():
    """Measured on the default (wrinkled) body: the top's centre vertex sits at
    H/2 + bulge − sag; the bottom is flat at −H/2 over exactly the flat part of the face
    (wrinkles fade off it); on the smooth body the middle column of the +y side lies at
    W/2 + (bulge + belly)·(1 − w²)², w the warped height, widest at belly_height below the
    middle."""
    shape = BagShape()
    half = np.array(shape.size_m) / 2
    inner = half - shape.edge_radius_m
    v, _ = filled_cuboid(shape)
    v = v.astype(np.float64)
    top_centre = (np.abs(v[:, 0]) < 1e-9) & (np.abs(v[:, 1]) < 1e-9) & (v[:, 2] > 0)
    assert top_centre.sum() == 1
    assert v[top_centre, 2][0] == pytest.approx(half[2] + shape.bulge_m - shape.sag_m, abs=1e-7)
    assert v[:, 2].min() == pytest.approx(-half[2], abs=1e-7)
    on_floor = np.abs(v[:, 2] + half[2]) < 1e-7
    assert np.abs(v[on_floor, :2]).max(axis=0) == pytest.approx(inner[:2], abs=1e-6)
    assert (np.abs(v[~on_floor, 2] + half[2]) > 1e-4).all()  # nothing else grazes the floor

    smooth, _ = filled_cuboid(shape, wrinkles=False)
    smooth = smooth.astype(np.float64)
    column = (np.abs(smooth[:, 0]) < 1e-9) & (smooth[:, 1] > half[1] - 1e-9) & (np.abs(smooth[:, 2]) <= inner[2])
    w = _warp(smooth[column, 2] / inner[2], shape.belly_height)
    np.testing.assert_allclose(
        smooth[column, 1] - half[1], (shape.bulge_m + shape.belly_m) * (1 - w**2) ** 2, atol=1e-7
    )
    widest = smooth[column][np.argmax(smooth[column, 1])]
    assert widest[2] == pytest.approx(-shape.belly_height * inner[2], abs=shape.edge_length_m)
    assert widest[1] == pytest.approx(half[1] + shape.bulge_m + shape.belly_m, abs=2e-5)


def _move(shape):
    """Per vertex: the smooth body's position (N, 3) and how far the wrinkles move it (N,)."""
    smooth, _ = filled_cuboid(shape, wrinkles=False)
    wrinkled, _ = filled_cuboid(shape)
    smooth = smooth.astype(np.float64)
    return smooth, np.linalg.norm(wrinkled - smooth, axis=1)


def test_creases_are_as_deep_as_configured_and_stay_near_the_corners():
    """Creases alone: the deepest move equals crease_depth_m (the deepest crease of each fan is
    exactly that deep; the mesh samples its crest within a few %, and crossing creases near a
    corner add up to at most half as much again); nothing farther from every corner than the
    crease length plus half its width (and the rounding) moves."""
    shape = BagShape(pucker_depth_m=0.0, flat_bottom=False, wrinkle_seed=5)
    smooth, move = _move(shape)
    assert shape.crease_depth_m * 0.95 <= move.max() <= shape.crease_depth_m * 1.5
    half = np.array(shape.size_m) / 2
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * half
    nearest = np.linalg.norm(smooth[:, None] - corners[None], axis=2).min(axis=1)
    reach = shape.crease_length_m + shape.crease_width_m / 2 + shape.bulge_m + shape.belly_m
    assert (move[nearest > reach] == 0).all()
    assert (move > 0.1 * shape.crease_depth_m).mean() > 0.05


def test_puckers_are_as_deep_as_configured_and_stay_along_the_seams():
    """Puckers alone: along the middle of every edge, where no other edge's puckers reach, the
    deepest move is pucker_depth_m to within the sampling of its crest, and never more; nothing
    farther than pucker_length_m from every edge (over the surface, plus the rounding) moves."""
    shape = BagShape(crease_depth_m=0.0, flat_bottom=False)
    smooth, move = _move(shape)
    half = np.array(shape.size_m) / 2
    # Distance over the sharp box from each of the 12 edges, e = (h_i − |p_i|) + (h_j − |p_j|).
    gap = half - np.abs(smooth)
    from_edges = np.sort(np.stack([gap[:, 1] + gap[:, 2], gap[:, 2] + gap[:, 0], gap[:, 0] + gap[:, 1]]), axis=0)
    reach = shape.pucker_length_m + shape.edge_radius_m + shape.bulge_m + shape.belly_m
    assert (move[from_edges[0] > reach] == 0).all()
    lone = (from_edges[0] < shape.pucker_length_m / 2) & (from_edges[1] > reach)
    assert shape.pucker_depth_m * 0.9 <= move[lone].max() <= shape.pucker_depth_m * 1.001


def test_wrinkles_fade_inside_the_folds():
    """sandbag-03's folded ends carry their pleats, not creases: where the fold is 98 % done
    (the smoothstep of the fold there is 0.9988) the wrinkles are faded to within 0.2 % of
    their depth."""
    smooth, _ = folded_cuboid(wrinkles=False)
    wrinkled, _ = folded_cuboid()
    end = np.abs(smooth[:, 0]) > FOLDED.size_m[0] / 2 + FOLDED.bulge_m + FOLDED.belly_m - 0.02 * FOLDED.fold_length_m
    assert end.sum() > 20
    np.testing.assert_allclose(wrinkled[end], smooth[end], atol=0.002 * 2 * FOLDED.crease_depth_m)
    assert np.abs(wrinkled - smooth).max() > 0.5 * FOLDED.crease_depth_m


def test_deterministic_bytes():
    a, b = filled_cuboid(), filled_cuboid()
    assert a[0].tobytes() == b[0].tobytes() and a[1].tobytes() == b[1].tobytes()


def test_the_seed_moves_only_the_wrinkles():
    """Another wrinkle_seed lays the creases and puckers out differently on the same lattice;
    the smooth body is the same to the byte."""
    a, b = BagShape(wrinkle_seed=1), BagShape(wrinkle_seed=2)
    va, ta = filled_cuboid(a)
    vb, tb = filled_cuboid(b)
    np.testing.assert_array_equal(ta, tb)
    assert np.abs(va - vb).max() > 0.5 * a.crease_depth_m
    assert filled_cuboid(a, wrinkles=False)[0].tobytes() == filled_cuboid(b, wrinkles=False)[0].tobytes()


def test_triangle_counts_stay_modest():
    """Every default variant, resolved for its wrinkles, stays under 30 k triangles (each bag
    instance and the amodal passes trace them)."""
    for make in (filled_cuboid, seamed_cuboid, folded_cuboid):
        _, t = make()
        assert len(t) <= 30_000


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"size_m": (0.3, 0.0, 0.1)}, "size_m"),
        ({"edge_radius_m": 0.07}, "edge_radius_m"),
        ({"edge_radius_m": -0.001}, "edge_radius_m"),
        ({"bulge_m": 0.5}, "bulge_m"),
        ({"edge_length_m": 0.0}, "edge_length_m"),
        ({"edge_steps": 0}, "edge_steps"),
        ({"seam_height_m": 0.003, "edge_radius_m": 0.0}, "seam_height_m"),
        ({"seam_height_m": 0.003, "seam_width_m": 0.05}, "seam_width_m"),
        ({"stitch_pitch_m": 0.0}, "stitch_pitch_m"),
        ({"stitch_depth": 1.5}, "stitch_depth"),
        ({"fold_length_m": 0.5}, "fold_length_m"),
        ({"gather": 0.9}, "gather"),
        ({"pleats": 1}, "pleats"),
        ({"pleat_depth_m": 0.1}, "pleat_depth_m"),
        ({"sag_m": -0.001}, "sag_m"),
        ({"belly_m": 0.04}, "belly_m"),
        ({"belly_height": 0.9}, "belly_height"),
        ({"crease_depth_m": 0.006}, "crease_depth_m"),
        ({"crease_length_m": 0.0}, "crease_length_m"),
        ({"crease_width_m": 0.1, "crease_length_m": 0.05}, "crease_width_m"),
        ({"creases_per_corner": 9}, "creases_per_corner"),
        ({"pucker_depth_m": 0.005}, "pucker_depth_m"),
        ({"pucker_pitch_m": 0.0}, "pucker_pitch_m"),
        ({"pucker_length_m": 0.07}, "pucker_length_m"),
        ({"wrinkle_seed": -1}, "wrinkle_seed"),
    ],
)
def test_bad_parameters_name_the_field(kwargs, field):
    with pytest.raises(ValueError, match=field):
        BagShape(**kwargs)


def test_variants_need_their_feature():
    with pytest.raises(ValueError, match="seam_height_m"):
        seamed_cuboid(BagShape())
    with pytest.raises(ValueError, match="fold_length_m"):
        folded_cuboid(BagShape())


def _uv_area(uv):
    e1, e2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
    return 0.5 * (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])


@pytest.mark.parametrize("shape", [BagShape(), SEAMED, FOLDED], ids=["01", "02", "03"])
def test_uv_atlas_is_a_valid_layout(shape):
    """Per-corner UVs for every triangle, inside [0, 1]², none mirrored (positive area), and no
    two triangles overlapping: random points of the atlas fall in at most one triangle."""
    from moonbot.scene.bag_mesh import uv_atlas

    uv = uv_atlas(shape).astype(np.float64)
    _, t = filled_cuboid(shape)
    assert uv.shape == (len(t), 3, 2)
    assert uv.min() >= 0.0 and uv.max() <= 1.0
    assert (_uv_area(uv) > 0).all()
    points = np.random.default_rng(0).random((3000, 2)) * [1.0, 0.5]
    a, b, c = uv[:, 0], uv[:, 1], uv[:, 2]
    hits = np.zeros(len(points), dtype=int)
    for i in range(0, len(points), 250):
        p = points[i : i + 250, None]
        d1 = (b - a)[None, :, 0] * (p[..., 1] - a[None, :, 1]) - (b - a)[None, :, 1] * (p[..., 0] - a[None, :, 0])
        d2 = (c - b)[None, :, 0] * (p[..., 1] - b[None, :, 1]) - (c - b)[None, :, 1] * (p[..., 0] - b[None, :, 0])
        d3 = (a - c)[None, :, 0] * (p[..., 1] - c[None, :, 1]) - (a - c)[None, :, 1] * (p[..., 0] - c[None, :, 0])
        hits[i : i + 250] = ((d1 > 0) & (d2 > 0) & (d3 > 0)).sum(axis=1)
    assert hits.max() == 1
    assert hits.mean() == pytest.approx(_uv_area(uv).sum() / 0.5, rel=0.1)  # coverage = area share


def test_uv_density_is_uniform_on_the_flat_box():
    """On the sharp, flat box the layout is an isometry up to one scale: every triangle's UV area
    over its 3D area is the same."""
    from moonbot.scene.bag_mesh import uv_atlas

    shape = BagShape(**PLAIN, edge_radius_m=0.0, bulge_m=0.0)
    v, t = filled_cuboid(shape)
    v = v.astype(np.float64)
    area3d = 0.5 * np.linalg.norm(np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]]), axis=1)
    ratio = _uv_area(uv_atlas(shape).astype(np.float64)) / area3d
    np.testing.assert_allclose(ratio, ratio[0], rtol=1e-4)


def test_uv_seams_only_along_box_edges():
    """Two triangles sharing an edge give its vertices the same UVs except where the edge lies on
    a box edge (chart border): seams are a small fraction of edges and never cross a face."""
    from moonbot.scene.bag_mesh import uv_atlas

    shape = BagShape()
    v, t = filled_cuboid(shape)
    uv = uv_atlas(shape)
    corner_uv = {}
    seams = shared = 0
    for tri, coords in zip(t, uv):
        for k in range(3):
            edge = (tri[k], tri[(k + 1) % 3])
            key = tuple(sorted(edge))
            value = {tri[k]: tuple(coords[k]), tri[(k + 1) % 3]: tuple(coords[(k + 1) % 3])}
            if key in corner_uv:
                shared += 1
                seams += corner_uv[key] != value
            else:
                corner_uv[key] = value
    assert shared == 3 * len(t) // 2
    assert 0 < seams < 0.03 * shared
