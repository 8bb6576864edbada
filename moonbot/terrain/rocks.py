"""Rocks and pebbles: how many, how large, where, and their irregular shapes (instanced meshes).

**Sizes.** Two populations, both Poisson processes.

- *Background*, on every procedural location: the cumulative power law N(≥D) = K·D^b rocks per m²
  (D in metres) that Shoemaker & Morris fitted to the Surveyor rock counts (Surveyor Program
  Results, NASA SP-184, 1969), which reach down to a few millimetres. The default takes Surveyor
  I's mare exponent, b = −2.11, and K = 2.34e-3: 38 rocks per m² of 1 cm and more, 1.3 of 5 cm,
  0.30 of 10 cm, 0.010 of 50 cm. That is ten times Surveyor I's published constant (5.0e4 per
  100 m² with D in mm, the unit reading that agrees with Cintala & McBride's (1995, NASA
  TM-104804) Lunar Orbiter counts of metre blocks), because the Apollo 11 surface photographs
  show that many rocks at cm–dm sizes: in AS11-40-5851, 3–6 m from the camera, ~2 per m² of 5 cm
  and more, and ~14 per m² of the ≳1 cm that the scan resolves. Sizes in a band [a, b) are
  drawn by inverting the truncated power law.
- *Crater ejecta*, at the crater location: Golombek & Rapp's (1997) rock-area model, the
  fraction of the ground covered by rocks of diameter ≥ D being F(D) = k·exp(−q·D),
  q = 1.79 + 0.152/k, D in metres; the number per m² in dD is n(D)dD = −F′(D)/(πD²/4)·dD =
  (4kq/π)·e^{−qD}/D²·dD, whose integral has the closed form G(D) = −e^{−qD}/D + q·E1(qD) (E1 the
  exponential integral), so the mean count per m² in [a, b) is (4kq/π)·(G(b) − G(a)). Its rock
  fraction is `k_crater` inside the rim and falls off outside as (r/R)^−3 like the ejecta that
  carried the rocks (thinning of a Poisson process, so counts per area stay exactly predictable).

**Only what the camera can see.** Rocks are drawn in octave bands of diameter; a band lies
within `PIXELS_REACH`·D of the target (a rock subtends at least ~2 pixels of a 640-pixel,
60° image there: 1 cm pebbles within 3 m, 10 cm rocks within 30 m) and within `reach_m`.

**Shapes.** `PROTOTYPES` irregular rocks, flattened (rocks lie on their broad side) and scaled
to unit longest horizontal extent: lobed boulders (an 80-face icosphere whose radius is jittered,
given a few broad random lobes and cut by three random fracture planes) and angular clasts (the
convex hull of 14 random points: a dozen or two large faces). The renderer shades their facets
flat, so every edge is sharp. Each rock is an instance of one of them: random yaw, scale D, sunk
into the ground by a fraction of its height drawn uniformly from `BURIAL`.

**How high they stand.** The prototypes' axes average 1 : 0.75 : 0.5 (longest horizontal, other
horizontal, height), the ratios of laboratory impact fragments, 2 : √2 : 1 (Fujiwara et al. 1978,
Icarus 31), lying on their broad side. The lunar engineering model's standard block stands half its
diameter above the ground (NASA SP-8023, "Lunar Surface Models", 1969), which such a shape reaches
only unburied; Apollo 12 rocks show the line between their buried and their exposed,
micro-cratered parts, so some burial stays. Sunk by 0–30 % (mean 15 %), a rock stands 0.43·D on
average; the 10–70 % used before left 0.30·D, and the flat plain's rock shadows were then shorter
than any the Apollo frames show at a like Sun (bench/results/README.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import ConvexHull
from scipy.special import exp1

from moonbot.config.schema import RocksConfig

PROTOTYPES = 8  # distinct rock meshes; every rock is an instance of one
CLAST_CORNERS = 14  # random points whose convex hull is an angular clast
PIXELS_REACH = 300.0  # rocks of diameter D are drawn within PIXELS_REACH·D of the target
BURIAL = (0.0, 0.3)  # the fraction of a rock's height below the ground: uniform in [lo, hi)
_TABLE = 4096  # inverse-CDF table size for the sizes


def golombek_q(k: float) -> float:
    """The exponent q(k) = 1.79 + 0.152/k of Golombek & Rapp (1997), per metre."""
    return 1.79 + 0.152 / k


def rocks_per_m2(k: float, lo: float, hi: float) -> float:
    """Mean number of rocks per m² with lo ≤ D < hi (metres) for rock fraction k."""
    if k <= 0.0:
        return 0.0
    q = golombek_q(k)

    def G(d: float) -> float:
        return -math.exp(-q * d) / d + q * float(exp1(q * d))

    return 4.0 * k * q / math.pi * (G(hi) - G(lo))


def power_law_per_m2(density: float, exponent: float, lo: float, hi: float) -> float:
    """Mean number of rocks per m² with lo ≤ D < hi (metres) under N(≥D) = density·D^exponent."""
    return density * (lo**exponent - hi**exponent)


def _power_law_sizes(rng: np.random.Generator, exponent: float, lo: float, hi: float, count: int) -> np.ndarray:
    """`count` diameters (metres) from N(≥D) ∝ D^exponent truncated to [lo, hi) (inverse CDF)."""
    a, b = lo**exponent, hi**exponent
    return (a - rng.random(count) * (a - b)) ** (1.0 / exponent)


def _sizes(rng: np.random.Generator, k: float, lo: float, hi: float, count: int) -> np.ndarray:
    """`count` diameters (metres) from n(D) ∝ e^{−qD}/D² on [lo, hi), by inverse CDF."""
    d = np.geomspace(lo, hi, _TABLE)
    cumulative = np.array([rocks_per_m2(k, lo, x) for x in d[1:]])
    cumulative = np.concatenate([[0.0], cumulative]) / cumulative[-1]
    return np.interp(rng.random(count), cumulative, d)


@dataclass(frozen=True)
class RockField:
    """Rocks on the ground: centres (K, 2) metres (world x, y), diameters (K,) metres, the
    prototype each uses (K,) int, yaw (K,) radians and burial (K,) as a fraction of height."""

    centres: np.ndarray
    diameters: np.ndarray
    prototype: np.ndarray
    yaw: np.ndarray
    burial: np.ndarray

    def __len__(self) -> int:
        return len(self.diameters)

    def subset(self, keep: np.ndarray) -> RockField:
        return RockField(
            self.centres[keep], self.diameters[keep], self.prototype[keep], self.yaw[keep], self.burial[keep]
        )


def band_half_size(config: RocksConfig, diameter: float) -> float:
    """Half-width (metres) of the square around the target in which rocks of `diameter` are
    drawn."""
    return min(config.reach_m, PIXELS_REACH * diameter)


def sample_rocks(seed: int, config: RocksConfig, crater: tuple[np.ndarray, float] | None = None) -> RockField:
    """The rocks of a location: the background population (power law), plus, with `crater` =
    (centre (2,) metres, rim diameter metres), the Golombek & Rapp population clustered on it.
    Deterministic from `seed`."""
    parts = []
    lo, band = config.min_diameter_m, 0
    while lo < config.max_diameter_m:
        hi = min(2.0 * lo, config.max_diameter_m)
        half = band_half_size(config, lo)
        area = (2.0 * half) ** 2
        rng = np.random.default_rng([seed, 0x0C5, band])
        # Background: homogeneous Poisson.
        mean = power_law_per_m2(config.density_per_m2, config.exponent, lo, hi) * area
        n = rng.poisson(mean) if half > 0 else 0
        centres = rng.uniform(-half, half, size=(n, 2))
        sizes = _power_law_sizes(rng, config.exponent, lo, hi, n)
        parts.append((centres, sizes))
        if crater is not None and config.k_crater > 0 and half > 0:
            # Clustered on the crater: a Poisson process of the rim's density, thinned by the
            # ejecta falloff, so the intensity at distance r is λ_rim·min(1, (r/R)^-3).
            centre, diameter = crater
            n = rng.poisson(rocks_per_m2(config.k_crater, lo, hi) * area)
            pts = rng.uniform(-half, half, size=(n, 2))
            s = np.hypot(*(pts - centre).T) / (diameter / 2.0)
            keep = rng.random(n) < crater_falloff(s)
            sizes = _sizes(rng, config.k_crater, lo, hi, n)
            parts.append((pts[keep], sizes[keep]))
        lo, band = hi, band + 1
    centres = np.concatenate([p[0] for p in parts]) if parts else np.zeros((0, 2))
    diameters = np.concatenate([p[1] for p in parts]) if parts else np.zeros(0)
    rng = np.random.default_rng([seed, 0x0C5, 0xFFFF])
    count = len(diameters)
    return RockField(
        centres,
        diameters,
        rng.integers(0, PROTOTYPES, count),
        rng.uniform(0, 2 * math.pi, count),
        rng.uniform(*BURIAL, count),
    )


def crater_falloff(s: np.ndarray) -> np.ndarray:
    """Relative rock fraction at s = r/R from a crater's centre: 1 inside the rim, (r/R)^-3
    outside (the ejecta thickness law)."""
    return np.minimum(1.0, np.maximum(s, 1e-12) ** -3.0)


def _icosphere(subdivisions: int) -> tuple[np.ndarray, np.ndarray]:
    """A unit icosphere: vertices (N, 3) float64 on the sphere, triangles (M, 3) int32,
    counter-clockwise seen from outside."""
    t = (1.0 + math.sqrt(5.0)) / 2.0
    v = [
        (-1, t, 0),
        (1, t, 0),
        (-1, -t, 0),
        (1, -t, 0),
        (0, -1, t),
        (0, 1, t),
        (0, -1, -t),
        (0, 1, -t),
        (t, 0, -1),
        (t, 0, 1),
        (-t, 0, -1),
        (-t, 0, 1),
    ]
    f = [
        (0, 11, 5),
        (0, 5, 1),
        (0, 1, 7),
        (0, 7, 10),
        (0, 10, 11),
        (1, 5, 9),
        (5, 11, 4),
        (11, 10, 2),
        (10, 7, 6),
        (7, 1, 8),
        (3, 9, 4),
        (3, 4, 2),
        (3, 2, 6),
        (3, 6, 8),
        (3, 8, 9),
        (4, 9, 5),
        (2, 4, 11),
        (6, 2, 10),
        (8, 6, 7),
        (9, 8, 1),
    ]
    vertices = [np.array(p, dtype=np.float64) / np.linalg.norm(p) for p in v]
    faces = f
    for _ in range(subdivisions):
        midpoint: dict[tuple[int, int], int] = {}

        def mid(a: int, b: int) -> int:
            key = (min(a, b), max(a, b))
            if key not in midpoint:
                m = vertices[a] + vertices[b]
                vertices.append(m / np.linalg.norm(m))
                midpoint[key] = len(vertices) - 1
            return midpoint[key]

        faces = [
            tri
            for a, b, c in faces
            for tri in (
                (a, mid(a, b), mid(c, a)),
                (b, mid(b, c), mid(a, b)),
                (c, mid(c, a), mid(b, c)),
                (mid(a, b), mid(b, c), mid(c, a)),
            )
        ]
    return np.array(vertices), np.array(faces, dtype=np.int32)


def _angular_clast(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A fractured clast: the convex hull of `CLAST_CORNERS` random points on a sphere, each
    pulled in by up to 30 % (vertices (N, 3) float64, triangles (M, 3) int32, counter-clockwise
    seen from outside). Convex, so closed and never self-intersecting; its few large faces meet
    in sharp edges."""
    direction = rng.normal(size=(CLAST_CORNERS, 3))
    points = direction / np.linalg.norm(direction, axis=1, keepdims=True) * rng.uniform(0.7, 1.0, (CLAST_CORNERS, 1))
    hull = ConvexHull(points)
    used = np.unique(hull.simplices)
    index = np.full(CLAST_CORNERS, -1)
    index[used] = np.arange(len(used))
    vertices, triangles = points[used], index[hull.simplices]
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    inward = np.einsum("ij,ij->i", np.cross(b - a, c - a), a - vertices.mean(axis=0)) < 0
    triangles[inward] = triangles[inward][:, ::-1]
    return vertices, triangles.astype(np.int32)


def _lobed_boulder(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A weathered boulder: an 80-face icosphere whose radius is jittered, given broad random
    lobes and cut by three random fracture planes (vertices (N, 3) float64, triangles (M, 3)
    int32). Star-shaped about the origin, so closed and never self-intersecting."""
    sphere, triangles = _icosphere(1)  # 80 faces: coarse enough to read as angular facets
    radius = 1.0 + rng.uniform(-0.08, 0.08, len(sphere))  # chipped corners
    for _ in range(6):  # broad lobes and dents
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        radius += rng.uniform(-0.25, 0.25) * np.maximum(sphere @ axis, 0.0) ** rng.uniform(2.0, 6.0)
    for _ in range(3):  # flat fracture faces: clip the radius against random planes
        normal = rng.normal(size=3)
        normal /= np.linalg.norm(normal)
        along = sphere @ normal
        cut = rng.uniform(0.55, 0.8)
        radius = np.where(along > 0, np.minimum(radius, cut / np.maximum(along, 1e-9)), radius)
    return sphere * radius[:, None], triangles


def rock_prototypes(seed: int = 0) -> list[tuple[np.ndarray, np.ndarray]]:
    """`PROTOTYPES` irregular rock meshes: (vertices (N, 3) float32, triangles (M, 3) int32),
    model frame with the longest horizontal extent 1 (so an instance's scale is its diameter D),
    centred on the origin, z up; flattened (rocks lie on their broad side). Even ones are lobed
    boulders, odd ones angular clasts (the Apollo photographs' cm-dm rocks are mostly angular
    fragments); every size draws from all of them."""
    meshes = []
    for p in range(PROTOTYPES):
        rng = np.random.default_rng([seed, 0x0C5, 0x9000 + p])
        v, triangles = (_angular_clast if p % 2 else _lobed_boulder)(rng)
        v = v * np.array([1.0, rng.uniform(0.6, 0.9), rng.uniform(0.35, 0.65)])
        v -= (v.max(axis=0) + v.min(axis=0)) / 2.0
        v /= max(np.ptp(v[:, 0]), np.ptp(v[:, 1]))
        meshes.append((v.astype(np.float32), triangles))
    return meshes


def rock_poses(rocks: RockField, prototypes: list[tuple[np.ndarray, np.ndarray]], height) -> np.ndarray:
    """World-from-model transforms (K, 4, 4) float64 of the rocks: yaw about z, scale by the
    diameter, and sunk so that `burial` of the rock's height lies below the ground height
    `height(x, y)` (a callable of metre arrays) under its centre."""
    K = len(rocks)
    poses = np.zeros((K, 4, 4))
    c, s = np.cos(rocks.yaw), np.sin(rocks.yaw)
    d = rocks.diameters
    poses[:, 0, 0], poses[:, 0, 1], poses[:, 1, 0], poses[:, 1, 1] = c * d, -s * d, s * d, c * d
    poses[:, 2, 2] = d
    poses[:, 3, 3] = 1.0
    bottom = np.array([float(prototypes[p][0][:, 2].min()) for p in range(len(prototypes))])
    top = np.array([float(prototypes[p][0][:, 2].max()) for p in range(len(prototypes))])
    lo, hi = bottom[rocks.prototype] * d, top[rocks.prototype] * d
    ground = height(rocks.centres[:, 0], rocks.centres[:, 1]) if K else np.zeros(0)
    poses[:, 0, 3], poses[:, 1, 3] = rocks.centres[:, 0], rocks.centres[:, 1]
    poses[:, 2, 3] = ground - lo - rocks.burial * (hi - lo)
    return poses
