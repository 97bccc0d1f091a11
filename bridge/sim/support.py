"""Where a free object's weight rests: its support footprint concentrated towards (or moved to) a centre of
pressure, as real contact geometry in Drake.

Why: a machined or moulded part never rests evenly on its whole bottom face. A slightly convex bottom, a burr or
a warped sheet puts the weight on a smaller region (often near the middle), which lowers the torsional friction
a push meets: the object turns more per millimetre of push, and the limit surface of planar sliding shrinks
(its moment axis scales with the footprint's radius of gyration). The real MIT pushes ask for exactly that: the
limit-surface baseline fitted on them picks a moment axis 0.62-0.88 times the uniform one (docs/real_push.md).

How: the object keeps its exact outline against the robot and other objects, and rests on a second collision
geometry that touches only what is anchored (the footprint of `sim/prisms.py`, `scene.filter_footprints`): the
object's own bottom polygon, scaled by `scale` about its area centroid and moved by `offset` (object frame).
Pressure over it is uniform (one fan of tetrahedra from its centre, `prisms.prism_tetrahedra`), so `scale`
sets the footprint's radius of gyration and with it the torsional friction; `offset` moves the centre of
pressure away from under the centre of mass, which turns a straight push. The whole weight still rests on it
(its Coulomb force is the same; only its moment and where it acts change). A `scale` above 1 stands for weight
towards the rim (a concave bottom resting on its edge): a uniform footprint of the same radius of gyration, which
reaches past the outline; it touches only what carries the object, never the robot. Neglected: a pressure that varies
smoothly inside the footprint (a cone, a ring): any distribution of the same radius of gyration and centre
has the same limit surface to first order, which is what a push can tell apart.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import SceneError
from ..odb import ObjectType

CIRCLE_VERTICES = 24  # a cylinder's footprint polygon
MIN_SCALE = 0.05  # a footprint smaller than this share of the object's is a point: a different object
MAX_SCALE = 1.8  # a square's corners are 1.73 radii of gyration out: no weight rests farther than that


@dataclass(frozen=True)
class SupportPressure:
    """A scene extra: object `object` rests on its footprint scaled by `scale` (MIN_SCALE to MAX_SCALE) about the
    footprint's centroid and moved by `offset` (m, object frame x y), or on `polygon` (object frame,
    counter-clockwise) when given. Applied where the object is added (`scene.add_object`); `add_to` checks that
    the object is there."""

    object: str
    scale: float = 1.0
    offset: tuple[float, float] = (0.0, 0.0)
    polygon: tuple[tuple[float, float], ...] | None = None

    def add_to(self, plant, world, odb, config) -> None:
        if self.object not in world.objects or odb.get(world.objects[self.object].type).fixed:
            free = [n for n, o in world.objects.items() if not odb.get(o.type).fixed]
            raise SceneError(f"support pressure: no free object {self.object!r} in world {world.name!r}; free objects: "
                             f"{', '.join(free) or 'none'}")


def bottom_polygon(obj_type: ObjectType, vertices: int, hull: bool = False) -> tuple[np.ndarray, float, float]:
    """(polygon (n, 2) counter-clockwise, z0, z1) of a flat-bottomed free object's footprint, object frame: a box's
    rectangle, a cylinder's circle as a polygon, a mesh prism's footprint (`prisms.footprint_polygon`: its outline,
    or hull when the type uses the hull or `hull` asks for it (`mesh_contact: "hull"`), simplified or subdivided to
    `vertices` vertices): at scale 1 what the object rests on without a support."""
    from .prisms import convex_hull, footprint_polygon, mesh_prism

    g = obj_type.geometry
    if g.shape == "box":
        hx, hy, hz = (s / 2 for s in g.size)
        # four fan triangles: how Drake's own compliant box rests (a finer fan turned a test push 5 deg more than
        # the box itself, a jump at the effect's null)
        return np.array([(-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy)]), -hz, hz
    if g.shape == "cylinder":
        r, length = g.size
        a = np.linspace(0.0, 2 * math.pi, CIRCLE_VERTICES, endpoint=False)
        return r * np.column_stack([np.cos(a), np.sin(a)]), -length / 2, length / 2
    prism = mesh_prism(g.mesh, g.scale) if g.shape == "mesh" and g.mesh is not None else None
    if prism is None:
        raise SceneError(f"a support footprint needs a flat-bottomed object (box, cylinder, mesh prism); type "
                         f"{obj_type.name!r} is a {'mesh that is not a prism' if g.shape == 'mesh' else g.shape}",
                         source=str(obj_type.source))
    outline = prism.outline
    if (g.convex or hull) and not prism.convex:
        outline = convex_hull(outline)
    footprint = footprint_polygon(outline, vertices)
    return (outline if footprint is None else footprint), prism.z0, prism.z1


def support_polygon(obj_type: ObjectType, support: SupportPressure, vertices: int,
                    hull: bool = False) -> tuple[np.ndarray, float, float]:
    """(the polygon, bottom z, top z) the object rests on under `support` (`hull`: as `bottom_polygon`): a
    compliant prism over it carries the object with uniform pressure (`scene.contact_shapes`)."""
    from .prisms import centroid, signed_area

    if obj_type.physics.hydroelastic_modulus is None:
        raise SceneError(f"support pressure on {support.object!r}: type {obj_type.name!r} has point contact (no "
                         "hydroelastic_modulus); a pressure distribution needs a compliant object",
                         source=str(obj_type.source))
    if not (math.isfinite(support.scale) and MIN_SCALE <= support.scale <= MAX_SCALE) or not all(
            math.isfinite(v) for v in support.offset):
        raise SceneError(f"support pressure on {support.object!r}: scale must be in [{MIN_SCALE}, {MAX_SCALE}] and the "
                         f"offset finite, got scale {support.scale!r}, offset {support.offset!r}")
    poly, z0, z1 = bottom_polygon(obj_type, vertices, hull)
    if support.polygon is not None:
        moved = np.asarray(support.polygon, dtype=float)
        if moved.ndim != 2 or moved.shape[1] != 2 or len(moved) < 3 or signed_area(moved) <= 0:
            raise SceneError(f"support pressure on {support.object!r}: polygon must be 3 or more (x, y) vertices, "
                             "counter-clockwise")
    else:
        c = centroid(poly)
        moved = c + support.scale * (poly - c) + np.asarray(support.offset, dtype=float)
    return moved, z0, z1


def widest_scale(obj_type: ObjectType, vertices: int = 16) -> float:
    """The largest `SupportPressure.scale` the object's bottom can carry its weight at: the radius of gyration of
    all the weight at the bottom's points farthest from its centroid over that of a uniform footprint (a disc's
    rim: sqrt 2, a square's corners: sqrt 3). A larger footprint twists as no distribution on the object can."""
    from .prisms import centroid

    try:
        poly, _, _ = bottom_polygon(obj_type, vertices)
    except SceneError:
        return MAX_SCALE
    farthest = float(np.max(np.linalg.norm(np.asarray(poly) - centroid(poly), axis=1)))
    return farthest / gyration_radius(poly)


def gyration_radius(poly: np.ndarray) -> float:
    """The radius of gyration (m) of a uniform polygon about its area centroid, sqrt(polar moment / area): a
    footprint's size as twisting sees it (footprints of one radius of gyration have nearly one limit surface)."""
    from .prisms import centroid

    p = np.asarray(poly, dtype=float) - centroid(poly)
    x, y = p[:, 0], p[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    area = cross.sum() / 2
    polar = (cross * (x * x + x * xn + xn * xn + y * y + y * yn + yn * yn)).sum() / 12
    return float(math.sqrt(polar / area))
