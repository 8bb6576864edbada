"""The render stage: a thin façade over the C++ core that turns a `SceneSpec` into an Embree
scene once and renders views of it, a dust scene's ejecta and cloud (moonbot.render.dust), each
bag's amodal mask (moonbot.render.amodal), and the camera exposure its tone map uses."""

from moonbot.render.amodal import AmodalMask, AmodalMasks, AmodalScenes, build_amodal_scenes, render_amodal_masks
from moonbot.render.dust import SceneDust, ViewDust
from moonbot.render.exposure import Exposure, exposure_scale, resolve_exposure
from moonbot.render.view import RenderedView, build_light_cache, build_scene, render_view

__all__ = [
    "AmodalMask",
    "AmodalMasks",
    "AmodalScenes",
    "Exposure",
    "RenderedView",
    "SceneDust",
    "ViewDust",
    "build_amodal_scenes",
    "build_light_cache",
    "build_scene",
    "exposure_scale",
    "render_amodal_masks",
    "render_view",
    "resolve_exposure",
]
