"""sandbag-01, -02 and -03 against exact geometric properties: a closed, consistently oriented 2-manifold of
sphere topology, outward faces, the extents and volume its parameters imply, and a diameter on
the paper's ~400 mm ADD-S scale."""

from __future__ import annotations

import math

import numpy as np
import pytest

from moonbot.scene.bag_mesh import FOLDED, SEAMED, BagShape, filled_cuboid, folded_cuboid, seamed_cuboid

SHAPES = {
    "default": BagShape(),
    "sharp-box": BagShape(edge_radius_m=0.0, bulge_m=0.0),
    "sharp-bulged": BagShape(edge_radius_m=0.0, bulge_m=0.01),
    "round-no-bulge": BagShape(edge_radius_m=0.02, bulge_m=0.0),
    "coarse": BagShape(edge_length_m=0.05),
    "long-thin": BagShape(size_m=(0.6, 0.1, 0.05), edge_radius_m=0.01, bulge_m=0.005),
    "seamed": SEAMED,
    "seamed-no-stitch": BagShape(seam_height_m=0.004, stitch_depth=0.0),
    "folded": FOLDED,
    "folded-deep": BagShape(fold_length_m=0.1, gather=0.5, pleats=7, pleat_depth_m=0.01),
}


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
    outward everywhere. Without seams the body is also convex and centred on the origin, so
    every triangle's normal points away from the origin."""
    v, t = filled_cuboid(shape)
    v = v.astype(np.float64)
    assert signed_volume(v, t) > 0
    if shape.seam_height_m == 0 and shape.fold_length_m == 0:
        n = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
        centroid = v[t].mean(axis=1)
        assert (np.einsum("ij,ij->i", n, centroid) > 0).all()


@pytest.mark.parametrize("shape", SHAPES.values(), ids=SHAPES.keys())
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
    rounded = (sx * sy * sz - (4 - math.pi) * r**2 * (sx + sy + sz - 6 * r)
               - (8 - 4 * math.pi / 3) * r**3)
    volume = signed_volume(v, t)
    faces = 2 * (sx * sy + sy * sz + sz * sx)
    assert volume <= rounded + faces * shape.bulge_m
    if shape.fold_length_m == 0:  # gathering the ends takes volume away
        assert volume >= rounded * 0.995
    if r == 0 and shape.bulge_m == 0:
        assert volume == pytest.approx(sx * sy * sz, rel=1e-6)


@pytest.mark.parametrize("make", [filled_cuboid, seamed_cuboid, folded_cuboid],
                         ids=["sandbag-01", "sandbag-02", "sandbag-03"])
def test_default_diameter_is_on_the_papers_scale(make):
    """ADD-S thresholds are 10 % and 20 % of a ~400 mm diameter: each default body's largest
    distance between surface points is 380–420 mm."""
    v, _ = make()
    v = v.astype(np.float64)
    diameter = max(np.linalg.norm(v[i:i + 512, None] - v[None], axis=2).max() for i in range(0, len(v), 512))
    assert 0.380 <= diameter <= 0.420


def test_seam_is_proud_by_its_height_and_only_on_the_edges():
    """sandbag-02 is sandbag-01 with vertices moved outward along the rounding normal on the
    edge arcs only: the largest move is the seam height (at the middle of an arc, between
    stitches), nothing on the flat faces moves, and the volume grows."""
    plain_v, plain_t = filled_cuboid(BagShape())
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
    plain_v, t = filled_cuboid(BagShape(**{**shape.__dict__, "fold_length_m": 0.0}))
    fold_v, _ = folded_cuboid(shape)

    def normals(v):
        v = v.astype(np.float64)
        return np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])

    assert (np.einsum("ij,ij->i", normals(plain_v), normals(fold_v)) > 0).all()
    np.testing.assert_array_equal(fold_v[:, 0], plain_v[:, 0])


def test_folded_ends_gather_the_cross_section():
    """With pleats off, every vertex's cross-section coordinates are the plain body's times
    1 − gather·s(t)², s the smoothstep of t = (|x| − start) / fold_length: exactly the gather
    law, 1 in the middle and 1 − gather at the very ends."""
    shape = BagShape(fold_length_m=0.06, pleat_depth_m=0.0, gather=0.3)
    plain, _ = filled_cuboid(BagShape(size_m=shape.size_m))
    folded, _ = folded_cuboid(shape)
    start = shape.size_m[0] / 2 + shape.bulge_m - shape.fold_length_m
    t = np.clip((np.abs(plain[:, 0].astype(np.float64)) - start) / shape.fold_length_m, 0, 1)
    scale = 1.0 - shape.gather * (t * t * (3 - 2 * t)) ** 2
    np.testing.assert_allclose(folded[:, 1:], plain[:, 1:] * scale[:, None], rtol=1e-6, atol=1e-9)
    assert scale.min() < 1.0 - shape.gather + 0.01 and scale.max() == 1.0


def _symmetric_under(v, R, tolerance=1e-6):
    """Fraction of vertices that the rotation R maps onto some vertex of the mesh."""
    key = lambda a: {tuple(p) for p in np.round(a / tolerance).astype(np.int64)}
    original = key(v.astype(np.float64))
    rotated = np.round((v.astype(np.float64) @ R.T) / tolerance).astype(np.int64)
    return np.mean([tuple(p) in original for p in rotated])


def test_folding_breaks_the_boxs_half_turns():
    """The plain and seamed bodies map onto themselves under the box's half-turns about x, y and
    z (their vertex sets are mirror-symmetric); the folded ends, folded differently, do not."""
    half_turns = [np.diag(d) for d in ([1.0, -1, -1], [-1.0, 1, -1], [-1.0, -1, 1])]
    for mesh in (filled_cuboid(), seamed_cuboid(BagShape(seam_height_m=0.003, stitch_pitch_m=0.01))):
        for R in half_turns:
            assert _symmetric_under(mesh[0], R, tolerance=2e-6) > 0.999
    folded, _ = folded_cuboid()
    for R in half_turns:
        assert _symmetric_under(folded, R, tolerance=2e-6) < 0.9


def test_deterministic_bytes():
    a, b = filled_cuboid(), filled_cuboid()
    assert a[0].tobytes() == b[0].tobytes() and a[1].tobytes() == b[1].tobytes()


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"size_m": (0.3, 0.0, 0.1)}, "size_m"), ({"edge_radius_m": 0.07}, "edge_radius_m"),
    ({"edge_radius_m": -0.001}, "edge_radius_m"), ({"bulge_m": 0.5}, "bulge_m"),
    ({"edge_length_m": 0.0}, "edge_length_m"), ({"edge_steps": 0}, "edge_steps"),
    ({"seam_height_m": 0.003, "edge_radius_m": 0.0}, "seam_height_m"),
    ({"seam_height_m": 0.003, "seam_width_m": 0.05}, "seam_width_m"),
    ({"stitch_pitch_m": 0.0}, "stitch_pitch_m"), ({"stitch_depth": 1.5}, "stitch_depth"),
    ({"fold_length_m": 0.5}, "fold_length_m"), ({"gather": 0.9}, "gather"),
    ({"pleats": 1}, "pleats"), ({"pleat_depth_m": 0.1}, "pleat_depth_m"),
])
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
        p = points[i:i + 250, None]
        d1 = (b - a)[None, :, 0] * (p[..., 1] - a[None, :, 1]) - (b - a)[None, :, 1] * (p[..., 0] - a[None, :, 0])
        d2 = (c - b)[None, :, 0] * (p[..., 1] - b[None, :, 1]) - (c - b)[None, :, 1] * (p[..., 0] - b[None, :, 0])
        d3 = (a - c)[None, :, 0] * (p[..., 1] - c[None, :, 1]) - (a - c)[None, :, 1] * (p[..., 0] - c[None, :, 0])
        hits[i:i + 250] = ((d1 > 0) & (d2 > 0) & (d3 > 0)).sum(axis=1)
    assert hits.max() == 1
    assert hits.mean() == pytest.approx(_uv_area(uv).sum() / 0.5, rel=0.1)  # coverage = area share


def test_uv_density_is_uniform_on_the_flat_box():
    """On the sharp, flat box the layout is an isometry up to one scale: every triangle's UV area
    over its 3D area is the same."""
    from moonbot.scene.bag_mesh import uv_atlas

    shape = BagShape(edge_radius_m=0.0, bulge_m=0.0)
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
