"""A fit's objective: trials replayed under parameter values and scored with the paper's error (eq. 1-4).

Every candidate's trials go to the executor as one batch of rollouts (`bridge.rollout`). Each trial is simulated
once per candidate (Drake's discrete solver is deterministic: the paper's K = 1), until its last observation, or
`Trial.settle` after the telemetry when the observations are sparse (before / after). A failed simulation is
counted and reported with its message; its samples score `compare.FAILED` so an optimiser ranks it last.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from ..errors import FitError
from ..odb import ObjectDatabase
from ..params import ParameterSet, Parameter, kind_named, trial_rollout
from ..rollout.compare import DEFAULT_C, PoseError, error_of_residuals, least_squares_vector, observed_residuals
from ..rollout.executors import Executor
from ..rollout.rollout import Job, start_contacts
from ..rollout.trials import Trial
from ..sim.simulate import MOVED_ROTATION, MOVED_TRANSLATION, ReplayResult, SimOptions

SAMPLE_RATE = 50.0  # Hz of the replay's pose tracks the observations are interpolated in
FRICTION_BOUNDS = (0.05, 1.2)  # of the ordinary parameters `bridge fit` fits without --params


@dataclass(frozen=True)
class TrialError:
    """A trial's error for one parameter vector; `failure` says why its simulation failed."""

    trial: str
    error: PoseError
    failure: str | None = None
    wall_time: float = 0.0  # s, in the process that simulated it
    cpu_time: float = 0.0  # s of CPU that process spent on it (wall_time minus waiting for a busy machine)

    @property
    def failed(self) -> bool:
        return self.failure is not None


def sim_options(trial: Trial) -> SimOptions:
    return SimOptions(sample_rate=SAMPLE_RATE, settle=trial.settle)


def jobs_for(trials: Sequence[Trial], spec: ParameterSet, values: Sequence[float] | None,
             odb: ObjectDatabase) -> list[Job]:
    """One job per trial: its rollout under `spec` at `values` (parameter units; None: the start values)."""
    model = spec.model(values)
    return [Job(trial_rollout(t, model, odb, strict=False), sim_options(t)) for t in trials]


def residuals_of(trial: Trial, result: ReplayResult | None, odb: ObjectDatabase) -> list[np.ndarray]:
    """The trial's (n, 6) pose residuals against a replay (None: failed) on its observed free objects."""
    free = {n for n, o in trial.world.objects.items() if not odb.get(o.type).fixed}
    return observed_residuals(trial.observations, free, trial.telemetry.end, result)


@dataclass(frozen=True, eq=False)
class Evaluation:
    """One parameter vector on every trial: each trial's error, and the residual vector whose squared norm is the
    paper's E^2 over all of them (what Levenberg-Marquardt minimises)."""

    errors: tuple[TrialError, ...]
    vector: np.ndarray

    @property
    def error(self) -> PoseError:
        return PoseError.merge(e.error for e in self.errors)


def evaluate(executor: Executor, trials: Sequence[Trial], spec: ParameterSet,
             xs: Sequence[Sequence[float] | None], *, c: float = DEFAULT_C) -> list[Evaluation]:
    """Every trial under every parameter vector (`xs[i]` in parameter units; None: the start values), one batch."""
    if not trials:
        raise FitError("evaluate needs at least one trial")
    jobs = [job for x in xs for job in jobs_for(trials, spec, x, executor.odb)]
    outcomes = executor.run(jobs)
    n = len(trials)
    out = []
    for i in range(len(xs)):
        errors, rows = [], []
        for trial, outcome in zip(trials, outcomes[i * n:(i + 1) * n]):
            residuals = residuals_of(trial, outcome.result, executor.odb)
            rows.extend(residuals)
            errors.append(TrialError(trial.name, error_of_residuals(residuals, c), outcome.failure,
                                     outcome.wall_time, outcome.cpu_time))
        out.append(Evaluation(tuple(errors), least_squares_vector(rows, c)))
    return out


def merge_errors(errors: Sequence[TrialError]) -> PoseError:
    return PoseError.merge(e.error for e in errors)


def failures(errors: Sequence[TrialError]) -> Mapping[str, str]:
    return {e.trial: e.failure for e in errors if e.failed}


# --- the ordinary parameters ----------------------------------------------------------------------------------
def default_spec(trials: Sequence[Trial], odb: ObjectDatabase) -> ParameterSet:
    """What `bridge fit` fits without --params: the friction of every object observed to move and of what it
    touches at the start (its support, neighbours), each starting at its object-database value, or at the value
    of the trials' base model (a diagnosed scene file, under `bridge fit --scene`).

    Contacts are read from each trial's initial state (no simulation), robot links and the floor left out.
    """
    friction = kind_named("friction")
    names: dict[str, float] = {}  # name -> start, in order of appearance
    for trial in trials:
        robot = trial.world.robot.name if trial.world.robot is not None else None
        moved = [tr.object for tr in trial.observations if tr.object in trial.world.objects and any(
            tr.initial().translation_to(p) > MOVED_TRANSLATION or tr.initial().rotation_to(p) > MOVED_ROTATION
            for p in tr.poses)]
        rollout = trial_rollout(trial, (), odb)
        contacts = start_contacts(rollout, odb)
        touched = [c.other(name) for name in moved for c in contacts if name in (c.body_a, c.body_b)]
        for name in [*moved, *touched]:
            if name in trial.world.objects and not (robot and name.startswith(robot + "/")):
                base = rollout.values.objects.get(name)
                mu = base.friction if base is not None else None
                names.setdefault(name, mu if mu is not None else friction.null(trial.world, odb, name))
    if not names:
        raise FitError("no observed object moves in the trials, so there is no friction to fit; pass --params")
    lo, hi = FRICTION_BOUNDS
    entries = tuple(Parameter(friction, name, bounds=FRICTION_BOUNDS, start=min(hi, max(lo, start)))
                    for name, start in names.items())
    return ParameterSet(entries, source="default parameters (friction of the moved objects and what they touch)")
