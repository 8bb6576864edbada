"""Small analytic scenes for the tests: meshes, cameras and a one-call renderer."""

from __future__ import annotations

import numpy as np

from moonbot import _core
from moonbot.config.schema import BagShape
from moonbot.scene.bag_mesh import filled_cuboid
from moonbot.scene.orbit import CameraPose, orbit_pose, pixel_directions

# What the pipeline's view stage adds to gt.json (moonbot.records.gt), for a view written alone.
VIEW_META = {
    "view": 0,
    "camera_azimuth_deg": 0.0,
    "camera_height_m": 1.0,
    "sun": {"azimuth_deg": 0.0, "elevation_deg": 10.0, "irradiance_w_m2": 1361.0},
    "render_seed": 0,
    "config_hash": "0" * 64,
    "moonbot_version": "test",
}

# Config overrides of a small close view of one bag on the analytic plane.
CLOSE_BAG_VIEW = {
    "terrain.location": "plane",
    "orbit.radius_m": 0.5,
    "orbit.height_m": 0.35,
    "sun.elevation_deg": 35.0,
    "camera.width": 160,
    "camera.height": 120,
    "render.bounces": 1,
}


def box(size: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    """An exact box centred on the origin: the sharp, unbulged lattice body, coarsely split."""
    return filled_cuboid(
        BagShape(
            size_m=size,
            edge_radius_m=0.0,
            bulge_m=0.0,
            sag_m=0.0,
            belly_m=0.0,
            crease_depth_m=0.0,
            pucker_depth_m=0.0,
            edge_length_m=min(size) / 2,
            edge_steps=1,
        )
    )


def plane(half: float) -> tuple[np.ndarray, np.ndarray]:
    """A square in z = 0, half-size `half` metres, normal +z."""
    v = np.array([[-half, -half, 0], [half, -half, 0], [half, half, 0], [-half, half, 0]], np.float32)
    return v, np.array([[0, 1, 2], [0, 2, 3]], np.int32)


def translation(x: float, y: float, z: float) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = (x, y, z)
    return m


def rotation_x(deg: float) -> np.ndarray:
    a = np.radians(deg)
    m = np.eye(4)
    m[1:3, 1:3] = [[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]
    return m


def K_for(width: int, height: int, f: float) -> np.ndarray:
    return np.array([[f, 0, width / 2], [0, f, height / 2], [0, 0, 1.0]])


def camera(K: np.ndarray, width: int, height: int, pose: CameraPose) -> _core.Camera:
    return _core.Camera(K[0, 0], K[1, 1], K[0, 2], K[1, 2], width, height, pose.R, pose.t)


def ground_and_box(
    box_size=(0.4, 0.4, 0.4), box_world=None, ground_world=None, ground_half=50.0
) -> tuple[_core.Scene, np.ndarray]:
    """A ground plane (label 0) and one box (label 1, model origin at its centre). Returns the
    committed scene and the box's world_from_model."""
    scene = _core.Scene()
    g = scene.add_mesh(*plane(ground_half))
    b = scene.add_mesh(*box(box_size))
    ground_world = np.eye(4) if ground_world is None else ground_world
    box_world = translation(0, 0, box_size[2] / 2) if box_world is None else box_world
    scene.add_background(g, ground_world, (0.12, 0.12, 0.12))
    scene.add_instance(b, box_world, 1, (0.5, 0.4, 0.3))
    scene.commit()
    return scene, box_world


__all__ = [
    "K_for",
    "box",
    "camera",
    "ground_and_box",
    "orbit_pose",
    "pixel_directions",
    "plane",
    "rotation_x",
    "translation",
]
