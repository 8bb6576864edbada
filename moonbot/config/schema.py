"""The configuration schema. Every field states its unit and its valid range; the loader
(`moonbot.config.load`) enforces both and names the offending field on error.

Frames and units follow docs/design.md: world is local East-North-Up in metres, angles in degrees,
Sun azimuth clockwise from North.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
from dataclasses import dataclass, field
from pathlib import Path, PurePath
from typing import Literal


def spec(
    doc: str, *, lo: float | None = None, hi: float | None = None, lo_open: bool = False, length: int | None = None
) -> dict:
    """Field metadata read by the loader: a description and an inclusive (or open-below) range
    that applies to a number or to each item of a tuple of numbers."""
    return {"doc": doc, "lo": lo, "hi": hi, "lo_open": lo_open, "length": length}


@dataclass(frozen=True)
class CameraConfig:
    """Pinhole camera; principal point at the image centre (W/2, H/2), square pixels."""

    width: int = field(default=640, metadata=spec("image width, pixels", lo=1, hi=32768))
    height: int = field(default=480, metadata=spec("image height, pixels", lo=1, hi=32768))
    hfov_deg: float = field(
        default=60.0, metadata=spec("horizontal field of view, degrees", lo=0.0, hi=179.0, lo_open=True)
    )


@dataclass(frozen=True)
class OrbitConfig:
    """The camera orbit around the target bag (paper 4.2.3): views at fixed azimuth steps."""

    radius_m: float = field(
        default=1.0,
        metadata=spec("horizontal distance from the target's centre, metres (0 = straight above)", lo=0.0, hi=1000.0),
    )
    height_m: float = field(
        default=0.5, metadata=spec("camera height above the target's centre, metres", lo=-10.0, hi=1000.0)
    )
    views: int = field(default=36, metadata=spec("views per orbit", lo=1, hi=3600))
    step_deg: float = field(default=10.0, metadata=spec("azimuth step between views, degrees", lo=-360.0, hi=360.0))
    start_azimuth_deg: float = field(
        default=0.0,
        metadata=spec(
            "azimuth of view 0 (clockwise from North, as seen from the target), degrees", lo=-360.0, hi=360.0
        ),
    )


@dataclass(frozen=True)
class SunConfig:
    azimuth_deg: float = field(
        default=120.0, metadata=spec("clockwise from North (0 = +y, 90 = +x), degrees", lo=-360.0, hi=360.0)
    )
    elevation_deg: float = field(default=12.0, metadata=spec("above the local horizon, degrees", lo=-90.0, hi=90.0))
    irradiance_w_m2: float = field(
        default=1361.0, metadata=spec("irradiance on a surface facing the Sun, W/m^2 (1361 at 1 au)", lo=0.0, hi=1e5)
    )
    angular_diameter_deg: float = field(
        default=0.533,
        metadata=spec("the Sun's disk, degrees (0.533 at 1 au; 0 = a point and hard shadows)", lo=0.0, hi=10.0),
    )
    earthshine: bool = field(default=False, metadata=spec("add the sunlit Earth as a second, faint disk light"))
    earth_azimuth_deg: float = field(
        default=180.0,
        metadata=spec("Earthshine: the Earth's azimuth, clockwise from North, degrees", lo=-360.0, hi=360.0),
    )
    earth_elevation_deg: float = field(
        default=30.0, metadata=spec("Earthshine: the Earth's elevation, degrees", lo=-90.0, hi=90.0)
    )
    earth_irradiance_w_m2: float = field(
        default=0.1,
        metadata=spec(
            "Earthshine: irradiance facing a full Earth, W/m^2 (reflected visible ~0.07-0.14, i.e. "
            "5e-5 to 1e-4 of sunlight; docs/physics.md)",
            lo=0.0,
            hi=10.0,
        ),
    )
    earth_color: tuple[float, float, float] = field(
        default=(0.85, 0.95, 1.2),
        metadata=spec(
            "Earthshine: linear RGB tint relative to sunlight (bluish: Rayleigh and oceans)", lo=0.0, hi=10.0, length=3
        ),
    )


# Var of one octave of value noise (lattice values uniform on [-1, 1], cubic fade): 1/3·(26/35)^3
# (cpp/include/moonbot/regolith_texture.h), which bounds the albedo factor below.
VALUE_NOISE_VARIANCE = (26.0 / 35.0) ** 3 / 3.0


@dataclass(frozen=True)
class GrainConfig:
    """Regolith's granular micro-texture at camera hits (cpp/include/moonbot/regolith_texture.h):
    albedo speckle and mm-cm relief below the terrain mesh's spacing, octaves of value noise of
    cells finest_cell_m·2^k up to coarsest_cell_m, a function of the world position prefiltered
    over each pixel's footprint (far ground gets exactly the mean albedo and no tilt). Applied to
    the terrain, rocks and ejecta fragments. albedo_rms and slope_rms_deg both 0 = off: no texture
    code runs. The relief's slope spread adds (in tan²) to the mesh's relief and to a Hapke θ̄."""

    albedo_rms: float = field(
        default=0.08,
        metadata=spec("relative RMS of the albedo factor at full resolution (mean 1 exactly)", lo=0.0, hi=0.5),
    )
    slope_rms_deg: float = field(
        default=12.5,
        metadata=spec(
            "1-D RMS slope (RMS of tan along any surface direction) of the relief at full resolution, degrees "
            "(12.5: the mare slope law's share between 1 cm and 1 mm, tan² of 13.9° at 1 mm less 6.3° at 1 cm)",
            lo=0.0,
            hi=45.0,
        ),
    )
    finest_cell_m: float = field(
        default=0.001, metadata=spec("smallest lattice cell, metres (clods, mm rock chips)", lo=1e-5, hi=1.0)
    )
    coarsest_cell_m: float = field(
        default=0.016,
        metadata=spec(
            "largest lattice cell, metres (octaves double up to it; below the mesh's 2 cm relief)", lo=1e-5, hi=1.0
        ),
    )
    hurst: float = field(
        default=0.6,
        metadata=spec(
            "relief amplitude grows with scale as cell^hurst (regolith 0.54-0.7 at 0.1 mm-cm)", lo=0.0, hi=1.0
        ),
    )
    seed: int = field(default=0, metadata=spec("keys the texture's lattices", lo=0, hi=2**63 - 1))

    @property
    def enabled(self) -> bool:
        return self.albedo_rms > 0.0 or self.slope_rms_deg > 0.0

    @property
    def octaves(self) -> int:
        return int(math.floor(math.log2(self.coarsest_cell_m / self.finest_cell_m * (1 + 1e-9)))) + 1

    def __post_init__(self) -> None:
        if self.coarsest_cell_m < self.finest_cell_m:
            raise ValueError(
                f"coarsest_cell_m: must be >= finest_cell_m = {self.finest_cell_m}, got {self.coarsest_cell_m}"
            )
        if self.octaves > 16:
            raise ValueError("coarsest_cell_m: at most 16 octaves (coarsest/finest <= 2^15)")
        limit = math.sqrt(VALUE_NOISE_VARIANCE / self.octaves)
        if self.albedo_rms >= limit:
            raise ValueError(
                f"albedo_rms: must be < {limit:.4f} for {self.octaves} octaves (the albedo "
                f"factor would reach 0), got {self.albedo_rms}"
            )


@dataclass(frozen=True)
class PhotometryConfig:
    """How regolith (terrain and rocks) reflects: moonbot/photometry.h, docs/physics.md

    Whatever the model, terrain.albedo is the normal albedo (reflectance at zero incidence,
    emission and phase, opposition surge included); the model sets only the angular shape.
    The Hapke fields are read only when model is "hapke"; their defaults are the global lunar
    set of Sato et al. 2014 (JGR 119:1775, doi:10.1002/2013JE004580), which implies a normal
    albedo of 0.266 — ignored here in favour of terrain.albedo."""

    model: Literal["lunar-lambert", "lambert", "hapke"] = field(
        default="lunar-lambert",
        metadata=spec(
            "lunar-lambert (McEwen: Lommel-Seeliger blended with Lambert by phase), lambert, or hapke "
            "(Hapke 2012 with porosity, both opposition effects and roughness: a slower reference)"
        ),
    )
    phase: Literal["exponential", "mcewen"] = field(
        default="exponential",
        metadata=spec("lunar-lambert phase weight L(g): exp(-g/60°) or McEwen's cubic (clamped to [0, 1])"),
    )
    surge_amplitude: float = field(
        default=1.8,
        metadata=spec(
            "shadow-hiding opposition surge B0 in 1 + B0/(1 + tan(g/2)/h), lunar-lambert and hapke "
            "(Hapke's B_S0; Sato et al. 2014: 1.8; 0 = off)",
            lo=0.0,
            hi=10.0,
        ),
    )
    surge_width: float = field(
        default=0.07,
        metadata=spec(
            "opposition surge width h, lunar-lambert and hapke (Hapke's h_S; Sato et al. 2014: 0.07)",
            lo=0.0,
            hi=10.0,
            lo_open=True,
        ),
    )
    w: float = field(
        default=0.32,
        metadata=spec("hapke: single-scattering albedo of a grain (Sato et al. 2014, 643 nm: 0.32)", lo=0.0, hi=1.0),
    )
    b: float = field(
        default=0.24,
        metadata=spec(
            "hapke: width of the double Henyey-Greenstein phase function's lobes (0 = isotropic; "
            "Sato et al. 2014: 0.24)",
            lo=0.0,
            hi=0.99,
        ),
    )
    c: float = field(
        default=0.30,
        metadata=spec(
            "hapke: weight of the back-scattering lobe, p = (1+c)/2·back + (1-c)/2·forward; c > 0 "
            "scatters back toward the Sun (Sato et al. 2014: 0.30)",
            lo=-1.0,
            hi=1.0,
        ),
    )
    roughness_deg: float = field(
        default=21.6,
        metadata=spec(
            "hapke: macroscopic roughness, the mean facet slope θ̄ of Hapke 1984, degrees, of the relief "
            "neither the terrain mesh nor the grain holds: terrain.roughness's law at smallest_m (29°, "
            "θ̄ 23.8°) less the 1 cm mesh's 5.5° facet slope and the grain's 12.5°, in tan² (23.5 with "
            "the grain off; Sato et al. 2014 fitted 23.4 to orbital images; 0 = smooth)",
            lo=0.0,
            hi=60.0,
        ),
    )
    filling_factor: float = field(
        default=0.3,
        metadata=spec(
            "hapke: volume fraction of grains φ (1 - porosity), giving Hapke's porosity factor "
            "K = -ln(1 - 1.209 φ^(2/3))/(1.209 φ^(2/3)) (0.3: K = 1.44; 0: K = 1)",
            lo=0.0,
            hi=0.75,
        ),
    )
    cboe_amplitude: float = field(
        default=0.0,
        metadata=spec(
            "hapke: coherent-backscatter opposition amplitude B_C0 (Sato et al. 2014: 0, off)", lo=0.0, hi=1.0
        ),
    )
    cboe_width: float = field(
        default=1.0,
        metadata=spec(
            "hapke: coherent-backscatter width h_C (unused while cboe_amplitude is 0)", lo=0.0, hi=10.0, lo_open=True
        ),
    )
    grain: GrainConfig = field(default_factory=GrainConfig)


@dataclass(frozen=True)
class RoughnessConfig:
    """Regolith relief (moonbot/terrain/roughness.py): a law of 1-D RMS slope against baseline,
    tan s(Δx) = tan s_b·(Δx/break_m)^(H−1), with H = hurst_coarse above break_m and hurst_fine
    below, through rms_slope_deg at baseline_m; the mesh carries the octaves it can resolve and
    terrain.photometry.roughness_deg the rest (Hapke's θ̄, for the law's total at smallest_m)."""

    rms_slope_deg: float = field(
        default=3.0,
        metadata=spec(
            "1-D RMS slope over baseline_m, degrees (LOLA maria: median 2.0° at 17 m, Rosenburg et al. "
            "2011, i.e. 3.0° RMS; highlands 7.5° median; 0 = no relief)",
            lo=0.0,
            hi=60.0,
        ),
    )
    baseline_m: float = field(
        default=17.0, metadata=spec("the baseline of rms_slope_deg, metres", lo=0.0, hi=100000.0, lo_open=True)
    )
    hurst_coarse: float = field(
        default=0.9,
        metadata=spec(
            "Hurst exponent above break_m (LOLA 57 m-2.7 km: maria 0.76, highlands 0.95; 0.9 keeps the "
            "cm-scale slope at the ~6° that Apollo photos' ~5 % shadow at a 12° Sun allows)",
            lo=0.0,
            hi=1.0,
            lo_open=True,
        ),
    )
    hurst_fine: float = field(
        default=0.65,
        metadata=spec(
            "Hurst exponent below break_m (Helfenstein & Shepard 1999, Apollo stereo: 0.54-0.7)",
            lo=0.0,
            hi=1.0,
            lo_open=True,
        ),
    )
    break_m: float = field(
        default=0.01,
        metadata=spec(
            "where the exponent changes, metres (the top of the stereo measurements' cm range)",
            lo=0.0,
            hi=100000.0,
            lo_open=True,
        ),
    )
    smallest_m: float = field(
        default=0.0001,
        metadata=spec(
            "the smallest relief, metres: the scale that sets Hapke's θ̄ (~100 µm, Hapke 2012 §12.2.4)",
            lo=0.0,
            hi=1.0,
            lo_open=True,
        ),
    )
    min_wavelength_m: float = field(
        default=0.02,
        metadata=spec("shortest octave of the mesh's relief, metres (two cells of a 1 cm mesh)", lo=0.001, hi=10.0),
    )
    max_wavelength_m: float = field(default=512.0, metadata=spec("longest octave, metres", lo=0.01, hi=100000.0))
    subgrid_shading: bool = field(
        default=True,
        metadata=spec(
            "shade the octaves the graded mesh could not hold where a pixel reads them (its cells grow "
            "0.02·distance): a bump prefiltered over the pixel, so the law's slopes reach every pixel "
            "(moonbot/subgrid_relief.h)"
        ),
    )


@dataclass(frozen=True)
class CratersConfig:
    """Small craters (moonbot/terrain/craters.py): cumulative density N(>=D) = density·D^-2
    per m² (docs/physics.md), degraded simple-crater profiles."""

    density: float = field(
        default=0.079,
        metadata=spec(
            "C in N(>=D) = C·D^-2 per m^2, D in metres (Trask 1966's standard equilibrium 0.079; Apollo 15 mare fit "
            "0.0336)",
            lo=0.0,
            hi=10.0,
        ),
    )
    min_diameter_m: float = field(
        default=0.05,
        metadata=spec(
            "smallest crater, metres (5 cells of the 1 cm tile; the equilibrium law holds down to 13 cm "
            "at Surveyor 7, Shoemaker et al. 1969)",
            lo=0.01,
            hi=1000.0,
        ),
    )
    max_diameter_m: float = field(default=200.0, metadata=spec("largest crater, metres", lo=0.01, hi=10000.0))
    site_max_diameter_m: float = field(
        default=1.0,
        metadata=spec(
            "no crater larger than this has its bowl within the fine tile: the work site was chosen "
            "outside large craters, metres",
            lo=0.0,
            hi=10000.0,
        ),
    )
    subgrid_shading: bool = field(
        default=True,
        metadata=spec(
            "shade the craters the graded mesh cannot draw (narrower than 5 cells, 0.1·distance), out to where "
            "they span a few pixels: their slopes and their walls' shadows at camera hits "
            "(moonbot/subgrid_craters.h)"
        ),
    )


@dataclass(frozen=True)
class RocksConfig:
    """Rocks and pebbles (moonbot/terrain/rocks.py): a background cumulative power law
    N(>=D) = density_per_m2·D^exponent per m² (D in metres; Shoemaker & Morris 1969, Surveyor),
    and at the crater location Golombek & Rapp's (1997) ejecta population, cumulative fractional
    area F(D) = k·exp(-q(k)·D), q(k) = 1.79 + 0.152/k; irregular instanced meshes."""

    density_per_m2: float = field(
        default=2.34e-3,
        metadata=spec(
            "background: rocks per m^2 of diameter >= 1 m in N(>=D) = density·D^exponent: 10x Surveyor I's "
            "5.0e4 per 100 m^2 with D in mm (2.34e-4), as the Apollo 11 photographs' cm-dm rocks show; "
            "0 = none",
            lo=0.0,
            hi=1.0,
        ),
    )
    exponent: float = field(
        default=-2.11,
        metadata=spec(
            "background: cumulative exponent b (Surveyor I -2.11, III -2.56, VI -2.51, VII -1.82)", lo=-6.0, hi=-0.5
        ),
    )
    k_crater: float = field(
        default=0.1,
        metadata=spec(
            "crater location: rock-covered fraction on the crater's rim (fresh ejecta: 0.05-0.4), "
            "falling off outside as (r/R)^-3 like the ejecta",
            lo=0.0,
            hi=0.5,
        ),
    )
    min_diameter_m: float = field(
        default=0.01, metadata=spec("smallest rock, metres (1 cm pebbles: 2 pixels at 3 m)", lo=0.005, hi=10.0)
    )
    max_diameter_m: float = field(default=1.5, metadata=spec("largest rock, metres", lo=0.005, hi=20.0))
    reach_m: float = field(
        default=60.0, metadata=spec("rocks lie within this distance of the target, metres", lo=0.0, hi=5000.0)
    )
    clearance_m: float = field(
        default=0.05,
        metadata=spec(
            "no rock lies within this distance of a bag's footprint (the site was cleared), metres", lo=0.0, hi=10.0
        ),
    )


# The ground a scene stands on: a location (procedural, or `dem`: a site from an imported DEM;
# moonbot.terrain.location builds them) or an analytic test ground.
LOCATIONS = ("flat", "hilly", "crater", "dem")
TEST_GROUNDS = ("plane", "slope")
LocationName = Literal[LOCATIONS + TEST_GROUNDS]


@dataclass(frozen=True)
class TerrainConfig:
    """The ground (moonbot/terrain/). A procedural location — `flat` (a mare plain), `hilly`,
    `crater` (beside a simple crater, with rocks) — or `dem`, a real site from a DEM imported
    with `moonbot terrain import`, each meshed from 1 cm at the bags out to the horizon on a
    curved Moon; or an analytic test ground: `plane` (z = 0) or `slope`."""

    location: LocationName = field(
        default="flat",
        metadata=spec(
            "procedural location (flat | hilly | crater), a DEM site (dem) or analytic ground (plane | slope)"
        ),
    )
    seed: int = field(
        default=0,
        metadata=spec(
            "terrain seed: a location is the same for every sample of a sweep, and cached per worker",
            lo=0,
            hi=2**63 - 1,
        ),
    )
    albedo: float = field(
        default=0.12,
        metadata=spec(
            "normal albedo of regolith: its reflectance at zero incidence, emission and phase, opposition "
            "surge included (mare ~0.09, highland ~0.15)",
            lo=0.0,
            hi=1.0,
        ),
    )
    photometry: PhotometryConfig = field(default_factory=PhotometryConfig)
    albedo_variation: float = field(
        default=0.2,
        metadata=spec(
            "procedural locations: albedo varies by up to this fraction at 50-400 m wavelengths (mature and "
            "immature soil; docs/physics.md: ±20 %)",
            lo=0.0,
            hi=0.9,
        ),
    )
    ejecta_brightening: float = field(
        default=0.5,
        metadata=spec(
            "crater: fresh ejecta are brighter by this fraction at the rim, falling as (r/R)^-3 (+50-100 %)",
            lo=0.0,
            hi=2.0,
        ),
    )
    extent_m: float = field(
        default=2000.0,
        metadata=spec(
            "half-width of the terrain square around the target, metres (the horizon of a camera 1 m "
            "up is 1.9 km away)",
            lo=0.0,
            hi=20000.0,
            lo_open=True,
        ),
    )
    detail_m: float = field(
        default=0.01, metadata=spec("grid spacing of the fine tile around the target, metres", lo=0.001, hi=1.0)
    )
    detail_extent_m: float = field(
        default=2.0, metadata=spec("half-width of the fine tile, metres", lo=0.01, hi=1000.0)
    )
    growth: float = field(
        default=1.02,
        metadata=spec(
            "ratio of neighbouring cells outside the fine tile (spacing ≈ (growth-1)·distance)",
            lo=1.0,
            hi=2.0,
            lo_open=True,
        ),
    )
    curvature: bool = field(
        default=True, metadata=spec("lower the terrain by the Moon's curvature, R - sqrt(R^2 - d^2), R = 1737.4 km")
    )
    roughness: RoughnessConfig = field(default_factory=RoughnessConfig)
    craters: CratersConfig = field(default_factory=CratersConfig)
    rocks: RocksConfig = field(default_factory=RocksConfig)
    hills_rms_slope_deg: float = field(
        default=8.0,
        metadata=spec(
            "hilly: RMS slope of the hills over a 25 m baseline, degrees (LOLA highlands ~5-10)", lo=0.0, hi=40.0
        ),
    )
    hills_wavelength_m: float = field(
        default=2048.0, metadata=spec("hilly: longest wavelength of the hills, metres", lo=8.0, hi=100000.0)
    )
    crater_diameter_m: float = field(
        default=20.0,
        metadata=spec(
            "crater: rim-crest diameter, metres (depth 0.13 D, rim 0.036 D)", lo=0.0, hi=1000.0, lo_open=True
        ),
    )
    crater_distance_m: float = field(
        default=12.0,
        metadata=spec(
            "crater: distance of its centre from the target, metres (D/2 = on the rim crest)", lo=0.0, hi=10000.0
        ),
    )
    crater_azimuth_deg: float = field(
        default=90.0,
        metadata=spec(
            "crater: direction of its centre from the target, clockwise from North, degrees", lo=-360.0, hi=360.0
        ),
    )
    dem_file: str = field(
        default="",
        metadata=spec(
            "dem: the LocalDem .npz written by `moonbot terrain import` (absolute, or relative to the "
            "working directory; every worker must see it)"
        ),
    )
    dem_site_m: tuple[float, float] = field(
        default=(0.0, 0.0),
        metadata=spec(
            "dem: the work site, metres east and north of the DEM's origin (snapped to the nearest DEM node)",
            lo=-1e6,
            hi=1e6,
            length=2,
        ),
    )
    slope_deg: float = field(default=15.0, metadata=spec("slope: inclination of the plane, degrees", lo=0.0, hi=60.0))
    slope_azimuth_deg: float = field(
        default=90.0, metadata=spec("slope: downhill direction, clockwise from North, degrees", lo=-360.0, hi=360.0)
    )

    def __post_init__(self) -> None:
        if self.location == "dem" and not self.dem_file:
            raise ValueError("dem_file: required when location is dem (a file from `moonbot terrain import`)")
        if self.detail_extent_m > self.extent_m:
            raise ValueError(f"detail_extent_m: must be <= extent_m = {self.extent_m}, got {self.detail_extent_m}")
        if self.craters.min_diameter_m >= self.craters.max_diameter_m:
            raise ValueError("craters.min_diameter_m: must be below craters.max_diameter_m")
        if self.rocks.min_diameter_m >= self.rocks.max_diameter_m:
            raise ValueError("rocks.min_diameter_m: must be below rocks.max_diameter_m")
        if self.roughness.min_wavelength_m >= self.roughness.max_wavelength_m:
            raise ValueError("roughness.min_wavelength_m: must be below roughness.max_wavelength_m")


@dataclass(frozen=True)
class BagShape:
    """Shape of one sandbag mesh variant; moonbot/scene/bag_mesh.py builds it, and its module
    docstring explains the body, the seam and the folds. Each field's unit is in its metadata.
    Checked on construction (a seam needs a rounded edge to sit on, for instance); the loader
    reports a failure with the field's path."""

    size_m: tuple[float, float, float] = field(
        default=(0.32, 0.20, 0.12), metadata=spec("body length, width, height before bulging, metres", length=3)
    )
    edge_radius_m: float = field(default=0.010, metadata=spec("rounding of edges and corners, metres"))
    bulge_m: float = field(default=0.008, metadata=spec("outward bow at each face centre, metres"))
    edge_length_m: float = field(
        default=0.006,
        metadata=spec(
            "triangle edge length on flat parts, metres (finer where the wrinkles need it: a quarter of "
            "the crease width or pucker pitch)"
        ),
    )
    edge_steps: int = field(
        default=4,
        metadata=spec("rows of vertices across each side of a rounded edge (4: 22.5° steps, 0.2 mm from a 10 mm arc)"),
    )
    seam_height_m: float = field(default=0.0, metadata=spec("seam ridge height, metres (0 = no seam)"))
    seam_width_m: float = field(default=0.006, metadata=spec("seam ridge width along the edge arc, metres"))
    stitch_pitch_m: float = field(default=0.012, metadata=spec("distance between stitches, metres"))
    stitch_depth: float = field(default=0.3, metadata=spec("stitch dip as a fraction of the seam height"))
    fold_length_m: float = field(default=0.0, metadata=spec("folded length at each short end, metres (0 = none)"))
    gather: float = field(default=0.25, metadata=spec("cross-section shrink at the very ends (fraction)"))
    pleats: int = field(default=5, metadata=spec("pleats around the +x end (the -x end has one more)"))
    pleat_depth_m: float = field(default=0.006, metadata=spec("pleat depth, metres"))
    sag_m: float = field(
        default=0.005, metadata=spec("how far the top's centre settles below the unsettled bulge, metres (0 = no sag)")
    )
    belly_m: float = field(default=0.002, metadata=spec("extra outward bow of the sides as the fill settles, metres"))
    belly_height: float = field(
        default=0.4,
        metadata=spec(
            "where the sides bow out most, as a fraction of the half-height below the middle (0 = the middle)"
        ),
    )
    flat_bottom: bool = field(default=True, metadata=spec("the bottom face rests pressed flat (no bulge)"))
    crease_depth_m: float = field(
        default=0.0025, metadata=spec("largest depth of the creases fanning from each corner, metres (0 = none)")
    )
    crease_length_m: float = field(default=0.07, metadata=spec("longest crease, metres"))
    crease_width_m: float = field(default=0.02, metadata=spec("crease width across, metres"))
    creases_per_corner: int = field(default=2, metadata=spec("creases from each corner onto each face meeting it"))
    pucker_depth_m: float = field(
        default=0.0012, metadata=spec("depth of the puckers where the seams gather the fabric, metres (0 = none)")
    )
    pucker_pitch_m: float = field(default=0.03, metadata=spec("mean spacing of the puckers along a seam, metres"))
    pucker_length_m: float = field(default=0.025, metadata=spec("how far a pucker runs onto the face, metres"))
    wrinkle_seed: int = field(default=0, metadata=spec("seed of the creases' and puckers' layout"))

    def __post_init__(self) -> None:
        if any(not s > 0 for s in self.size_m):
            raise ValueError(f"size_m: every side must be > 0, got {self.size_m}")
        if not 0 <= self.edge_radius_m < min(self.size_m) / 2:
            raise ValueError(f"edge_radius_m: must be in [0, {min(self.size_m) / 2}), got {self.edge_radius_m}")
        if not 0 <= self.bulge_m <= min(self.size_m) / 4:
            raise ValueError(f"bulge_m: must be in [0, {min(self.size_m) / 4}], got {self.bulge_m}")
        if not 0 < self.edge_length_m <= min(self.size_m) / 2:
            raise ValueError(f"edge_length_m: must be in (0, {min(self.size_m) / 2}], got {self.edge_length_m}")
        if not 1 <= self.edge_steps <= 64:
            raise ValueError(f"edge_steps: must be in 1..64, got {self.edge_steps}")
        if not 0 <= self.seam_height_m <= 0.05:
            raise ValueError(f"seam_height_m: must be in [0, 0.05], got {self.seam_height_m}")
        if self.seam_height_m > 0 and self.edge_radius_m == 0:
            raise ValueError("seam_height_m: a seam needs rounded edges (edge_radius_m > 0)")
        arc = self.edge_radius_m * math.pi / 2
        if self.seam_height_m > 0 and not 0 < self.seam_width_m <= arc:
            raise ValueError(f"seam_width_m: must be in (0, {arc:.4g}] (the edge arc), got {self.seam_width_m}")
        if not self.stitch_pitch_m > 0:
            raise ValueError(f"stitch_pitch_m: must be > 0, got {self.stitch_pitch_m}")
        if not 0 <= self.stitch_depth <= 1:
            raise ValueError(f"stitch_depth: must be in [0, 1], got {self.stitch_depth}")
        if not 0 <= self.fold_length_m <= self.size_m[0] / 2:
            raise ValueError(f"fold_length_m: must be in [0, {self.size_m[0] / 2}], got {self.fold_length_m}")
        if not 0 <= self.gather <= 0.6:
            raise ValueError(f"gather: must be in [0, 0.6], got {self.gather}")
        if not 2 <= self.pleats <= 32:
            raise ValueError(f"pleats: must be in 2..32, got {self.pleats}")
        if not 0 <= self.pleat_depth_m <= min(self.size_m[1:]) / 4:
            raise ValueError(f"pleat_depth_m: must be in [0, {min(self.size_m[1:]) / 4}], got {self.pleat_depth_m}")
        if not 0 <= self.sag_m <= min(self.size_m) / 4:
            raise ValueError(f"sag_m: must be in [0, {min(self.size_m) / 4}], got {self.sag_m}")
        if not 0 <= self.belly_m <= min(self.size_m) / 4:
            raise ValueError(f"belly_m: must be in [0, {min(self.size_m) / 4}], got {self.belly_m}")
        if not 0 <= self.belly_height <= 0.8:
            raise ValueError(f"belly_height: must be in [0, 0.8], got {self.belly_height}")
        # A wrinkle must be wide against its depth, or it would fold the surface through itself.
        if not 0 <= self.crease_depth_m <= self.crease_width_m / 4:
            raise ValueError(
                f"crease_depth_m: must be in [0, crease_width_m / 4 = {self.crease_width_m / 4}], "
                f"got {self.crease_depth_m}"
            )
        if not 0 < self.crease_length_m <= min(self.size_m[:2]):
            raise ValueError(f"crease_length_m: must be in (0, {min(self.size_m[:2])}], got {self.crease_length_m}")
        if not 0 < self.crease_width_m <= self.crease_length_m:
            raise ValueError(
                f"crease_width_m: must be in (0, crease_length_m = {self.crease_length_m}], got {self.crease_width_m}"
            )
        if not 0 <= self.creases_per_corner <= 8:
            raise ValueError(f"creases_per_corner: must be in 0..8, got {self.creases_per_corner}")
        if not 0 <= self.pucker_depth_m <= self.pucker_pitch_m / 8:
            raise ValueError(
                f"pucker_depth_m: must be in [0, pucker_pitch_m / 8 = {self.pucker_pitch_m / 8}], "
                f"got {self.pucker_depth_m}"
            )
        if not 0 < self.pucker_pitch_m <= min(self.size_m):
            raise ValueError(f"pucker_pitch_m: must be in (0, {min(self.size_m)}], got {self.pucker_pitch_m}")
        if not 0 < self.pucker_length_m <= min(self.size_m) / 2:
            raise ValueError(f"pucker_length_m: must be in (0, {min(self.size_m) / 2}], got {self.pucker_length_m}")
        if not 0 <= self.wrinkle_seed < 2**63:
            raise ValueError(f"wrinkle_seed: must be in [0, 2^63), got {self.wrinkle_seed}")


# The built-in mesh variants by name and their BOP obj_ids: the one table of object ids. Meshes of
# your own (meshes.user) follow from FIRST_USER_OBJ_ID, in the order of their paths.
BUILTIN_MESHES = {"sandbag-01": 1, "sandbag-02": 2, "sandbag-03": 3}
FIRST_USER_OBJ_ID = max(BUILTIN_MESHES.values()) + 1
# Mesh files trimesh reads without further system libraries (FBX: none of trimesh's loaders).
MESH_FILE_SUFFIXES = (".obj", ".ply", ".glb", ".gltf")


@dataclass(frozen=True)
class UserMeshConfig:
    """A bag mesh of your own, read, checked and repaired by moonbot/scene/user_mesh.py. Its
    model frame is the file's, turned so `up_axis` points up (+z) and moved so the centre of its
    bounding box is the origin; lengths are converted from `unit` to metres."""

    path: str = field(
        default="", metadata=spec("the mesh file (.obj, .ply, .glb or .gltf), relative to the working directory")
    )
    name: str = field(
        default="",
        metadata=spec(
            "the mesh's name in bags.mesh, task ids, the dataset tree and YOLO's classes: letters, digits, "
            "'-' or '_' ('' = the file's stem, lower-cased)"
        ),
    )
    unit: Literal["m", "cm", "mm"] = field(default="m", metadata=spec("the file's unit of length"))
    up_axis: Literal["auto", "+x", "-x", "+y", "-y", "+z", "-z"] = field(
        default="auto",
        metadata=spec(
            "the file's axis that points up when the bag rests as modelled (auto: +y for .glb/.gltf, glTF's "
            "own convention; +z otherwise)"
        ),
    )
    texture: str = field(
        default="",
        metadata=spec(
            "a base-colour image (PNG or JPEG, sRGB) on the mesh's own UVs, in place of its material's "
            "('' = the material's, if it has one)"
        ),
    )
    sha256: str = field(
        default="",
        metadata=spec(
            "the file's SHA-256 (hex); filled in when the config is loaded, and a config whose file has "
            "changed since is refused"
        ),
    )


@dataclass(frozen=True)
class MeshesConfig:
    """The three SynBag-1.0 mesh variants (obj_id 1, 2, 3) and meshes of your own (`user`, obj_id
    4, 5, ... in the order of their paths). sandbag-03 is longer by default: its folds take up
    fabric, and 0.36 m keeps its diameter on the paper's ~400 mm ADD-S scale."""

    sandbag_01: BagShape = field(default_factory=lambda: BagShape(wrinkle_seed=1))
    sandbag_02: BagShape = field(default_factory=lambda: BagShape(seam_height_m=0.003, wrinkle_seed=2))
    sandbag_03: BagShape = field(
        default_factory=lambda: BagShape(size_m=(0.36, 0.20, 0.12), fold_length_m=0.06, wrinkle_seed=3)
    )
    user: tuple[UserMeshConfig, ...] = field(
        default=(),
        metadata=spec(
            "meshes of your own; bags.mesh and a split's meshes may also name a file directly, which adds "
            "it here with the defaults. Sorted by path when loaded: that order numbers their obj_ids"
        ),
    )

    def objects(self) -> dict[int, str]:
        """Every object of a dataset made with these meshes: {obj_id: name}, ascending; the
        built-in variants always, then the user meshes."""
        out = {obj_id: name for name, obj_id in BUILTIN_MESHES.items()}
        out.update({FIRST_USER_OBJ_ID + k: entry.name for k, entry in enumerate(self.user)})
        return out

    def obj_id(self, name: str) -> int:
        """The BOP obj_id of the mesh named `name` (a built-in variant or a user mesh)."""
        for obj_id, known in self.objects().items():
            if known == name:
                return obj_id
        raise ValueError(f"bags.mesh: no mesh named {name!r} (known: {', '.join(self.objects().values())})")

    def user_mesh(self, name: str) -> UserMeshConfig | None:
        """The meshes.user entry named `name`; None for a built-in variant."""
        return next((entry for entry in self.user if entry.name == name), None)


@dataclass(frozen=True)
class SettleConfig:
    """Dropping the placed bags as rigid bodies under lunar gravity until they rest (MuJoCo;
    moonbot/scene/settle.py). Off, the bags keep their geometric resting poses."""

    enabled: bool = field(default=True, metadata=spec("drop and settle the bags (false: geometric rest only)"))
    gravity_m_s2: float = field(default=1.62, metadata=spec("gravity, m/s^2 (the Moon: 1.62)", lo=0.01, hi=100.0))
    friction: float = field(
        default=0.75,
        metadata=spec(
            "Coulomb friction of fabric on regolith and on fabric (tan 37°, regolith's nominal internal "
            "friction angle, docs/physics.md)",
            lo=0.0,
            hi=5.0,
        ),
    )
    rolling_friction_m: float = field(
        default=0.005,
        metadata=spec(
            "rolling and torsional friction as a lever arm, metres: a filled bag flattens against its "
            "support and does not rock or spin freely (a rigid bulged box would rock for seconds)",
            lo=0.0,
            hi=0.1,
        ),
    )
    density_kg_m3: float = field(
        default=1500.0, metadata=spec("bulk density of a filled bag, kg/m^3 (regolith 1300-1900)", lo=1.0, hi=20000.0)
    )
    margin_m: float = field(
        default=0.001,
        metadata=spec(
            "contact margin: bags come to rest this far from the ground and from each other, metres",
            lo=0.0,
            hi=0.05,
            lo_open=True,
        ),
    )
    timestep_s: float = field(default=0.004, metadata=spec("integration step, seconds", lo=1e-5, hi=0.05))
    contact_time_s: float = field(
        default=0.02,
        metadata=spec(
            "contact stiffness as a time constant (MuJoCo solref[0]), seconds; at least 2 steps", lo=1e-4, hi=1.0
        ),
    )
    contact_damping: float = field(
        default=1.0, metadata=spec("contact damping ratio (MuJoCo solref[1]); 1 = critically damped", lo=0.0, hi=10.0)
    )
    drop_m: float = field(
        default=0.005,
        metadata=spec("height above their geometric rest the bags are dropped from, metres", lo=0.0, hi=1.0),
    )
    rest_speed_m_s: float = field(
        default=0.002,
        metadata=spec(
            "a bag is at rest when no point of it moves faster than this, m/s", lo=1e-6, hi=1.0, lo_open=True
        ),
    )
    rest_time_s: float = field(
        default=0.2, metadata=spec("all bags must stay at rest this long, seconds", lo=0.0, hi=10.0)
    )
    max_time_s: float = field(
        default=15.0,
        metadata=spec(
            "simulated time after which bags still moving are an error, seconds", lo=0.0, hi=600.0, lo_open=True
        ),
    )
    ground_step_m: float = field(
        default=0.01,
        metadata=spec("grid spacing of the ground height field the bags collide with, metres", lo=0.001, hi=1.0),
    )

    def __post_init__(self) -> None:
        if self.contact_time_s < 2 * self.timestep_s:
            raise ValueError(
                f"contact_time_s: must be at least 2 x timestep_s = {2 * self.timestep_s}, got {self.contact_time_s}"
            )


@dataclass(frozen=True)
class FabricConfig:
    """The bags' woven fabric (paper 3.3.2; cpp/include/moonbot/fabric.h): a plain weave
    evaluated analytically in metres of fabric, prefiltered over each pixel's footprint. Its
    mean colour is `bags.albedo`."""

    pitch_m: float = field(
        default=0.0015,
        metadata=spec(
            "centre-to-centre distance of neighbouring yarns, metres (a common PP sandbag's 10 x 10 "
            "tapes per inch is 0.00254; this tight weave is finer)",
            lo=1e-5,
            hi=0.05,
        ),
    )
    relief_m: float = field(
        default=0.0001,
        metadata=spec("height of a yarn float's crown over the pits between yarns, metres", lo=0.0, hi=0.01),
    )
    contrast: float = field(
        default=0.04,
        metadata=spec("albedo modulation between crowns (+) and pits (-), a fraction of the mean", lo=0.0, hi=1.0),
    )
    sheen: float = field(
        default=0.1,
        metadata=spec(
            "weight s of the polypropylene tapes' glossy lobe: BRDF (1-s)·albedo/π + s·f_tape, an anisotropic "
            "GGX lobe oriented along each tape (cpp/include/moonbot/fabric.h); 0 = matte",
            lo=0.0,
            hi=1.0,
        ),
    )
    sheen_along: float = field(
        default=0.35,
        metadata=spec("GGX roughness of a tape along its length (the over-under waviness)", lo=0.01, hi=1.0),
    )
    sheen_across: float = field(
        default=0.12, metadata=spec("GGX roughness of a tape across its width (flat slit film)", lo=0.01, hi=1.0)
    )


@dataclass(frozen=True)
class StainConfig:
    """Dirt on the bags. mode stamp (paper 3.4; cpp/include/moonbot/stain.h): per bag a UV mask of
    `resolution`^2 texels accumulates `seeds` splats of side `brush_size` (UV units) and
    opacity `opacity` at random UV centres; base colour = lerp(clean, M * dirt_colour, M).
    mode dust (cpp/include/moonbot/soiling.h): `seeds` deposits of regolith dust near the bottom
    and the top of each bag plus a band along its ground contact, grainy where partial; base
    colour = lerp(clean, dirt_colour, m)."""

    seeds: int = field(
        default=0,
        metadata=spec(
            "number of stamps per bag (the paper sweeps 0, 15, 30, 90); 0 = clean, no mask allocated", lo=0, hi=100000
        ),
    )
    brush_size: float = field(
        default=0.18,
        metadata=spec(
            "side of the square one stamp covers, UV units (1 UV = 1.04 m on the default bag's atlas)",
            lo=0.0,
            hi=0.5,
            lo_open=True,
        ),
    )
    opacity: float = field(
        default=0.5,
        metadata=spec("mask added by one stamp at the splat's centre (overlaps add, then clamp at 1)", lo=0.0, hi=1.0),
    )
    dirt_colour: tuple[float, float, float] = field(
        default=(0.12, 0.11, 0.10),
        metadata=spec("linear RGB of fully stained fabric: regolith dust (docs/physics.md)", lo=0.0, hi=1.0, length=3),
    )
    resolution: int = field(
        default=512,
        metadata=spec("mask texels per side (512: 2 mm texels on the default bag, 1 MiB per bag)", lo=1, hi=8192),
    )
    mode: Literal["stamp", "dust"] = field(
        default="stamp",
        metadata=spec(
            "stamp: the paper's splat stamps into a UV mask; dust: regolith dust gathered at the ground "
            "contact and where handled, grainy at its edges (cpp/include/moonbot/soiling.h; seeds deposits "
            "of opacity `opacity`, colour dirt_colour)"
        ),
    )
    contact_height_m: float = field(
        default=0.025,
        metadata=spec(
            "dust: e-folding height of the dust band above the bag's lowest point, metres", lo=0.0, hi=1.0, lo_open=True
        ),
    )
    deposit_radius_m: float = field(
        default=0.04,
        metadata=spec(
            "dust: mean radius of one deposit, metres (radii 0.6-1.4 times it)", lo=0.0, hi=1.0, lo_open=True
        ),
    )
    handled_share: float = field(
        default=0.25,
        metadata=spec(
            "dust: share of deposits left near the top by handling (the rest near the bottom)", lo=0.0, hi=1.0
        ),
    )
    speckle: float = field(
        default=0.8,
        metadata=spec("dust: strength of the grainy break-up of partial cover (0 = smooth)", lo=0.0, hi=2.0),
    )


@dataclass(frozen=True)
class BagsConfig:
    """Bags as rigid bodies, meshes from `meshes`."""

    count: int = field(
        default=1, metadata=spec("number of bags, instance ids 1..count; the first is the orbit target", lo=1, hi=255)
    )
    layout: Literal["single", "scattered", "stacked"] = field(
        default="single", metadata=spec("single bag, bags scattered around the target, or a running-bond wall")
    )
    gap_m: float = field(default=0.02, metadata=spec("clearance between neighbouring bags, metres", lo=0.0, hi=1.0))
    scatter_radius_m: float = field(
        default=1.0,
        metadata=spec("scattered layout: bags lie within this distance of the target, metres", lo=0.0, hi=100.0),
    )
    mesh: str = field(
        default="sandbag-01",
        metadata=spec(
            "the bags' mesh: a built-in variant (sandbag-01, sandbag-02, sandbag-03: BOP obj_id 1, 2, 3), the "
            "name of a meshes.user entry, or a mesh file (.obj, .ply, .glb, .gltf; added to meshes.user)"
        ),
    )
    albedo: tuple[float, float, float] = field(
        default=(0.55, 0.45, 0.32), metadata=spec("linear RGB albedo of the fabric (tan)", lo=0.0, hi=1.0, length=3)
    )
    yaw_deg: float = field(
        default=20.0, metadata=spec("rotation of the target (and the wall) about +z, degrees", lo=-360.0, hi=360.0)
    )
    settle: SettleConfig = field(default_factory=SettleConfig)
    fabric: FabricConfig = field(default_factory=FabricConfig)
    stain: StainConfig = field(default_factory=StainConfig)

    def __post_init__(self) -> None:
        if self.layout == "single" and self.count != 1:
            raise ValueError(f"count: the single layout holds one bag, got {self.count}")


@dataclass(frozen=True)
class RenderConfig:
    spp: int = field(
        default=4, metadata=spec("RGB samples per pixel (depth and masks use the pixel centre)", lo=1, hi=65536)
    )
    threads: int = field(default=0, metadata=spec("render threads, 0 = all cores", lo=0, hi=1024))
    exact_depth: bool = field(
        default=True,
        metadata=spec(
            "re-solve hit distances in double (depth exact at kilometre coordinates, ~15 ns a ray); "
            "false keeps Embree's float32 distance"
        ),
    )
    light_samples: int = field(
        default=1, metadata=spec("shadow rays per sample toward the Sun's disk (soft shadow edges)", lo=1, hi=1024)
    )
    adaptive_full_spread: float = field(
        default=4.0,
        metadata=spec(
            "adaptive anti-aliasing: 0 brings every refined pixel up to adaptive_spp samples; f > 0 gives it a share "
            "of the samples past spp in proportion to its base samples' direct-luminance spread over f times the "
            "frame's mean, moved to the nearest power of two (a whole net of its sample sequence)",
            lo=0.0,
        ),
    )
    penumbra_light_samples: int = field(
        default=2,
        metadata=spec(
            "adaptive anti-aliasing: shadow rays toward the Sun's disk per refinement sample in a penumbra (where the "
            "pixel's or a neighbour's base samples' Sun rays partly escape); elsewhere a refinement sample casts one",
            lo=1,
            hi=1024,
        ),
    )
    bounces: int = field(
        default=2,
        metadata=spec("diffuse inter-reflections lighting the shadows (0 = direct sunlight only)", lo=0, hi=16),
    )
    adaptive_spp: int = field(
        default=128,
        metadata=spec(
            "adaptive anti-aliasing: the samples a pixel gets (at most, with adaptive_full_spread) when its spp base "
            "samples (or a neighbour's; with spp 1 the pixel-centre samples of its 3x3 neighbourhood) disagree in "
            "direct luminance (adaptive_threshold); past spp >= 2 they carry direct light only, over spp 1 the whole "
            "radiance; off where it is 0 or not above spp",
            lo=0,
            hi=65536,
        ),
    )
    adaptive_threshold: float = field(
        default=0.5,
        metadata=spec(
            "spread (max - min) of direct luminance over the samples compared (adaptive_spp), over "
            "sqrt(their mean x the frame's mean direct luminance), above which adaptive_spp refines a pixel; with "
            "dust (spp >= 2) all three as the image shows them, through the cloud and with its glow",
            lo=0.0,
            hi=1000.0,
        ),
    )
    adaptive_contrast: float = field(
        default=4.0,
        metadata=spec(
            "adaptive anti-aliasing (spp >= 2): a pixel whose 3x3 neighbourhood's base samples, taken together, spread "
            "beyond this times sqrt(their mean x the frame's mean direct luminance) (adaptive_threshold's measure, "
            "a bar of its own) is refined, its share (adaptive_full_spread) following that spread: a sunlit face "
            "beside ground lit at a grazing angle, a lit ridge across a shadow, where a pixel's own and its "
            "neighbours' samples each see part of the contrast; 0 = off",
            lo=0.0,
        ),
    )
    adaptive_error_target: float = field(
        default=0.014,
        metadata=spec(
            "adaptive anti-aliasing (spp >= 2, adaptive_full_spread > 0): the share's spread is chosen per view, the "
            "largest adaptive_full_spread x 2^(j/8) (j = 0..40) whose refined pixels' predicted error, relative to the "
            "image's mean luminance (through the dust, its glow included), is at most this: an easy view spends "
            "fewer samples, a hard one more (bench_accuracy; docs/performance.md); 0 = off, "
            "adaptive_full_spread always",
            lo=0.0,
            hi=1.0,
        ),
    )
    texture_filter_px: float = field(
        default=1.0,
        metadata=spec(
            "width, in pixels, of the box each camera sample's textures (regolith grain, weave, dust cover) are "
            "prefiltered over: 1 = its pixel, integrated by the pixel's samples as a sensor does; wider is "
            "blurrier and refines fewer pixels (bench_accuracy and bench realism measure both)",
            lo=0.25,
            hi=8.0,
        ),
    )
    indirect: Literal["path", "cache"] = field(
        default="cache",
        metadata=spec(
            "how a pixel's first hit gets its indirect light: path = its own bounce paths (the reference); "
            "cache = a per-task world-space cache of indirect irradiance per vertex of the static scene, "
            "filled on first touch and shared by every view (cpp/include/moonbot/light_cache.h); "
            "no cache is built when bounces is 0"
        ),
    )
    cache_rays_bags: int = field(
        default=1024,
        metadata=spec(
            "indirect: cache: gather rays per bag lattice node or vertex (bags have few vertices and much of the indirect "
            "light's noise)",
            lo=1,
            hi=65536,
        ),
    )
    cache_rays_terrain: int = field(
        default=64,
        metadata=spec(
            "indirect: cache: gather rays per lattice node (or vertex) of the terrain and rocks", lo=1, hi=65536
        ),
    )
    cache_gather_error: float = field(
        default=0.0,
        metadata=spec(
            "indirect: cache: adaptive gathering: a node (or vertex) gathers its rays again while the relative "
            "standard error of its luminance is above this, up to cache_rays_max_factor times its rays; the rays go to "
            "shadowed ground lit by a few sunlit patches, where a fixed count leaves blotches; 0 = a fixed count",
            lo=0.0,
            hi=1.0,
        ),
    )
    cache_rays_max_factor: int = field(
        default=8,
        metadata=spec(
            "indirect: cache: the most rays adaptive gathering reaches, as a multiple of cache_rays_terrain / "
            "cache_rays_bags (the products at most 65536)",
            lo=1,
            hi=1024,
        ),
    )
    cache_terrain_cell_m: float = field(
        default=0.025,
        metadata=spec(
            "indirect: cache: spacing of the world-space lattice the terrain's and rocks' indirect light is "
            "gathered on, metres (it varies far more slowly than the 1 cm terrain grid); 0 = every vertex",
            lo=0.0,
            hi=100.0,
        ),
    )
    cache_bag_cell_m: float = field(
        default=0.01,
        metadata=spec(
            "indirect: cache: the same lattice spacing on the bags (cache_rays_bags a node), metres; 0 = every vertex",
            lo=0.0,
            hi=100.0,
        ),
    )
    cache_terrain_filter_cells: float = field(
        default=2.0,
        metadata=spec(
            "indirect: cache: radius, in lattice cells, of the tent filter a terrain or rock vertex reads the "
            "lattice through: 1 = bilinear between the four nodes around it; wider averages more nodes' "
            "independent gathers (fewer blotches on shadowed ground) and blurs the light over 2 x radius cells "
            "(the bags' lattice is read bilinearly)",
            lo=1.0,
            hi=4.0,
        ),
    )
    embree_isa: Literal["auto", "sse2", "sse4.2", "avx", "avx2", "avx512"] = field(
        default="auto",
        metadata=spec(
            "SIMD instruction set of Embree's ray traversal: auto = $MOONBOT_EMBREE_ISA where set, else avx2 "
            "where the CPU runs it (as fast as avx512 in bench/bench_embree_isa.py, and clear of the AVX-512 "
            "kernels), else the widest it runs; images do not depend on it"
        ),
    )

    def __post_init__(self) -> None:
        most = max(self.cache_rays_terrain, self.cache_rays_bags) * self.cache_rays_max_factor
        if most > 65536:
            raise ValueError(
                f"cache_rays_max_factor: {self.cache_rays_max_factor} x the gather rays "
                f"({max(self.cache_rays_terrain, self.cache_rays_bags)}) is {most}, past 65536 a node"
            )

    @property
    def refinement_spp(self) -> int:
        """adaptive_spp where it applies (above spp), else 0: a render asked for at least as many
        uniform samples refines nothing."""
        return self.adaptive_spp if self.adaptive_spp > self.spp else 0


@dataclass(frozen=True)
class ToneMapConfig:
    """Camera exposure, then Reinhard (2002) on luminance to 8-bit sRGB (moonbot/render/exposure.py
    has the photometry and its sources)."""

    ev100: float | Literal["auto"] = field(
        default="auto",
        metadata=spec(
            "camera exposure value at ISO 100 (saturation-based: luminance 1.2·2^EV100 cd/m² saturates; "
            "Apollo's sunlit setting is 14.2), or auto: the EV100 at which a Lambertian of terrain.albedo "
            "under the configured Sun (held at >= 1° elevation) reads as a reflected-light meter's "
            "mid-grey (K = 12.5): 12.98 for the default 12° Sun and albedo 0.12",
            lo=-10.0,
            hi=30.0,
        ),
    )
    veiling_glare: float = field(
        default=0.02,
        metadata=spec(
            "the lens's veiling glare index (ISO 9358): every pixel gains this fraction of the frame's mean "
            "radiance before the tone map, so shadows are never black; coated photographic lenses measure "
            "~1-3 %; 0 = none",
            lo=0.0,
            hi=0.5,
        ),
    )


@dataclass(frozen=True)
class OutputConfig:
    png_compression: int = field(
        default=1,
        metadata=spec(
            "PNG deflate level 0-9, also rgb.exr's zip level (1 is ~2.5x faster than 6 for ~20 % more bytes)",
            lo=0,
            hi=9,
        ),
    )
    exr: bool = field(
        default=False,
        metadata=spec(
            "also write rgb.exr: the linear radiance before tone mapping, float32 RGB, W/(m^2·sr), zip "
            "at png_compression's level"
        ),
    )


# The largest ejecta time step the core accepts, seconds (_core.MAX_DUST_STEP; a test checks
# they agree). The schema stays importable without the compiled core.
MAX_DUST_STEP_S = 0.1


@dataclass(frozen=True)
class EjectaConfig:
    """Emitter 1, granular ejecta (paper 3.2; cpp/include/moonbot/dust.h): rock fragments thrown
    up from a disc around the emitter in bursts, flying in vacuum and bouncing on everything in
    the scene until they rest. Opaque regolith geometry: background (label 0) in the masks, and
    in depth. Numbers: docs/physics.md"""

    count: int = field(
        default=200, metadata=spec("fragments per burst (0 = no ejecta: none simulated, no mesh)", lo=0, hi=1000000)
    )
    spawn_radius_m: float = field(
        default=0.1,
        metadata=spec(
            "fragments leave from a horizontal disc of this radius around the emitter, metres", lo=0.0, hi=100.0
        ),
    )
    cone_half_angle_deg: float = field(
        default=45.0,
        metadata=spec(
            "launch directions are uniform over this cone about the vertical, degrees (paper: 45)", lo=0.0, hi=90.0
        ),
    )
    mean_speed_m_s: float = field(
        default=0.5, metadata=spec("launch speeds are uniform in [0.5, 1.5] × this, m/s (paper: 0.5)", lo=0.0, hi=100.0)
    )
    min_diameter_m: float = field(
        default=0.01,
        metadata=spec(
            "smallest fragment, metres (diameters uniform in [min, max]; paper: 1-2 cm)", lo=0.0, hi=1.0, lo_open=True
        ),
    )
    max_diameter_m: float = field(default=0.02, metadata=spec("largest fragment, metres", lo=0.0, hi=1.0, lo_open=True))
    gravity_m_s2: float = field(
        default=1.62, metadata=spec("gravity the fragments fall under, m/s^2 (the Moon: 1.62)", lo=0.0, hi=100.0)
    )
    restitution: float = field(
        default=0.4,
        metadata=spec(
            "share of the normal speed a bounce keeps [unverified in the literature; DEM practice 0.3-0.5]",
            lo=0.0,
            hi=0.95,
        ),
    )
    friction: float = field(
        default=0.6,
        metadata=spec(
            "Coulomb friction of a bounce: tangential speed lost <= this × the normal impulse", lo=0.0, hi=10.0
        ),
    )
    rest_speed_m_s: float = field(
        default=0.02,
        metadata=spec(
            "a bounce leaving a fragment slower than this puts it at rest, m/s", lo=0.0, hi=10.0, lo_open=True
        ),
    )
    burst_period_s: float = field(
        default=2.0,
        metadata=spec(
            "every fragment is thrown again every this many seconds (the paper's loop), seconds",
            lo=0.0,
            hi=3600.0,
            lo_open=True,
        ),
    )

    def __post_init__(self) -> None:
        if self.min_diameter_m > self.max_diameter_m:
            raise ValueError(
                f"min_diameter_m: must be <= max_diameter_m = {self.max_diameter_m}, got {self.min_diameter_m}"
            )


@dataclass(frozen=True)
class CloudConfig:
    """Emitter 2, the fine-dust cloud (paper 3.2; cpp/include/moonbot/dust.h): Gaussian puffs born
    at a steady rate in a box below the emitter, drifting out along a cone, growing, their opacity
    rising fast then fading over their life; rendered as a medium (moonbot/medium.h) that
    attenuates and scatters sunlight in RGB only."""

    box_m: tuple[float, float, float] = field(
        default=(0.7, 2.0, 0.5),
        metadata=spec("spawn box east × north × up, metres (paper: 0.7 × 2.0 × 0.5)", lo=0.0, hi=1000.0, length=3),
    )
    vertical_offset_m: float = field(
        default=-1.7,
        metadata=spec("the spawn box's centre this far above the emitter, metres (paper: -1.7)", lo=-1000.0, hi=1000.0),
    )
    axis: tuple[float, float, float] = field(
        default=(1.0, 0.0, 500.0),
        metadata=spec("cone axis east, north, up (any length but 0; paper: (1, 0, 500))", lo=-1e6, hi=1e6, length=3),
    )
    cone_half_angle_deg: float = field(
        default=45.0,
        metadata=spec(
            "launch directions are uniform over this cone about the axis, degrees (paper: 45)", lo=0.0, hi=180.0
        ),
    )
    speed_m_s: float = field(default=0.7, metadata=spec("launch speed of a puff, m/s (paper: 0.7)", lo=0.0, hi=100.0))
    gravity_m_s2: float = field(
        default=0.0,
        metadata=spec(
            "gravity the puffs fall under, m/s^2: 0, as the paper's sprites drift. In vacuum fine dust is "
            "ballistic too (1.62), but a 0.7 m/s launch then rises 15 cm and lands within 0.9 s: no "
            "haze lasting 5 s",
            lo=0.0,
            hi=100.0,
        ),
    )
    lifetime_s: float = field(
        default=5.0, metadata=spec("a puff's life, seconds (paper: 5)", lo=0.0, hi=3600.0, lo_open=True)
    )
    rate_per_s: float = field(
        default=40.0,
        metadata=spec("puffs born a second (rate × lifetime are alive at once, at most 100000)", lo=0.0, hi=1e5),
    )
    sigma_m: float = field(
        default=0.15, metadata=spec("a puff's standard deviation at birth, metres", lo=0.0, hi=100.0, lo_open=True)
    )
    growth_m_s: float = field(
        default=0.08, metadata=spec("a puff's standard deviation grows by this much a second, m/s", lo=0.0, hi=100.0)
    )
    optical_depth: float = field(
        default=0.25,
        metadata=spec(
            "optical depth through a puff's centre at its most opaque (0 = no cloud: no medium traced)",
            lo=0.0,
            hi=100.0,
        ),
    )
    rise_fraction: float = field(
        default=0.1,
        metadata=spec(
            "opacity rises linearly over this fraction of a puff's life, then falls as "
            "((1 - u)/(1 - rise))^2; in (0, 1)",
            lo=0.0,
            hi=1.0,
            lo_open=True,
        ),
    )
    albedo: tuple[float, float, float] = field(
        default=(0.55, 0.51, 0.45),
        metadata=spec("single-scattering albedo of the dust grains, linear RGB", lo=0.0, hi=1.0, length=3),
    )
    asymmetry: float = field(
        default=0.7,
        metadata=spec(
            "Henyey-Greenstein asymmetry g of the grains' phase function (> 0 scatters forward); in (-1, 1)",
            lo=-1.0,
            hi=1.0,
            lo_open=True,
        ),
    )
    voxel_m: float = field(
        default=0.05,
        metadata=spec(
            "side of the grid cells the cloud is baked on for rendering and its march step, metres; "
            "bench/results/medium-*.json: at 0.05, 6 % RMS error in the scattered light for 10× a dust-free view's time",
            lo=0.001,
            hi=10.0,
        ),
    )
    march_stride_px: int = field(
        default=4,
        metadata=spec(
            "pixels between the camera rays that march the cloud, 1, 2, 4 or 8 (the pixels between read "
            "the four marched rays around them at their own hit distance); bench/results/medium-*.json: "
            "4 differs from 1 by 0.3 % RMS of the mean radiance (the grid's own error: 6 %) and saves 40 % "
            "of a dusty view's time",
            lo=1,
            hi=8,
        ),
    )

    def __post_init__(self) -> None:
        if not any(self.axis):
            raise ValueError(f"axis: must not be zero, got {self.axis}")
        if self.rate_per_s * self.lifetime_s > 1e5:
            raise ValueError(
                f"rate_per_s: at most 100000 puffs may be alive (rate_per_s × lifetime_s), got "
                f"{self.rate_per_s} × {self.lifetime_s} = {self.rate_per_s * self.lifetime_s:g}"
            )
        if self.rise_fraction >= 1.0:
            raise ValueError(f"rise_fraction: must be < 1, got {self.rise_fraction}")
        if self.asymmetry >= 1.0:
            raise ValueError(f"asymmetry: must be < 1, got {self.asymmetry}")
        if self.march_stride_px not in (1, 2, 4, 8):
            raise ValueError(f"march_stride_px: must be 1, 2, 4 or 8, got {self.march_stride_px}")


@dataclass(frozen=True)
class DustConfig:
    """Dust stirred up beside the work site, as a rover would (paper 3.2): granular
    ejecta (`ejecta`, opaque fragments) and a fine-dust cloud (`cloud`, a medium in RGB only).
    Off, a scene runs no dust code, builds no dust geometry and traces no medium. Both emitters
    stand on the ground `emitter_offset_m` from the target bag's centre; each view has its own
    capture time, warmup_s + view × view_interval_s. The seed is the dataset seed, hashed."""

    enabled: bool = field(default=False, metadata=spec("simulate and render dust in this scene"))
    emitter_offset_m: tuple[float, float] = field(
        default=(0.5, 0.3),
        metadata=spec(
            "the emitters stand this far east and north of the target bag's centre, on the ground, metres",
            lo=-1000.0,
            hi=1000.0,
            length=2,
        ),
    )
    warmup_s: float = field(
        default=6.0,
        metadata=spec(
            "capture time of view 0 after the emitters start, seconds (at least cloud.lifetime_s for a "
            "plume in steady state)",
            lo=0.0,
            hi=1e5,
        ),
    )
    view_interval_s: float = field(
        default=0.25, metadata=spec("time between the captures of consecutive orbit views, seconds", lo=0.0, hi=3600.0)
    )
    time_step_s: float = field(
        default=0.01,
        metadata=spec(
            "largest ejecta integration step, seconds (flight is exact; the step sets how finely contacts "
            "are found: bench/results/dust-*.json)",
            lo=0.0,
            hi=MAX_DUST_STEP_S,
            lo_open=True,
        ),
    )
    ejecta: EjectaConfig = field(default_factory=EjectaConfig)
    cloud: CloudConfig = field(default_factory=CloudConfig)


# A split's axes: its scenes' (meshes › locations › bag counts › stain seeds › dust), then its tasks'.
SPLIT_AXES = (
    "meshes",
    "locations",
    "bag_counts",
    "stain_seeds",
    "dust",
    "sun_elevations_deg",
    "sun_azimuths_deg",
    "camera_heights_m",
)
# BOP numbers scenes and images with six digits: ids 0..999999.
MAX_SCENES = 1_000_000
MAX_IMAGES_PER_SCENE = 1_000_000


@dataclass(frozen=True)
class SplitConfig:
    """One split of the sweep (paper 4.2, docs/scaling.md "The SynBag-1.0 sweep"): its scenes are every
    combination of meshes × locations × bag counts × stain seeds × dust, in that nesting order,
    and each scene is rendered in one task per Sun elevation × Sun azimuth × camera height (each
    task the orbit's views). An empty list takes the base config's single value."""

    name: str = field(default="train", metadata=spec("the split's directory name (train, test, ...)"))
    meshes: tuple[str, ...] = field(
        default=(), metadata=spec("bag meshes (bags.mesh): built-in variants, meshes.user names or mesh files")
    )
    locations: tuple[LocationName, ...] = field(default=(), metadata=spec("terrain locations (terrain.location)"))
    bag_counts: tuple[int, ...] = field(
        default=(),
        metadata=spec(
            "bags per scene (bags.count; more than one are laid out as the sweep's many_bags_layout)", lo=1, hi=255
        ),
    )
    stain_seeds: tuple[int, ...] = field(
        default=(), metadata=spec("stain stamps per bag (bags.stain.seeds)", lo=0, hi=100000)
    )
    dust: tuple[bool, ...] = field(default=(), metadata=spec("dust off and/or on (dust.enabled)"))
    sun_elevations_deg: tuple[float, ...] = field(
        default=(), metadata=spec("Sun elevations, degrees (sun.elevation_deg)", lo=-90.0, hi=90.0)
    )
    sun_azimuths_deg: tuple[float, ...] = field(
        default=(), metadata=spec("Sun azimuths, degrees clockwise from North (sun.azimuth_deg)", lo=0.0, hi=360.0)
    )
    camera_heights_m: tuple[float, ...] = field(
        default=(), metadata=spec("camera heights above the target's centre, metres (orbit.height_m)", lo=0.0, hi=100.0)
    )
    draw_from: str = field(
        default="",
        metadata=spec(
            "the split whose grid this one draws its scenes and tasks from (e.g. val from train; its own axes stay "
            "empty); empty: this split is its own grid"
        ),
    )
    scenes: int = field(
        default=0,
        metadata=spec(
            "with draw_from: scenes drawn, balanced over the meshes (moonbot.sweep.tasks.draw)", lo=0, hi=MAX_SCENES
        ),
    )
    tasks_per_scene: int = field(
        default=0,
        metadata=spec(
            "with draw_from: Sun × camera-height tasks drawn per scene; 0 = all of the source's", lo=0, hi=MAX_SCENES
        ),
    )

    def __post_init__(self) -> None:
        if not self.name or not all(c.isalnum() or c in "-_" for c in self.name):
            raise ValueError(f"name: must be letters, digits, '-' or '_', got {self.name!r}")
        for axis in SPLIT_AXES:
            values = getattr(self, axis)
            if len(set(values)) != len(values):
                raise ValueError(f"{axis}: repeats a value: {list(values)}")
        if self.draw_from:
            given = [axis for axis in SPLIT_AXES if getattr(self, axis)]
            if given:
                raise ValueError(
                    f"{given[0]}: a split that draws from {self.draw_from!r} takes its axes from it; leave them empty"
                )
            if self.scenes < 1:
                raise ValueError(f"scenes: a split that draws from {self.draw_from!r} needs scenes >= 1")
        elif self.scenes or self.tasks_per_scene:
            raise ValueError(f"{'scenes' if self.scenes else 'tasks_per_scene'}: only for a split with draw_from")
        scenes = math.prod(max(1, len(getattr(self, axis))) for axis in SPLIT_AXES[:5])
        if scenes > MAX_SCENES:
            raise ValueError(
                f"meshes: {scenes} scenes (meshes × locations × bag_counts × stain_seeds × dust) exceed "
                f"BOP's six-digit scene ids (at most {MAX_SCENES})"
            )


@dataclass(frozen=True)
class SweepConfig:
    """What `moonbot generate` renders: the splits (none: the base config's one scene and one
    task, as split "default"). The base config sets everything the splits do not vary."""

    splits: tuple[SplitConfig, ...] = field(default=(), metadata=spec("the splits, in dataset order"))
    many_bags_layout: Literal["scattered", "stacked"] = field(
        default="scattered",
        metadata=spec("layout of a scene with more than one bag (one bag lies alone: layout single)"),
    )

    def __post_init__(self) -> None:
        names = [s.name for s in self.splits]
        if len(set(names)) != len(names):
            raise ValueError(f"splits: two splits are named alike: {names}")
        grids = {s.name for s in self.splits if not s.draw_from}
        for k, split in enumerate(self.splits):
            if not split.draw_from:
                continue
            if split.draw_from not in grids:
                raise ValueError(
                    f"splits[{k}].draw_from: {split.draw_from!r} is not a split with its own axes "
                    f"(those are: {sorted(grids)})"
                )
            source = next(s for s in self.splits if s.name == split.draw_from)
            scenes = math.prod(max(1, len(getattr(source, axis))) for axis in SPLIT_AXES[:5])
            shots = math.prod(max(1, len(getattr(source, axis))) for axis in SPLIT_AXES[5:])
            if split.scenes > scenes:
                raise ValueError(
                    f"splits[{k}].scenes: {split.scenes} is more than the {scenes} scenes of {split.draw_from!r}"
                )
            if split.tasks_per_scene > shots:
                raise ValueError(
                    f"splits[{k}].tasks_per_scene: {split.tasks_per_scene} is more than the {shots} "
                    f"tasks a scene of {split.draw_from!r} has"
                )


@dataclass(frozen=True)
class Config:
    """A whole moonbot configuration. Load with `moonbot.config.load_config`."""

    seed: int = field(default=0, metadata=spec("dataset seed", lo=0, hi=2**63 - 1))
    camera: CameraConfig = field(default_factory=CameraConfig)
    orbit: OrbitConfig = field(default_factory=OrbitConfig)
    sun: SunConfig = field(default_factory=SunConfig)
    terrain: TerrainConfig = field(default_factory=TerrainConfig)
    bags: BagsConfig = field(default_factory=BagsConfig)
    meshes: MeshesConfig = field(default_factory=MeshesConfig)
    render: RenderConfig = field(default_factory=RenderConfig)
    tonemap: ToneMapConfig = field(default_factory=ToneMapConfig)
    output: OutputConfig = field(default_factory=OutputConfig)
    dust: DustConfig = field(default_factory=DustConfig)
    sweep: SweepConfig = field(default_factory=SweepConfig)

    def __post_init__(self) -> None:
        # Every mesh the config names resolves to a built-in variant or a meshes.user entry, by
        # name, so task ids and the dataset tree are file-name safe and a task's config (which
        # keeps meshes.user whole) numbers the objects as its sweep does.
        meshes, bags, sweep = _resolve_meshes(self.meshes, self.bags, self.sweep)
        object.__setattr__(self, "meshes", meshes)
        object.__setattr__(self, "bags", bags)
        object.__setattr__(self, "sweep", sweep)
        by_name = {s.name: s for s in self.sweep.splits}
        for k, split in enumerate(self.sweep.splits):
            grid = by_name[split.draw_from] if split.draw_from else split
            tasks = split.tasks_per_scene or math.prod(max(1, len(getattr(grid, axis))) for axis in SPLIT_AXES[5:])
            if tasks * self.orbit.views > MAX_IMAGES_PER_SCENE:
                raise ValueError(
                    f"sweep.splits[{k}]: {tasks} tasks × {self.orbit.views} views a scene exceed BOP's "
                    f"six-digit image ids (at most {MAX_IMAGES_PER_SCENE} images a scene)"
                )


def _mesh_name(path: str) -> str:
    """The name a mesh file gets by default: its stem, lower-cased, other characters than
    letters, digits, '-' and '_' as '-'."""
    stem = PurePath(path).stem.lower()
    return "".join(c if c.isascii() and (c.isalnum() or c in "-_") else "-" for c in stem) or "mesh"


def _file_sha256(path: str, where: str) -> str:
    try:
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()
    except OSError as e:
        raise ValueError(f"{where}: {path}: cannot read ({e.strerror or e})") from None


def _resolve_meshes(
    meshes: MeshesConfig, bags: BagsConfig, sweep: SweepConfig
) -> tuple[MeshesConfig, BagsConfig, SweepConfig]:
    """meshes.user completed and sorted by path (each with its name, concrete up axis and the
    file's SHA-256), with bags.mesh and the splits' meshes as names. Raises ValueError naming the
    field for a mesh that is neither built in, nor a user mesh's name, nor a readable mesh file,
    for two user meshes of one name or file, and for a file changed since its SHA-256 was taken."""
    entries: dict[str, tuple[UserMeshConfig, str]] = {}  # path → (entry, the field that named it)

    def add(entry: UserMeshConfig, where: str) -> None:
        suffix = PurePath(entry.path).suffix.lower()
        if suffix == ".fbx":
            raise ValueError(
                f"{where}: {entry.path}: FBX is not read (trimesh has no FBX loader); export the "
                f"mesh as glTF (.glb) or OBJ"
            )
        if suffix not in MESH_FILE_SUFFIXES:
            raise ValueError(f"{where}: {entry.path!r} is not a mesh file ({', '.join(MESH_FILE_SUFFIXES)})")
        if entry.path in entries:
            raise ValueError(f"{where}: {entry.path} is listed twice")
        name = entry.name or _mesh_name(entry.path)
        if not all(c.isascii() and (c.isalnum() or c in "-_") for c in name):
            raise ValueError(f"{where}: name must be letters, digits, '-' or '_', got {name!r}")
        clash = [p for p, (e, _) in entries.items() if e.name == name]
        if name in BUILTIN_MESHES or clash:
            raise ValueError(
                f"{where}: the name {name!r} is taken (by {clash[0] if clash else 'a built-in variant'}); "
                f"give meshes.user entries distinct names"
            )
        up = entry.up_axis if entry.up_axis != "auto" else "+y" if suffix in (".glb", ".gltf") else "+z"
        digest = _file_sha256(entry.path, where)
        if entry.sha256 and entry.sha256 != digest:
            raise ValueError(
                f"{where}: {entry.path} has changed since this config was made (SHA-256 "
                f"{digest[:12]}…, not {entry.sha256[:12]}…)"
            )
        entries[entry.path] = (dataclasses.replace(entry, name=name, up_axis=up, sha256=digest), where)

    for k, entry in enumerate(meshes.user):
        if not entry.path:
            raise ValueError(f"meshes.user[{k}].path: required")
        add(entry, f"meshes.user[{k}]")

    def resolve(value: str, where: str) -> str:
        if value in BUILTIN_MESHES:
            return value
        for entry, _ in entries.values():
            if value in (entry.name, entry.path):
                return entry.name
        if PurePath(value).suffix.lower() in MESH_FILE_SUFFIXES + (".fbx",):
            add(UserMeshConfig(path=value), where)
            return entries[value][0].name
        raise ValueError(
            f"{where}: must be one of {', '.join(BUILTIN_MESHES)}, a meshes.user name or a mesh "
            f"file ({', '.join(MESH_FILE_SUFFIXES)}), got {value!r}"
        )

    mesh = resolve(bags.mesh, "bags.mesh")
    splits = []
    for i, split in enumerate(sweep.splits):
        names = tuple(resolve(m, f"sweep.splits[{i}].meshes[{j}]") for j, m in enumerate(split.meshes))
        try:
            splits.append(dataclasses.replace(split, meshes=names))
        except ValueError as e:  # a file named twice, once by its path and once by its name
            raise ValueError(f"sweep.splits[{i}].{e}") from None
    splits = tuple(splits)
    user = tuple(entry for _, (entry, _) in sorted(entries.items()))
    if mesh == bags.mesh and splits == sweep.splits and user == meshes.user:
        return meshes, bags, sweep
    return (
        dataclasses.replace(meshes, user=user),
        dataclasses.replace(bags, mesh=mesh),
        dataclasses.replace(sweep, splits=splits),
    )
