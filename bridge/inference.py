"""The inference module (paper, Section III-D): turn a simulated geometric state into the new symbolic state.

Only objects that moved, plus those that touched one that moved, are re-evaluated (and the robot, which always
moves during teleoperation). For each, every predicate its type provides with an SIE is decided again: the
object's old facts of that predicate are replaced by what the SIE returns. Every other fact is kept.
An SIE that raises or returns malformed facts is reported and leaves its predicate's facts as they were.

State Inference Entities (SIEs) are small classifiers, stored with object types, that turn geometry into
facts. An SIE gets the object's name and an `EvaluationContext` (every pose, the contacts and their forces,
the other objects and their types, the object database) and returns the ground facts of its predicate that hold for that
object -- an empty list when none does. Unlike the paper's ``[name, predicate, value]`` lists, a result is a
sequence of typed `Fact`s, so n-ary and multi-valued predicates need no convention.

Writing one::

    from bridge.inference import SIE

    class Upright(SIE):
        def __init__(self, max_tilt_deg: float = 20.0):
            self.max_tilt = math.radians(max_tilt_deg)

        def evaluate(self, obj, ctx):
            tilt = angle_between(ctx.pose(obj).z_axis(), (0, 0, 1))
            return [self.fact(obj)] if tilt < self.max_tilt else []
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Iterable, Mapping, Sequence

import numpy as np

from .errors import BridgeError
from .odb import Geometry, ObjectDatabase, ObjectType, PredicateDecl
from .values import Contact, Fact, Pose
from .world import WorldState, check_fact



# --- SIEs ---------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class EvaluationContext:
    """Everything an SIE may look at. `contacts` is None when no simulation ran (geometry only)."""

    world: WorldState
    odb: ObjectDatabase
    contacts: tuple[Contact, ...] | None = None
    time: float = 0.0
    min_contact_force: float = 1e-3  # N: lighter contacts are numerical noise

    # --- objects ------------------------------------------------------------------------------
    def pose(self, name: str) -> Pose:
        return self.world.objects[name].pose

    def type_of(self, name: str) -> ObjectType:
        if self.world.robot is not None and name == self.world.robot.name:
            return self.odb.get(self.world.robot.type)
        return self.odb.get(self.world.objects[name].type)

    def geometry(self, name: str) -> Geometry:
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
    declaration: PredicateDecl | None = None

    def evaluate(self, obj: str, ctx: EvaluationContext) -> Sequence[Fact] | Fact | None:
        raise NotImplementedError

    def fact(self, *args: str) -> Fact:
        """A fact of this SIE's predicate."""
        return Fact(self.predicate, tuple(args))


def angle_between(a: Iterable[float], b: Iterable[float]) -> float:
    a, b = np.asarray(tuple(a), dtype=float), np.asarray(tuple(b), dtype=float)
    cos = float(a @ b / (np.linalg.norm(a) * np.linalg.norm(b)))
    return float(np.arccos(np.clip(cos, -1.0, 1.0)))


# --- inference ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SIEFailure:
    object: str
    predicate: str
    sie: str
    message: str

    def __str__(self) -> str:
        return f"SIE {self.sie} for ({self.predicate} ...) of object {self.object!r} failed: {self.message}; its facts were kept"


@dataclass(frozen=True)
class InferenceResult:
    world: WorldState  # poses after the simulation, facts inferred
    evaluated: tuple[str, ...]
    added: frozenset[Fact]
    removed: frozenset[Fact]
    failures: tuple[SIEFailure, ...] = ()


def select_objects(world: WorldState, moved: Iterable[str], contact_pairs: Iterable[tuple[str, str]]) -> tuple[str, ...]:
    """Moved objects, objects that touched a moved one, and the robot; in world order."""
    moved = set(moved)
    touched = set()
    for a, b in contact_pairs:
        a, b = a.split("/")[0], b.split("/")[0]
        if a in moved:
            touched.add(b)
        if b in moved:
            touched.add(a)
    chosen = moved | touched
    names = [n for n in world.objects if n in chosen]
    if world.robot is not None:
        names.append(world.robot.name)
    return tuple(names)


def infer_state(
    before: WorldState,
    odb: ObjectDatabase,
    poses: Mapping[str, Pose],
    contacts: Sequence[Contact] | None,
    moved: Iterable[str],
    contact_pairs: Iterable[tuple[str, str]] = (),
    *,
    time: float = 0.0,
) -> InferenceResult:
    """Re-decide the facts of the selected objects in the world with the new `poses` and final `contacts`."""
    after = before.with_poses(poses)
    ctx = EvaluationContext(after, odb, tuple(contacts) if contacts is not None else None, time)
    selected = select_objects(before, moved, contact_pairs)
    replaced: dict[tuple[str, str, int], frozenset[Fact]] = {}
    failures: list[SIEFailure] = []
    for name in selected:
        obj_type = odb.get(after.type_name(name))
        for predicate, decl in obj_type.predicates.items():
            sie = odb.sie(obj_type.name, predicate)
            if sie is None:
                continue
            try:
                facts = _validated(sie.evaluate(name, ctx), name, decl.subject, predicate, after, odb)
            except Exception as exc:  # an SIE is user code: any failure is reported, never fatal
                message = str(exc) if isinstance(exc, BridgeError) else f"{type(exc).__name__}: {exc}"
                failures.append(SIEFailure(name, predicate, str(decl.sie), message))
                continue
            replaced[(predicate, name, decl.subject)] = facts
    def decided(f: Fact) -> bool:
        return any(f.predicate == p and len(f.args) > i and f.args[i] == name for (p, name, i) in replaced)

    stale = {f for f in before.facts if decided(f)}
    new = frozenset().union(*replaced.values()) if replaced else frozenset()
    facts = (before.facts - stale) | new
    # what was uncertain before stays so unless it was decided again
    kept = {f: p for f, p in before.probabilities.items() if not decided(f)}
    world = replace(after.with_facts(facts), probabilities=kept, samples=before.samples if kept else 0)
    return InferenceResult(
        world=world, evaluated=selected,
        added=facts - before.facts, removed=before.facts - facts, failures=tuple(failures))


def _validated(result, obj: str, subject: int, predicate: str, world: WorldState, odb: ObjectDatabase) -> frozenset[Fact]:
    """An SIE's return value as facts about `obj`, or a BridgeError saying what is wrong with it."""
    if result is None:
        return frozenset()
    if isinstance(result, Fact):
        result = [result]
    if isinstance(result, (str, bytes)) or not isinstance(result, Iterable):
        raise BridgeError(f"returned {result!r}; expected a list of Fact")
    facts = []
    for item in result:
        if not isinstance(item, Fact):
            raise BridgeError(f"returned {item!r}; expected Fact objects like Fact('{predicate}', ({obj!r}, ...))")
        if item.predicate != predicate:
            raise BridgeError(f"returned {item} for predicate {predicate!r}")
        if len(item.args) <= subject or item.args[subject] != obj:
            raise BridgeError(f"returned {item}, which is not about {obj!r} (argument {subject + 1})")
        check_fact(item, world, odb, None, "result", error=BridgeError)
        facts.append(item)
    return frozenset(facts)
