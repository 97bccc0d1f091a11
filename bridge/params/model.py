"""A model: parameter values (`Setting`s, in order) and how they turn a rollout into the one simulated.

A fitted parameter file, a diagnosed scene file, a diagnosis' candidate and a proof's concealed truth are all
models. `apply_model` applies the settings in order; the members of a family (a post's x and y, a tilt's
slopes) are collected and built once, after the others, with the missing members at their null values.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

from ..errors import ParameterError
from ..odb import ObjectDatabase
from ..rollout.rollout import Rollout
from ..rollout.trials import Trial
from .kinds import Family, kind_named


@dataclass(frozen=True, order=True)
class Setting:
    """One value of one kind on one target. `effect` labels the effect it belongs to (reports, scene files);
    it takes no part in equality, so the same values are the same model whatever they were called."""

    kind: str
    target: str
    value: float
    effect: str = field(default="", compare=False)

    @property
    def name(self) -> str:
        return f"{self.kind}[{self.target}]"


Model = tuple[Setting, ...]


def apply_model(model: Sequence[Setting], rollout: Rollout, odb: ObjectDatabase, *, strict: bool = True,
                source: str | None = None) -> Rollout:
    """`rollout` with every setting applied. A setting whose target names nothing in the rollout's world is an
    error (`strict`) or skipped (a parameter file written for several recordings, each with its own objects)."""
    world = rollout.world
    families: dict[tuple[type[Family], str], dict[str, float]] = {}
    for s in model:
        kind = kind_named(s.kind)
        names = kind.select(s.target, world, odb)
        if not names:
            if strict:
                raise ParameterError(f"{s.name}: {s.target!r} names nothing in world {world.name!r}; "
                                  f"{kind.valid_targets([world], odb)}", source=source)
            continue
        if kind.family is not None:
            for name in names:
                families.setdefault((kind.family, name), {})[kind.component] = float(s.value)
        else:
            rollout = kind.apply(float(s.value), names, rollout, odb)
    for (family, target), values in families.items():
        rollout = family.realise(_with_nulls(family, values, world, odb, target), target, rollout, odb)
    return rollout


def canonical_model(model: Sequence[Setting], world, odb: ObjectDatabase) -> Model:
    """`model` without the settings that reproduce the world model: those of a kind that is `null_is_world` at its
    null value, and those of a kind `inert_without` another that the model no longer sets on that target. Two
    models with the same canonical form simulate the same thing (a diagnosis' candidate at its null values is the
    friction model it extends)."""
    kept = []
    for s in model:
        kind = kind_named(s.kind)
        if kind.null_is_world:
            try:
                null = kind.null(world, odb, s.target)
            except (ParameterError, KeyError):
                null = None
            if null is not None and float(s.value) == float(null):
                continue
        kept.append(s)
    return tuple(s for s in kept if kind_named(s.kind).inert_without is None
                 or any(o.kind == kind_named(s.kind).inert_without and o.target == s.target for o in kept))


def _with_nulls(family: type[Family], values: dict[str, float], world, odb, target) -> dict[str, float]:
    return {component: values[component] if component in values else kind_named(kind).null(world, odb, target)
            for component, kind in family.members.items()}


def trial_rollout(trial: Trial, model: Sequence[Setting], odb: ObjectDatabase, *, strict: bool = True) -> Rollout:
    """The rollout of a trial under `model`: the recording's world and telemetry, then the trial's base model
    (a diagnosed scene file), then `model`. A joint offset is relative to the raw recording (`raw_relative`)."""
    rollout = Rollout(trial.world, trial.telemetry, name=trial.name)
    return apply_model(raw_relative(tuple(trial.base) + tuple(model), trial), rollout, odb, strict=strict,
                       source=str(trial.source))


def raw_relative(model: Sequence[Setting], trial: Trial) -> Model:
    """`model` with every non-zero joint offset made relative to the raw recording. The loader moved the tip
    track of a rod recorded inside the object out of it (`StartClearance.shift`: a simulation cannot start in
    penetration); a model that says where the rod really was (true = raw + offset) replaces that repair, so the
    same offset means the same rod in every recording, repaired or not. At zero the repair stays: no offset is
    the recording as the loader made it replayable."""
    from dataclasses import replace

    from ..recording.adjustments import StartClearance

    shifts = {joint: value for a in trial.adjustments if isinstance(a, StartClearance) and a.moved
              for joint, value in zip(a.joints, a.shift)}
    if not shifts:
        return tuple(model)
    return tuple(replace(s, value=float(s.value) - shifts[s.target])
                 if s.kind == "joint_offset" and s.target in shifts and float(s.value) != 0.0 else s for s in model)
