"""Scene composition: terrain, bag meshes, placement and the orbit camera, as plain numpy data
(`SceneSpec`) that the render stage hands to the C++ core."""

from moonbot.scene.compose import BagInstance, SceneSpec, compose_scene
from moonbot.scene.orbit import CameraPose, intrinsics, orbit_pose, pixel_directions

__all__ = ["BagInstance", "CameraPose", "SceneSpec", "compose_scene", "intrinsics", "orbit_pose", "pixel_directions"]
