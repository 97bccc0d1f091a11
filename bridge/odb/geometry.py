"""Geometric queries on object types that SIEs need (extent along a direction, footprint), without Drake."""
from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np

from ..values import Pose
from .types import Geometry


@lru_cache(maxsize=64)
def mesh_vertices(path: Path, scale: float) -> np.ndarray:
    """Vertices of an OBJ file (only 'v' lines are needed for extents)."""
    rows = []
    with open(path, encoding="utf-8", errors="replace") as f:
        for line in f:
            if line.startswith("v "):
                rows.append([float(v) for v in line.split()[1:4]])
    return np.asarray(rows, dtype=float) * scale


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
