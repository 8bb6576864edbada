"""BOP object models (bop_toolkit's conventions): meshes in millimetres as binary PLY with vertex
normals in `models/obj_NNNNNN.ply`, the same surface remeshed evenly in `models_eval/` (a mesh,
as in BOP's datasets: bop_toolkit's error functions take its vertices as the model's points, and
its renderer, for VSD and the pose visualisations, its triangles), and in both folders
`models_info.json` with each model's diameter,
extents and discrete symmetries (4×4, row-major, millimetres) — bop_toolkit reads it from the
folder of the model type it loads (models/ or models_eval/)."""

from __future__ import annotations

import itertools
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial import ConvexHull, cKDTree

from moonbot.atomic_io import atomic_write
from moonbot.scene.normals import vertex_normals

# A rotation is a symmetry when it maps the surface onto itself within this fraction of the
# diameter (the BOP convention the issue names: 1 %).
SYMMETRY_TOLERANCE = 0.01
# Spacing of the evenly resampled surface (models_eval and the symmetry search), millimetres.
EVAL_SPACING_MM = 1.5
# Turns about a candidate axis that must all hold for a continuous symmetry: each at least 5°
# from every multiple of 360°/n for n ≤ 12, so no n-fold body passes them at 1 % of its diameter.
CONTINUOUS_TRIAL_DEG = (15.0, 114.0, 171.0)
# n-fold turns tried about each candidate axis besides the box's 24 rotations.
MAX_FOLD = 12


@dataclass(frozen=True)
class ModelInfo:
    """One models_info.json entry; lengths in millimetres. `symmetries` are 4×4 model-frame
    rigid transforms other than the identity (a turn about an axis through the origin, or
    through the surface's centroid, then with the translation that keeps that axis in place);
    `continuous` are (unit axis (3,), offset (3,): a point of the axis) of the axes the surface
    is symmetric about at every angle (BOP's symmetries_continuous), turns about which the
    discrete list then leaves out."""

    diameter: float
    minimum: tuple[float, float, float]
    size: tuple[float, float, float]
    symmetries: tuple[np.ndarray, ...]
    continuous: tuple[tuple[np.ndarray, np.ndarray], ...] = ()

    def to_json(self) -> dict:
        info = {
            "diameter": self.diameter,
            "min_x": self.minimum[0],
            "min_y": self.minimum[1],
            "min_z": self.minimum[2],
            "size_x": self.size[0],
            "size_y": self.size[1],
            "size_z": self.size[2],
        }
        if self.symmetries:
            info["symmetries_discrete"] = [s.reshape(-1).tolist() for s in self.symmetries]
        if self.continuous:
            info["symmetries_continuous"] = [
                {"axis": axis.tolist(), "offset": offset.tolist()} for axis, offset in self.continuous
            ]
        return info


def diameter(vertices: np.ndarray) -> float:
    """Exact largest distance between two points of a polyhedral surface (same unit as
    `vertices`): it is attained at two vertices of the convex hull, so only those are paired."""
    v = vertices.astype(np.float64)
    hull = v[ConvexHull(v).vertices]
    return float(
        max(np.linalg.norm(hull[i : i + 512, None] - hull[None], axis=2).max() for i in range(0, len(hull), 512))
    )


def sample_surface(vertices: np.ndarray, triangles: np.ndarray, spacing: float, seed: int = 0) -> np.ndarray:
    """Points (K, 3) float64 spread evenly over the surface, about one per spacing² of area: each
    triangle gets its share of the count by area, placed uniformly inside it. Deterministic for
    `seed`."""
    return sample_surface_faces(vertices, triangles, spacing, seed)[0]


def sample_surface_faces(
    vertices: np.ndarray, triangles: np.ndarray, spacing: float, seed: int = 0
) -> tuple[np.ndarray, np.ndarray]:
    """sample_surface's points (K, 3) float64 and the triangle each lies on (K,) int64, so a
    caller can give each point its face's normal."""
    v = vertices.astype(np.float64)
    a, b, c = v[triangles[:, 0]], v[triangles[:, 1]], v[triangles[:, 2]]
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    rng = np.random.default_rng(seed)
    expected = area / spacing**2
    counts = np.floor(expected + rng.random(len(area))).astype(int)  # unbiased rounding
    which = np.repeat(np.arange(len(area)), counts)
    r1, r2 = rng.random(len(which)), rng.random(len(which))
    flip = r1 + r2 > 1.0  # fold the unit square onto the triangle
    r1, r2 = np.where(flip, 1.0 - r1, r1), np.where(flip, 1.0 - r2, r2)
    return a[which] + r1[:, None] * (b - a)[which] + r2[:, None] * (c - a)[which], which


def resample_mesh(vertices: np.ndarray, triangles: np.ndarray, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """The surface remeshed with vertices about one per spacing² of area: each triangle is cut
    into n² similar triangles, n = √(2 × its area) / spacing rounded (at least 1: n² triangles
    hold about n²/2 vertices), vertices shared between triangles merged. The surface is the same
    (the faces' total area is the mesh's); orientation is kept. Returns (vertices (K, 3) float64,
    triangles (M, 3) int64), in `vertices`' unit; deterministic."""
    v = vertices.astype(np.float64)
    corners = v[triangles]  # (T, 3, 3)
    area = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)
    steps = np.maximum(1, np.rint(np.sqrt(2.0 * area) / spacing)).astype(int)
    points, faces, offset = [], [], 0
    for n in np.unique(steps):
        i, j = (a.ravel() for a in np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij"))
        inside = i + j <= n
        i, j = i[inside], j[inside]
        index = {(a, b): k for k, (a, b) in enumerate(zip(i.tolist(), j.tolist()))}
        up = [(index[a, b], index[a + 1, b], index[a, b + 1]) for (a, b) in index if a + b < n]
        down = [(index[a + 1, b], index[a + 1, b + 1], index[a, b + 1]) for (a, b) in index if a + b < n - 1]
        # Barycentric weights of the first, second and third corner; a shared edge's points get
        # the same weights from both of its triangles, so they come out bit for bit equal.
        weights = np.stack([(n - i - j) / n, i / n, j / n], axis=1)  # (P, 3)
        chosen = np.flatnonzero(steps == n)
        group = corners[chosen]  # (G, 3, 3)
        lattice = (
            weights[None, :, 0, None] * group[:, None, 0]
            + weights[None, :, 1, None] * group[:, None, 1]
            + weights[None, :, 2, None] * group[:, None, 2]
        )  # (G, P, 3)
        template = np.array(up + down, np.int64)
        points.append(lattice.reshape(-1, 3))
        faces.append((template[None] + (offset + np.arange(len(chosen)) * len(weights))[:, None, None]).reshape(-1, 3))
        offset += len(chosen) * len(weights)
    merged, inverse = np.unique(np.concatenate(points), axis=0, return_inverse=True)
    return merged, inverse.reshape(-1)[np.concatenate(faces)]


def axis_rotations() -> list[np.ndarray]:
    """The 24 rotations (3, 3) of the cube's symmetry group, the identity first: every way to lay
    a body's model axes along three given orthogonal axes."""
    out = [np.eye(3)]
    for perm in itertools.permutations(range(3)):
        for signs in itertools.product((1.0, -1.0), repeat=3):
            R = np.zeros((3, 3))
            R[range(3), perm] = signs
            if np.linalg.det(R) > 0 and not np.allclose(R, np.eye(3)):
                out.append(R)
    return out


def find_symmetries(
    vertices: np.ndarray, triangles: np.ndarray, tolerance: float, spacing: float
) -> tuple[list[np.ndarray], dict[str, float]]:
    """Rotations of the axis-aligned candidate group that map the surface onto itself: the
    largest distance from a rotated surface sample to the unrotated samples must be within
    `tolerance` (same unit as `vertices`). Returns the symmetries as 3×3 rotations and, per
    candidate, that largest distance (over a subset for a candidate the subset already rejects),
    so a report can show how clear each decision was."""
    points = sample_surface(vertices, triangles, spacing)
    test = _SymmetryTest(points, tolerance)
    found, distances = [], {}
    for R in axis_rotations()[1:]:  # the candidates: all but the identity
        worst = test.worst(R, np.zeros(3))
        distances[str(R.astype(int).tolist())] = worst
        if worst <= tolerance:
            found.append(R)
    return found, distances


class _SymmetryTest:
    """How far a rigid motion moves the surface samples `points` (K, 3) off themselves: the
    largest distance from a moved sample to its nearest unmoved one. Most candidates miss by
    far more than `tolerance`: evenly spread subsets (about 256, then 4096 samples) reject them
    at once, and only the survivors are measured at every sample."""

    def __init__(self, points: np.ndarray, tolerance: float) -> None:
        self.points, self.tolerance = points, tolerance
        self.tree = cKDTree(points)
        self.probes = [points[:: max(1, len(points) // n)] for n in (256, 4096)] + [points]

    def worst(self, R: np.ndarray, t: np.ndarray) -> float:
        for probe in self.probes:
            worst = float(self.tree.query(probe @ R.T + t, k=1, workers=-1 if len(probe) > 4096 else 1)[0].max())
            if worst > self.tolerance:
                break
        return worst


def axis_turn(axis: np.ndarray, angle: float) -> np.ndarray:
    """The rotation (3, 3) by `angle` radians about the unit `axis` (right-handed; Rodrigues)."""
    K = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + math.sin(angle) * K + (1.0 - math.cos(angle)) * (K @ K)


def find_all_symmetries(
    vertices: np.ndarray, triangles: np.ndarray, tolerance: float, spacing: float
) -> tuple[list[np.ndarray], list[tuple[np.ndarray, np.ndarray]]]:
    """Discrete and continuous symmetries of the surface within `tolerance` (find_symmetries'
    test), in the model frame, same unit as `vertices`. Candidate axes: x, y and z through the
    origin, and the surface's principal axes (of its samples' second moments, each whose moment
    differs from the others' by more than 1 % of the largest) through its centroid where they
    differ from those. An axis is continuous when turns by each of
    CONTINUOUS_TRIAL_DEG hold. Discrete candidates: the box's 24 rotations first (as
    find_symmetries tries them), then the n-fold turns (n ≤ MAX_FOLD) and half-turns about each
    candidate axis, each once; turns about a continuous axis are left out. Returns (4×4 transforms
    in that order, [(unit axis, offset)])."""
    points = sample_surface(vertices, triangles, spacing)
    test = _SymmetryTest(points, tolerance)
    centroid = points.mean(axis=0)
    axes = [(np.eye(3)[k], np.zeros(3)) for k in range(3)]
    moments, vectors = np.linalg.eigh(np.cov((points - centroid).T))
    for k in range(3):
        if min(abs(moments[k] - moments[j]) for j in range(3) if j != k) <= 0.01 * moments.max():
            continue  # a repeated moment: any axis in its plane is principal, none is the body's
        axis = vectors[:, k] * (1.0 if vectors[:, k][np.argmax(np.abs(vectors[:, k]))] > 0 else -1.0)
        if not any(
            abs(axis @ a) > math.cos(math.radians(1.0)) and np.linalg.norm(np.cross(centroid - o, a)) <= tolerance
            for a, o in axes
        ):
            axes.append((axis, centroid))

    def motion(R: np.ndarray, offset: np.ndarray) -> np.ndarray:
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = R, offset - R @ offset
        return T

    continuous = [
        (a, o)
        for a, o in axes
        if all(
            test.worst(axis_turn(a, math.radians(d)), o - axis_turn(a, math.radians(d)) @ o) <= tolerance
            for d in CONTINUOUS_TRIAL_DEG
        )
    ]

    def about_continuous(T: np.ndarray) -> bool:
        """Whether T turns about a continuous axis (it is then implied by that axis)."""
        for a, o in continuous:
            if np.allclose(T[:3, :3] @ a, a, atol=1e-9) and np.allclose(
                T @ np.append(o, 1.0), np.append(o, 1.0), atol=1e-6 * max(1.0, tolerance)
            ):
                return True
        return False

    candidates = [motion(R, np.zeros(3)) for R in axis_rotations()[1:]]
    for a, o in axes:
        for n in range(2, MAX_FOLD + 1):
            candidates += [motion(axis_turn(a, 2 * math.pi * k / n), o) for k in range(1, n) if math.gcd(k, n) == 1]
    found: list[np.ndarray] = []
    tried: set[bytes] = set()
    for T in candidates:
        key = (
            np.round(T, 9) + 0.0
        ).tobytes()  # (+ 0.0: no -0.0) a turn reached twice (a half-turn is every even fold's) is tried once
        if key in tried:
            continue
        tried.add(key)
        if not about_continuous(T) and test.worst(T[:3, :3], T[:3, 3]) <= tolerance:
            found.append(T)
    return found, continuous


def model_info(vertices_mm: np.ndarray, triangles: np.ndarray) -> ModelInfo:
    """models_info.json entry of a mesh in millimetres, model origin at the body's centre."""
    d = diameter(vertices_mm)
    symmetries, continuous = find_all_symmetries(vertices_mm, triangles, SYMMETRY_TOLERANCE * d, EVAL_SPACING_MM)
    lo = vertices_mm.min(axis=0).astype(np.float64)
    hi = vertices_mm.max(axis=0).astype(np.float64)
    return ModelInfo(
        diameter=d,
        minimum=tuple(lo.tolist()),
        size=tuple((hi - lo).tolist()),
        symmetries=tuple(symmetries),
        continuous=tuple(continuous),
    )


def write_ply(path: Path, vertices: np.ndarray, triangles: np.ndarray, normals: np.ndarray | None = None) -> None:
    """Binary little-endian PLY: float x y z (and nx ny nz), triangles as uchar-counted int
    lists, the layout bop_toolkit reads. Written atomically."""
    fields = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")]
    if normals is not None:
        fields += [("nx", "<f4"), ("ny", "<f4"), ("nz", "<f4")]
    vertex = np.empty(len(vertices), dtype=fields)
    vertex["x"], vertex["y"], vertex["z"] = vertices.T
    if normals is not None:
        vertex["nx"], vertex["ny"], vertex["nz"] = normals.T
    face = np.empty(len(triangles), dtype=[("n", "u1"), ("i", "<i4", (3,))])
    face["n"], face["i"] = 3, triangles
    header = ["ply", "format binary_little_endian 1.0", "comment made by moonbot", f"element vertex {len(vertices)}"]
    header += [f"property float {name}" for name, _ in fields]
    header += [f"element face {len(triangles)}", "property list uchar int vertex_indices", "end_header"]

    def write(f) -> None:
        f.write(("\n".join(header) + "\n").encode("ascii"))
        f.write(vertex.tobytes())
        f.write(face.tobytes())

    atomic_write(path, "wb", write)


def read_ply(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Reads a PLY that write_ply wrote (binary little-endian float x y z [nx ny nz], triangles as
    uchar-counted int lists): (vertices (N, 3) float64, triangles (M, 3) int64). Raises ValueError
    naming the file for any other layout."""
    data = Path(path).read_bytes()
    end = data.find(b"end_header\n")
    if not data.startswith(b"ply\n") or end < 0:
        raise ValueError(f"{path}: not a PLY file")
    header = data[:end].decode("ascii", "replace").splitlines()
    try:
        n_vertex = int(next(line.split()[2] for line in header if line.startswith("element vertex")))
        n_face = int(next(line.split()[2] for line in header if line.startswith("element face")))
    except (StopIteration, ValueError, IndexError):
        raise ValueError(f"{path}: PLY header lacks vertex or face counts") from None
    props = [line.split()[2] for line in header if line.startswith("property float")]
    if (
        "format binary_little_endian 1.0" not in header
        or props[:3] != ["x", "y", "z"]
        or "property list uchar int vertex_indices" not in header
    ):
        raise ValueError(f"{path}: not the layout moonbot writes (binary little-endian, float xyz, uchar/int faces)")
    vertex = np.frombuffer(data, dtype=[(p, "<f4") for p in props], count=n_vertex, offset=end + len("end_header\n"))
    face = np.frombuffer(
        data, dtype=[("n", "u1"), ("i", "<i4", (3,))], count=n_face, offset=end + len("end_header\n") + vertex.nbytes
    )
    if np.any(face["n"] != 3):
        raise ValueError(f"{path}: faces must be triangles")
    vertices = np.stack([vertex["x"], vertex["y"], vertex["z"]], axis=1).astype(np.float64)
    return vertices, face["i"].astype(np.int64)


def write_models(out_dir: Path, meshes: dict[int, tuple[np.ndarray, np.ndarray]]) -> dict[int, ModelInfo]:
    """Writes models/ and models_eval/ under `out_dir`, each with its models_info.json, for
    {obj_id: (vertices in metres, triangles)}; returns the infos."""
    (out_dir / "models").mkdir(parents=True, exist_ok=True)
    (out_dir / "models_eval").mkdir(parents=True, exist_ok=True)
    infos = {}
    for obj_id, (vertices, triangles) in sorted(meshes.items()):
        mm = vertices.astype(np.float64) * 1000.0
        write_ply(
            out_dir / "models" / f"obj_{obj_id:06d}.ply",
            mm.astype(np.float32),
            triangles,
            vertex_normals(vertices, triangles),
        )
        evaluation, faces = resample_mesh(mm, triangles, EVAL_SPACING_MM)
        write_ply(
            out_dir / "models_eval" / f"obj_{obj_id:06d}.ply",
            evaluation.astype(np.float32),
            faces,
            vertex_normals(evaluation, faces),
        )
        infos[obj_id] = model_info(mm, triangles)
    text = json.dumps({str(k): v.to_json() for k, v in infos.items()}, indent=2) + "\n"
    for folder in ("models", "models_eval"):
        atomic_write(out_dir / folder / "models_info.json", "w", lambda f: f.write(text))
    return infos
