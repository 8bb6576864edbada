"""Binary little-endian PLY for the peers' scene export: float32 x, y, z per vertex (plus any
float32 per-vertex properties, e.g. albedo_r/g/b), faces as a uchar count and int32 indices.
Numpy only, so that the Cycles venv (its own numpy) and the main venv share it."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def write_ply(
    path: Path,
    vertices: np.ndarray,
    triangles: np.ndarray,
    vertex_properties: dict[str, np.ndarray] | None = None,
    comment: str = "",
) -> None:
    """Writes (N, 3) `vertices` (float32 metres) and (M, 3) `triangles` (int32 indices) with
    optional (N,) float32 `vertex_properties` after x, y, z."""
    vertices = np.asarray(vertices, dtype="<f4")
    triangles = np.asarray(triangles, dtype="<i4")
    extra = {k: np.asarray(v, dtype="<f4") for k, v in (vertex_properties or {}).items()}
    names = ["x", "y", "z", *extra]
    header = ["ply", "format binary_little_endian 1.0"]
    header += [f"comment {line}" for line in comment.splitlines() if line]
    header += [
        f"element vertex {len(vertices)}",
        *(f"property float {n}" for n in names),
        f"element face {len(triangles)}",
        "property list uchar int vertex_indices",
        "end_header",
    ]
    vrec = np.empty(len(vertices), dtype=[(n, "<f4") for n in names])
    vrec["x"], vrec["y"], vrec["z"] = vertices.T
    for k, v in extra.items():
        vrec[k] = v
    frec = np.empty(len(triangles), dtype=[("n", "u1"), ("i", "<i4", (3,))])
    frec["n"], frec["i"] = 3, triangles
    with open(path, "wb") as f:
        f.write(("\n".join(header) + "\n").encode("ascii"))
        f.write(vrec.tobytes())
        f.write(frec.tobytes())


def read_ply(path: Path) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """Reads a file written by write_ply: (vertices (N, 3) float32, triangles (M, 3) int32,
    {name: (N,) float32} of the other vertex properties)."""
    data = Path(path).read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    lines = data[:end].decode("ascii").splitlines()
    if lines[1] != "format binary_little_endian 1.0":
        raise ValueError(f"{path}: not a binary little-endian PLY")
    names, counts, element = [], {}, None
    for line in lines:
        words = line.split()
        if words[0] == "element":
            element = words[1]
            counts[element] = int(words[2])
        elif words[0] == "property" and element == "vertex":
            if words[1] != "float":
                raise ValueError(f"{path}: vertex property {words[-1]} is not float")
            names.append(words[2])
        elif words[0] == "property" and element == "face" and words[1:4] != ["list", "uchar", "int"]:
            raise ValueError(f"{path}: faces must be 'list uchar int'")
    vdt = np.dtype([(n, "<f4") for n in names])
    nv, nf = counts["vertex"], counts["face"]
    vrec = np.frombuffer(data, dtype=vdt, count=nv, offset=end)
    frec = np.frombuffer(data, dtype=[("n", "u1"), ("i", "<i4", (3,))], count=nf, offset=end + nv * vdt.itemsize)
    if nf and not np.all(frec["n"] == 3):
        raise ValueError(f"{path}: only triangles are supported")
    vertices = np.column_stack([vrec["x"], vrec["y"], vrec["z"]])
    extra = {n: np.array(vrec[n]) for n in names if n not in ("x", "y", "z")}
    return vertices, np.array(frec["i"]), extra
