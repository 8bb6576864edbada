"""Bag meshes of your own (meshes.user; paper 3.3.1: a newly modelled mesh is taken in as it is).

A file (.obj, .ply, .glb, .gltf) is read with trimesh, then, in this order:
1. **checked**: every vertex finite, at least one triangle;
2. **converted** to the model frame: lengths from the declared unit to metres, turned so the
   declared up axis is +z (the shortest turn; for +y, glTF's up, that is +90° about x:
   (x, y, z) → (x, −z, y), Blender's own import);
3. **repaired**, each step counted in the report: vertices within `MERGE_TOLERANCE` of the
   bounding-box diagonal merged (files split vertices along UV and normal seams); triangles
   left with a repeated vertex or no area, and repeats of a triangle, dropped; holes whose
   boundary loop spans at most `HOLE_TOLERANCE` of the diagonal closed by a fan from their
   centroid; each connected piece's triangles wound consistently and outward (positive
   volume);
4. **validated**: closed (every edge shared by two or more triangles, wound consistently where
   two), positive volume, diagonal within `DIAGONAL_RANGE_M`; edges shared by more than two
   triangles (non-manifold) are reported, not refused: ray tracing, the BOP files and the
   overlap tests need a closed surface, not a manifold one;
5. **recentred**: the bounding box's centre is the model origin (BOP's models are centred).

Every failure is a ValueError naming the file. The surface is shaded as the built-in bags are,
woven fabric on an atlas of six box-projection charts (each triangle on the chart of its
normal's dominant axis, all at one scale, so the weave's metres hold within a factor of
1/cos 54.7° = 1.73 on oblique triangles). A base-colour texture (the material's, or `texture`)
gives the bag its colour: the instance's albedo is the texture's mean linear colour over the
surface, and each vertex's colour (the texture at its UV) a factor per channel on it,
interpolated across triangles by the core, so detail finer than the vertex spacing is averaged
away. Normal, roughness and
metallic textures are ignored, with a warning in the report: the fabric brings its own relief
and sheen.
"""

from __future__ import annotations

import functools
import json
import logging
import struct
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import ConvexHull, cKDTree

from moonbot.config.schema import UserMeshConfig

# Vertices closer than this fraction of the bounding-box diagonal are one vertex.
MERGE_TOLERANCE = 1e-6
# Holes whose boundary loop spans at most this fraction of the diagonal are closed.
HOLE_TOLERANCE = 0.05
# A bag's bounding-box diagonal after the unit, metres: a hand-sized bag to a bulk bag.
DIAGONAL_RANGE_M = (0.05, 3.0)
_UNITS_M = {"m": 1.0, "cm": 0.01, "mm": 0.001}


@dataclass(frozen=True)
class MeshReport:
    """What reading and repairing one file did, and what the result is. Lengths in metres,
    volumes in cubic metres; `hull_fit` is the convex hull's volume over the mesh's (1 for a
    convex body)."""

    path: str
    vertices_read: int
    triangles_read: int
    merged_vertices: int
    dropped_triangles: int
    filled_holes: int
    flipped_triangles: int
    non_manifold_edges: int
    pieces: int
    diagonal_m: float
    volume_m3: float
    hull_fit: float
    warnings: tuple[str, ...] = ()


@dataclass(frozen=True)
class UserMesh:
    """A user mesh ready for a scene: `vertices` (N, 3) float32 metres in the model frame (z up,
    origin at the bounding box's centre), outward `triangles` (M, 3) int32, `corner_uvs`
    (M, 3, 2) float32 on the box-projection atlas (`metres_per_uv` metres of surface per UV
    unit), and from a base-colour texture its mean linear RGB `albedo` and per-vertex, per-channel
    factor `vertex_albedo` (N, 3) float32 (both None without a texture)."""

    name: str
    vertices: np.ndarray
    triangles: np.ndarray
    corner_uvs: np.ndarray
    metres_per_uv: float
    albedo: tuple[float, float, float] | None
    vertex_albedo: np.ndarray | None
    report: MeshReport = field(repr=False)


def load_user_mesh(entry: UserMeshConfig) -> UserMesh:
    """The meshes.user entry read, converted, repaired, checked and recentred (module
    docstring). Cached per process: the entry carries the file's SHA-256, so a changed file is
    another entry. Raises ValueError naming the file."""
    return _load(entry)


@functools.lru_cache(maxsize=16)
def _load(entry: UserMeshConfig) -> UserMesh:
    path = entry.path
    warnings: list[str] = []
    vertices, triangles, colours = _read(path, entry.texture, warnings)
    n_read, m_read = len(vertices), len(triangles)
    bad = ~np.isfinite(vertices).all(axis=1)
    if bad.any():
        raise ValueError(
            f"{path}: {int(bad.sum())} of {len(vertices)} vertices are not finite "
            f"(NaN or infinite; the first is vertex {int(np.argmax(bad))})"
        )
    if len(triangles) == 0:
        raise ValueError(f"{path}: no triangles (a point cloud or an empty file)")
    vertices = vertices * _UNITS_M[entry.unit] @ up_rotation(entry.up_axis).T

    diagonal = float(np.linalg.norm(np.ptp(vertices, axis=0)))
    if not diagonal > 0:
        raise ValueError(f"{path}: every vertex is at one point (no extent)")
    vertices, triangles, colours, merged = _merge_vertices(vertices, triangles, colours, MERGE_TOLERANCE * diagonal)
    triangles, dropped = _drop_degenerate(vertices, triangles, (MERGE_TOLERANCE * diagonal) ** 2)  # area, m²
    if len(triangles) == 0:
        raise ValueError(f"{path}: every triangle has zero area")
    vertices, triangles, colours, filled = _fill_holes(path, vertices, triangles, colours, diagonal)
    triangles, flipped, pieces = _orient(path, vertices, triangles)
    non_manifold = _check_closed(path, vertices, triangles)
    if non_manifold:
        warnings.append(f"{non_manifold} non-manifold edges (shared by more than two triangles)")

    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    diagonal = float(np.linalg.norm(hi - lo))
    low, high = DIAGONAL_RANGE_M
    if not low <= diagonal <= high:
        raw = diagonal / _UNITS_M[entry.unit]
        fits = [f"unit {u!r} gives {raw * f:.4g} m" for u, f in _UNITS_M.items() if low <= raw * f <= high]
        raise ValueError(
            f"{path}: its bounding box's diagonal is {diagonal:.4g} m in unit {entry.unit!r}, outside "
            f"the {low}..{high} m a bag may span" + (f" ({'; '.join(fits)}: set meshes.user's unit)" if fits else "")
        )
    vertices = vertices - (lo + hi) / 2.0
    volume = signed_volume(vertices, triangles)
    hull = ConvexHull(vertices)
    report = MeshReport(
        path=path,
        vertices_read=n_read,
        triangles_read=m_read,
        merged_vertices=merged,
        dropped_triangles=dropped,
        filled_holes=filled,
        flipped_triangles=flipped,
        non_manifold_edges=non_manifold,
        pieces=pieces,
        diagonal_m=diagonal,
        volume_m3=volume,
        hull_fit=float(hull.volume / volume),
        warnings=tuple(warnings),
    )
    vertices32 = vertices.astype(np.float32)
    triangles32 = triangles.astype(np.int32)
    corner_uvs, metres_per_uv = box_atlas(vertices, triangles)
    albedo, factor = _albedo(vertices, triangles, colours)
    return UserMesh(
        name=entry.name,
        vertices=vertices32,
        triangles=triangles32,
        corner_uvs=corner_uvs,
        metres_per_uv=metres_per_uv,
        albedo=albedo,
        vertex_albedo=factor,
        report=report,
    )


def _read(path: str, texture: str, warnings: list[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """(vertices (N, 3) float64 in the file's frame and unit, triangles (M, 3) int64, linear RGB
    base colour per vertex (N, 3) or None) of a mesh file, its scene graph's transforms applied.
    The colour is the base-colour texture's (`texture`, else the material's, times glTF's linear
    baseColorFactor) at each vertex's UV, or the file's vertex colours (sRGB)."""
    import trimesh  # here: scenes of the built-in bags never load it

    if not Path(path).is_file():
        raise ValueError(f"{path}: no such file")
    _refuse_draco(path)
    complaints = _Complaints()
    logger = logging.getLogger("trimesh")
    logger.addHandler(complaints)
    propagate, logger.propagate = logger.propagate, False  # its complaints go into the report
    try:
        mesh = trimesh.load(path, force="mesh", process=False)
    except Exception as e:  # trimesh raises whatever its parsers do: the file is the culprit
        raise ValueError(f"{path}: cannot read as a mesh ({type(e).__name__}: {e})") from None
    finally:
        logger.removeHandler(complaints)
        logger.propagate = propagate
    warnings += [f"trimesh: {text}" for text in complaints.texts]
    if not isinstance(mesh, trimesh.Trimesh):
        raise ValueError(f"{path}: no triangles (it holds a {type(mesh).__name__})")
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    triangles = np.asarray(mesh.faces, dtype=np.int64).reshape(-1, 3)
    visual = mesh.visual
    uv = getattr(visual, "uv", None)
    uv = np.asarray(uv, dtype=np.float64) if uv is not None and len(uv) == len(vertices) else None
    material = getattr(visual, "material", None)
    image, factor = None, np.ones(3)
    if material is not None and not complaints.missing_image:  # else trimesh put in a 2 × 2 stand-in
        image = getattr(material, "baseColorTexture", None) or getattr(material, "image", None)
        base = getattr(material, "baseColorFactor", None)
        if base is not None:
            factor = np.asarray(base[:3], dtype=np.float64) / 255.0
        for kind in ("normalTexture", "metallicRoughnessTexture", "occlusionTexture", "emissiveTexture"):
            if getattr(material, kind, None) is not None:
                warnings.append(f"its {kind} is ignored (the bags' woven fabric has its own relief and sheen)")
    if texture:
        from PIL import Image

        try:
            with Image.open(texture) as opened:
                image = opened.convert("RGB")
        except OSError as e:
            raise ValueError(f"{path}: texture {texture}: cannot read ({e})") from None
        factor = np.ones(3)
    if image is not None:
        if uv is None:
            warnings.append("its base-colour texture is ignored: the mesh has no UV coordinates")
            return vertices, triangles, None
        return vertices, triangles, _texture_colours(np.asarray(image.convert("RGB"), dtype=np.uint8), uv) * factor
    if getattr(visual, "kind", None) == "vertex":
        return vertices, triangles, srgb_to_linear(np.asarray(visual.vertex_colors, dtype=np.float64)[:, :3] / 255.0)
    return vertices, triangles, None


class _Complaints(logging.Handler):
    """Collects what trimesh logs while it reads a file, for the report."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.texts: list[str] = []
        self.missing_image = False

    def emit(self, record: logging.LogRecord) -> None:
        text = record.getMessage()
        if record.exc_info and record.exc_info[1] is not None:
            text += f" ({type(record.exc_info[1]).__name__}: {record.exc_info[1]})"
        self.missing_image |= "image" in text.lower()
        self.texts.append(text)


def _refuse_draco(path: str) -> None:
    """ValueError for a glTF whose geometry is Draco-compressed: trimesh decodes it only with
    DracoPy and otherwise fills the vertices with zeros."""
    suffix = Path(path).suffix.lower()
    try:
        data = Path(path).read_bytes()
        if suffix == ".glb" and data[:4] == b"glTF" and len(data) >= 20:
            length, kind = struct.unpack_from("<I4s", data, 12)
            document = json.loads(data[20 : 20 + length]) if kind == b"JSON" else {}
        elif suffix == ".gltf":
            document = json.loads(data)
        else:
            return
    except (OSError, ValueError, struct.error):
        return  # trimesh's own reading names the problem
    needed = set(document.get("extensionsRequired", [])) | set(document.get("extensionsUsed", []))
    if "KHR_draco_mesh_compression" in needed:
        try:
            import DracoPy  # noqa: F401
        except ImportError:
            raise ValueError(
                f"{path}: its geometry is Draco-compressed (KHR_draco_mesh_compression), which needs the "
                f"DracoPy package; decompress it first (e.g. gltf-transform copy)"
            ) from None


def up_rotation(up_axis: str) -> np.ndarray:
    """The rotation (3, 3) taking the unit vector `up_axis` ('+x', '-y', ...) to +z: the
    shortest turn (+90° about x for +y; a half-turn about x for −z)."""
    sign = 1.0 if up_axis[0] == "+" else -1.0
    up = sign * np.eye(3)["xyz".index(up_axis[1])]
    if up[2] > 0.5:
        return np.eye(3)
    if up[2] < -0.5:
        return np.diag([1.0, -1.0, -1.0])
    axis = np.cross(up, [0.0, 0.0, 1.0])  # unit: up ⟂ z
    K = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + K + K @ K  # Rodrigues at 90°


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    """sRGB-encoded values in [0, 1] to linear (IEC 61966-2-1)."""
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _texture_colours(image: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Linear RGB (N, 3) of the sRGB `image` (H, W, 3) uint8 at `uv` (N, 2), bilinear, wrapping
    (glTF's default sampler), v up from the image's bottom row as glTF and OBJ mean it."""
    h, w = image.shape[:2]
    linear = srgb_to_linear(image.astype(np.float64) / 255.0)
    x = np.mod(uv[:, 0], 1.0) * w - 0.5
    y = (1.0 - np.mod(uv[:, 1], 1.0)) * h - 0.5
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]

    def at(i, j):
        return linear[np.mod(j, h), np.mod(i, w)]

    return (
        (1 - fx) * (1 - fy) * at(x0, y0)
        + fx * (1 - fy) * at(x0 + 1, y0)
        + (1 - fx) * fy * at(x0, y0 + 1)
        + fx * fy * at(x0 + 1, y0 + 1)
    )


def _merge_vertices(
    vertices: np.ndarray, triangles: np.ndarray, colours: np.ndarray | None, tolerance: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, int]:
    """Vertices within `tolerance` (metres) of each other, directly or through a chain, become
    the first of them (in file order); colours are averaged over each group. Unused vertices
    go. Returns the vertices, triangles re-indexed, colours and how many vertices merged away."""
    used = np.unique(triangles)
    pairs = cKDTree(vertices[used]).query_pairs(tolerance, output_type="ndarray")
    n = len(used)
    graph = (
        coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
        if len(pairs)
        else coo_matrix((n, n))
    )
    _, label = connected_components(graph, directed=False)
    # Number the groups by their first member, so the result follows the file's order.
    first = np.full(label.max() + 1, n)
    np.minimum.at(first, label, np.arange(n))
    order = np.argsort(first, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    group = rank[label]
    remap = np.full(len(vertices), -1, dtype=np.int64)
    remap[used] = group
    out = vertices[used[np.sort(first)]]
    merged_colours = None
    if colours is not None:
        sums = np.zeros((len(out), 3))
        np.add.at(sums, group, colours[used])
        merged_colours = sums / np.bincount(group, minlength=len(out))[:, None]
    return out, remap[triangles], merged_colours, int(n - len(out))


def _drop_degenerate(vertices: np.ndarray, triangles: np.ndarray, min_area: float) -> tuple[np.ndarray, int]:
    """Triangles without a repeated vertex, of area above `min_area`, each vertex set once (the
    first in file order). Returns them and how many went."""
    t = triangles
    distinct = (t[:, 0] != t[:, 1]) & (t[:, 1] != t[:, 2]) & (t[:, 0] != t[:, 2])
    v = vertices[t]
    area2 = 0.25 * np.sum(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]) ** 2, axis=1)
    keep = distinct & (area2 > min_area**2)
    _, first = np.unique(np.sort(t, axis=1), axis=0, return_index=True)
    once = np.zeros(len(t), dtype=bool)
    once[first] = True
    keep &= once
    return t[keep], int(len(t) - keep.sum())


def _edge_table(triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Directed half-edges (3M, 2) in triangle order (triangle k owns rows 3k..3k+2), each
    half-edge's undirected edge index (3M,) and each undirected edge's count of triangles."""
    half = triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    _, edge, count = np.unique(np.sort(half, axis=1), axis=0, return_inverse=True, return_counts=True)
    return half, edge.reshape(-1), count


def _fill_holes(
    path: str, vertices: np.ndarray, triangles: np.ndarray, colours: np.ndarray | None, diagonal: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, int]:
    """Closes each boundary loop spanning at most HOLE_TOLERANCE of `diagonal` by a fan of
    triangles from a new vertex at its centroid, wound against the loop's own edges. Raises
    ValueError naming the file when a larger hole remains."""
    half, edge, count = _edge_table(triangles)
    boundary = half[count[edge] == 1]
    if len(boundary) == 0:
        return vertices, triangles, colours, 0
    following: dict[int, list[int]] = {}
    for a, b in sorted(map(tuple, boundary.tolist())):
        following.setdefault(a, []).append(b)
    loops = []
    for start in sorted(following):
        while following.get(start):
            loop, at = [start], following[start].pop(0)
            while at != start and following.get(at):
                loop.append(at)
                at = following[at].pop(0)
            loops.append(loop)
    new_vertices, new_triangles, new_colours = [], [], []
    largest = 0.0
    for loop in loops:
        points = vertices[loop]
        span = float(np.linalg.norm(np.ptp(points, axis=0)))
        if span > HOLE_TOLERANCE * diagonal or len(loop) < 3:
            largest = max(largest, span)
            continue
        centre = len(vertices) + len(new_vertices)
        new_vertices.append(points.mean(axis=0))
        if colours is not None:
            new_colours.append(colours[loop].mean(axis=0))
        # A boundary half-edge a→b belongs to a triangle; its neighbour across must run b→a.
        new_triangles += [(b, a, centre) for a, b in zip(loop, loop[1:] + loop[:1])]
    if largest > 0:
        raise ValueError(
            f"{path}: not watertight: an open boundary spans {largest:.4g} m, "
            f"{100 * largest / diagonal:.3g} % of the diagonal (holes up to {100 * HOLE_TOLERANCE:g} % "
            f"are closed)"
        )
    vertices = np.concatenate([vertices, np.array(new_vertices)])
    triangles = np.concatenate([triangles, np.array(new_triangles, dtype=np.int64)])
    if colours is not None:
        colours = np.concatenate([colours, np.array(new_colours)])
    return vertices, triangles, colours, len(new_vertices)


def _orient(path: str, vertices: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, int, int]:
    """Triangles wound consistently across every edge two of them share, then each connected
    piece turned outward (positive signed volume). Returns them, how many were flipped and the
    number of pieces. Raises ValueError naming the file for a one-sided (Möbius) piece."""
    half, edge, count = _edge_table(triangles)
    m = len(triangles)
    owner = np.arange(3 * m) // 3
    manifold = np.flatnonzero(count[edge] == 2)
    order = manifold[np.argsort(edge[manifold], kind="stable")]
    a, b = owner[order[0::2]], owner[order[1::2]]
    same = np.all(half[order[0::2]] == half[order[1::2]], axis=1)  # same direction: one must flip
    neighbours: list[list[tuple[int, bool]]] = [[] for _ in range(m)]
    for i, j, s in zip(a.tolist(), b.tolist(), same.tolist()):
        neighbours[i].append((j, s))
        neighbours[j].append((i, s))
    flip = np.full(m, -1, dtype=np.int8)
    pieces = []
    for seed in range(m):
        if flip[seed] >= 0:
            continue
        flip[seed] = 0
        queue, piece = deque([seed]), [seed]
        while queue:
            i = queue.popleft()
            for j, s in neighbours[i]:
                want = flip[i] ^ int(s)
                if flip[j] < 0:
                    flip[j] = want
                    queue.append(j)
                    piece.append(j)
                elif flip[j] != want:
                    raise ValueError(
                        f"{path}: a piece of the surface is one-sided (its triangles cannot be "
                        f"wound consistently, as on a Möbius strip)"
                    )
        pieces.append(np.array(piece))
    out = np.where(flip[:, None] == 1, triangles[:, ::-1], triangles)
    for piece in pieces:
        if signed_volume(vertices, out[piece]) < 0:
            out[piece] = out[piece, ::-1]
    flipped = int(np.sum(np.any(out != triangles, axis=1)))
    return out, flipped, len(pieces)


def _check_closed(path: str, vertices: np.ndarray, triangles: np.ndarray) -> int:
    """Raises ValueError naming the file unless every edge is shared by two or more triangles
    and the surface encloses a positive volume; returns the number of non-manifold edges."""
    _, edge, count = _edge_table(triangles)
    if np.any(count == 1):
        raise ValueError(
            f"{path}: not watertight after repair: {int(np.sum(count == 1))} edges bound a single triangle"
        )
    if not signed_volume(vertices, triangles) > 0:
        raise ValueError(f"{path}: encloses no volume")
    return int(np.sum(count > 2))


def signed_volume(vertices: np.ndarray, triangles: np.ndarray) -> float:
    """The volume enclosed by a closed, outward-wound surface (negative if inward), in the
    cube of `vertices`' unit: the divergence theorem, one tetrahedron per triangle."""
    v = np.asarray(vertices, dtype=np.float64)[triangles]
    return float(np.einsum("ij,ij->i", v[:, 0], np.cross(v[:, 1], v[:, 2])).sum() / 6.0)


def box_atlas(vertices: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, float]:
    """Corner UVs (M, 3, 2) float32 in [0, 1]² and metres per UV unit: every triangle projected
    along the dominant axis of its normal onto that side's chart; six charts of side S (the
    mesh's largest extent) tiled three by two, so a UV unit is 3·S metres along both axes."""
    v = np.asarray(vertices, dtype=np.float64)
    lo = v.min(axis=0)
    side = float(np.ptp(v, axis=0).max())
    corners = v[triangles] - lo  # (M, 3, 3), within [0, side]
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    axis = np.argmax(np.abs(normal), axis=1)
    chart = 2 * axis + (normal[np.arange(len(axis)), axis] > 0)  # 0..5: −x, +x, −y, +y, −z, +z
    s_axis, t_axis = (axis + 1) % 3, (axis + 2) % 3
    rows = np.arange(len(axis))[:, None]
    s = corners[rows, np.arange(3)[None, :], s_axis[:, None]]
    t = corners[rows, np.arange(3)[None, :], t_axis[:, None]]
    col, row = (chart % 3)[:, None], (chart // 3)[:, None]
    uv = np.stack([(col * side + s) / (3 * side), (row * side + t) / (3 * side)], axis=-1)
    return uv.astype(np.float32), 3.0 * side


def _albedo(
    vertices: np.ndarray, triangles: np.ndarray, colours: np.ndarray | None
) -> tuple[tuple[float, float, float] | None, np.ndarray | None]:
    """From per-vertex linear colours (N, 3): their area-weighted mean over the surface (each
    vertex weighs a third of its triangles' area) and each vertex's colour over that mean, per
    channel (N, 3), so that mean × factor is the vertex's colour (at most 1). (None, None)
    without colours."""
    if colours is None:
        return None, None
    v = vertices[triangles]
    area = 0.5 * np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1)
    weight = np.zeros(len(vertices))
    for k in range(3):
        np.add.at(weight, triangles[:, k], area / 3.0)
    mean = np.clip((colours * weight[:, None]).sum(axis=0) / weight.sum(), 1e-4, 1.0)
    factor = np.clip(colours, 0.0, 1.0) / mean
    return tuple(float(c) for c in mean), factor.astype(np.float32)


# A user mesh whose convex hull holds more than this many times its volume settles as convex
# parts (moonbot.scene.convex_parts), not as its hull.
DECOMPOSE_ABOVE_HULL_FIT = 1.2


@functools.lru_cache(maxsize=16)
def user_convex_parts(entry: UserMeshConfig):
    """The entry's mesh as convex parts for settling (moonbot.scene.convex_parts), cached per
    process like the mesh."""
    from moonbot.scene.convex_parts import convex_parts

    mesh = load_user_mesh(entry)
    return convex_parts(mesh.vertices, mesh.triangles, mesh.report.volume_m3)


def describe(entry: UserMeshConfig) -> list[str]:
    """Lines telling what reading `entry` repaired and found, and how settling will collide it
    (its hull, or its convex parts with their fit), for `moonbot meshes`."""
    r = load_user_mesh(entry).report
    lines = [
        f"{entry.name}: {r.path} ({entry.unit}, up {entry.up_axis}): {r.vertices_read} vertices, "
        f"{r.triangles_read} triangles read",
        f"  repaired: {r.merged_vertices} vertices merged (within {MERGE_TOLERANCE:g} of the diagonal), "
        f"{r.dropped_triangles} degenerate or repeated triangles dropped, {r.filled_holes} holes closed "
        f"(up to {100 * HOLE_TOLERANCE:g} % of the diagonal), {r.flipped_triangles} triangles turned outward",
        f"  {r.pieces} piece(s), diagonal {1000 * r.diagonal_m:.1f} mm, volume {1e6 * r.volume_m3:.4g} cm³, "
        f"convex hull {r.hull_fit:.3f} × the volume",
    ]
    if r.hull_fit > DECOMPOSE_ABOVE_HULL_FIT:
        parts = user_convex_parts(entry)
        lines.append(
            f"  settles as {len(parts.parts)} convex parts, {parts.parts_fit:.3f} × the volume "
            f"(the hull is above {DECOMPOSE_ABOVE_HULL_FIT})"
        )
    else:
        lines.append("  settles as its convex hull")
    lines += [f"  warning: {w}" for w in r.warnings]
    return lines
