"""
moonbot's C++ core: Embree scene, camera, lights, renderer, image I/O, lunar frames, DEM import, bag fabric and stain, dust.
"""
from __future__ import annotations
import collections.abc
import numpy
import numpy.typing
import typing
__all__: list[str] = ['Camera', 'CloudParams', 'DirectionalLight', 'EjectaParams', 'FabricParams', 'GrainParams', 'LUNAR_RADIUS', 'LightCache', 'LightCacheSettings', 'LunarFrame', 'MAX_DUST_STEP', 'Medium', 'Photometry', 'RegolithGrain', 'RenderSettings', 'SPAWN_CLEARANCE', 'Scene', 'SoilingParams', 'StainMask', 'StainParams', 'SubgridCraters', 'SubgridRelief', 'WovenSurface', 'cloud_puffs', 'curvature_drop', 'embree_isas', 'fabric_eval', 'henyey_greenstein', 'import_dem', 'measure_embree_limit', 'puff_optical_depth', 'read_image', 'render', 'resolve_embree_isa', 'simulate_ejecta', 'splat', 'splat_support_area', 'stain_mask', 'stain_mask_bytes', 'stain_masks_allocated', 'stained_base_colour', 'stamp_centres', 'tonemap_reinhard', 'weave_height', 'write_image']
class Photometry:
    """
    A photometric function: BRDF = albedo/pi * shape(mu_i, mu_o, g) (moonbot/photometry.h). model 'lambert' | 'lunar-lambert' (McEwen) | 'hapke' (Hapke 2012 with porosity, SHOE, CBOE, roughness; shape normalised to 1 at i = e = g = 0). The Hapke fields are read only by 'hapke' but checked whatever the model; their defaults are the Sato et al. 2014 lunar set. Ranges: `ranges`.
    """
    fields: typing.ClassVar[tuple] = ('model', 'phase', 'surge_amplitude', 'surge_width', 'w', 'b', 'c', 'roughness_deg', 'filling_factor', 'cboe_amplitude', 'cboe_width')
    ranges: typing.ClassVar[dict] = {'surge_amplitude': (0.0, 10.0, False, False), 'surge_width': (0.0, 10.0, True, False), 'w': (0.0, 1.0, False, False), 'b': (0.0, 1.0, False, True), 'c': (-1.0, 1.0, False, False), 'roughness_deg': (0.0, 60.0, False, False), 'filling_factor': (0.0, 0.75, False, False), 'cboe_amplitude': (0.0, 1.0, False, False), 'cboe_width': (0.0, 10.0, True, False)}
    @typing.overload
    def __init__(self) -> None:
        """
        The C++ defaults.
        """
    @typing.overload
    def __init__(self, **kwargs) -> None:
        """
        The C++ defaults with the fields given set (by name), validated.
        """
    def __repr__(self) -> str:
        ...
    def hapke_reflectance(self, mu_i: typing.SupportsFloat | typing.SupportsIndex, mu_o: typing.SupportsFloat | typing.SupportsIndex, cos_g: typing.SupportsFloat | typing.SupportsIndex) -> float:
        """
        Hapke's bidirectional reflectance r(i, e, g) = mu_i * BRDF, per steradian, un-normalised (radiance / collimated irradiance).
        """
    def shape(self, mu_i: typing.SupportsFloat | typing.SupportsIndex, mu_o: typing.SupportsFloat | typing.SupportsIndex, cos_g: typing.SupportsFloat | typing.SupportsIndex) -> float:
        """
        BRDF / (albedo/pi) for cosines of incidence and emission (both > 0, else 0) and cos phase.
        """
    def validate(self) -> None:
        """
        Raises ValueError naming the first field out of its range.
        """
    @property
    def b(self) -> float:
        """
        hapke: double Henyey-Greenstein lobe width
        """
    @b.setter
    def b(self, arg1: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def c(self) -> float:
        """
        hapke: double Henyey-Greenstein weight (c > 0: back-scattering)
        """
    @c.setter
    def c(self, arg1: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def cboe_amplitude(self) -> float:
        """
        hapke: coherent-backscatter amplitude B_C0
        """
    @cboe_amplitude.setter
    def cboe_amplitude(self, arg1: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def cboe_width(self) -> float:
        """
        hapke: coherent-backscatter width h_C
        """
    @cboe_width.setter
    def cboe_width(self, arg1: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def filling_factor(self) -> float:
        """
        hapke: volume fraction of grains phi (porosity factor K; 0: K = 1)
        """
    @filling_factor.setter
    def filling_factor(self, arg1: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def hapke_normal_albedo(self) -> float | None:
        """
        Hapke's normal albedo A_N = pi * r(0, 0, 0) for these parameters (the shape's normaliser); None for other models.
        """
    @property
    def model(self) -> str:
        """
        'lambert' | 'lunar-lambert' | 'hapke'
        """
    @model.setter
    def model(self, arg1: str) -> None:
        ...
    @property
    def phase(self) -> str:
        """
        lunar-lambert phase weight L(g): 'exponential' (exp(-g/60 deg)) | 'mcewen' (cubic, clamped)
        """
    @phase.setter
    def phase(self, arg1: str) -> None:
        ...
    @property
    def porosity_factor(self) -> float | None:
        """
        Hapke's porosity factor K(filling_factor); None for other models.
        """
    @property
    def roughness_deg(self) -> float:
        """
        hapke: mean facet slope theta-bar of Hapke 1984, degrees
        """
    @roughness_deg.setter
    def roughness_deg(self, arg1: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def surge_amplitude(self) -> float:
        """
        opposition surge 1 + B0/(1 + tan(g/2)/h): B0 (0 = off; Hapke's B_S0)
        """
    @surge_amplitude.setter
    def surge_amplitude(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def surge_width(self) -> float:
        """
        the surge's width h (Hapke's h_S)
        """
    @surge_width.setter
    def surge_width(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def w(self) -> float:
        """
        hapke: single-scattering albedo of a grain
        """
    @w.setter
    def w(self, arg1: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
class FabricParams:
    """
    The procedural weave of a bag's cloth (moonbot/fabric.h).
    """
    fields: typing.ClassVar[tuple] = ('pitch_m', 'relief_m', 'contrast', 'albedo', 'sheen', 'sheen_along', 'sheen_across')
    @typing.overload
    def __init__(self) -> None:
        """
        The C++ defaults.
        """
    @typing.overload
    def __init__(self, **kwargs) -> None:
        """
        The C++ defaults with the fields given set (by name), validated.
        """
    def __repr__(self) -> str:
        ...
    def validate(self) -> None:
        """
        Raises ValueError naming the first field out of its range.
        """
    @property
    def albedo(self) -> tuple[float, float, float]:
        """
        the tapes' albedo (3,), linear RGB, each in [0, 1]
        """
    @albedo.setter
    def albedo(self, arg1: typing.Any) -> None:
        ...
    @property
    def contrast(self) -> float:
        """
        albedo contrast between warp and weft, [0, 1]
        """
    @contrast.setter
    def contrast(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def pitch_m(self) -> float:
        """
        weave pitch, metres, > 0
        """
    @pitch_m.setter
    def pitch_m(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def relief_m(self) -> float:
        """
        weave relief, metres, >= 0
        """
    @relief_m.setter
    def relief_m(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def sheen(self) -> float:
        """
        weight of the tapes' glossy lobe, [0, 1] (0: matte)
        """
    @sheen.setter
    def sheen(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def sheen_across(self) -> float:
        """
        GGX roughness across a tape, [0.01, 1]
        """
    @sheen_across.setter
    def sheen_across(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def sheen_along(self) -> float:
        """
        GGX roughness along a tape, [0.01, 1]
        """
    @sheen_along.setter
    def sheen_along(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
class StainParams:
    """
    The dirt on a bag (moonbot/stain.h; Dust mode: its deposits).
    """
    fields: typing.ClassVar[tuple] = ('stamps', 'brush_size', 'opacity', 'resolution')
    @typing.overload
    def __init__(self) -> None:
        """
        The C++ defaults.
        """
    @typing.overload
    def __init__(self, **kwargs) -> None:
        """
        The C++ defaults with the fields given set (by name), validated.
        """
    def __repr__(self) -> str:
        ...
    def validate(self) -> None:
        """
        Raises ValueError naming the first field out of its range.
        """
    @property
    def brush_size(self) -> float:
        """
        stamp size, a fraction of the texture
        """
    @brush_size.setter
    def brush_size(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def opacity(self) -> float:
        """
        one stamp's coverage at its centre, [0, 1]
        """
    @opacity.setter
    def opacity(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def resolution(self) -> int:
        """
        stain mask texels a side, [1, 8192]
        """
    @resolution.setter
    def resolution(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def stamps(self) -> int:
        """
        stamps (Dust mode: deposits), >= 0; 0 = clean, nothing made
        """
    @stamps.setter
    def stamps(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
class SoilingParams:
    """
    The shape of Dust mode's regolith dust (moonbot/soiling.h); its deposits and opacity are StainParams' stamps and opacity.
    """
    fields: typing.ClassVar[tuple] = ('contact_height_m', 'deposit_radius_m', 'handled_share', 'speckle')
    @typing.overload
    def __init__(self) -> None:
        """
        The C++ defaults.
        """
    @typing.overload
    def __init__(self, **kwargs) -> None:
        """
        The C++ defaults with the fields given set (by name), validated.
        """
    def __repr__(self) -> str:
        ...
    def validate(self) -> None:
        """
        Raises ValueError naming the first field out of its range.
        """
    @property
    def contact_height_m(self) -> float:
        """
        the contact band's e-folding height, metres, (0, 1]
        """
    @contact_height_m.setter
    def contact_height_m(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def deposit_radius_m(self) -> float:
        """
        mean deposit radius, metres, (0, 1]
        """
    @deposit_radius_m.setter
    def deposit_radius_m(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def handled_share(self) -> float:
        """
        share of deposits near the top, [0, 1]
        """
    @handled_share.setter
    def handled_share(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def speckle(self) -> float:
        """
        grain strength, [0, 2]
        """
    @speckle.setter
    def speckle(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
class WovenSurface:
    """
    A bag's cloth: the procedural weave (fabric; sheen > 0 adds the tapes' glossy lobe) on the mesh's corner UVs and its dirt, made per instance from stain_seed: stain_mode 'stamp' paints the paper's stain (stain.h), 'dust' gathers regolith dust (soiling.h); 0 stamps = clean, nothing made.
    """
    fields: typing.ClassVar[tuple] = ('fabric', 'metres_per_uv', 'stain', 'stain_seed', 'dirt_colour', 'stain_mode', 'soiling')
    @typing.overload
    def __init__(self) -> None:
        """
        The C++ defaults.
        """
    @typing.overload
    def __init__(self, **kwargs) -> None:
        """
        The C++ defaults with the fields given set (by name), validated.
        """
    def __repr__(self) -> str:
        ...
    def validate(self) -> None:
        """
        Raises ValueError naming the first field out of its range.
        """
    @property
    def dirt_colour(self) -> tuple[float, float, float]:
        """
        the dirt's colour (3,), linear RGB, each in [0, 1]
        """
    @dirt_colour.setter
    def dirt_colour(self, arg1: typing.Any) -> None:
        ...
    @property
    def fabric(self) -> FabricParams:
        """
        the weave (FabricParams)
        """
    @fabric.setter
    def fabric(self, arg0: FabricParams) -> None:
        ...
    @property
    def metres_per_uv(self) -> float:
        """
        fabric metres per atlas UV unit, > 0
        """
    @metres_per_uv.setter
    def metres_per_uv(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def soiling(self) -> SoilingParams:
        """
        Dust mode's shape (SoilingParams)
        """
    @soiling.setter
    def soiling(self, arg0: SoilingParams) -> None:
        ...
    @property
    def stain(self) -> StainParams:
        """
        the dirt's stamps (StainParams)
        """
    @stain.setter
    def stain(self, arg0: StainParams) -> None:
        ...
    @property
    def stain_mode(self) -> str:
        """
        'stamp' | 'dust'
        """
    @stain_mode.setter
    def stain_mode(self, arg1: str) -> None:
        ...
    @property
    def stain_seed(self) -> int:
        """
        keys this instance's dirt
        """
    @stain_seed.setter
    def stain_seed(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
class GrainParams:
    """
    Regolith's granular micro-texture (moonbot/regolith_texture.h).
    """
    fields: typing.ClassVar[tuple] = ('albedo_rms', 'slope_rms_deg', 'finest_cell_m', 'coarsest_cell_m', 'hurst', 'seed')
    @typing.overload
    def __init__(self) -> None:
        """
        The C++ defaults.
        """
    @typing.overload
    def __init__(self, **kwargs) -> None:
        """
        The C++ defaults with the fields given set (by name), validated.
        """
    def __repr__(self) -> str:
        ...
    def validate(self) -> None:
        """
        Raises ValueError naming the first field out of its range.
        """
    @property
    def albedo_rms(self) -> float:
        """
        relative RMS of the unfiltered albedo factor, [0, 0.5]
        """
    @albedo_rms.setter
    def albedo_rms(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def coarsest_cell_m(self) -> float:
        """
        largest lattice cell, metres, >= finest, <= 1
        """
    @coarsest_cell_m.setter
    def coarsest_cell_m(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def finest_cell_m(self) -> float:
        """
        smallest lattice cell, metres, > 0
        """
    @finest_cell_m.setter
    def finest_cell_m(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def hurst(self) -> float:
        """
        relief amplitude grows as cell^hurst, [0, 1]
        """
    @hurst.setter
    def hurst(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def seed(self) -> int:
        """
        keys the lattices
        """
    @seed.setter
    def seed(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def slope_rms_deg(self) -> float:
        """
        1-D RMS slope of the unfiltered relief, degrees, [0, 45]
        """
    @slope_rms_deg.setter
    def slope_rms_deg(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
class SubgridRelief:
    """
    The roughness octaves a graded terrain mesh did not hold, given back to the shading (subgrid_relief.h; moonbot/terrain/location.py's subgrid_relief builds it).
    """
    def __init__(self, wavelengths: typing.Any, amplitudes: typing.Any, angles: typing.Any, offsets: typing.Any, keys: typing.Any, axis: typing.Any, spacing: typing.Any) -> None:
        """
        Octaves: wavelengths and amplitudes (K,) metres, angles (K,) radians, lattice offsets (K, 2), lattice keys (K,) uint64; the mesh's graded axis (n,) and each node's cell (n,), metres. ValueError naming the argument on bad input.
        """
    def cell(self, points: typing.Any) -> numpy.typing.NDArray[numpy.float64]:
        """
        The mesh's cell (N,) metres at world points (N, 2) (x, y) metres.
        """
    def eval(self, points: typing.Any, footprint_m: typing.SupportsFloat | typing.SupportsIndex) -> tuple[numpy.typing.NDArray[numpy.float64], numpy.typing.NDArray[numpy.float64]]:
        """
        (mean gradient over the pixel's box (N, 3), slope spread about it (N,) tan²) of the dropped relief at world points (N, 3) metres, for a pixel of footprint footprint_m metres.
        """
    def height(self, points: typing.Any, cell: typing.Any) -> numpy.typing.NDArray[numpy.float64]:
        """
        Unfiltered height (N,) metres of the relief a mesh of cell (N,) metres drops, at world points (N, 2).
        """
    @property
    def octaves(self) -> int:
        """
        octaves with a non-zero amplitude
        """
class SubgridCraters:
    """
    The small craters a graded terrain mesh did not draw, given back to the shading as their slopes and their walls' shadows (subgrid_craters.h; moonbot/terrain/location.py's subgrid_craters builds it).
    """
    def __init__(self, centres: typing.Any, diameters: typing.Any, degradation: typing.Any, table_degradation: typing.Any, radius_step: typing.SupportsFloat | typing.SupportsIndex, table: typing.Any, table_reach: typing.Any) -> None:
        """
        Craters: centres (K, 2) world metres, diameters (K,) metres, degradation (K,) σ/R; craters.py's profile table: its diffusion lengths (R,) from 0, its radius step (crater radii), its heights over diameter (R, C) and each row's reach (R,) crater radii. ValueError naming the argument on bad input.
        """
    def __len__(self) -> int:
        ...
    def gradient(self, points: typing.Any, footprint_m: typing.SupportsFloat | typing.SupportsIndex = 0.0) -> numpy.typing.NDArray[numpy.float64]:
        """
        (∂z/∂x, ∂z/∂y) (N, 2) of the summed profiles at world points (N, 2) metres, craters narrower than two footprints of footprint_m metres left out (0: all).
        """
    def height(self, points: typing.Any) -> numpy.typing.NDArray[numpy.float64]:
        """
        Summed height (N,) metres of the craters' profiles at world points (N, 2) metres.
        """
    def shadowed(self, points: typing.Any, to_light: typing.Any, normal: typing.Any) -> numpy.typing.NDArray[numpy.bool]:
        """
        Whether a crater's wall hides light from to_light (3,) at terrain points (N, 3) world metres on ground of normal (3,): (N,) bool.
        """
class RegolithGrain:
    """
    Regolith's granular micro-texture (regolith_texture.h): octaves of value noise of cells finest_cell_m·2^k up to coarsest_cell_m (metres), an albedo factor of relative RMS albedo_rms and relief of 1-D RMS slope slope_rms_deg (degrees), prefiltered over each pixel's footprint; on the terrain also the roughness its mesh did not hold (a SubgridRelief).
    """
    def __init__(self, params: GrainParams, subgrid: SubgridRelief = None) -> None:
        """
        Its octaves laid out (none where params are not enabled); ValueError naming the field on bad params. subgrid: read with the grain, its gradient and slope spread added.
        """
    def eval(self, points: typing.Any, footprint_m: typing.SupportsFloat | typing.SupportsIndex) -> tuple[numpy.typing.NDArray[numpy.float64], numpy.typing.NDArray[numpy.float64]]:
        """
        (albedo factor (N,) float64, relief gradient (N, 3) float64) at world points (N, 3) metres, as a pixel of footprint footprint_m metres sees them there: the albedo prefiltered over it, the relief's mean gradient over the pixel's box (regolith_texture.h).
        """
    @property
    def flat_footprint_m(self) -> float:
        """
        footprints (metres) at or above this give exactly the mean
        """
    @property
    def octaves(self) -> int:
        """
        octaves of value noise, finest to coarsest cell
        """
class Scene:
    """
    Triangle-mesh prototypes and their instances; metres, world ENU.
    """
    def __init__(self, embree_isa: str = 'auto', watertight: bool = True) -> None:
        """
        An empty scene whose rays Embree traces in `embree_isa` (auto, sse2, sse4.2, avx, avx2, avx512; see resolve_embree_isa). watertight=False (Embree's default BVHs, no second look at shared vertices) exists only to measure what watertightness costs and buys.
        """
    def add_background(self, mesh: typing.SupportsInt | typing.SupportsIndex, world_from_object: typing.Any, albedo: typing.Any, photometry: Photometry = ..., grain: RegolithGrain = None, moving: bool = False, craters: SubgridCraters = None) -> int:
        """
        Add unlabelled geometry (terrain, rocks): label 0 in masks. grain: a RegolithGrain textures its camera hits (None: no texture). moving: it moves between views (the dust's ejecta), so a LightCache neither caches it nor lets it shade what it caches. craters: the SubgridCraters its mesh did not draw (needs a grain; world coordinates, so only for geometry placed at the identity). Returns the instance index.
        """
    def add_instance(self, mesh: typing.SupportsInt | typing.SupportsIndex, world_from_object: typing.Any, instance_id: typing.SupportsInt | typing.SupportsIndex, albedo: typing.Any, photometry: Photometry = ..., woven: WovenSurface | None = None) -> int:
        """
        Add a labelled object: world_from_object (4, 4) affine, metres; instance_id 1..255 (unique); albedo (3,) linear RGB in [0, 1] (a woven surface's mean colour); woven: a WovenSurface (the mesh needs corner_uvs). Returns the instance index.
        """
    def add_mesh(self, vertices: typing.Any, triangles: typing.Any, corner_uvs: typing.Any = None, vertex_albedo: typing.Any = None, vertex_normals: typing.Any = None) -> int:
        """
        Add a prototype mesh: vertices (N, 3) float, metres; triangles (M, 3) int; optional corner_uvs (M, 6) float: (u, v) of each triangle's three corners, for woven materials; optional vertex_albedo (N,) or (N, 3) float >= 0: a factor on the albedo per vertex, or per vertex and RGB channel; optional vertex_normals (N, 3) float: smooth shading normals (object frame). Builds its BVH. Returns the mesh index.
        """
    def commit(self) -> None:
        """
        Build the top-level BVH; required before rendering.
        """
    def intersect(self, origins: typing.Any, directions: typing.Any) -> tuple[numpy.typing.NDArray[numpy.float64], numpy.typing.NDArray[numpy.int64], numpy.typing.NDArray[numpy.int64]]:
        """
        Closest hits of rays (origins and directions (N, 3), metres, world; narrowed to float32 as Embree traces them), watertight as the renderer's camera rays are: (t (N,) float64 in units of |direction|, inf on a miss; instance (N,) int64, -1 on a miss; primitive (N,) int64, the triangle's index in its mesh, -1 on a miss). For checking the traversal itself; renders resolve hits in double on top of this.
        """
    def update_mesh(self, mesh: typing.SupportsInt | typing.SupportsIndex, vertices: typing.Any) -> None:
        """
        Move mesh `mesh`'s vertices to `vertices` (N, 3) float, metres, the same N (triangles stay) and rebuild that mesh's BVH alone; commit() before the next render. For geometry that moves between views (the dust's ejecta); not for meshes with vertex normals.
        """
    @property
    def bvh_builds(self) -> int:
        """
        BVH builds so far: one per mesh plus one per commit.
        """
    @property
    def committed(self) -> bool:
        """
        commit() has run since the last change
        """
    @property
    def embree_isa(self) -> str:
        """
        The ISA Embree traces this scene's rays in (never 'auto').
        """
    @property
    def instance_count(self) -> int:
        """
        instances added, labelled and background
        """
    @property
    def mesh_count(self) -> int:
        """
        prototype meshes added
        """
class Camera:
    """
    Pinhole camera, OpenCV axes (x right, y down, z forward).
    """
    def __init__(self, fx: typing.SupportsFloat | typing.SupportsIndex, fy: typing.SupportsFloat | typing.SupportsIndex, cx: typing.SupportsFloat | typing.SupportsIndex, cy: typing.SupportsFloat | typing.SupportsIndex, width: typing.SupportsInt | typing.SupportsIndex, height: typing.SupportsInt | typing.SupportsIndex, R: typing.Any, t: typing.Any) -> None:
        """
        Intrinsics in pixels; R (3, 3) and t (3,) metres map world to camera: x_cam = R x_world + t.
        """
    def project(self, points: typing.Any) -> numpy.typing.NDArray[numpy.float64]:
        """
        Project world points (N, 3) metres to (u, v, z): pixel coordinates with pixel centres at +0.5, and z-depth in metres.
        """
    @property
    def center(self) -> numpy.typing.NDArray[numpy.float64]:
        """
        Camera centre in the world frame (3,), metres.
        """
    @property
    def height(self) -> int:
        """
        pixels
        """
    @property
    def width(self) -> int:
        """
        pixels
        """
class DirectionalLight:
    """
    A distant disk light, the Sun or the Earth (Earthshine): azimuth clockwise from North (0 = +y, 90 = +x) and elevation above the horizon, degrees; irradiance, W/m^2 on a surface facing it (default: the Sun's at 1 au); angular diameter of its disk, degrees (0 = a point); linear RGB tint of the irradiance.
    """
    def __init__(self, azimuth_deg: typing.SupportsFloat | typing.SupportsIndex, elevation_deg: typing.SupportsFloat | typing.SupportsIndex, irradiance: typing.SupportsFloat | typing.SupportsIndex = 1361.0, angular_diameter_deg: typing.SupportsFloat | typing.SupportsIndex = 0.0, color: typing.Any = (1.0, 1.0, 1.0)) -> None:
        """
        ValueError naming the field: elevation in [-90, 90], irradiance in [0, 1e7], angular diameter in [0, 10], each color channel in [0, 10].
        """
    @property
    def angular_diameter_deg(self) -> float:
        ...
    @property
    def azimuth_deg(self) -> float:
        """
        clockwise from North, degrees
        """
    @property
    def color(self) -> tuple[float, float, float]:
        """
        linear RGB tint
        """
    @property
    def direction(self) -> numpy.typing.NDArray[numpy.float64]:
        """
        Unit vector toward the light, world ENU, (3,) float64.
        """
    @property
    def elevation_deg(self) -> float:
        """
        above the horizon, degrees
        """
    @property
    def irradiance(self) -> float:
        """
        W/m^2
        """
class EjectaParams:
    """
    Emitter 1, granular ejecta (moonbot/dust.h): world metres, seconds, degrees.
    """
    fields: typing.ClassVar[tuple] = ('origin', 'spawn_radius_m', 'count', 'cone_half_angle_deg', 'mean_speed_m_s', 'min_diameter_m', 'max_diameter_m', 'gravity_m_s2', 'restitution', 'friction', 'rest_speed_m_s', 'burst_period_s')
    @typing.overload
    def __init__(self) -> None:
        """
        The C++ defaults.
        """
    @typing.overload
    def __init__(self, **kwargs) -> None:
        """
        The C++ defaults with the fields given set (by name), validated.
        """
    def __repr__(self) -> str:
        ...
    def validate(self) -> None:
        """
        Raises ValueError naming the first field out of its range.
        """
    @property
    def burst_period_s(self) -> float:
        """
        every fragment is re-launched every period, seconds, (0, 3600]
        """
    @burst_period_s.setter
    def burst_period_s(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def cone_half_angle_deg(self) -> float:
        """
        launch directions: uniform over this cone about +z, degrees, [0, 90]
        """
    @cone_half_angle_deg.setter
    def cone_half_angle_deg(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def count(self) -> int:
        """
        fragments per burst, 0..1000000
        """
    @count.setter
    def count(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def friction(self) -> float:
        """
        Coulomb: tangential speed lost <= friction x normal impulse, [0, 10]
        """
    @friction.setter
    def friction(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def gravity_m_s2(self) -> float:
        """
        m/s^2, [0, 100]
        """
    @gravity_m_s2.setter
    def gravity_m_s2(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def max_diameter_m(self) -> float:
        """
        metres, >= min_diameter_m, <= 1
        """
    @max_diameter_m.setter
    def max_diameter_m(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def mean_speed_m_s(self) -> float:
        """
        launch speeds uniform in [0.5, 1.5] x this, m/s, [0, 100]
        """
    @mean_speed_m_s.setter
    def mean_speed_m_s(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def min_diameter_m(self) -> float:
        """
        fragment diameters uniform in [min, max], metres, > 0
        """
    @min_diameter_m.setter
    def min_diameter_m(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def origin(self) -> tuple[float, float, float]:
        """
        centre of the spawn disc (3,), world metres, on the ground
        """
    @origin.setter
    def origin(self, arg1: typing.Any) -> None:
        ...
    @property
    def rest_speed_m_s(self) -> float:
        """
        a bounce leaving less than this puts the fragment at rest, m/s, (0, 10]
        """
    @rest_speed_m_s.setter
    def rest_speed_m_s(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def restitution(self) -> float:
        """
        normal speed kept by a bounce, [0, 0.95]
        """
    @restitution.setter
    def restitution(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def spawn_radius_m(self) -> float:
        """
        fragments leave from a horizontal disc of this radius, metres, [0, 100]
        """
    @spawn_radius_m.setter
    def spawn_radius_m(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
class CloudParams:
    """
    Emitter 2, the fine-dust cloud (moonbot/dust.h): world metres, seconds, degrees.
    """
    fields: typing.ClassVar[tuple] = ('origin', 'box_m', 'vertical_offset_m', 'axis', 'cone_half_angle_deg', 'speed_m_s', 'gravity_m_s2', 'lifetime_s', 'rate_per_s', 'sigma_m', 'growth_m_s', 'optical_depth', 'rise_fraction')
    @typing.overload
    def __init__(self) -> None:
        """
        The C++ defaults.
        """
    @typing.overload
    def __init__(self, **kwargs) -> None:
        """
        The C++ defaults with the fields given set (by name), validated.
        """
    def __repr__(self) -> str:
        ...
    def validate(self) -> None:
        """
        Raises ValueError naming the first field out of its range.
        """
    @property
    def axis(self) -> tuple[float, float, float]:
        """
        cone axis (3,), world, any length but 0
        """
    @axis.setter
    def axis(self, arg1: typing.Any) -> None:
        ...
    @property
    def box_m(self) -> tuple[float, float, float]:
        """
        spawn box east x north x up (3,), metres, each in [0, 1000]
        """
    @box_m.setter
    def box_m(self, arg1: typing.Any) -> None:
        ...
    @property
    def cone_half_angle_deg(self) -> float:
        """
        degrees, [0, 180]
        """
    @cone_half_angle_deg.setter
    def cone_half_angle_deg(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def gravity_m_s2(self) -> float:
        """
        m/s^2, [0, 100]
        """
    @gravity_m_s2.setter
    def gravity_m_s2(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def growth_m_s(self) -> float:
        """
        growth of that deviation with age, m/s, [0, 100]
        """
    @growth_m_s.setter
    def growth_m_s(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def lifetime_s(self) -> float:
        """
        a puff's life, seconds, (0, 3600]
        """
    @lifetime_s.setter
    def lifetime_s(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def optical_depth(self) -> float:
        """
        through a puff's centre at its most opaque, [0, 100]
        """
    @optical_depth.setter
    def optical_depth(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def origin(self) -> tuple[float, float, float]:
        """
        the emitter on the ground (3,), world metres
        """
    @origin.setter
    def origin(self, arg1: typing.Any) -> None:
        ...
    @property
    def rate_per_s(self) -> float:
        """
        puffs born a second, >= 0, rate x lifetime <= 100000
        """
    @rate_per_s.setter
    def rate_per_s(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def rise_fraction(self) -> float:
        """
        opacity rises linearly over this fraction of life, (0, 1)
        """
    @rise_fraction.setter
    def rise_fraction(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def sigma_m(self) -> float:
        """
        a puff's standard deviation at birth, metres, (0, 100]
        """
    @sigma_m.setter
    def sigma_m(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def speed_m_s(self) -> float:
        """
        launch speed of a puff, m/s, [0, 100]
        """
    @speed_m_s.setter
    def speed_m_s(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def vertical_offset_m(self) -> float:
        """
        the box's centre this far above origin, metres, [-1000, 1000]
        """
    @vertical_offset_m.setter
    def vertical_offset_m(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
class Medium:
    """
    Dust as a participating medium (moonbot/medium.h): Gaussian puffs, their single-scattering albedo and Henyey-Greenstein asymmetry, and how finely a render traces them.
    """
    fields: typing.ClassVar[tuple] = ('puffs', 'albedo', 'asymmetry', 'voxel_m', 'floor_z', 'march_stride_px')
    @typing.overload
    def __init__(self) -> None:
        """
        The C++ defaults.
        """
    @typing.overload
    def __init__(self, **kwargs) -> None:
        """
        The C++ defaults with the fields given set (by name), validated.
        """
    @typing.overload
    def __init__(self, puffs: typing.Any, **kwargs) -> None:
        """
        Medium(puffs=puffs, **fields).
        """
    def __repr__(self) -> str:
        ...
    def validate(self) -> None:
        """
        Raises ValueError naming the first field out of its range.
        """
    @property
    def albedo(self) -> tuple[float, float, float]:
        """
        single-scattering albedo (3,), linear RGB, each in [0, 1]
        """
    @albedo.setter
    def albedo(self, arg1: typing.Any) -> None:
        ...
    @property
    def asymmetry(self) -> float:
        """
        Henyey-Greenstein g, (-1, 1)
        """
    @asymmetry.setter
    def asymmetry(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def floor_z(self) -> float:
        """
        no dust is seen or lit below this height (the ground), metres
        """
    @floor_z.setter
    def floor_z(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def march_stride_px(self) -> int:
        """
        1, 2, 4 or 8: the pixels between the camera rays that march the dust (the others interpolate)
        """
    @march_stride_px.setter
    def march_stride_px(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def puff_count(self) -> int:
        """
        puffs in the medium
        """
    @property
    def puffs(self) -> numpy.typing.NDArray[numpy.float64]:
        """
        (N, 5) float64: centre x, y, z (world metres), sigma (metres, > 0), peak extinction (1/m, >= 0)
        """
    @puffs.setter
    def puffs(self, arg1: typing.Any) -> None:
        ...
    @property
    def voxel_m(self) -> float:
        """
        spacing of the grid the dust is baked on per render and its march step, metres, [0.001, 100]
        """
    @voxel_m.setter
    def voxel_m(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
class LightCacheSettings:
    """
    How a LightCache gathers (moonbot/light_cache.h).
    """
    fields: typing.ClassVar[tuple] = ('bounces', 'rays_objects', 'rays_background', 'background_cell_m', 'object_cell_m', 'background_filter_cells', 'gather_error', 'max_rays_factor', 'seed', 'threads')
    @typing.overload
    def __init__(self) -> None:
        """
        The C++ defaults.
        """
    @typing.overload
    def __init__(self, **kwargs) -> None:
        """
        The C++ defaults with the fields given set (by name), validated.
        """
    def __repr__(self) -> str:
        ...
    def validate(self) -> None:
        """
        Raises ValueError naming the first field out of its range.
        """
    @property
    def background_cell_m(self) -> float:
        """
        the background's world-space lattice spacing, metres (0 = per vertex)
        """
    @background_cell_m.setter
    def background_cell_m(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def background_filter_cells(self) -> float:
        """
        radius, in lattice cells, of the tent filter a background vertex reads the lattice through, 1..4 (1 = bilinear; the bags' lattice is always read bilinearly)
        """
    @background_filter_cells.setter
    def background_filter_cells(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def bounces(self) -> int:
        """
        path vertices after each gather point (as RenderSettings.bounces), 1..16
        """
    @bounces.setter
    def bounces(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def gather_error(self) -> float:
        """
        adaptive gathering: more rays while a vertex's relative standard error is above this, 0..1 (0 = a fixed count)
        """
    @gather_error.setter
    def gather_error(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def max_rays_factor(self) -> int:
        """
        the most rays adaptive gathering reaches, as a multiple of rays_objects / rays_background, 1..1024
        """
    @max_rays_factor.setter
    def max_rays_factor(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def object_cell_m(self) -> float:
        """
        the same for labelled instances, metres (0 = per vertex)
        """
    @object_cell_m.setter
    def object_cell_m(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def rays_background(self) -> int:
        """
        gather rays per vertex (or lattice node) on background instances (terrain, rocks), 1..65536
        """
    @rays_background.setter
    def rays_background(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def rays_objects(self) -> int:
        """
        gather rays per vertex (or lattice node) on labelled instances (bags), 1..65536
        """
    @rays_objects.setter
    def rays_objects(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def seed(self) -> int:
        """
        keys the gather rays
        """
    @seed.setter
    def seed(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def threads(self) -> int:
        """
        worker threads of fill_all, 0 = all
        """
    @threads.setter
    def threads(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
class LightCache:
    """
    A world-space cache of indirect light over a committed scene's non-moving instances (cpp/include/moonbot/light_cache.h): filled per vertex on first touch by render(), shared by every view of the scene.
    """
    def __init__(self, scene: Scene, sun: DirectionalLight, earth: DirectionalLight | None = None, settings: LightCacheSettings = ...) -> None:
        """
        A cache over `scene` for these lights, gathering as `settings` (a LightCacheSettings) says.
        """
    def at(self, instance: typing.SupportsInt | typing.SupportsIndex, prim: typing.SupportsInt | typing.SupportsIndex, u: typing.SupportsFloat | typing.SupportsIndex, v: typing.SupportsFloat | typing.SupportsIndex, normal: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"] | None = None) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """
        As vertex(), at barycentrics (u, v) of triangle `prim` (the vertices' values interpolated); with `normal` (unit, world), each vertex's value tilted from its vertex normal to it first.
        """
    def covers(self, instance: typing.SupportsInt | typing.SupportsIndex) -> bool:
        """
        Whether instance `instance` is cached (it was not moving when the cache was built).
        """
    def fill_all(self) -> None:
        """
        Fill every vertex of the covered instances (rendering fills only what it touches).
        """
    def stats(self) -> dict:
        """
        Cumulative: vertices filled, blocks allocated, background lattice nodes and their probe_rays, gather_rays and shadow_rays they traced (each vertex counted once: deterministic), bytes held, redundant_fills (vertices a racing thread computed again) and fill_seconds (thread-seconds; these two depend on the threads).
        """
    def tilt_gradient(self, instance: typing.SupportsInt | typing.SupportsIndex, vertex: typing.SupportsInt | typing.SupportsIndex) -> tuple[float, float, float]:
        """
        (x, y, z) W/m², world: the rotation gradient of a vertex's irradiance luminance; a normal n near the vertex's n0 gets about Y0 + (n - n0)·gradient (light_cache.h IndirectLight::tilt_gradient).
        """
    def vertex(self, instance: typing.SupportsInt | typing.SupportsIndex, vertex: typing.SupportsInt | typing.SupportsIndex) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """
        ((E_r, E_g, E_b) W/m², (x, y, z) luminance-weighted mean of the unit incident directions, world: length 1 for light from one direction, less the more it spreads) at a vertex of a covered instance, filled first if it is not yet.
        """
class RenderSettings:
    """
    A render's quality and threads (moonbot/render.h).
    """
    fields: typing.ClassVar[tuple] = ('spp', 'seed', 'threads', 'exact_depth', 'light_samples', 'penumbra_light_samples', 'adaptive_full_spread', 'adaptive_contrast', 'adaptive_error_target', 'bounces', 'adaptive_spp', 'adaptive_threshold', 'texture_filter_px')
    @typing.overload
    def __init__(self) -> None:
        """
        The C++ defaults.
        """
    @typing.overload
    def __init__(self, **kwargs) -> None:
        """
        The C++ defaults with the fields given set (by name), validated.
        """
    def __repr__(self) -> str:
        ...
    def validate(self) -> None:
        """
        Raises ValueError naming the first field out of its range.
        """
    @property
    def adaptive_contrast(self) -> float:
        """
        0 = off; c > 0: a pixel whose 3x3 neighbourhood's base samples together spread beyond c times sqrt(their mean x the frame's) is refined, its share following that spread
        """
    @adaptive_contrast.setter
    def adaptive_contrast(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def adaptive_error_target(self) -> float:
        """
        0 = off; e in (0, 1]: the share's f is chosen per view, the largest adaptive_full_spread x 2^(j/8) whose refined pixels' predicted error, relative to the image's mean luminance (through the dust, its glow included), is at most e
        """
    @adaptive_error_target.setter
    def adaptive_error_target(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def adaptive_full_spread(self) -> float:
        """
        0: every refined pixel gets adaptive_spp; f > 0: its samples past spp in proportion to its spread over f times the frame's mean, moved to the nearest power of two
        """
    @adaptive_full_spread.setter
    def adaptive_full_spread(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def adaptive_spp(self) -> int:
        """
        0 = off, else the samples (direct light only past spp) a pixel whose samples disagree is brought up to, spp < adaptive_spp <= 65536
        """
    @adaptive_spp.setter
    def adaptive_spp(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def adaptive_threshold(self) -> float:
        """
        relative spread of direct luminance over a pixel's base samples that refines it, >= 0
        """
    @adaptive_threshold.setter
    def adaptive_threshold(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def bounces(self) -> int:
        """
        diffuse inter-reflections, 0 (direct light only)..16
        """
    @bounces.setter
    def bounces(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def exact_depth(self) -> bool:
        """
        re-solve hit distances in double (exact at kilometre coordinates); False keeps Embree's float32 t
        """
    @exact_depth.setter
    def exact_depth(self, arg0: bool) -> None:
        ...
    @property
    def light_samples(self) -> int:
        """
        shadow rays per sample toward the Sun's disk, 1..1024
        """
    @light_samples.setter
    def light_samples(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def penumbra_light_samples(self) -> int:
        """
        shadow rays toward the Sun's disk per refinement sample in a penumbra, 1..1024
        """
    @penumbra_light_samples.setter
    def penumbra_light_samples(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def seed(self) -> int:
        """
        keys the counter-based generator (with pixel and sample)
        """
    @seed.setter
    def seed(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def spp(self) -> int:
        """
        RGB samples per pixel, 1..65536; 1 = the pixel-centre ray, no jitter
        """
    @spp.setter
    def spp(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def texture_filter_px(self) -> float:
        """
        width in pixels of the box each sample's textures are prefiltered over, 0.25..8 (1 = its pixel)
        """
    @texture_filter_px.setter
    def texture_filter_px(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def threads(self) -> int:
        """
        worker threads, 0 = all hardware threads, at most 1024
        """
    @threads.setter
    def threads(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
class LunarFrame:
    """
    Local East-North-Up frame on the lunar sphere (GeographicLib), metres.
    """
    def __init__(self, lat0_deg: typing.SupportsFloat | typing.SupportsIndex, lon0_deg: typing.SupportsFloat | typing.SupportsIndex, h0: typing.SupportsFloat | typing.SupportsIndex = 0.0, radius: typing.SupportsFloat | typing.SupportsIndex = 1737400.0) -> None:
        """
        The frame at latitude lat0_deg, longitude lon0_deg (degrees) and height h0 (metres) on a sphere of `radius` metres.
        """
    def to_enu(self, lat_deg: typing.SupportsFloat | typing.SupportsIndex, lon_deg: typing.SupportsFloat | typing.SupportsIndex, h: typing.SupportsFloat | typing.SupportsIndex) -> tuple[float, float, float]:
        """
        (lat°, lon°, h m) → (east, north, up) metres.
        """
    def to_geodetic(self, east: typing.SupportsFloat | typing.SupportsIndex, north: typing.SupportsFloat | typing.SupportsIndex, up: typing.SupportsFloat | typing.SupportsIndex) -> tuple[float, float, float]:
        """
        (east, north, up) metres → (lat°, lon°, h m).
        """
class StainMask:
    """
    A bag's dirt mask: R x R float32 in [0, 1], row j = v, column i = u (np.asarray gives a read-only view that keeps it alive).
    """
    def sample(self, uv: typing.Any) -> numpy.typing.NDArray[numpy.float32]:
        """
        Bilinear mask values (N,) float32 at uv (N, 2): u wraps, v clamps to the outermost texel centres.
        """
    @property
    def resolution(self) -> int:
        """
        texels a side
        """
def cloud_puffs(params: CloudParams, seed: typing.SupportsInt | typing.SupportsIndex, time_s: typing.SupportsFloat | typing.SupportsIndex) -> numpy.typing.NDArray[numpy.float64]:
    """
    The fine-dust cloud (moonbot/dust.h, emitter 2) at time_s: the puffs alive then, (N, 5) float64 rows of centre x, y, z (world metres), sigma (metres) and peak extinction (1/m).
    """
def curvature_drop(distance: typing.SupportsFloat | typing.SupportsIndex, radius: typing.SupportsFloat | typing.SupportsIndex = 1737400.0) -> float:
    """
    Height lost to curvature at horizontal distance d (metres) on a sphere: ≈ d²/2R.
    """
def embree_isas() -> list[str]:
    """
    The ISAs this CPU can run Embree's kernels in, narrowest first (names as embree_isa takes them).
    """
def fabric_eval(xy: typing.Any, footprint: typing.Any, params: FabricParams = ...) -> tuple[numpy.typing.NDArray[numpy.float64], numpy.typing.NDArray[numpy.float64]]:
    """
    The woven fabric `params` (its pitch, relief, contrast and albedo; sheen plays no part) at points xy (N, 2) float64, metres of fabric (x along the warp = tangent, y along the weft = bitangent), prefiltered over footprint (N,) metres (Gaussian, sigma = footprint/2). Returns (albedo (N, 3) linear RGB, normal (N, 3) unit vectors in the (tangent, bitangent, normal) frame), float64.
    """
def henyey_greenstein(cos_theta: typing.SupportsFloat | typing.SupportsIndex, g: typing.SupportsFloat | typing.SupportsIndex) -> float:
    """
    Henyey-Greenstein phase function per steradian (g > 0: forward).
    """
def import_dem(path: str, lat_deg: typing.SupportsFloat | typing.SupportsIndex, lon_deg: typing.SupportsFloat | typing.SupportsIndex, size_m: typing.SupportsFloat | typing.SupportsIndex, spacing_m: typing.SupportsFloat | typing.SupportsIndex = 0.0, curvature: bool = True, height_scale: typing.SupportsFloat | typing.SupportsIndex = 1.0, height_offset: typing.SupportsFloat | typing.SupportsIndex = 0.0, nodata: typing.SupportsFloat | typing.SupportsIndex | None = None, png_range: tuple[typing.SupportsFloat | typing.SupportsIndex, typing.SupportsFloat | typing.SupportsIndex] | None = None, png_pixel_m: typing.SupportsFloat | typing.SupportsIndex | None = None, png_center: tuple[typing.SupportsFloat | typing.SupportsIndex, typing.SupportsFloat | typing.SupportsIndex] | None = None) -> dict:
    """
    Crop a square of size_m metres around (lat_deg, lon_deg) from a GeoTIFF (.tif/.tiff) or a 16-bit PNG heightmap (.png: needs png_range=(min_m, max_m) and png_pixel_m; png_center (lat, lon) defaults to the crop centre) and resample it onto a local ENU grid. Heights: (raw·file scale + file offset)·height_scale + height_offset metres; nodata overrides the file's GDAL_NODATA. Returns a dict: heights (ny, nx) float64 metres, row 0 = south, east fastest; spacing_m; lat_deg, lon_deg, h0_m (the ENU origin); curvature; voids_filled; source_pixel_m (the smaller of source_pixel_east_m / _north_m); source_format, source_width, source_height, height_scale, height_offset (composed), nodata; footprint (u_min, v_min, u_max, v_max) in source pixels. OSError for unreadable files and bad georeferences, ValueError for arguments and crops (both name the file or field).
    """
def measure_embree_limit(scene: Scene, camera: Camera, sun: DirectionalLight, threads: typing.SupportsInt | typing.SupportsIndex = 0, repeats: typing.SupportsInt | typing.SupportsIndex = 5, bounces: typing.SupportsInt | typing.SupportsIndex = 0) -> dict:
    """
    Median seconds Embree alone takes for the rays of one spp=1 render (pixel-centre camera rays, Sun shadow rays from their hits, `bounces` generations of diffuse bounce rays and the Sun shadow rays from their hits, as lists per generation): one ray at a time, as 8- and 16-ray packets and as the renderer's 64-ray streams, each tile traced from a cached copy and timed alone (the busiest thread's sum); the streams also traced in place from memory, wall-clock.
    """
def puff_optical_depth(centre: typing.Any, sigma_m: typing.SupportsFloat | typing.SupportsIndex, peak_extinction: typing.SupportsFloat | typing.SupportsIndex, origin: typing.Any, direction: typing.Any, t_max: typing.SupportsFloat | typing.SupportsIndex = ...) -> float:
    """
    Optical depth of one Gaussian dust puff (extinction peak·exp(-|x-centre|²/2σ²) per metre) along the ray origin + t·direction/|direction|, t in [0, t_max] metres; closed form.
    """
def read_image(path: str) -> numpy.ndarray:
    """
    Read an image through OpenImageIO: (H, W) or (H, W, C), uint8 / uint16 as stored, float32 otherwise. Raises OSError naming the path.
    """
def render(scene: Scene, camera: Camera, sun: DirectionalLight | None, settings: RenderSettings = ..., passes: collections.abc.Sequence[str] = ['rgb', 'depth', 'instance'], earth: DirectionalLight | None = None, medium: Medium = None, light_cache: LightCache = None) -> dict:
    """
    Render one view with `settings` (a RenderSettings). Returns a dict with the requested passes: rgb (H, W, 3) float32 W/(m^2 sr), depth (H, W) float32 z-depth in metres (0 = no hit), instance (H, W) uint8 (0 = background); and the counts camera_rays, second_look_rays (camera rays traced again where one may have slipped through a shared vertex), shadow_rays (bounce_shadow_rays of them from bounce vertices), bounce_rays, medium_rays (the dust's shadow rays toward the Sun), refined_pixels and refinement_rays (adaptive anti-aliasing's pixels and their extra rays), and seconds. sun: the Sun (a DirectionalLight), or None for the depth and instance passes alone (nothing is lit, no shadow ray traced); earth: a second light (Earthshine); medium: dust (a Medium) attenuating and scattering sunlight in rgb only; light_cache: a LightCache built for this scene, these lights and settings.bounces, from which camera hits on the surfaces it covers take their indirect light (no bounce rays).
    """
def resolve_embree_isa(name: str = 'auto') -> str:
    """
    The ISA a scene asked for `name` traces in here: 'auto' is $MOONBOT_EMBREE_ISA where set, else avx2 where this CPU runs it, else the widest it runs. ValueError for an unknown name or one this CPU cannot run.
    """
def simulate_ejecta(scene: Scene, params: EjectaParams, seed: typing.SupportsInt | typing.SupportsIndex, time_s: typing.SupportsFloat | typing.SupportsIndex, dt_s: typing.SupportsFloat | typing.SupportsIndex = 0.01, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> dict:
    """
    Granular ejecta (moonbot/dust.h) of the burst under way at time_s, flown in vacuum under gravity from launch in steps of at most dt_s and bounced on the scene's geometry (call it before the fragments' own mesh is in the scene, or they collide with themselves). Returns position (N, 3) and velocity (N, 3) float64 (metres, m/s, world), diameter (N,) metres, age (N,) seconds since launch, bounces (N,) int32, corrections (N,) int32 (times found behind a surface and put back in front: 0 in a scene of outward-facing solids), resting (N,) bool, and the fragments as one mesh in world metres: vertices (12 N, 3) float32, triangles (20 N, 3) uint32.
    """
def splat(local: typing.Any) -> numpy.typing.NDArray[numpy.float64]:
    """
    The splat shape B (N,) at local coordinates (N, 2), clamped to [0, 1]^2.
    """
def splat_support_area() -> float:
    """
    Area of {B > 0} in the unit local square.
    """
def stain_mask(seed: typing.SupportsInt | typing.SupportsIndex, params: StainParams, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> StainMask:
    """
    Paints a bag's dirt mask (paper 3.4) from params.stamps splats (a StainParams) at centres keyed by `seed`: a StainMask, or None when stamps == 0 (nothing allocated). The mask does not depend on `threads`.
    """
def stain_mask_bytes() -> int:
    """
    Bytes of stain masks alive now, process-wide.
    """
def stain_masks_allocated() -> int:
    """
    Stain masks ever allocated in this process.
    """
def stained_base_colour(clean: typing.Any, mask: typing.Any, dirt: typing.Any) -> numpy.typing.NDArray[numpy.float64]:
    """
    The paper's base colour lerp(clean, m*dirt, m), m clamped to [0, 1]: clean (N, 3) and dirt (3,) linear RGB, mask (N,). Returns (N, 3) float64.
    """
def stamp_centres(seed: typing.SupportsInt | typing.SupportsIndex, stamps: typing.SupportsInt | typing.SupportsIndex) -> numpy.typing.NDArray[numpy.float64]:
    """
    The stamp centres (stamps, 2) float64 in [0, 1)^2 (u, v).
    """
def tonemap_reinhard(rgb: typing.Any, exposure: typing.SupportsFloat | typing.SupportsIndex, veiling_glare: typing.SupportsFloat | typing.SupportsIndex = 0.0) -> tuple[numpy.typing.NDArray[numpy.uint8], int]:
    """
    Linear radiance (H, W, 3) × exposure (sr·m²/W) → Reinhard on luminance → 8-bit sRGB. Returns ((H, W, 3) uint8, number of pixels with a NaN, ±Inf or negative channel). NaN, -Inf and negatives count as 0; +Inf and overflow as the brightest value (1e30). veiling_glare > 0 (ISO 9358's index, a fraction) first adds the lens's uniform veil, that fraction of each channel's mean over the pixels whose channels are all finite and >= 0, to those pixels.
    """
def weave_height(a: typing.SupportsFloat | typing.SupportsIndex, b: typing.SupportsFloat | typing.SupportsIndex) -> float:
    """
    The unfiltered weave height in [0, 1] at a = pi*x/pitch, b = pi*y/pitch.
    """
def write_image(path: str, pixels: typing.Any, png_compression: typing.SupportsInt | typing.SupportsIndex = 1, attributes: dict = {}) -> None:
    """
    Write an image through OpenImageIO, atomically. Format from the extension: .png (uint8/uint16), .exr (float32), .tif/.tiff. `attributes` ({name: str or float}) go into the header (EXR keeps all). Raises OSError naming the path on failure.
    """
LUNAR_RADIUS: float = 1737400.0
MAX_DUST_STEP: float = 0.1
SPAWN_CLEARANCE: float = 0.001
