"""What every effect shares: its parameters, how an applied effect changes a replay, and the evidence its
signature is read from.

An effect is one class with a small required surface (`name`, `targets`, `params`, `contribute`) and optional
hooks (`signature`, `seeds`, `describe`). `contribute` says how the effect enters the Drake replay, as data:

- scene values written into a context (`objects`: friction / mass / centre of mass, `forces`: constant external
  forces), no rebuild;
- a telemetry transform (`time_shift`, `joint_offsets`);
- scene extras (geometry added before Finalize, e.g. a welded post) - a new scene per distinct extra;
- context hooks run between samples (e.g. a friction region);
- pose overrides for the world before the replay (a tilted support fixture and what stands on it) - a new
  scene when a fixture moves.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, ClassVar, Mapping, Sequence

import numpy as np

from ...errors import DiagnosisError
from ...odb import ObjectDatabase
from ...odb.geometry import contains_xy, half_extents, z_range
from ...sim.scene import ObjectParams, SceneParams
from ...values import Pose
from ...world import WorldState


@dataclass(frozen=True)
class ParamSpec:
    """One parameter: bounds, the value at which the effect does nothing (`null`, where fits start), a
    typical size (`scale`: the finite-difference step and the unit of the normalised search space) and, when it
    has one, the departure from null below which it makes no physical difference worth reporting
    (`negligible`: a fit may still use it to soak up the start poses' error)."""

    name: str
    lower: float
    upper: float
    null: float
    scale: float
    unit: str = ""
    doc: str = ""
    negligible: float | None = None

    def __post_init__(self) -> None:
        if not (self.lower <= self.null <= self.upper) or not self.scale > 0:
            raise DiagnosisError(f"parameter {self.name!r}: need lower <= null <= upper and scale > 0, got "
                                 f"{self.lower}, {self.null}, {self.upper}, scale {self.scale}")


@dataclass(frozen=True)
class Applied:
    """An effect applied with values: what a scene file stores and what a replay resolves."""

    effect: str
    target: str
    params: tuple[tuple[str, float], ...] = ()

    @classmethod
    def of(cls, effect: str, target: str, values: Mapping[str, float] | None = None) -> "Applied":
        return cls(effect, target, tuple((k, float(v)) for k, v in (values or {}).items()))

    def values(self) -> dict[str, float]:
        return dict(self.params)


@dataclass(frozen=True)
class Contribution:
    """How an applied effect changes one replay (see the module docstring). Collections are tuples of pairs so
    the value is hashable and picklable."""

    objects: tuple[tuple[str, ObjectParams], ...] = ()
    forces: tuple[tuple[str, tuple[float, float, float]], ...] = ()
    time_shift: float = 0.0
    joint_offsets: tuple[tuple[str, float], ...] = ()
    extras: tuple = ()
    hooks: tuple = ()
    poses: tuple[tuple[str, Pose], ...] = ()


@dataclass(frozen=True)
class Evidence:
    """What an effect's signature reads: per (recording, object) features from the localisation, the recordings'
    world (shared structure) and the robot's joints. Built by `identify` from a `Localisation`."""

    features: tuple[Mapping[str, Any], ...]
    world: WorldState
    odb: ObjectDatabase
    joint_kinds: Mapping[str, str] = field(default_factory=dict)
    force_scale: float | None = None  # observed / simulated force on the robot while it pushes (None: no sensor)

    def significant(self) -> tuple[Mapping[str, Any], ...]:
        return tuple(f for f in self.features if f.get("significant"))

    def mean(self, key: str, default: float = 0.0, only_significant: bool = True) -> float:
        values = [f[key] for f in (self.significant() if only_significant else self.features)
                  if f.get(key) is not None and np.isfinite(f[key])]
        return float(np.mean(values)) if values else default


class Effect:
    """Base class. Subclasses set the class attributes and implement `targets`, `params`, `contribute`."""

    name: ClassVar[str] = ""
    summary: ClassVar[str] = ""  # one line: what is wrong in the world model
    mechanism: ClassVar[str] = ""  # how the model enters the replay: scene values / telemetry / extra / hook
    signature_text: ClassVar[str] = ""  # what it leaves in the residual, in words
    smooth: ClassVar[bool] = True  # False: no useful gradient at the null value; fits start from `seeds`

    def targets(self, world: WorldState, odb: ObjectDatabase, observed: Sequence[str]) -> tuple[str, ...]:
        raise NotImplementedError

    def params(self, world: WorldState, odb: ObjectDatabase, target: str) -> tuple[ParamSpec, ...]:
        raise NotImplementedError

    def contribute(self, world: WorldState, odb: ObjectDatabase, target: str,
                   values: Mapping[str, float]) -> Contribution:
        raise NotImplementedError

    # --- optional hooks --------------------------------------------------------------------------------------
    def signature(self, evidence: Evidence, target: str) -> float:
        """Plausibility in [0, 1] of this effect given the localisation; orders the search (default 0.5)."""
        return 0.5

    def seeds(self, evidence: Evidence, target: str) -> list[dict[str, float]]:
        """Starting values for a fit (default: the null values)."""
        return [{p.name: p.null for p in self.params(evidence.world, evidence.odb, target)}]

    def describe(self, world: WorldState, odb: ObjectDatabase, target: str,
                 values: Mapping[str, float]) -> dict[str, float]:
        """Derived quantities for the report (e.g. an angle and a direction from slope components)."""
        return {}

    def negligible(self, world: WorldState, odb: ObjectDatabase, target: str, values: Mapping[str, float]) -> bool:
        """True when every parameter that declares a `negligible` size is within it of its null value (then the
        effect adds nothing a user would act on; parameters without one, e.g. a mass the effect shares with
        `mass`, do not count). False when no parameter declares one."""
        sized = [p for p in self.params(world, odb, target) if p.negligible is not None]
        return bool(sized) and all(abs(values.get(p.name, p.null) - p.null) < p.negligible for p in sized)

    # --- shared helpers -----------------------------------------------------------------------------------------
    def null_values(self, world: WorldState, odb: ObjectDatabase, target: str) -> dict[str, float]:
        return {p.name: p.null for p in self.params(world, odb, target)}

    def check_values(self, world: WorldState, odb: ObjectDatabase, target: str,
                     values: Mapping[str, float], source: str | None = None) -> dict[str, float]:
        """Every parameter given, nothing unknown, inside the bounds (a scene file is user input)."""
        specs = {p.name: p for p in self.params(world, odb, target)}
        unknown = sorted(set(values) - set(specs))
        if unknown:
            raise DiagnosisError(f"effect {self.name!r} has no parameter {unknown[0]!r}; parameters: "
                                 f"{', '.join(specs) or 'none'}", source=source)
        out = {}
        for name, spec in specs.items():
            if name not in values:
                raise DiagnosisError(f"effect {self.name!r} needs parameter {name!r}", source=source)
            value = values[name]
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise DiagnosisError(f"effect {self.name!r}: {name} must be a finite number, got {value!r}",
                                     source=source)
            out[name] = float(value)
        return out


# --- world helpers shared by effects ----------------------------------------------------------------------------
def movable_objects(world: WorldState, odb: ObjectDatabase) -> tuple[str, ...]:
    return tuple(n for n, o in world.objects.items() if not odb.get(o.type).fixed)


def support_of(world: WorldState, odb: ObjectDatabase, name: str) -> str | None:
    """The fixture an object stands on: its footprint holds the object's centre and its top is the highest
    one below the object's bottom (within 2 cm)."""
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


def surface_top(world: WorldState, odb: ObjectDatabase, surface: str) -> float:
    o = world.objects[surface]
    return z_range(odb.get(o.type).geometry, o.pose)[1]


def footprint_half(world: WorldState, odb: ObjectDatabase, name: str) -> np.ndarray:
    """Half extents (x, y, z) of an object's bounding box in its own frame."""
    return half_extents(odb.get(world.objects[name].type).geometry)


def merge_object_params(a: ObjectParams, b: ObjectParams) -> ObjectParams:
    """b's values where it has them, a's elsewhere."""
    return replace(a, **{k: v for k, v in vars(b).items() if v is not None})


def scene_params(contributions: Sequence[Contribution]) -> SceneParams:
    objects: dict[str, ObjectParams] = {}
    forces: dict[str, np.ndarray] = {}
    for c in contributions:
        for name, p in c.objects:
            objects[name] = merge_object_params(objects.get(name, ObjectParams()), p)
        for name, f in c.forces:
            forces[name] = forces.get(name, np.zeros(3)) + np.asarray(f, dtype=float)
    return SceneParams(objects=objects, external_forces={n: tuple(float(x) for x in f) for n, f in forces.items()})
