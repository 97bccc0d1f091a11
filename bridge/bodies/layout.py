"""Where things stand on a table, for action bodies: extents along directions, free spots, push directions.

Pure geometry on a world state (no Drake): a body asks here whether a pushed or toppled object would stay on its
support and away from the other objects before it plans a motion.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Sequence

import numpy as np

from ..odb import ObjectDatabase
from ..odb.geometry import contains_xy, support, z_range
from ..world import WorldState

UP = np.array([0.0, 0.0, 1.0])
SUPPORT_MARGIN = 0.015  # m an object's footprint keeps inside its support's edge
FREE_MARGIN = 0.03  # m between an object's planned footprint and any other object (more than touching's gap)


def horizontal(v: Sequence[float]) -> np.ndarray:
    v = np.array([v[0], v[1], 0.0], dtype=float)
    n = np.linalg.norm(v)
    return v / n if n > 1e-9 else v


@dataclass(frozen=True)
class Footprint:
    """A rectangle on a support: centre (x, y), unit axis `d` (horizontal) with half length `a`, half width `b`
    across it."""

    centre: np.ndarray
    d: np.ndarray
    a: float
    b: float

    @property
    def e(self) -> np.ndarray:
        return np.cross(UP, self.d)

    def corners(self) -> list[np.ndarray]:
        return [self.centre + sa * self.a * self.d + sb * self.b * self.e for sa in (-1, 1) for sb in (-1, 1)]


class Layout:
    """The objects of a world as seen from above."""

    def __init__(self, world: WorldState, odb: ObjectDatabase):
        self.world = world
        self.odb = odb

    def geometry(self, name: str):
        return self.odb.get(self.world.objects[name].type).geometry

    def pose(self, name: str):
        return self.world.objects[name].pose

    def reach(self, name: str, direction: Sequence[float]) -> float:
        """How far `name` extends along `direction` (world), measured from the origin."""
        return support(self.geometry(name), self.pose(name), np.asarray(direction, dtype=float))

    def half_extent(self, name: str, direction: Sequence[float]) -> float:
        """Half the object's thickness along a unit `direction`, i.e. from its centre to its face."""
        d = np.asarray(direction, dtype=float)
        return 0.5 * (self.reach(name, d) + self.reach(name, -d))

    def centre(self, name: str) -> np.ndarray:
        """The centre of the object's world bounding box (its origin for the primitives)."""
        return np.array([0.5 * (self.reach(name, e) - self.reach(name, -e)) for e in np.eye(3)])

    def z_range(self, name: str) -> tuple[float, float]:
        return z_range(self.geometry(name), self.pose(name))

    def top(self, name: str) -> float:
        return self.z_range(name)[1]

    def is_fixed(self, name: str) -> bool:
        return self.odb.get(self.world.objects[name].type).fixed

    def movables(self) -> list[str]:
        return [n for n in self.world.objects if not self.is_fixed(n)]

    def side_normals(self, name: str) -> list[np.ndarray]:
        """Horizontal directions to push `name` in: its side faces' normals (8 directions for round objects)."""
        g = self.geometry(name)
        if g.shape == "box":
            R = self.pose(name).rotation()
            dirs = []
            for axis in range(3):
                col = R[:, axis]
                if abs(col[2]) < 0.5:  # a side, not the top or bottom
                    dirs += [horizontal(col), horizontal(-col)]
            return dirs
        return [np.array([math.cos(a), math.sin(a), 0.0]) for a in np.arange(8) * math.pi / 4]

    def footprint(self, name: str, d: np.ndarray) -> Footprint:
        """The object's footprint now, in the frame of direction `d`."""
        e = np.cross(UP, d)
        return Footprint(np.append(self.centre(name)[:2], 0.0), d,
                         self.half_extent(name, d), self.half_extent(name, e))

    def on_support(self, fp: Footprint, support_name: str, margin: float = SUPPORT_MARGIN) -> bool:
        """Every corner of `fp` lies over the support's top, `margin` inside its edge."""
        g, pose = self.geometry(support_name), self.pose(support_name)
        return all(contains_xy(g, pose, c, margin=margin) for c in fp.corners())

    def blocking(self, fp: Footprint, ignore: Iterable[str], margin: float = FREE_MARGIN) -> list[str]:
        """Objects (movable or fixed, except `ignore` and supports under `fp`) whose footprint comes within
        `margin` of `fp` (separating axes `d` and `e`)."""
        skip = set(ignore)
        found = []
        for other in self.world.objects:
            if other in skip or self.is_fixed(other):
                continue
            clear = False
            for axis, half in ((fp.d, fp.a), (fp.e, fp.b)):
                lo = -self.reach(other, -axis)
                hi = self.reach(other, axis)
                c = float(fp.centre @ axis)
                if hi < c - half - margin or lo > c + half + margin:
                    clear = True
                    break
            if not clear:
                found.append(other)
        return found

    def gap(self, a: str, b: str, d: np.ndarray) -> float:
        """Distance `a` must travel along `d` to meet `b` (negative when they overlap along `d`)."""
        return -self.reach(b, -d) - self.reach(a, d)

    def lateral_overlap(self, a: str, b: str, d: np.ndarray) -> float:
        """How much `a` and `b` overlap across `d` (negative: `a` would pass `b` by)."""
        e = np.cross(UP, d)
        return min(self.reach(a, e), self.reach(b, e)) - max(-self.reach(a, -e), -self.reach(b, -e))

    def corridor(self, a: Sequence[float], b: Sequence[float], width: float) -> list[str]:
        """Movable objects whose footprint comes within `width` of the segment a -> b (seen from above)."""
        a2, b2 = np.array([a[0], a[1], 0.0]), np.array([b[0], b[1], 0.0])
        length = float(np.linalg.norm(b2 - a2))
        d = (b2 - a2) / length if length > 1e-6 else np.array([1.0, 0.0, 0.0])
        fp = Footprint((a2 + b2) / 2, d, length / 2 + width, width)
        return self.blocking(fp, (), margin=0.0)

    def free_spots(self, obj: str, support_name: str, near: Sequence[float], step: float = 0.02) -> list[np.ndarray]:
        """Spots (x, y) on `support_name` where `obj` (upright, as it is turned now) would stand clear of every
        other object, nearest to `near` first."""
        pose = self.pose(support_name)
        R = pose.rotation()
        half = np.array([self.half_extent(support_name, R[:, 0]), self.half_extent(support_name, R[:, 1])])
        d = horizontal(self.pose(obj).rotation()[:, 0])
        if np.linalg.norm(d) < 0.5:
            d = np.array([1.0, 0.0, 0.0])
        e = np.cross(UP, d)
        a, b = self.half_extent(obj, d), self.half_extent(obj, e)
        spots = []
        for u in np.arange(-half[0], half[0] + 1e-9, step):
            for v in np.arange(-half[1], half[1] + 1e-9, step):
                xy = pose.position + u * R[:, 0] + v * R[:, 1]
                fp = Footprint(np.array([xy[0], xy[1], 0.0]), d, a, b)
                if self.on_support(fp, support_name) and not self.blocking(fp, (obj, support_name)):
                    spots.append(fp.centre)
        near = np.array([near[0], near[1], 0.0])
        return sorted(spots, key=lambda s: float(np.linalg.norm(s - near)))
