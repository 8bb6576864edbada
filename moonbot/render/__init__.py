"""The render stage: a thin façade over the C++ core that turns a `SceneSpec` into an Embree
scene once and renders views of it."""

from moonbot.render.view import RenderedView, build_scene, exposure_scale, render_view

__all__ = ["RenderedView", "build_scene", "exposure_scale", "render_view"]
