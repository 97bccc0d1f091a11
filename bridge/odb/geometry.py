"""Geometric queries on object types that SIEs need (extent along a direction, footprint), without Drake."""
from __future__ import annotations

import math
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..errors import ObjectDatabaseError
from ..values import Pose
from .types import Geometry


def mesh_vertices(path: Path, scale: float) -> np.ndarray:
    """Vertices of an OBJ file (only 'v' lines are needed for extents). A file that is no OBJ mesh (random
    bytes, other text, no faces, a vertex that is not three finite numbers, a face naming a missing vertex) is an
    `ObjectDatabaseError` naming it: Drake would fail on it later without saying which file."""
    return mesh_data(path, scale)[0]


@lru_cache(maxsize=64)
def mesh_data(path: Path, scale: float) -> tuple[np.ndarray, tuple[tuple[int, ...], ...]]:
    """Vertices (scaled) and faces (0-based vertex indices) of an OBJ file, validated as `mesh_vertices` says."""
    src = str(path)
    try:
        text = Path(path).read_bytes().decode("utf-8")
    except OSError as exc:
        raise ObjectDatabaseError(f"cannot read mesh: {exc.strerror or exc}", source=src) from None
    except UnicodeDecodeError as exc:
        raise ObjectDatabaseError(f"not an OBJ mesh: byte 0x{exc.object[exc.start]:02x} at offset {exc.start} is "
                                  "not text", source=src) from None
    rows: list[list[float]] = []
    faces: list[tuple[int, list[str]]] = []
    for number, line in enumerate(text.splitlines(), start=1):
        words = line.split()
        if not words or words[0] != "v" and words[0] != "f":
            continue
        if words[0] == "f":
            faces.append((number, words[1:]))
            continue
        try:
            vertex = [float(v) for v in words[1:4]]
        except ValueError:
            vertex = []
        if len(vertex) != 3 or not all(math.isfinite(v) for v in vertex):
            raise ObjectDatabaseError(f"not an OBJ mesh: {line.strip()[:40]!r} is not a vertex 'v x y z' of three "
                                      "finite numbers", source=src, field=f"line {number}")
        rows.append(vertex)
    if len(rows) < 3 or not faces:
        raise ObjectDatabaseError(f"not an OBJ mesh: {len(rows)} vertex line(s) ('v x y z') and {len(faces)} face "
                                  "line(s) ('f i j k'); a mesh needs at least 3 and 1", source=src)
    indexed = []
    for number, corners in faces:
        try:
            index = [int(c.split("/")[0]) for c in corners]
        except ValueError:
            index = []
        if len(index) < 3 or not all(1 <= i <= len(rows) or -len(rows) <= i <= -1 for i in index):
            raise ObjectDatabaseError(f"not an OBJ mesh: face {' '.join(corners)[:40]!r} does not name 3 or more of "
                                      f"the {len(rows)} vertices", source=src, field=f"line {number}")
        indexed.append(tuple(i - 1 if i > 0 else len(rows) + i for i in index))
    vertices = np.asarray(rows, dtype=float) * scale
    vertices.setflags(write=False)  # cached: shared by every caller
    return vertices, tuple(indexed)


def support(geometry: Geometry, pose: Pose, direction: np.ndarray) -> float:
    """max over the shape of <point, direction> in the world frame: how far the shape reaches along `direction`."""
    d = np.asarray(direction, dtype=float)
    R = pose.rotation()
    local = R.T @ d
    centre = float(pose.position @ d)
    if geometry.shape == "box":
        return centre + float(np.abs(local) @ (np.asarray(geometry.size) / 2))
    if geometry.shape == "sphere":
        return centre + geometry.size[0] * float(np.linalg.norm(d))
    if geometry.shape == "cylinder":
        radius, length = geometry.size
        axial = abs(local[2])
        radial = float(np.linalg.norm(local[:2]))
        return centre + radius * radial + length / 2 * axial
    if geometry.mesh is None:
        raise ValueError(f"mesh {geometry.unresolved} is not available")
    return centre + float(np.max(mesh_vertices(geometry.mesh, geometry.scale) @ local))


def z_range(geometry: Geometry, pose: Pose) -> tuple[float, float]:
    """Lowest and highest world z of the shape."""
    up = np.array([0.0, 0.0, 1.0])
    return -support(geometry, pose, -up), support(geometry, pose, up)


def half_extents(geometry: Geometry) -> np.ndarray:
    """Half sizes of the shape's bounding box in its own frame."""
    identity = Pose()
    return np.array([support(geometry, identity, e) for e in np.eye(3)])


def contains_xy(geometry: Geometry, pose: Pose, point: np.ndarray, margin: float = 0.0) -> bool:
    """Whether the world point's x, y lie over the shape's footprint (its local bounding box), shrunk by `margin`."""
    local = pose.rotation().T @ (np.asarray(point, dtype=float) - pose.position)
    half = half_extents(geometry)
    if geometry.shape in ("cylinder", "sphere"):
        return float(np.linalg.norm(local[:2])) <= half[0] - margin
    return bool(abs(local[0]) <= half[0] - margin and abs(local[1]) <= half[1] - margin)
