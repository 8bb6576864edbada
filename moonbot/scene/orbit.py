"""The orbit camera: intrinsics from the field of view, and world-to-camera poses on a circle
around the target (OpenCV axes: x right, y down, z forward)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from moonbot.config.schema import CameraConfig


@dataclass(frozen=True)
class CameraPose:
    """World-to-camera rigid transform: x_cam = R @ x_world + t. R (3, 3) float64, t (3,) metres."""

    R: np.ndarray
    t: np.ndarray

    @property
    def center(self) -> np.ndarray:
        """Camera centre in the world frame, metres."""
        return -self.R.T @ self.t


def intrinsics(camera: CameraConfig) -> np.ndarray:
    """K (3, 3) float64 for square pixels with the principal point at the image centre
    (W/2, H/2 in continuous pixel coordinates, where pixel u spans [u, u+1))."""
    f = (camera.width / 2.0) / math.tan(math.radians(camera.hfov_deg) / 2.0)
    return np.array([[f, 0.0, camera.width / 2.0], [0.0, f, camera.height / 2.0], [0.0, 0.0, 1.0]])


def orbit_pose(target: np.ndarray, radius_m: float, height_m: float, azimuth_deg: float) -> CameraPose:
    """Camera at horizontal distance `radius_m` from `target` (world, metres) toward
    `azimuth_deg` (clockwise from North) and `height_m` above it, looking at the target.

    The image x axis is taken from the azimuth rather than from cross(forward, up), so the pose
    stays exact when the camera is straight above the target (radius 0) or straight below.
    """
    a = math.radians(azimuth_deg)
    outward = np.array([math.sin(a), math.cos(a), 0.0])
    eye = np.asarray(target, dtype=np.float64) + radius_m * outward + np.array([0.0, 0.0, height_m])
    forward = np.asarray(target, dtype=np.float64) - eye
    norm = np.linalg.norm(forward)
    if norm == 0.0:
        raise ValueError("orbit: radius_m and height_m are both 0, the camera sits on the target")
    z = forward / norm
    # Right-hand side of a viewer at `outward` looking inward, horizontal: ⟂ to z by construction.
    x = np.array([-math.cos(a), math.sin(a), 0.0])
    y = np.cross(z, x)  # image down
    R = np.stack([x, y, z])
    return CameraPose(R=R, t=-R @ eye)


CAMERA_CLEARANCE_M = 0.05  # the lowest a camera may sit above the ground under it


def orbit_height(target: np.ndarray, radius_m: float, height_m: float, azimuth_deg: float, ground) -> float:
    """The orbit height (metres above the target) to use at `azimuth_deg`: `height_m`, raised
    where the ground under the camera (`ground.height`, metres) would come within
    CAMERA_CLEARANCE_M of it. On slopes and hills a fixed height above the target can put the
    camera inside the hill uphill of it; a real camera rig cannot go there."""
    a = math.radians(azimuth_deg)
    x, y = target[0] + radius_m * math.sin(a), target[1] + radius_m * math.cos(a)
    floor = float(ground.height(np.array([x]), np.array([y]))[0]) + CAMERA_CLEARANCE_M - float(target[2])
    return max(height_m, floor)


def pixel_directions(K: np.ndarray, pose: CameraPose, width: int, height: int) -> np.ndarray:
    """World-frame directions (H, W, 3) float64 of the rays through pixel centres (u + 0.5,
    v + 0.5), scaled so their component along the optical axis is 1: a point at z-depth z along
    pixel (u, v) is pose.center + z · directions[v, u]."""
    u, v = np.meshgrid(np.arange(width) + 0.5, np.arange(height) + 0.5)
    cam = np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones_like(u)], axis=-1)
    return cam @ pose.R  # row vectors: (Rᵀ d)ᵀ = dᵀ R
