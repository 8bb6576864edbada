"""Running work: views of one scene on this machine (`run_views`); the Dask sweep will live here."""

from moonbot.pipeline.views import ViewResult, run_views

__all__ = ["ViewResult", "run_views"]
