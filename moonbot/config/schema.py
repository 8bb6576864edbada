"""The configuration schema. Every field states its unit and its valid range; the loader
(`moonbot.config.load`) enforces both and names the offending field on error.

Frames and units follow DESIGN.md: world is local East-North-Up in metres, angles in degrees,
Sun azimuth clockwise from North.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal


def spec(doc: str, *, lo: float | None = None, hi: float | None = None,
         lo_open: bool = False, length: int | None = None) -> dict:
    """Field metadata read by the loader: a description and an inclusive (or open-below) range
    that applies to a number or to each item of a tuple of numbers."""
    return {"doc": doc, "lo": lo, "hi": hi, "lo_open": lo_open, "length": length}


@dataclass(frozen=True)
class CameraConfig:
    """Pinhole camera; principal point at the image centre (W/2, H/2), square pixels."""

    width: int = field(default=640, metadata=spec("image width, pixels", lo=1, hi=32768))
    height: int = field(default=480, metadata=spec("image height, pixels", lo=1, hi=32768))
    hfov_deg: float = field(default=60.0, metadata=spec(
        "horizontal field of view, degrees", lo=0.0, hi=179.0, lo_open=True))


@dataclass(frozen=True)
class OrbitConfig:
    """The camera orbit around the target bag (paper 4.2.3): views at fixed azimuth steps."""

    radius_m: float = field(default=1.0, metadata=spec(
        "horizontal distance from the target's centre, metres (0 = straight above)", lo=0.0, hi=1000.0))
    height_m: float = field(default=0.5, metadata=spec(
        "camera height above the target's centre, metres", lo=-10.0, hi=1000.0))
    views: int = field(default=36, metadata=spec("views per orbit", lo=1, hi=3600))
    step_deg: float = field(default=10.0, metadata=spec("azimuth step between views, degrees", lo=-360.0, hi=360.0))
    start_azimuth_deg: float = field(default=0.0, metadata=spec(
        "azimuth of view 0 (clockwise from North, as seen from the target), degrees", lo=-360.0, hi=360.0))


@dataclass(frozen=True)
class SunConfig:
    azimuth_deg: float = field(default=120.0, metadata=spec(
        "clockwise from North (0 = +y, 90 = +x), degrees", lo=-360.0, hi=360.0))
    elevation_deg: float = field(default=12.0, metadata=spec(
        "above the local horizon, degrees", lo=-90.0, hi=90.0))
    irradiance_w_m2: float = field(default=1361.0, metadata=spec(
        "irradiance on a surface facing the Sun, W/m^2 (1361 at 1 au)", lo=0.0, hi=1e5))


@dataclass(frozen=True)
class TerrainConfig:
    kind: Literal["flat"] = field(default="flat", metadata=spec("terrain model"))
    size_m: float = field(default=200.0, metadata=spec(
        "side of the square patch centred on the target, metres", lo=0.0, hi=20000.0, lo_open=True))
    albedo: float = field(default=0.12, metadata=spec("Lambertian albedo of regolith", lo=0.0, hi=1.0))


@dataclass(frozen=True)
class BagsConfig:
    """Bags as rigid bodies; obj_id 1 is the cuboid sandbag-01."""

    count: int = field(default=1, metadata=spec("number of bags; the first is the orbit target", lo=1, hi=1))
    size_m: tuple[float, float, float] = field(default=(0.32, 0.20, 0.12), metadata=spec(
        "body length, width, height, metres", lo=0.001, hi=10.0, length=3))
    albedo: tuple[float, float, float] = field(default=(0.55, 0.45, 0.32), metadata=spec(
        "linear RGB albedo of the fabric (tan)", lo=0.0, hi=1.0, length=3))
    yaw_deg: float = field(default=20.0, metadata=spec(
        "rotation of the target about +z, degrees", lo=-360.0, hi=360.0))


@dataclass(frozen=True)
class RenderConfig:
    spp: int = field(default=4, metadata=spec("RGB samples per pixel (depth and masks use the pixel centre)", lo=1, hi=65536))
    threads: int = field(default=0, metadata=spec("render threads, 0 = all cores", lo=0, hi=1024))
    exact_depth: bool = field(default=True, metadata=spec(
        "re-solve hit distances in double (depth exact at kilometre coordinates, ~15 ns a ray); "
        "false keeps Embree's float32 distance"))


@dataclass(frozen=True)
class ToneMapConfig:
    exposure_stops: float = field(default=2.0, metadata=spec(
        "exposure in stops above the level at which a white Lambertian surface facing the Sun "
        "maps to 1.0 before Reinhard", lo=-30.0, hi=30.0))


@dataclass(frozen=True)
class OutputConfig:
    png_compression: int = field(default=1, metadata=spec(
        "PNG deflate level 0-9 (1 is ~2.5x faster than 6 for ~20 % more bytes)", lo=0, hi=9))


@dataclass(frozen=True)
class Config:
    """A whole moonbot configuration. Load with `moonbot.config.load_config`."""

    seed: int = field(default=0, metadata=spec("dataset seed", lo=0, hi=2**63 - 1))
    camera: CameraConfig = field(default_factory=CameraConfig)
    orbit: OrbitConfig = field(default_factory=OrbitConfig)
    sun: SunConfig = field(default_factory=SunConfig)
    terrain: TerrainConfig = field(default_factory=TerrainConfig)
    bags: BagsConfig = field(default_factory=BagsConfig)
    render: RenderConfig = field(default_factory=RenderConfig)
    tonemap: ToneMapConfig = field(default_factory=ToneMapConfig)
    output: OutputConfig = field(default_factory=OutputConfig)
