"""YOLO polygons of instance masks (moonbot.yolo): traced boundaries fill exactly the mask,
thinning keeps the extent, pieces and holes are joined into one ring, rows and YAML follow the
Ultralytics rules (docs.ultralytics.com/datasets/detect and /segment)."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from moonbot.yolo import boundary_loops, data_yaml, detect_row, mask_polygon, segment_row, yolo_class

from masks import raster

pytestmark = pytest.mark.unit


def area(loop: np.ndarray) -> float:
    x, y = loop[:, 0].astype(float), loop[:, 1].astype(float)
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


@settings(max_examples=150, deadline=None)
@given(arrays(np.bool_, st.tuples(st.integers(1, 12), st.integers(1, 12))))
def test_unthinned_ring_fills_exactly_the_mask(mask):
    """Any mask — several pieces, holes, pixels touching at a corner — is reproduced pixel for
    pixel by its one bridged ring at tolerance 0."""
    ring = mask_polygon(mask, tolerance=0.0)
    if not mask.any():
        assert ring is None
        return
    np.testing.assert_array_equal(raster(ring, *mask.shape), mask)


@settings(max_examples=150, deadline=None)
@given(arrays(np.bool_, st.tuples(st.integers(1, 12), st.integers(1, 12))))
def test_thinned_ring_keeps_the_extent(mask):
    ring = mask_polygon(mask)
    if ring is None:
        return
    ys, xs = np.nonzero(mask)
    assert ring[:, 0].min() == xs.min() and ring[:, 0].max() == xs.max() + 1
    assert ring[:, 1].min() == ys.min() and ring[:, 1].max() == ys.max() + 1
    assert len(np.unique(ring, axis=0)) >= 4  # never misread as a box


def test_loops_orientation_and_corner_touching_pixels():
    """Outer boundaries are clockwise on screen (positive shoelace area with y down), holes
    anticlockwise; pixels touching only at a corner get a loop each."""
    ring = np.zeros((5, 5), bool)
    ring[1:4, 1:4] = True
    ring[2, 2] = False
    loops = boundary_loops(ring)
    assert sorted(area(l) for l in loops) == [-1.0, 9.0]
    diagonal = np.array([[1, 0], [0, 1]], bool)
    loops = boundary_loops(diagonal)
    assert len(loops) == 2 and all(area(l) == 1.0 and len(l) == 4 for l in loops)


def test_thinning_shrinks_a_disc_and_stays_close():
    yy, xx = np.mgrid[0:200, 0:300]
    disc = (xx - 150) ** 2 / 80**2 + (yy - 100) ** 2 / 50**2 < 1
    exact, thin = mask_polygon(disc, 0.0), mask_polygon(disc)
    assert len(thin) < len(exact) / 4
    filled = raster(thin, 200, 300)
    assert (filled & disc).sum() / (filled | disc).sum() > 0.98


def test_rows_and_yaml():
    mask = np.zeros((10, 20), bool)
    mask[2:5, 4:10] = True  # columns 4..9, rows 2..4
    assert detect_row(2, mask) == "1 0.350000 0.350000 0.300000 0.300000"
    row = segment_row(1, mask).split()
    assert row[0] == "0" and len(row) == 9  # a rectangle: four corners
    assert detect_row(1, np.zeros((4, 4), bool)) is None and segment_row(1, np.zeros((4, 4), bool)) is None
    assert yolo_class(4) == 3  # a user mesh's (obj_id 4, the first after the built-in variants)
    with pytest.raises(ValueError, match="obj_id: 0"):
        yolo_class(0)
    data = yaml.safe_load(data_yaml(["default"], "detect"))
    assert data["train"] == data["val"] == "images/default" and "test" not in data and data["nc"] == 3
    data = yaml.safe_load(data_yaml(["train", "val", "test"], "segment"))
    assert (data["train"], data["val"], data["test"]) == ("images/train", "images/val", "images/test")
    # Without a val split the model is selected on training images, never on the test images.
    data = yaml.safe_load(data_yaml(["train", "test"], "detect"))
    assert (data["train"], data["val"], data["test"]) == ("images/train", "images/train", "images/test")
    data = yaml.safe_load(data_yaml(["test"], "detect"))
    assert data["train"] == data["val"] == data["test"] == "images/test"
    data = yaml.safe_load(data_yaml(["train"], "detect", {1: "sandbag-01", 2: "sandbag-02", 3: "sandbag-03", 4: "can"}))
    assert data["nc"] == 4 and data["names"][3] == "can"
