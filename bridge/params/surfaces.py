"""Where objects stand in a world state: which fixture supports which object, its top, an object's half extents.
Parameter kinds and effects ask here which objects a tilted surface carries and where a patch or a post goes."""
from __future__ import annotations

import math

import numpy as np

from ..odb import ObjectDatabase
from ..odb.geometry import contains_xy, half_extents, z_range
from ..world import WorldState


def movable_objects(world: WorldState, odb: ObjectDatabase) -> tuple[str, ...]:
    return tuple(n for n, o in world.objects.items() if not odb.get(o.type).fixed)


def support_of(world: WorldState, odb: ObjectDatabase, name: str) -> str | None:
    """The fixture an object stands on: its footprint holds the object's centre and its top is the highest one
    below the object's bottom (within 2 cm)."""
    obj = world.objects[name]
    bottom = z_range(odb.get(obj.type).geometry, obj.pose)[0]
    best, best_top = None, -math.inf
    for other, o in world.objects.items():
        t = odb.get(o.type)
        if not t.fixed or t.geometry is None:
            continue
        top = z_range(t.geometry, o.pose)[1]
        if top <= bottom + 0.005 and bottom - top < 0.02 and contains_xy(t.geometry, o.pose, obj.pose.position) \
                and top > best_top:
            best, best_top = other, top
    return best


def supported_by(world: WorldState, odb: ObjectDatabase, surface: str) -> tuple[str, ...]:
    return tuple(n for n in movable_objects(world, odb) if support_of(world, odb, n) == surface)


def surfaces_under(world: WorldState, odb: ObjectDatabase, objects) -> tuple[str, ...]:
    """The supports of the given movable objects, each once."""
    found = [support_of(world, odb, n) for n in objects if n in movable_objects(world, odb)]
    return tuple(dict.fromkeys(s for s in found if s))


def surface_top(world: WorldState, odb: ObjectDatabase, surface: str) -> float:
    o = world.objects[surface]
    return z_range(odb.get(o.type).geometry, o.pose)[1]


def footprint_half(world: WorldState, odb: ObjectDatabase, name: str) -> np.ndarray:
    """Half extents (x, y, z) of an object's bounding box in its own frame."""
    return half_extents(odb.get(world.objects[name].type).geometry)
