"""What every effect shares. An effect is a named bundle of parameter kinds (`bridge.params.kinds`) on a target,
plus what a diagnosis reads to find it (its signature, seeds to start fits from) and, optionally, how the proof
conceals it in a generated world by a physical mechanism other than the model the diagnosis fits.

Required surface: `name`, `kinds` (and `targets`). Optional hooks: `members` (which kind on which target, when
not all on the effect's target), `fixed` (kinds held at a value while the effect applies), `judged_by` (the
kinds whose negligible size decides whether the effect is worth reporting), `reduces_to` (the effect nested in
this one, e.g. `mass` in `com_offset`), `signature`, `seeds`, `describe`;
for the proof `draw_truth`, `conceal` and `recovered`.

Parameters are named as everywhere in bridge: ``kind[target]`` (e.g. ``com_x[block]``).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar, Mapping, Sequence

import numpy as np

from ...errors import DiagnosisError
from ...odb import ObjectDatabase
from ...params import Parameter, ParameterSet, Setting, kind_named
from ...params.surfaces import movable_objects
from ...world import WorldState

FRICTION_KINDS = ("friction", "dynamic_friction", "sliding_friction", "robot_friction")


def model_friction(model: Sequence[Setting], world: WorldState, odb: ObjectDatabase, name: str) -> float:
    """The dynamic coefficient `name` (an object or 'robot/link') has under `model`'s friction settings, whichever
    kinds set it (a pair coefficient moves its partners', `kinds.PairFriction`)."""
    from ...params.kinds import current_friction
    from ...params.model import apply_model
    from ...rollout.rollout import Rollout

    rollout = apply_model([s for s in model if s.kind in FRICTION_KINDS], Rollout(world, None), odb)
    return current_friction(rollout, odb, name)


@dataclass(frozen=True)
class Evidence:
    """What an effect's signature reads: per (recording, object) features from the localisation, the recordings'
    world (shared structure). Built by `identify` from a `Localisation`."""

    features: tuple[Mapping[str, Any], ...]
    world: WorldState
    odb: ObjectDatabase
    force_scale: float | None = None  # observed / simulated force on the robot while it pushes (None: no sensor)
    # what the loader's evidence says (`bridge.diagnosis.loader`): the share of recordings whose rod started inside
    # the object beyond the noise, the calibration offset the evidence implies (m per robot joint, relative to the
    # raw recording), whether it shows before any simulation (start penetrations, contact gaps)
    started_inside: float = 0.0
    loader_offset: Mapping[str, float] | None = None
    offset_evident: bool = False
    # the recorded frame on the focus object that the pushing samples imply (`diagnosis.outline`), by parameter
    # name, when they make it evident (None otherwise)
    frame: Mapping[str, float] | None = None
    # how far outside (> 0) or inside the modelled outline the rod pushed on every side (m, `loader.ContactFit`),
    # when the contact gaps make it evident (None otherwise): a larger or smaller object, or a stiffer contact
    inflation: float | None = None
    # the latency the contact gaps of recordings pushed at different speeds measure (s, `loader.ContactFit`), when
    # they make it evident (None otherwise)
    latency: float | None = None
    # the downhill slope (sin(theta) x the downhill unit vector, world x-y) that balances the work the robot did on
    # the object (`diagnosis.work`: a seed, no measurement), when it is pinned and not negligible (None otherwise)
    slope: tuple[float, float] | None = None

    def significant(self) -> tuple[Mapping[str, Any], ...]:
        return tuple(f for f in self.features if f.get("significant"))

    def mean(self, key: str, default: float = 0.0, only_significant: bool = True) -> float:
        values = [f[key] for f in (self.significant() if only_significant else self.features)
                  if f.get(key) is not None and np.isfinite(f[key])]
        return float(np.mean(values)) if values else default


@dataclass(frozen=True, eq=False)
class Truth:
    """What the proof concealed: effect, target, the parameters the diagnosis should recover (by name), and how."""

    effect: str
    target: str
    params: dict[str, float]
    mechanism: str
    extra: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return {"effect": self.effect, "target": self.target, "params": self.params, "mechanism": self.mechanism,
                **({"extra": self.extra} if self.extra else {})}


@dataclass(frozen=True)
class Recovery:
    """Did a diagnosis find the concealed parameters? The tolerance is stated in `text`."""

    ok: bool
    error: float | None  # the compared quantity's error, in its unit
    unit: str
    text: str


class Effect:
    """Base class. Subclasses set the class attributes and implement `targets`."""

    name: ClassVar[str] = ""
    summary: ClassVar[str] = ""  # one line: what is wrong in the world model
    mechanism: ClassVar[str] = ""  # how the model enters the replay: scene values / telemetry / poses / extra
    signature_text: ClassVar[str] = ""  # what it leaves in the residual, in words
    smooth: ClassVar[bool] = True  # False: no useful gradient at the null value; fits start from `seeds`
    local: ClassVar[bool] = False  # True: it sits at one place of a surface; pushes that miss it do not show it
    # True: its seeds come from the work the robot did (`diagnosis.work`), which reads them jointly with a sliding
    # coefficient, so its screen also starts from that coefficient where the friction fit contradicts it
    reads_work: ClassVar[bool] = False
    kinds: ClassVar[tuple[str, ...]] = ()
    fixed: ClassVar[Mapping[str, float]] = {}
    judged_by: ClassVar[tuple[str, ...] | None] = None  # None: every kind with a negligible size
    reduces_to: ClassVar[str | None] = None  # the effect nested in this one, which a fit whose own (`judged_by`)
    #                                          parameters are negligible is (`identify._nested`)

    def targets(self, world: WorldState, odb: ObjectDatabase, observed: Sequence[str]) -> tuple[str, ...]:
        raise NotImplementedError

    def members(self, world: WorldState, odb: ObjectDatabase, target: str) -> tuple[tuple[str, str], ...]:
        """(kind, target) of each parameter, in order (default: every kind on the effect's target)."""
        return tuple((k, target) for k in self.kinds)

    # --- parameters and models -----------------------------------------------------------------------------
    def parameters(self, world: WorldState, odb: ObjectDatabase, target: str) -> tuple[Parameter, ...]:
        """The free parameters (starting at the world model's values) and the fixed ones."""
        free = tuple(Parameter.of(k, t, world, odb, effect=self.name) for k, t in self.members(world, odb, target))
        held = tuple(Parameter(kind_named(k), target, value=v, effect=self.name) for k, v in self.fixed.items())
        return free + held

    def parameter_set(self, world: WorldState, odb: ObjectDatabase, target: str) -> ParameterSet:
        return ParameterSet(self.parameters(world, odb, target), source=f"effect {self.name} on {target}")

    def null_values(self, world: WorldState, odb: ObjectDatabase, target: str) -> dict[str, float]:
        return {p.name: p.start for p in self.parameters(world, odb, target) if p.free}

    def model(self, world: WorldState, odb: ObjectDatabase, target: str,
              values: Mapping[str, float]) -> tuple[Setting, ...]:
        """The effect's settings at `values` (by parameter name; missing ones at their null)."""
        params = self.parameter_set(world, odb, target)
        unknown = sorted(set(values) - set(params.names))
        if unknown:
            raise DiagnosisError(f"effect {self.name!r} on {target!r} has no parameter {unknown[0]!r}; parameters: "
                                 f"{', '.join(params.names) or 'none'}")
        return params.model([values.get(n, p.start) for n, p in zip(params.names, params.free)])

    # --- optional hooks --------------------------------------------------------------------------------------
    def signature(self, evidence: Evidence, target: str) -> float:
        """Plausibility in [0, 1] of this effect given the localisation; orders the search (default 0.5)."""
        return 0.5

    def seeds(self, evidence: Evidence, target: str) -> list[dict[str, float]]:
        """Starting values for a fit, by parameter name (default: the null values)."""
        return [self.null_values(evidence.world, evidence.odb, target)]

    def fit_region(self, start: Mapping[str, float], target: str) -> dict[str, tuple[float, float]]:
        """Bounds (by parameter name) that the screen's step from the best seed and the full fit from the screened
        point (`start`) keep to, within the kinds' own (default: none). A local effect's place stays near where the evidence seeded it: moved far away it
        explains other recordings than those that showed it, another hypothesis."""
        return {}

    def describe(self, world: WorldState, odb: ObjectDatabase, target: str,
                 values: Mapping[str, float]) -> dict[str, float]:
        """Derived quantities for the report (e.g. an angle and a direction from slope components)."""
        return {}

    def negligible(self, world: WorldState, odb: ObjectDatabase, target: str, values: Mapping[str, float]) -> bool:
        """True when every parameter that counts (`judged_by`) and declares a negligible size is within it of its
        null value: then the effect adds nothing a user would act on. False when none declares one."""
        sized = []
        for kind_name, kind_target in self.members(world, odb, target):
            if self.judged_by is not None and kind_name not in self.judged_by:
                continue
            kind = kind_named(kind_name)
            size = kind.negligible(world, odb, kind_target)
            if size is not None:
                name = f"{kind_name}[{kind_target}]"
                null = kind.null(world, odb, kind_target)
                sized.append(abs(values.get(name, null) - null) < size)
        return bool(sized) and all(sized)

    # --- the proof (optional) ----------------------------------------------------------------------------------
    def draw_truth(self, scene, odb: ObjectDatabase, rng: np.random.Generator, magnitude: int,
                   sign: float) -> Truth:
        """The concealed values of a proof case (magnitude 0, 1, 2: small, medium, large; `sign` +-1 when the
        effect can go either way); `scene` is a `bridge.prove.scenes.SceneSpec`."""
        raise DiagnosisError(f"the proof cannot conceal effect {self.name!r}")

    def conceal(self, truth: Truth, scene, odb: ObjectDatabase, rollout):
        """(the true rollout, the telemetry the recorder writes) of one generated recording, from the exact
        `rollout` of the world model: the effect made by a physical mechanism, not by the model."""
        raise DiagnosisError(f"the proof cannot conceal effect {self.name!r}")

    def recorded_track(self, truth: Truth, track: np.ndarray) -> np.ndarray:
        """What the recorder reports of an object's true (T, 7) track (default: the track; a tracker that follows
        another frame on the object changes it)."""
        return track

    def target_matches(self, concealed: str, found: str, world: WorldState, odb: ObjectDatabase) -> bool:
        """Whether a diagnosis that names `found` found the concealed target."""
        return found == concealed

    def recovered(self, truth: Truth, found: Mapping[str, float], model: Sequence[Setting], world: WorldState,
                  odb: ObjectDatabase) -> Recovery:
        """Whether `found` (the winner's parameters) matches `truth`, within a tolerance stated in the text."""
        return Recovery(False, None, "", f"no recovery check for {self.name}")


# --- helpers shared by effects ----------------------------------------------------------------------------------
def movable_observed(world: WorldState, odb: ObjectDatabase, observed: Sequence[str]) -> tuple[str, ...]:
    movable = movable_objects(world, odb)
    return tuple(n for n in observed if n in movable)


def pname(kind: str, target: str) -> str:
    """A parameter's name: ``kind[target]``."""
    return f"{kind}[{target}]"
