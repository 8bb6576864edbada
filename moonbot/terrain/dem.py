"""Real terrain: a lunar DEM cropped around a site and resampled onto the world's local
East-North-Up grid (metres), ready to become a ground.

`import_dem` reads a GeoTIFF (geographic or equirectangular on the 1737.4 km sphere) or a 16-bit
PNG heightmap through the C++ core (`moonbot._core.import_dem`, cpp/src/dem_import.cpp), which fills
voids, crops, and converts to ENU in double precision with GeographicLib. The result is a
`LocalDem`; `LocalDem.save`/`load` keep it in a `.npz` that is written atomically and byte for
byte the same for the same content.
"""

from __future__ import annotations

import io
import json
import math
import os
import zipfile
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from moonbot import _core

# Names the file's members and their meaning; bump when they change.
FORMAT = "moonbot.local_dem/1"

# Every member is stamped with this time so the same content gives the same bytes (zip's
# earliest representable date).
_ZIP_EPOCH = (1980, 1, 1, 0, 0, 0)


@dataclass(frozen=True, eq=False)
class LocalDem:
    """A DEM patch on a local ENU grid.

    heights: (ny, nx) float64 metres, `up` of the surface at each node (read-only). Row 0 is the
        south edge and east varies fastest; node (i, j) sits at east = (i − (nx−1)/2)·spacing_m,
        north = (j − (ny−1)/2)·spacing_m, so the centre node is the ENU origin.
    spacing_m: grid spacing, metres.
    lat_deg, lon_deg, h0_m: the ENU origin, selenographic degrees and metres above the
        1737.4 km reference sphere (h0_m is the DEM's height there, so heights near the origin
        are ≈ 0).
    curvature: True if heights are the true ENU up (the sphere falls away ≈ d²/2R); False for a
        flat-earth patch (up = h_dem − h0 under each node).
    source: where it came from: path, format, size, pixel sizes, height scale/offset, nodata,
        voids filled (JSON-compatible values).
    """

    heights: np.ndarray
    spacing_m: float
    lat_deg: float
    lon_deg: float
    h0_m: float
    curvature: bool
    source: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        h = np.array(self.heights, dtype=np.float64, copy=True)
        if h.ndim != 2 or h.shape[0] < 2 or h.shape[1] < 2:
            raise ValueError(f"heights: must be a 2-D grid of at least 2 x 2, got shape {h.shape}")
        if not np.isfinite(h).all():
            raise ValueError("heights: must be finite (a DEM import fills every void)")
        h.setflags(write=False)
        object.__setattr__(self, "heights", h)
        for name in ("spacing_m", "lat_deg", "lon_deg", "h0_m"):
            value = getattr(self, name)
            if (
                isinstance(value, bool)
                or not isinstance(value, (int, float, np.floating, np.integer))
                or not math.isfinite(value)
            ):
                raise ValueError(f"{name}: must be a finite number, got {value!r}")
            object.__setattr__(self, name, float(value))
        if self.spacing_m <= 0:
            raise ValueError(f"spacing_m: must be > 0, got {self.spacing_m}")
        if not -90.0 <= self.lat_deg <= 90.0:
            raise ValueError(f"lat_deg: must be in [-90, 90], got {self.lat_deg}")
        if not isinstance(self.curvature, (bool, np.bool_)):
            raise ValueError(f"curvature: must be a bool, got {self.curvature!r}")
        object.__setattr__(self, "curvature", bool(self.curvature))
        try:
            source = json.loads(json.dumps(dict(self.source), allow_nan=False))
        except (TypeError, ValueError) as e:
            raise ValueError(f"source: must hold JSON values only ({e})") from None
        object.__setattr__(self, "source", source)

    @property
    def shape(self) -> tuple[int, int]:
        """(ny, nx)."""
        return self.heights.shape  # type: ignore[return-value]

    @property
    def east_m(self) -> np.ndarray:
        """(nx,) float64 east coordinates of the grid columns, metres."""
        nx = self.heights.shape[1]
        return (np.arange(nx) - (nx - 1) / 2) * self.spacing_m

    @property
    def north_m(self) -> np.ndarray:
        """(ny,) float64 north coordinates of the grid rows (row 0 = south), metres."""
        ny = self.heights.shape[0]
        return (np.arange(ny) - (ny - 1) / 2) * self.spacing_m

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Writes the patch to `path` (.npz of .npy members, uncompressed, readable with
        np.load), atomically: a temporary beside it is renamed over the target, so a failed
        write leaves any previous file intact. Same content, same bytes. Raises OSError naming
        the file."""
        target = Path(path)
        members = {
            "format": np.array(FORMAT),
            "heights": self.heights,
            "spacing_m": np.float64(self.spacing_m),
            "lat_deg": np.float64(self.lat_deg),
            "lon_deg": np.float64(self.lon_deg),
            "h0_m": np.float64(self.h0_m),
            "curvature": np.bool_(self.curvature),
            "source": np.array(json.dumps(self.source, sort_keys=True)),
        }
        tmp = target.with_name(f".{target.name}.{os.getpid()}.tmp")
        try:
            with open(tmp, "wb") as f:
                with zipfile.ZipFile(f, "w", compression=zipfile.ZIP_STORED) as zf:
                    for name, value in members.items():
                        buf = io.BytesIO()
                        np.lib.format.write_array(buf, np.asarray(value), allow_pickle=False)
                        info = zipfile.ZipInfo(f"{name}.npy", date_time=_ZIP_EPOCH)
                        info.external_attr = 0o644 << 16
                        zf.writestr(info, buf.getvalue())
                f.flush()
                os.fsync(f.fileno())
            os.replace(tmp, target)
        except OSError as e:
            tmp.unlink(missing_ok=True)
            raise OSError(f"{target}: cannot write ({e.strerror or e})") from None
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise
        return target

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> LocalDem:
        """Reads a file written by `save`. Raises OSError naming the file if it cannot be read,
        ValueError naming it if it is not a LocalDem file."""
        source = Path(path)
        try:
            # Our own handle, so it is closed even when numpy gives up on the content.
            with open(source, "rb") as f:
                loaded = np.load(f, allow_pickle=False)
                if not isinstance(loaded, np.lib.npyio.NpzFile):
                    raise ValueError("a single .npy array, not an .npz archive")
                with loaded as npz:
                    members = {name: npz[name] for name in npz.files}
        except OSError as e:
            raise OSError(f"{source}: cannot read ({e.strerror or e})") from None
        except (ValueError, zipfile.BadZipFile, EOFError) as e:
            raise ValueError(f"{source}: not a LocalDem file ({e})") from None
        if "format" not in members or str(members["format"]) != FORMAT:
            raise ValueError(f"{source}: not a LocalDem file (format member is not '{FORMAT}')")
        missing = {"heights", "spacing_m", "lat_deg", "lon_deg", "h0_m", "curvature", "source"} - set(members)
        if missing:
            raise ValueError(f"{source}: LocalDem file lacks {', '.join(sorted(missing))}")
        try:
            return cls(
                heights=members["heights"],
                spacing_m=float(members["spacing_m"]),
                lat_deg=float(members["lat_deg"]),
                lon_deg=float(members["lon_deg"]),
                h0_m=float(members["h0_m"]),
                curvature=bool(members["curvature"]),
                source=json.loads(str(members["source"])),
            )
        except (ValueError, TypeError) as e:
            raise ValueError(f"{source}: {e}") from None


def import_dem(
    path: str | os.PathLike[str],
    lat_deg: float,
    lon_deg: float,
    size_m: float,
    *,
    spacing_m: float | None = None,
    curvature: bool = True,
    scale: float = 1.0,
    offset: float = 0.0,
    nodata: float | None = None,
    png_range: tuple[float, float] | None = None,
    png_pixel_m: float | None = None,
    png_center: tuple[float, float] | None = None,
) -> LocalDem:
    """Crops a square of `size_m` metres centred on (lat_deg, lon_deg) from a DEM file and
    resamples it onto a local ENU grid (see `LocalDem`).

    path: a GeoTIFF (.tif/.tiff; one band; geographic degrees or equirectangular metres on the
        lunar sphere) or a 16-bit grey PNG (.png; then `png_range` = (height of 0, height of
        65535) in metres and `png_pixel_m` are required, and `png_center` = (lat, lon) of the
        image centre defaults to the crop centre).
    spacing_m: grid spacing; None = the source pixel size (the smaller of its east and north
        ground sizes at the crop centre). The grid has 2·floor(size/2/spacing) + 1 nodes a side.
    scale, offset: height = (raw·file scale + file offset)·scale + offset metres, the file's
        part from GDAL_METADATA (e.g. scale=1000 for SLDEM2015 km floats, 0.5 for LOLA int16).
    nodata: raw value marking voids; overrides the file's GDAL_NODATA. NaN/Inf are always voids.

    Raises OSError for a missing or unreadable file or a georeference it cannot use, ValueError
    for bad arguments, a crop that leaves the raster or an all-void crop; messages name the
    file or the field.
    """
    if spacing_m is not None and not spacing_m > 0:
        raise ValueError(f"spacing_m: must be > 0 (or None for the source pixel size), got {spacing_m}")
    result = _core.import_dem(
        os.fspath(path),
        lat_deg,
        lon_deg,
        size_m,
        0.0 if spacing_m is None else spacing_m,
        curvature,
        scale,
        offset,
        nodata,
        png_range,
        png_pixel_m,
        png_center,
    )
    source = {
        "path": os.fspath(path),
        "format": result["source_format"],
        "width": result["source_width"],
        "height": result["source_height"],
        "pixel_m": result["source_pixel_m"],
        "pixel_east_m": result["source_pixel_east_m"],
        "pixel_north_m": result["source_pixel_north_m"],
        "height_scale": result["height_scale"],
        "height_offset_m": result["height_offset"],
        "nodata": result["nodata"],
        "voids_filled": result["voids_filled"],
        "footprint_px": list(result["footprint"]),
    }
    if result["nodata"] is not None and not math.isfinite(result["nodata"]):
        source["nodata"] = str(result["nodata"])  # JSON has no NaN
    return LocalDem(
        heights=result["heights"],
        spacing_m=result["spacing_m"],
        lat_deg=result["lat_deg"],
        lon_deg=result["lon_deg"],
        h0_m=result["h0_m"],
        curvature=result["curvature"],
        source=source,
    )


def corner_curvature_drop(dem: LocalDem) -> float:
    """How far the lunar sphere falls below the tangent plane at the grid's corner, metres."""
    ny, nx = dem.shape
    d = math.hypot((nx - 1) / 2 * dem.spacing_m, (ny - 1) / 2 * dem.spacing_m)
    return _core.curvature_drop(d, _core.LUNAR_RADIUS + dem.h0_m)


def summary(dem: LocalDem, written: Path | None = None) -> str:
    """One paragraph for people: grid, spacing, height range, voids filled and the curvature drop
    at the crop corner."""
    ny, nx = dem.shape
    src = dem.source
    corner = math.hypot((nx - 1) / 2, (ny - 1) / 2) * dem.spacing_m
    drop = corner_curvature_drop(dem)
    origin = f"lat {dem.lat_deg:.6f}°, lon {dem.lon_deg:.6f}°, h0 {dem.h0_m:.2f} m"
    text = (
        f"{src.get('path', 'DEM')} ({src.get('format', '?')}, {src.get('width', '?')}×{src.get('height', '?')} px "
        f"of {src.get('pixel_east_m', math.nan):.2f} × {src.get('pixel_north_m', math.nan):.2f} m) → "
        f"{nx} × {ny} grid at {dem.spacing_m:g} m spacing ({(nx - 1) * dem.spacing_m:g} m square) about "
        f"{origin}; heights {dem.heights.min():.3f} … {dem.heights.max():.3f} m up; "
        f"{src.get('voids_filled', 0)} void pixels filled. "
    )
    if dem.curvature:
        text += (
            f"Curvature on: the sphere falls {_length(drop)} below the tangent plane at the "
            f"crop corner ({corner:.1f} m out)."
        )
    else:
        text += (
            f"Curvature off (flat-earth patch); the sphere would fall {_length(drop)} at the "
            f"crop corner ({corner:.1f} m out)."
        )
    if written is not None:
        text += f" Written {written}."
    return text


def _length(metres: float) -> str:
    return f"{metres * 1000:.1f} mm" if metres < 1.0 else f"{metres:.3f} m"
