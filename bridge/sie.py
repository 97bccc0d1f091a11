"""State Inference Entities: small classifiers, stored with object types, that turn geometry into facts.

An SIE gets the object's name and an `EvaluationContext` (every pose, the contacts and their forces, the other
objects and their types, the object database) and returns the ground facts of its predicate that hold for that
object -- an empty list when none does. Unlike the paper's ``[name, predicate, value]`` lists, a result is a
sequence of typed `Fact`s, so n-ary and multi-valued predicates need no convention.

Writing one::

    from bridge.sie import SIE

    class Upright(SIE):
        def __init__(self, max_tilt_deg: float = 20.0):
            self.max_tilt = math.radians(max_tilt_deg)

        def evaluate(self, obj, ctx):
            tilt = angle_between(ctx.pose(obj).z_axis(), (0, 0, 1))
            return [self.fact(obj)] if tilt < self.max_tilt else []
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Iterable, Sequence

import numpy as np

from .values import Contact, Fact, Pose

if TYPE_CHECKING:
    from .odb import Geometry, ObjectDatabase, ObjectType, PredicateDecl
    from .world import WorldState


@dataclass(frozen=True)
class EvaluationContext:
    """Everything an SIE may look at. `contacts` is None when no simulation ran (geometry only)."""

    world: "WorldState"
    odb: "ObjectDatabase"
    contacts: tuple[Contact, ...] | None = None
    time: float = 0.0
    min_contact_force: float = 1e-3  # N: lighter contacts are numerical noise

    # --- objects ------------------------------------------------------------------------------
    def pose(self, name: str) -> Pose:
        return self.world.objects[name].pose

    def type_of(self, name: str) -> "ObjectType":
        if self.world.robot is not None and name == self.world.robot.name:
            return self.odb.get(self.world.robot.type)
        return self.odb.get(self.world.objects[name].type)

    def geometry(self, name: str) -> "Geometry":
        geometry = self.type_of(name).geometry
        if geometry is None:
            raise ValueError(f"object {name!r} has no geometry")
        return geometry

    def is_a(self, name: str, pddl_type: str) -> bool:
        return self.odb.pddl_is_a(self.type_of(name).pddl_type, pddl_type)

    def objects(self, pddl_type: str | None = None) -> list[str]:
        """Object names (robot excluded), optionally only those of a PDDL type."""
        return [n for n in self.world.objects if pddl_type is None or self.is_a(n, pddl_type)]

    @property
    def robot(self) -> str | None:
        return self.world.robot.name if self.world.robot is not None else None

    # --- contacts -----------------------------------------------------------------------------
    def contacts_of(self, name: str) -> list[Contact]:
        return [c for c in self.contacts or () if c.involves(name) and c.magnitude >= self.min_contact_force]

    def in_contact(self, a: str, b: str) -> bool:
        """Whether a and b touch (b may be a robot link prefix like 'robot/finger_left')."""
        return any(c.involves(b) for c in self.contacts_of(a))


class SIE:
    """Base class. Subclasses implement `evaluate`; `predicate` and `declaration` are set by the object database."""

    predicate: str = ""
    declaration: "PredicateDecl | None" = None

    def evaluate(self, obj: str, ctx: EvaluationContext) -> Sequence[Fact] | Fact | None:
        raise NotImplementedError

    def fact(self, *args: str) -> Fact:
        """A fact of this SIE's predicate."""
        return Fact(self.predicate, tuple(args))


def angle_between(a: Iterable[float], b: Iterable[float]) -> float:
    a, b = np.asarray(tuple(a), dtype=float), np.asarray(tuple(b), dtype=float)
    cos = float(a @ b / (np.linalg.norm(a) * np.linalg.norm(b)))
    return float(np.arccos(np.clip(cos, -1.0, 1.0)))
