"""Settling bags as rigid bodies under lunar gravity with MuJoCo (the `mujoco-core` wheel from
PyPI, headless; Kubric and BlenderProc settle objects with PyBullet the same way).

Each bag is a free body whose collision shape is the convex hull of the points it is given: its
mesh's vertices, or points whose hull holds the mesh and is smooth over its wrinkles
(bag_mesh.collision_points); or, for a concave user mesh, several convex hulls, its convex parts
(moonbot.scene.convex_parts), one geom each on the same body. MuJoCo collides convex shapes;
every point of the bag lies inside its hull or parts, so shapes that do not touch mean bags that
do not touch. The ground is a MuJoCo height field sampled from the `Ground` on a grid of
`ground_step_m` aligned with the world origin, so where the renderer's terrain grid uses the same
spacing both are the same surface. Contacts engage at `margin_m`, so bags come to rest that far
from what supports them rather than sunk into it by the soft contact model.

Only the bags' neighbourhood is simulated: the height field spans their footprints plus a border
of one bag length; a bag that slides out of it is an error naming the friction and slope.
MuJoCo is single-threaded and deterministic, so the same poses and config give the same bytes.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
from scipy.spatial import ConvexHull

from moonbot.config.schema import SettleConfig
from moonbot.terrain.ground import Ground

_CHECK_EVERY = 10  # steps between rest checks


@dataclass(frozen=True)
class Settled:
    """Settled world-from-model poses ((4, 4) float64 rigid, one per bag, in input order),
    the simulated time and steps it took, and the wall-clock seconds spent."""

    poses: list[np.ndarray]
    simulated_s: float
    steps: int
    seconds: float


def _quat(R: np.ndarray) -> np.ndarray:
    import mujoco

    q = np.empty(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(R, dtype=np.float64).ravel())
    return q


def _frame_with_z(normal: np.ndarray) -> np.ndarray:
    """A rotation (3, 3) whose third column is the unit vector `normal`."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(normal[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, normal)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(normal, x), normal])


def _grid(poses: list[np.ndarray], reach: float, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Grid coordinates xs, ys (float64, metres) of spacing `step`, aligned with the origin,
    covering every bag's centre ± `reach`: the region the simulation keeps the bags in."""
    centres = np.array([p[:2, 3] for p in poses])
    lo = np.floor((centres.min(axis=0) - reach) / step).astype(int)
    hi = np.ceil((centres.max(axis=0) + reach) / step).astype(int)
    return step * np.arange(lo[0], hi[0] + 1), step * np.arange(lo[1], hi[1] + 1)


def settle(
    vertices: np.ndarray | list[np.ndarray], poses: list[np.ndarray], ground: Ground, config: SettleConfig
) -> Settled:
    """Drops bags whose collision shape is the convex hull of `vertices` ((N, 3) model frame,
    metres: the mesh's, or bag_mesh.collision_points; or a list of such arrays, one convex part
    each) from `poses` (world-from-model
    (4, 4), resting or a little above their supports) onto `ground` and each other, and steps
    until every point of every bag has moved slower than `rest_speed_m_s` for `rest_time_s`.
    Raises ValueError naming the field when they do not rest in `max_time_s` or slide away."""
    import mujoco  # imported here: scenes that do not settle never load the physics engine

    start = time.perf_counter()
    parts = [np.asarray(p, dtype=np.float64) for p in (vertices if isinstance(vertices, list) else [vertices])]
    hulls = [p[ConvexHull(p).vertices] for p in parts]
    everything = np.concatenate(hulls)
    reach = float(np.linalg.norm(everything.max(axis=0) - everything.min(axis=0)))  # one bag diagonal
    radius = float(np.linalg.norm(everything, axis=1).max())  # model origin to the farthest point

    spec = mujoco.MjSpec()
    spec.option.gravity = [0.0, 0.0, -config.gravity_m_s2]
    spec.option.timestep = config.timestep_s
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC  # no pyramid artefacts in sticking friction
    spec.option.impratio = 10.0  # stiff friction relative to normal force: no creep down slopes
    names = ["bag"] if len(hulls) == 1 else [f"bag-part{k}" for k in range(len(hulls))]
    if len(hulls) > 1:
        # Bodies of several parts collide through libccd: MuJoCo's native convex collider let
        # four stacked rings of 6 parts rest 0.18 mm into each other (inside margin_m, which
        # libccd keeps: 1.00 mm; a single hull keeps it either way, 0.96 mm).
        spec.option.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_NATIVECCD)
    for name, hull in zip(names, hulls):
        spec.add_mesh(name=name, uservert=hull.ravel().tolist())

    solref = [config.contact_time_s, config.contact_damping]
    # Sliding, torsional and rolling friction (condim 6 enables the last two).
    friction = [config.friction, config.rolling_friction_m, config.rolling_friction_m]
    # MuJoCo sums the margins of a pair of geoms: half on each makes every gap margin_m.
    contact = dict(friction=friction, solref=solref, margin=config.margin_m / 2, condim=6)
    xs, ys = _grid(poses, reach, config.ground_step_m)
    cx, cy, rx, ry = (xs[0] + xs[-1]) / 2, (ys[0] + ys[-1]) / 2, (xs[-1] - xs[0]) / 2, (ys[-1] - ys[0]) / 2
    plane = ground.plane()
    if plane is not None:  # exact, and far cheaper than the many prisms of a height field
        point, normal = plane
        spec.worldbody.add_geom(
            type=mujoco.mjtGeom.mjGEOM_PLANE,
            size=[0.0, 0.0, 1.0],
            pos=point.tolist(),
            quat=_quat(_frame_with_z(normal)).tolist(),
            **contact,
        )
    else:  # rows along y, columns along x, as MuJoCo stores a height field
        heights = ground.height(*np.meshgrid(xs, ys, indexing="xy"))
        base, span = float(heights.min()), float(heights.max() - heights.min())
        spec.add_hfield(
            name="ground",
            size=[rx, ry, max(span, 1e-6), reach],
            nrow=heights.shape[0],
            ncol=heights.shape[1],
            userdata=((heights - base) / max(span, 1e-300)).ravel().tolist(),
        )
        spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_HFIELD, hfieldname="ground", pos=[cx, cy, base], **contact)
    for k, pose in enumerate(poses):
        body = spec.worldbody.add_body(name=f"bag{k}", pos=pose[:3, 3].tolist(), quat=_quat(pose[:3, :3]).tolist())
        body.add_freejoint()
        for name in names:
            body.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=name, density=config.density_kg_m3, **contact)
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)

    rest_steps = max(1, math.ceil(config.rest_time_s / config.timestep_s))
    max_steps = math.ceil(config.max_time_s / config.timestep_s)
    still, steps = 0, 0
    bodies = slice(1, 1 + len(poses))
    while True:
        mujoco.mj_step(model, data, nstep=_CHECK_EVERY)
        steps += _CHECK_EVERY
        qvel = data.qvel.reshape(len(poses), 6)
        # The fastest point of a bag moves at most |v_origin| + |ω|·radius.
        speed = np.linalg.norm(qvel[:, :3], axis=1) + np.linalg.norm(qvel[:, 3:], axis=1) * radius
        still = still + _CHECK_EVERY if speed.max() < config.rest_speed_m_s else 0
        if still >= rest_steps:
            break
        outside = np.any(np.abs(data.xpos[bodies, :2] - [cx, cy]) > [rx, ry], axis=1)
        if outside.any():
            raise ValueError(
                f"bags.settle.friction: bag {int(np.argmax(outside)) + 1} slid off the ground "
                f"(friction {config.friction} cannot hold it on this slope)"
            )
        if steps >= max_steps:
            raise ValueError(
                f"bags.settle.max_time_s: bags still moving after {config.max_time_s} s "
                f"(fastest point {speed.max():.3g} m/s)"
            )
    settled = []
    for k in range(len(poses)):
        pose = np.eye(4)
        pose[:3, :3] = data.xmat[1 + k].reshape(3, 3)
        pose[:3, 3] = data.xpos[1 + k]
        settled.append(pose)
    return Settled(poses=settled, simulated_s=float(data.time), steps=steps, seconds=time.perf_counter() - start)
