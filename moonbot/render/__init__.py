"""The render stage: a thin façade over the C++ core that turns a `SceneSpec` into an Embree
scene once and renders views of it, and the camera exposure its tone map uses."""

from moonbot.render.exposure import Exposure, exposure_scale, resolve_exposure
from moonbot.render.view import RenderedView, build_scene, render_view

__all__ = ["Exposure", "RenderedView", "build_scene", "exposure_scale", "render_view", "resolve_exposure"]
