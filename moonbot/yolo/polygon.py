"""One polygon per instance mask, as Ultralytics' segmentation labels need
(Ultralytics' segment format): the mask's boundary traced along pixel edges, thinned
by Douglas–Peucker, and every piece (separate components, holes) joined into a single ring.

Coordinates are continuous pixel coordinates: pixel (x, y) is the square [x, x+1) × [y, y+1), so
a traced boundary runs along integer grid lines and encloses exactly the mask's pixels.

- Tracing: every pixel edge between a mask pixel and a non-mask pixel is a directed edge with the
  mask on its right (on screen, y down): outer boundaries run clockwise, holes anticlockwise.
  Edges are chained into closed loops; where two mask pixels touch only at a corner the chain
  turns toward the mask, so such pixels belong to separate loops (4-connectivity).
- Thinning: each loop keeps its four extreme vertices (leftmost, topmost, rightmost,
  bottommost: so the polygon's extent is exactly the mask's box) and, between them, the vertices
  Douglas–Peucker keeps at `tolerance` (DEFAULT_TOLERANCE_PX, 1 px: on a 160 × 100 px ellipse
  with a hole, 58 vertices and an IoU of 0.988 with the mask at pixel centres, against 300 and
  1.0 at 0.5 px; 0 keeps every corner and is exact).
- Joining: starting from the loop of largest area, each remaining loop is spliced in at its
  vertex nearest to the ring so far, along a zero-width bridge walked there and back. The bridges
  cancel under both the even-odd and the non-zero fill rule, so the ring fills the mask's pieces
  and leaves its holes.
"""

from __future__ import annotations

import numpy as np

# Douglas–Peucker tolerance, pixels: the ring stays within a pixel of the traced boundary.
DEFAULT_TOLERANCE_PX = 1.0

# Direction codes, clockwise on screen (y down): a right turn is +1.
_EAST, _SOUTH, _WEST, _NORTH = 0, 1, 2, 3
_STEP = np.array([[1, 0], [0, 1], [-1, 0], [0, -1]], dtype=np.int64)


def boundary_loops(mask: np.ndarray) -> list[np.ndarray]:
    """The closed boundaries of `mask` (H, W) bool along pixel edges: a list of (N, 2) int64
    arrays of corner vertices (x, y), in traversal order (mask on the right), without the closing
    repeat. Outer boundaries are clockwise on screen, holes anticlockwise. Deterministic order."""
    ys, xs = np.nonzero(mask)
    if xs.size == 0:
        return []
    x0, y0 = int(xs.min()), int(ys.min())
    crop = mask[y0 : int(ys.max()) + 1, x0 : int(xs.max()) + 1]
    p = np.pad(crop, 1)  # p[y + 1, x + 1] is crop[y, x]; outside is False
    h, w = crop.shape
    # Horizontal grid line y (0..h) between rows y-1 and y; vertical line x between columns x-1, x.
    above, below = p[:-1, 1:-1], p[1:, 1:-1]  # (h + 1, w): rows y - 1 and y at line y, column x
    left, right = p[1:-1, :-1], p[1:-1, 1:]  # (h, w + 1): columns x - 1 and x at line x, row y
    starts, dirs = [], []
    yy, xx = np.nonzero(below & ~above)  # top edges: east from (x, y)
    starts.append(np.stack([xx, yy], 1))
    dirs.append(np.full(xx.size, _EAST))
    yy, xx = np.nonzero(above & ~below)  # bottom edges: west from (x + 1, y)
    starts.append(np.stack([xx + 1, yy], 1))
    dirs.append(np.full(xx.size, _WEST))
    yy, xx = np.nonzero(right & ~left)  # left edges: north from (x, y + 1)
    starts.append(np.stack([xx, yy + 1], 1))
    dirs.append(np.full(xx.size, _NORTH))
    yy, xx = np.nonzero(left & ~right)  # right edges: south from (x, y)
    starts.append(np.stack([xx, yy], 1))
    dirs.append(np.full(xx.size, _SOUTH))
    start = np.concatenate(starts).astype(np.int64)
    direction = np.concatenate(dirs).astype(np.int64)
    end = start + _STEP[direction]
    n = start.shape[0]
    # out[vertex, direction]: the edge leaving `vertex` that way, or -1.
    vid = lambda v: v[:, 1] * (w + 1) + v[:, 0]  # noqa: E731 - a one-line index map
    out = np.full(((h + 1) * (w + 1), 4), -1, dtype=np.int64)
    out[vid(start), direction] = np.arange(n)
    at = vid(end)
    # At a vertex where mask pixels touch diagonally two edges leave: turn right (into the mask).
    nxt = out[at, (direction + 1) % 4]
    nxt = np.where(nxt < 0, out[at, direction], nxt)
    nxt = np.where(nxt < 0, out[at, (direction + 3) % 4], nxt)
    if (nxt < 0).any():  # cannot happen for a binary mask: in-degree equals out-degree everywhere
        raise RuntimeError("boundary_loops: an open boundary chain")
    seen = np.zeros(n, dtype=bool)
    loops = []
    for first in range(n):
        if seen[first]:
            continue
        chain = []
        e = first
        while not seen[e]:
            seen[e] = True
            chain.append(e)
            e = nxt[e]
        chain = np.array(chain)
        d = direction[chain]
        corner = d != np.roll(d, 1)  # the edge turns at its start vertex
        loops.append(start[chain[corner]] + (x0, y0))
    return loops


def _douglas_peucker(points: np.ndarray, tolerance: float) -> np.ndarray:
    """Indices of the vertices of the open polyline `points` (N, 2) that Douglas–Peucker keeps at
    `tolerance` (its two ends always), ascending."""
    keep = np.zeros(len(points), dtype=bool)
    keep[0] = keep[-1] = True
    stack = [(0, len(points) - 1)]
    while stack:
        i, j = stack.pop()
        if j <= i + 1:
            continue
        a, b = points[i].astype(np.float64), points[j].astype(np.float64)
        seg = b - a
        rel = points[i + 1 : j].astype(np.float64) - a
        length = float(np.hypot(*seg))
        if length > 0.0:
            dist = np.abs(seg[0] * rel[:, 1] - seg[1] * rel[:, 0]) / length
        else:
            dist = np.hypot(rel[:, 0], rel[:, 1])
        k = int(np.argmax(dist))
        if dist[k] > tolerance:
            m = i + 1 + k
            keep[m] = True
            stack.append((i, m))
            stack.append((m, j))
    return np.flatnonzero(keep)


def _extremes(loop: np.ndarray) -> list[int]:
    """Indices of a loop's leftmost (then topmost), topmost (then rightmost), rightmost (then
    bottommost) and bottommost (then leftmost) vertices, ascending, without repeats."""
    x, y = loop[:, 0], loop[:, 1]
    picks = {
        int(np.lexsort((y, x))[0]),
        int(np.lexsort((-x, y))[0]),
        int(np.lexsort((-y, -x))[0]),
        int(np.lexsort((x, -y))[0]),
    }
    return sorted(picks)


def simplify_loop(loop: np.ndarray, tolerance: float = DEFAULT_TOLERANCE_PX) -> np.ndarray:
    """`loop` (N, 2) thinned by Douglas–Peucker at `tolerance` pixels between its extreme
    vertices, which are always kept (the extent does not change)."""
    anchors = _extremes(loop)
    kept = []
    for a, b in zip(anchors, anchors[1:] + [anchors[0] + len(loop)]):
        idx = np.arange(a, b + 1) % len(loop)
        kept.extend(idx[_douglas_peucker(loop[idx], tolerance)][:-1].tolist())
    return loop[kept]


def _area(loop: np.ndarray) -> float:
    x, y = loop[:, 0].astype(np.float64), loop[:, 1].astype(np.float64)
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def mask_polygon(mask: np.ndarray, tolerance: float = DEFAULT_TOLERANCE_PX) -> np.ndarray | None:
    """One ring (N, 2) float64 of continuous pixel coordinates (x, y) covering `mask` (H, W)
    bool: its boundary loops thinned and bridged (module docstring). None for an empty mask.
    The ring's extent is exactly the mask's: x from min column to max column + 1, likewise y."""
    loops = [simplify_loop(loop, tolerance) for loop in boundary_loops(mask)]
    if not loops:
        return None
    # The largest outer boundary first (ties: tracing order); outer loops have positive area.
    first = max(range(len(loops)), key=lambda i: (_area(loops[i]), -i))
    ring = loops.pop(first)
    while loops:
        best = None
        for k, loop in enumerate(loops):
            d = ((ring[:, None, :] - loop[None, :, :]) ** 2).sum(axis=2)
            i, j = np.unravel_index(int(np.argmin(d)), d.shape)
            if best is None or d[i, j] < best[0]:
                best = (d[i, j], k, int(i), int(j))
        _, k, i, j = best
        loop = np.roll(loops.pop(k), -j, axis=0)
        # ... ring[i] → loop[j] → around the loop → loop[j] → ring[i] → ring[i + 1] ...
        ring = np.concatenate([ring[: i + 1], loop, loop[:1], ring[i:]])
    return ring.astype(np.float64)
