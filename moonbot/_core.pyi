"""Type stubs for the compiled core `moonbot._core` (cpp/bindings). Units: metres, degrees,
W/m² and W/(m²·sr); frames: world East-North-Up, camera OpenCV (x right, y down, z forward)."""

from collections.abc import Sequence
from typing import TypedDict

import numpy as np
from numpy.typing import ArrayLike, NDArray

LUNAR_RADIUS: float

class WovenSurface:
    def __init__(self, pitch_m: float = 1.5e-3, relief_m: float = 1.0e-4, contrast: float = 0.04,
                 metres_per_uv: float = 1.0, stamps: int = 0, brush_size: float = 0.18, opacity: float = 0.5,
                 resolution: int = 512, stain_seed: int = 0,
                 dirt_colour: ArrayLike = (0.12, 0.11, 0.10), sheen: float = 0.0, sheen_along: float = ...,
                 sheen_across: float = ..., stain_mode: str = "stamp", contact_height_m: float = ...,
                 deposit_radius_m: float = ..., handled_share: float = ..., speckle: float = ...) -> None: ...

class RegolithGrain:
    def __init__(self, albedo_rms: float = 0.0, slope_rms_deg: float = 0.0, finest_cell_m: float = 1e-3,
                 coarsest_cell_m: float = 1.6e-2, hurst: float = 0.6, seed: int = 0) -> None: ...
    @property
    def octaves(self) -> int: ...
    @property
    def flat_footprint_m(self) -> float: ...
    def eval(self, points: ArrayLike, footprint_m: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]: ...

def embree_isas() -> list[str]: ...
def resolve_embree_isa(name: str = "auto") -> str: ...

class Scene:
    def __init__(self, embree_isa: str = "auto", watertight: bool = True) -> None: ...
    @property
    def embree_isa(self) -> str: ...
    def add_mesh(self, vertices: ArrayLike, triangles: ArrayLike, corner_uvs: ArrayLike | None = None,
                 vertex_albedo: ArrayLike | None = None, vertex_normals: ArrayLike | None = None) -> int: ...
    def add_instance(self, mesh: int, world_from_object: ArrayLike, instance_id: int,
                     albedo: ArrayLike, photometry: Photometry = ...,
                     woven: WovenSurface | None = None) -> int: ...
    def add_background(self, mesh: int, world_from_object: ArrayLike, albedo: ArrayLike,
                       photometry: Photometry = ..., grain: RegolithGrain | None = None,
                       moving: bool = False) -> int: ...
    def update_mesh(self, mesh: int, vertices: ArrayLike) -> None: ...
    def commit(self) -> None: ...
    def intersect(self, origins: ArrayLike, directions: ArrayLike) -> tuple[
        NDArray[np.float64], NDArray[np.int64], NDArray[np.int64]]: ...
    @property
    def committed(self) -> bool: ...
    @property
    def mesh_count(self) -> int: ...
    @property
    def instance_count(self) -> int: ...
    @property
    def bvh_builds(self) -> int: ...

class Camera:
    def __init__(self, fx: float, fy: float, cx: float, cy: float, width: int, height: int,
                 R: ArrayLike, t: ArrayLike) -> None: ...
    @property
    def width(self) -> int: ...
    @property
    def height(self) -> int: ...
    @property
    def center(self) -> NDArray[np.float64]: ...
    def project(self, points: ArrayLike) -> NDArray[np.float64]: ...

class Photometry:
    def __init__(self, model: str = "lambert", phase: str = "exponential", surge_amplitude: float = 0.0,
                 surge_width: float = 0.07, *, w: float = 0.32, b: float = 0.24, c: float = 0.30,
                 roughness_deg: float = 23.4, filling_factor: float = 0.3, cboe_amplitude: float = 0.0,
                 cboe_width: float = 1.0) -> None: ...
    def shape(self, mu_i: float, mu_o: float, cos_g: float) -> float: ...
    @property
    def model(self) -> str: ...
    def hapke_reflectance(self, mu_i: float, mu_o: float, cos_g: float) -> float: ...
    @property
    def hapke_normal_albedo(self) -> float | None: ...
    @property
    def porosity_factor(self) -> float | None: ...

class Sun:
    def __init__(self, azimuth_deg: float, elevation_deg: float, irradiance: float = 1361.0,
                 angular_diameter_deg: float = 0.0, color: ArrayLike = (1.0, 1.0, 1.0)) -> None: ...
    @property
    def direction(self) -> NDArray[np.float64]: ...
    @property
    def irradiance(self) -> float: ...
    @property
    def angular_diameter_deg(self) -> float: ...

class LightCacheStats(TypedDict):
    vertices: int
    blocks: int
    nodes: int
    probe_rays: int
    gather_rays: int
    shadow_rays: int
    bytes: int
    redundant_fills: int  # thread-dependent
    fill_seconds: float   # thread-seconds, thread-dependent

class LightCache:
    def __init__(self, scene: Scene, sun: Sun, earth: Sun | None = None, bounces: int = 2,
                 rays_objects: int = 256, rays_background: int = 64, background_cell_m: float = 0.0, object_cell_m: float = 0.0,
                 seed: int = 0, threads: int = 0) -> None: ...
    def covers(self, instance: int) -> bool: ...
    def vertex(self, instance: int, vertex: int) -> tuple[tuple[float, float, float], tuple[float, float, float]]: ...
    def fill_all(self) -> None: ...
    def stats(self) -> LightCacheStats: ...

class RenderOutput(TypedDict, total=False):
    rgb: NDArray[np.float32]
    depth: NDArray[np.float32]
    instance: NDArray[np.uint8]
    camera_rays: int
    second_look_rays: int
    shadow_rays: int
    bounce_shadow_rays: int
    bounce_rays: int
    medium_rays: int
    refined_pixels: int
    refinement_rays: int
    seconds: float

def render(scene: Scene, camera: Camera, sun: Sun, spp: int = 1, seed: int = 0, threads: int = 0,
           passes: Sequence[str] = ("rgb", "depth", "instance"),
           exact_depth: bool = True, light_samples: int = 1, bounces: int = 0,
           earth: Sun | None = None, medium: Medium | None = None,
           light_cache: LightCache | None = None, adaptive_spp: int = 0,
           adaptive_threshold: float = 0.25) -> RenderOutput: ...
def tonemap_reinhard(rgb: ArrayLike, exposure: float) -> tuple[NDArray[np.uint8], int]: ...
def write_image(path: str, pixels: ArrayLike, png_compression: int = 1,
                attributes: dict[str, str | float] = ...) -> None: ...
def read_image(path: str) -> NDArray[np.uint8] | NDArray[np.uint16] | NDArray[np.float32]: ...

class LunarFrame:
    def __init__(self, lat0_deg: float, lon0_deg: float, h0: float = 0.0,
                 radius: float = ...) -> None: ...
    def to_enu(self, lat_deg: float, lon_deg: float, h: float) -> tuple[float, float, float]: ...
    def to_geodetic(self, east: float, north: float, up: float) -> tuple[float, float, float]: ...

def curvature_drop(distance: float, radius: float = ...) -> float: ...

class DemImport(TypedDict):
    heights: NDArray[np.float64]  # (ny, nx) metres up, row 0 = south, east fastest
    spacing_m: float
    lat_deg: float
    lon_deg: float
    h0_m: float
    curvature: bool
    voids_filled: int
    source_pixel_m: float
    source_pixel_east_m: float
    source_pixel_north_m: float
    source_format: str
    source_width: int
    source_height: int
    height_scale: float
    height_offset: float
    nodata: float | None
    footprint: tuple[float, float, float, float]

def import_dem(path: str, lat_deg: float, lon_deg: float, size_m: float, spacing_m: float = 0.0,
               curvature: bool = True, height_scale: float = 1.0, height_offset: float = 0.0,
               nodata: float | None = None, png_range: tuple[float, float] | None = None,
               png_pixel_m: float | None = None,
               png_center: tuple[float, float] | None = None) -> DemImport: ...

def measure_embree_limit(scene: Scene, camera: Camera, sun: Sun, threads: int = 0,
                         repeats: int = 5, bounces: int = 0) -> dict[str, float | int | list]: ...

# The bag's appearance (fabric.h, stain.h).
def fabric_eval(xy: ArrayLike, footprint: ArrayLike, pitch_m: float = 0.0015,
                relief_m: float = 0.0001, contrast: float = 0.04,
                albedo: ArrayLike = (0.55, 0.45, 0.32)
                ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """xy (N, 2) metres of fabric, footprint (N,) metres → (albedo (N, 3) linear RGB,
    normal (N, 3) unit, tangent-space (warp, weft, normal))."""
def weave_height(a: float, b: float) -> float: ...

class StainMask:
    """R × R float32 mask in [0, 1]; np.asarray(mask) is a read-only (R, R) view, row = v."""
    @property
    def resolution(self) -> int: ...
    def sample(self, uv: ArrayLike) -> NDArray[np.float32]: ...  # (N, 2) → (N,)
    def __buffer__(self, flags: int, /) -> memoryview: ...

def stain_mask(seed: int, stamps: int, brush_size: float = 0.18, opacity: float = 0.5,
               resolution: int = 512, threads: int = 0) -> StainMask | None: ...
def stamp_centres(seed: int, stamps: int) -> NDArray[np.float64]: ...  # (stamps, 2) u, v
def splat(local: ArrayLike) -> NDArray[np.float64]: ...  # (N, 2) → (N,)
def splat_support_area() -> float: ...
def stained_base_colour(clean: ArrayLike, mask: ArrayLike, dirt: ArrayLike) -> NDArray[np.float64]: ...
def stain_mask_bytes() -> int: ...
def stain_masks_allocated() -> int: ...

MAX_DUST_STEP: float
SPAWN_CLEARANCE: float  # metres between a fragment's bounding sphere and the surface under it at launch

class EjectaState(TypedDict):
    position: NDArray[np.float64]  # (N, 3) metres, world
    velocity: NDArray[np.float64]  # (N, 3) m/s
    diameter: NDArray[np.float64]  # (N,) metres
    age: NDArray[np.float64]       # (N,) seconds since launch
    bounces: NDArray[np.int32]
    corrections: NDArray[np.int32]  # times found behind a surface and put back in front of it
    resting: NDArray[np.bool_]
    vertices: NDArray[np.float32]  # (12 N, 3) the fragments as one mesh, world metres
    triangles: NDArray[np.uint32]  # (20 N, 3)

def simulate_ejecta(scene: Scene, seed: int, time_s: float, dt_s: float = 0.01, origin: ArrayLike = (0.0, 0.0, 0.0),
                    count: int = 200, spawn_radius_m: float = 0.1, cone_half_angle_deg: float = 45.0,
                    mean_speed_m_s: float = 0.5, min_diameter_m: float = 0.01, max_diameter_m: float = 0.02,
                    gravity_m_s2: float = 1.62, restitution: float = 0.4, friction: float = 0.6,
                    rest_speed_m_s: float = 0.02, burst_period_s: float = 2.0, threads: int = 0) -> EjectaState: ...
def puff_optical_depth(centre: ArrayLike, sigma_m: float, peak_extinction: float, origin: ArrayLike,
                       direction: ArrayLike, t_max: float = ...) -> float: ...
def cloud_puffs(seed: int, time_s: float, origin: ArrayLike = (0.0, 0.0, 0.0), box_m: ArrayLike = (0.7, 2.0, 0.5),
                vertical_offset_m: float = -1.7, axis: ArrayLike = (1.0, 0.0, 500.0), cone_half_angle_deg: float = 45.0,
                speed_m_s: float = 0.7, gravity_m_s2: float = 0.0, lifetime_s: float = 5.0, rate_per_s: float = 40.0,
                sigma_m: float = 0.15, growth_m_s: float = 0.08, optical_depth: float = 0.25,
                rise_fraction: float = 0.1) -> NDArray[np.float64]: ...  # (N, 5): x, y, z, sigma, peak
def henyey_greenstein(cos_theta: float, g: float) -> float: ...

class Medium:
    def __init__(self, puffs: ArrayLike, albedo: ArrayLike = (0.55, 0.51, 0.45), asymmetry: float = 0.7,
                 voxel_m: float = 0.05, floor_z: float = ..., march_stride_px: int = 1) -> None: ...
    @property
    def puff_count(self) -> int: ...
