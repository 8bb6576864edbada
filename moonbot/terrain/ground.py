"""Grounds: height fields the bags rest on and the renderer draws.

A `Ground` is a height field z = h(x, y) over the world's East-North-Up frame (metres), with
its gradient and a triangle mesh of it. Placement and physics settling read the height and the
gradient; the renderer reads the mesh.

- `GridGround`: heights sampled on a (graded) grid, the ground *being* its triangulation; the
  procedural locations (`location.py`) are GridGrounds.
- `FlatGround`: z = 0; `SlopedGround`: a plane falling at `slope_deg` toward
  `downhill_azimuth_deg` (clockwise from North), through the origin. Exact analytic test
  grounds, meshed with two triangles (the renderer resolves hits in double precision).
- `CraterGround`: a bare fresh simple crater (docs/physics.md): a parabolic bowl of depth
  0.13·D below a rim of height 0.036·D (Pike 1977; Stopar et al. 2017 for D < 400 m), an ejecta
  blanket falling off as (r/R)^-3 outside (McGetchin et al. 1973). Its rim crest is a sharp
  ridge (the profile is continuous there, its slope is not): the hard case for placement and
  physics tests."""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from moonbot.terrain.craters import DEPTH_RATIO as CRATER_DEPTH_RATIO
from moonbot.terrain.craters import EJECTA_EXPONENT
from moonbot.terrain.craters import RIM_RATIO as CRATER_RIM_RATIO


class Ground(ABC):
    """A height field over the world plane."""

    size_m: float

    @abstractmethod
    def height(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Ground height z (metres, float64) under world points (x, y) of any matching shape."""

    @abstractmethod
    def gradient(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(dh/dx, dh/dy), dimensionless, float64, shaped like x. On the crater's rim crest,
        where the slope jumps, the outer side's value."""

    def plane(self) -> tuple[np.ndarray, np.ndarray] | None:
        """(a point on it, its unit normal) when the ground is a plane, else None: physics can
        then collide with the exact plane instead of a sampled height field."""
        return None

    @abstractmethod
    def mesh(self) -> tuple[np.ndarray, np.ndarray]:
        """The ground as triangles: (vertices (N, 3) float32 metres, triangles (M, 3) int32),
        a square of side `size_m` centred on the origin, counter-clockwise seen from above."""

    def patch(self, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The triangles of `mesh()` whose plan bounds meet the rectangle lo..hi ((2,) metres):
        (vertices (N, 3) float64, triangles (M, 3) int32), for exact contact checks."""
        v, t = self.mesh()
        corners = v[t]
        near = np.all(corners.max(axis=1)[:, :2] >= lo, axis=1) & np.all(corners.min(axis=1)[:, :2] <= hi, axis=1)
        return v.astype(np.float64), t[near]


# The analytic grounds' innermost grid cell, metres; cells double outward from it.
PLANE_CELL_M = 0.25


def _plane_lines(half: float) -> np.ndarray:
    """Grid lines of an analytic ground, metres: 0, ±PLANE_CELL_M, doubling outward, and ±half."""
    steps = [0.0]
    step = PLANE_CELL_M
    while step < half:
        steps.append(step)
        step *= 2.0
    steps.append(half)
    return np.array(sorted({-s for s in steps} | set(steps)))


def _plane_mesh(size_m: float, a: float, b: float) -> tuple[np.ndarray, np.ndarray]:
    """The plane z = a·x + b·y over the square of side size_m, on a grid whose cells are
    PLANE_CELL_M wide at the origin and double outward (1,568 triangles at 4 km). A plane needs no
    tessellation for its shape (the renderer resolves hits in double), but float32 traversal
    places a triangle to ~1e-7 of its vertices' coordinates, and rays leaving a surface must start
    above that (cpp/src/rays.h, lift_off): small triangles near the bags keep that lift, and so
    the shadows' positions, at tens of micrometres."""
    lines = _plane_lines(size_m / 2.0)
    n = len(lines)
    x, y = np.meshgrid(lines, lines)  # vertex (row j, column i) at (lines[i], lines[j])
    xy = np.column_stack([x.ravel(), y.ravel()])
    vertices = np.column_stack([xy, a * xy[:, 0] + b * xy[:, 1]]).astype(np.float32)
    corner = (np.arange(n - 1)[None, :] + n * np.arange(n - 1)[:, None]).ravel()
    # Counter-clockwise seen from above: (i, j), (i+1, j), (i+1, j+1) and (i, j), (i+1, j+1), (i, j+1).
    triangles = np.concatenate(
        [np.column_stack([corner, corner + 1, corner + n + 1]), np.column_stack([corner, corner + n + 1, corner + n])]
    )
    return vertices, triangles.astype(np.int32)


@dataclass(frozen=True)
class FlatGround(Ground):
    size_m: float = 200.0

    def height(self, x, y):
        return np.zeros(np.broadcast(x, y).shape)

    def gradient(self, x, y):
        zero = np.zeros(np.broadcast(x, y).shape)
        return zero, zero.copy()

    def plane(self):
        return np.zeros(3), np.array([0.0, 0.0, 1.0])

    def mesh(self):
        return _plane_mesh(self.size_m, 0.0, 0.0)


@dataclass(frozen=True)
class SlopedGround(Ground):
    """z = -tan(slope)·((x, y) · downhill), downhill = (sin az, cos az)."""

    slope_deg: float
    downhill_azimuth_deg: float = 90.0
    size_m: float = 200.0

    def _ab(self) -> tuple[float, float]:
        t = math.tan(math.radians(self.slope_deg))
        az = math.radians(self.downhill_azimuth_deg)
        return -t * math.sin(az), -t * math.cos(az)

    def height(self, x, y):
        a, b = self._ab()
        return a * np.asarray(x, dtype=np.float64) + b * np.asarray(y, dtype=np.float64)

    def gradient(self, x, y):
        a, b = self._ab()
        shape = np.broadcast(x, y).shape
        return np.full(shape, a), np.full(shape, b)

    def plane(self):
        a, b = self._ab()
        return np.zeros(3), np.array([-a, -b, 1.0]) / math.sqrt(a * a + b * b + 1.0)

    def mesh(self):
        return _plane_mesh(self.size_m, *self._ab())


@dataclass(frozen=True)
class CraterGround(Ground):
    """A simple crater of rim-crest diameter `diameter_m`, its centre `centre_distance_m` from
    the origin toward `azimuth_deg` (clockwise from North). The default distance D/2 puts the
    origin, where the target bag stands, on the rim crest. Height 0 far from the crater."""

    diameter_m: float = 8.0
    centre_distance_m: float = 4.0
    azimuth_deg: float = 90.0
    size_m: float = 200.0
    detail_m: float = 0.01
    detail_half_width_m: float = 2.0
    growth: float = 1.1

    @property
    def centre(self) -> tuple[float, float]:
        az = math.radians(self.azimuth_deg)
        return self.centre_distance_m * math.sin(az), self.centre_distance_m * math.cos(az)

    def _radial(self, x, y):
        cx, cy = self.centre
        dx, dy = np.asarray(x, dtype=np.float64) - cx, np.asarray(y, dtype=np.float64) - cy
        return dx, dy, np.hypot(dx, dy)

    def height(self, x, y):
        R = self.diameter_m / 2.0
        depth, rim = CRATER_DEPTH_RATIO * self.diameter_m, CRATER_RIM_RATIO * self.diameter_m
        _, _, r = self._radial(x, y)
        s = r / R
        inside = rim - depth * (1.0 - s * s)
        outside = rim * np.maximum(s, 1.0) ** -EJECTA_EXPONENT
        return np.where(s < 1.0, inside, outside)

    def gradient(self, x, y):
        R = self.diameter_m / 2.0
        depth, rim = CRATER_DEPTH_RATIO * self.diameter_m, CRATER_RIM_RATIO * self.diameter_m
        dx, dy, r = self._radial(x, y)
        s = r / R
        dh_dr = np.where(
            s < 1.0, 2.0 * depth * s / R, -EJECTA_EXPONENT * rim / R * np.maximum(s, 1.0) ** (-EJECTA_EXPONENT - 1.0)
        )
        safe = np.where(r > 0.0, r, 1.0)  # the bowl's floor is flat at its centre
        return dh_dr * dx / safe, dh_dr * dy / safe

    def mesh(self):
        axis = graded_axis(self.size_m / 2.0, self.detail_half_width_m, self.detail_m, self.growth)
        X, Y = np.meshgrid(axis, axis, indexing="xy")
        vertices = np.column_stack([X.ravel(), Y.ravel(), self.height(X, Y).ravel()])
        return vertices.astype(np.float32), grid_triangles(len(axis), len(axis))


class GridGround(Ground):
    """A height field sampled on a (graded) grid and meshed by `grid_triangles`: heights `z`
    (ny, nx) float64 metres at the nodes `x_axis` (nx,) × `y_axis` (ny,), both increasing.
    Between nodes the ground *is* the rendered triangulation: `height` and `gradient`
    interpolate linearly on the same two triangles per cell, so placement, physics and the
    renderer agree to float32 rounding. Outside the grid the edge cells extend flat-wise."""

    def __init__(self, x_axis: np.ndarray, y_axis: np.ndarray, z: np.ndarray) -> None:
        self.x_axis = np.asarray(x_axis, dtype=np.float64)
        self.y_axis = np.asarray(y_axis, dtype=np.float64)
        self.z = np.asarray(z, dtype=np.float64)
        if self.z.shape != (len(self.y_axis), len(self.x_axis)):
            raise ValueError(
                f"z: shape {self.z.shape} does not match the axes ({len(self.y_axis)}, {len(self.x_axis)})"
            )
        if min(self.z.shape) < 2 or np.any(np.diff(self.x_axis) <= 0) or np.any(np.diff(self.y_axis) <= 0):
            raise ValueError("x_axis, y_axis: need at least 2 strictly increasing nodes each")
        if not np.all(np.isfinite(self.z)):
            raise ValueError("z: heights must be finite")
        self.size_m = float(min(self.x_axis[-1] - self.x_axis[0], self.y_axis[-1] - self.y_axis[0]))

    def _cell(self, x, y):
        """Cell indices (i, j), fractions (fx, fy) in [0, 1] and cell sizes (dx, dy)."""
        x, y = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
        i = np.clip(np.searchsorted(self.x_axis, x, side="right") - 1, 0, len(self.x_axis) - 2)
        j = np.clip(np.searchsorted(self.y_axis, y, side="right") - 1, 0, len(self.y_axis) - 2)
        dx = self.x_axis[i + 1] - self.x_axis[i]
        dy = self.y_axis[j + 1] - self.y_axis[j]
        return i, j, (x - self.x_axis[i]) / dx, (y - self.y_axis[j]) / dy, dx, dy

    def _corners(self, i, j):
        z = self.z
        return z[j, i], z[j, i + 1], z[j + 1, i + 1], z[j + 1, i]  # a, b, c, d as grid_triangles

    def height(self, x, y):
        i, j, fx, fy, _, _ = self._cell(x, y)
        a, b, c, d = self._corners(i, j)
        lower = fx >= fy  # triangle (a, b, c) below the a–c diagonal, else (a, c, d)
        return np.where(lower, a + fx * (b - a) + fy * (c - b), a + fy * (d - a) + fx * (c - d))

    def gradient(self, x, y):
        i, j, fx, fy, dx, dy = self._cell(x, y)
        a, b, c, d = self._corners(i, j)
        lower = fx >= fy
        return (np.where(lower, b - a, c - d) / dx, np.where(lower, c - b, d - a) / dy)

    def mesh(self):
        X, Y = np.meshgrid(self.x_axis, self.y_axis, indexing="xy")
        vertices = np.column_stack([X.ravel(), Y.ravel(), self.z.ravel()]).astype(np.float32)
        return vertices, grid_triangles(len(self.x_axis), len(self.y_axis))

    def vertex_normals(self) -> np.ndarray:
        """Smooth shading normals (N, 3) float32, unit, one per `mesh()` vertex: the surface's
        normal from central differences of the heights on the graded grid (one-sided at its
        edges), so the renderer can shade the triangulation as the smooth ground it samples."""
        dz_dy, dz_dx = np.gradient(self.z, self.y_axis, self.x_axis)
        n = np.stack([-dz_dx, -dz_dy, np.ones_like(self.z)], axis=-1).reshape(-1, 3)
        return (n / np.linalg.norm(n, axis=1, keepdims=True)).astype(np.float32)

    def patch(self, lo, hi):
        i0 = max(int(np.searchsorted(self.x_axis, lo[0], side="right")) - 1, 0)
        j0 = max(int(np.searchsorted(self.y_axis, lo[1], side="right")) - 1, 0)
        i1 = min(int(np.searchsorted(self.x_axis, hi[0], side="left")), len(self.x_axis) - 1)
        j1 = min(int(np.searchsorted(self.y_axis, hi[1], side="left")), len(self.y_axis) - 1)
        i1, j1 = max(i1, i0 + 1), max(j1, j0 + 1)
        xs, ys = self.x_axis[i0 : i1 + 1], self.y_axis[j0 : j1 + 1]
        X, Y = np.meshgrid(xs, ys, indexing="xy")
        # Through float32, as the renderer holds them, so contact checks see the drawn surface.
        v = np.column_stack([X.ravel(), Y.ravel(), self.z[j0 : j1 + 1, i0 : i1 + 1].ravel()])
        return v.astype(np.float32).astype(np.float64), grid_triangles(len(xs), len(ys))


def graded_axis(half_m: float, fine_half_m: float, step_m: float, growth: float) -> np.ndarray:
    """Sorted grid coordinates over [-half_m, half_m] (float64, metres): uniform `step_m` within
    ±fine_half_m, then steps growing by `growth` per cell to the ends (both ends included)."""
    if not (0 < step_m and growth >= 1.0 and 0 < fine_half_m <= half_m):
        raise ValueError(f"graded_axis: bad parameters {half_m=}, {fine_half_m=}, {step_m=}, {growth=}")
    n_fine = max(1, round(fine_half_m / step_m))
    fine = step_m * np.arange(0, n_fine + 1)
    outer = [fine[-1]]
    step = step_m
    while outer[-1] < half_m:
        step *= growth
        outer.append(min(outer[-1] + step, half_m))
    if len(outer) > 2 and outer[-1] - outer[-2] < 0.5 * step:
        del outer[-2]  # no sliver cell at the edge
    positive = np.concatenate([fine, outer[1:]])
    return np.concatenate([-positive[:0:-1], positive])


def grid_triangles(nx: int, ny: int) -> np.ndarray:
    """Triangles (2·(nx-1)·(ny-1), 3) int32 of a row-major nx × ny vertex grid (x fastest),
    counter-clockwise seen from +z when x and y increase along the grid."""
    i = np.arange(nx - 1)[None, :] + nx * np.arange(ny - 1)[:, None]
    a, b, c, d = i, i + 1, i + nx + 1, i + nx
    tris = np.stack([np.stack([a, b, c], -1), np.stack([a, c, d], -1)], axis=2)
    return tris.reshape(-1, 3).astype(np.int32)


def flat_patch(size_m: float) -> tuple[np.ndarray, np.ndarray]:
    """A square in the z = 0 plane centred on the origin, normal +z: (vertices (4, 3) float32
    metres, triangles (2, 3) int32)."""
    return FlatGround(size_m=size_m).mesh()
