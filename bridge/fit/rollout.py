"""Rollout: simulate trials with given parameter values and score them with the paper's error (eq. 1-4).

One Drake diagram per trial *structure* (objects and their types, fixture poses, robot and its base) is built
per process and kept in a module-level cache; every evaluation writes its parameters into a fresh context
(`Scene.new_context`), so a fit never rebuilds a diagram. Drake's discrete solver is deterministic, so each
trial is simulated once per candidate (the paper's K = 1).

Comparison: every observation after t = 0 is compared with the simulated pose at its time (linear position,
normalised-lerp orientation between the replay's samples). A sparse observation (before / after) taken at or
after the end of the telemetry is compared with the final pose, after `Trial.settle` seconds at rest.
A simulation that fails (`SimulationFailure`) scores `FAILURE_ERROR` on each of its samples and is reported.
"""
from __future__ import annotations

import time as wallclock
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from ..errors import FitError, SimulationFailure
from ..odb import ObjectDatabase
from ..sim.replay import ReplayOptions, ReplayResult, replay
from ..sim.scene import Scene, SimConfig, build_scene
from ..values import quat_to_rotation
from .error import DEFAULT_C, PoseError, pose_error_arrays
from .params import ParameterSpec, apply_params
from .trials import Trial

FAILURE_ERROR = 1.0  # m: the per-sample error of a failed simulation (large, finite, so optimisers can rank it)
SAMPLE_RATE = 50.0  # Hz of the replay's pose tracks the observations are interpolated in
_CACHE_SIZE = 128
_SCENES: dict[tuple, Scene] = {}


@dataclass(frozen=True)
class TrialError:
    """A trial's error for one parameter vector; `failure` says why the simulation failed (error is then
    `FAILURE_ERROR` per sample)."""

    trial: str
    error: PoseError
    failure: str | None = None
    wall_time: float = 0.0  # s, in the process that simulated it
    cpu_time: float = 0.0  # s of CPU that process spent on it (wall_time minus waiting for a busy machine)

    @property
    def failed(self) -> bool:
        return self.failure is not None


def evaluate(trials: Sequence[Trial], spec: ParameterSpec, x: Sequence[float] | None, *, odb: ObjectDatabase,
             c: float = DEFAULT_C, config: SimConfig = SimConfig()) -> tuple[PoseError, tuple[TrialError, ...]]:
    """The error over all `trials` for free-parameter values `x` (parameter units, `spec.names` order; None:
    the start values) and each trial's own."""
    if not trials:
        raise FitError("evaluate needs at least one trial")
    errors = tuple(evaluate_trial(t, spec, x, odb=odb, c=c, config=config) for t in trials)
    return PoseError.merge(e.error for e in errors), errors


def evaluate_trial(trial: Trial, spec: ParameterSpec, x: Sequence[float] | None, *, odb: ObjectDatabase,
                   c: float = DEFAULT_C, config: SimConfig = SimConfig()) -> TrialError:
    started, cpu = wallclock.perf_counter(), wallclock.process_time()
    try:
        result = simulate_trial(trial, spec, x, odb=odb, config=config)
    except SimulationFailure as exc:
        count = sum(len(_compared_times(trial, track)) for track in trial.observations if track.object in trial.world.objects)
        failed = PoseError(FAILURE_ERROR, 0.0, FAILURE_ERROR, max(count, 1))
        return TrialError(trial.name, failed, str(exc), wallclock.perf_counter() - started,
                          wallclock.process_time() - cpu)
    error = compare(trial, result, c)
    return TrialError(trial.name, error, None, wallclock.perf_counter() - started, wallclock.process_time() - cpu)


def simulate_trial(trial: Trial, spec: ParameterSpec | None, x: Sequence[float] | None, *, odb: ObjectDatabase,
                   config: SimConfig = SimConfig(), sample_rate: float = SAMPLE_RATE) -> ReplayResult:
    """Replay one trial with the parameters applied, in this process's cached scene for its structure."""
    if spec is None:
        params, telemetry = trial.base_params, trial.telemetry
    else:
        params, telemetry = apply_params(spec, x, trial.world, trial.telemetry, odb, base=trial.base_params)
    scene = scene_for(trial, odb, config)
    options = ReplayOptions(sample_rate=sample_rate, settle=trial.settle)
    return replay(scene, telemetry, world=trial.world, params=params, options=options)


def scene_for(trial: Trial, odb: ObjectDatabase, config: SimConfig = SimConfig()) -> Scene:
    """The cached diagram for the trial's structure, built on first use in this process."""
    key = _structure(trial, odb, config)
    scene = _SCENES.get(key)
    if scene is None:
        if len(_SCENES) >= _CACHE_SIZE:
            _SCENES.pop(next(iter(_SCENES)))
        scene = _SCENES[key] = build_scene(trial.world, odb, config, extras=trial.extras)
    return scene


def _structure(trial: Trial, odb: ObjectDatabase, config: SimConfig) -> tuple:
    world = trial.world
    objects = tuple((n, o.type, o.pose if odb.get(o.type).fixed else None) for n, o in world.objects.items())
    robot = None if world.robot is None else (world.robot.name, world.robot.type, world.robot.base_pose)
    return (str(odb.root), id(odb), objects, robot, config, repr(trial.extras))


# --- comparison ----------------------------------------------------------------------------------------------
def compare(trial: Trial, result: ReplayResult, c: float = DEFAULT_C) -> PoseError:
    """The paper's error between the simulated and the observed poses of the trial's observed objects."""
    t_obs, R_obs, t_sim, R_sim = [], [], [], []
    for track in trial.observations:
        if track.object not in result.tracks:
            continue  # a fixture: it cannot move in simulation
        times = _compared_times(trial, track)
        if not len(times):
            continue
        index = np.searchsorted(track.times, times)
        poses = [track.poses[i] for i in index]
        t_obs.append(np.array([p.xyz for p in poses]))
        R_obs.append(np.array([p.rotation() for p in poses]))
        xyz, R = simulated_poses(result, track.object, _query_times(trial, times, result))
        t_sim.append(xyz)
        R_sim.append(R)
    if not t_obs:
        raise FitError("no observed pose of a free object after t = 0 to compare with", source=str(trial.source))
    return pose_error_arrays(np.concatenate(t_obs), np.concatenate(R_obs), np.concatenate(t_sim),
                             np.concatenate(R_sim), c)


def _compared_times(trial: Trial, track) -> np.ndarray:
    return track.times[track.times > 0]


def _query_times(trial: Trial, times: np.ndarray, result: ReplayResult) -> np.ndarray:
    if trial.observations.is_dense:
        return np.clip(times, 0.0, result.times[-1])
    return np.where(times >= trial.telemetry.end, result.times[-1], np.clip(times, 0.0, result.times[-1]))


def simulated_poses(result: ReplayResult, name: str, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions (N, 3) and rotation matrices (N, 3, 3) of `name` at `times`, interpolated between samples."""
    track = result.tracks[name]
    xyz = np.column_stack([np.interp(times, result.times, track[:, k]) for k in range(3)])
    quats = track[:, 3:7].copy()
    for k in range(1, len(quats)):  # one hemisphere, so neighbours interpolate the short way
        if quats[k] @ quats[k - 1] < 0:
            quats[k] = -quats[k]
    q = np.column_stack([np.interp(times, result.times, quats[:, k]) for k in range(4)])
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return xyz, np.array([quat_to_rotation(row) for row in q])


def merge_errors(errors: Sequence[TrialError]) -> PoseError:
    return PoseError.merge(e.error for e in errors)


def failures(errors: Sequence[TrialError]) -> Mapping[str, str]:
    return {e.trial: e.failure for e in errors if e.failed}


# --- the ordinary parameters ----------------------------------------------------------------------------------
FRICTION_BOUNDS = (0.05, 1.2)


def default_spec(trials: Sequence[Trial], odb: ObjectDatabase, config: SimConfig = SimConfig()) -> ParameterSpec:
    """What `bridge fit` fits without --params: the friction of every object observed to move and of what it
    touches at the start (its support, neighbours), each starting at its object-database value (or a diagnosed
    scene file's, under `bridge fit --scene`).

    Contacts are read from each trial's initial state (no simulation), robot links and the floor left out.
    """
    from ..sim.replay import PROXIMITY, ContactReader, MOVED_ROTATION, MOVED_TRANSLATION
    from .params import PARAMETER_KINDS, ParamSpec

    names: dict[str, float] = {}  # name -> start (its type's friction), in order of appearance
    for trial in trials:
        robot = trial.world.robot.name if trial.world.robot is not None else None
        moved = [tr.object for tr in trial.observations if tr.object in trial.world.objects and any(
            tr.initial().translation_to(p) > MOVED_TRANSLATION or tr.initial().rotation_to(p) > MOVED_ROTATION
            for p in tr.poses)]
        scene = scene_for(trial, odb, config)
        contacts = ContactReader(scene).read(scene.new_context(trial.world), 0.0, proximity=PROXIMITY)
        touched = [c.other(name) for name in moved for c in contacts if name in (c.body_a, c.body_b)]
        for name in [*moved, *touched]:
            if name in trial.world.objects and not (robot and name.startswith(robot + "/")):
                scene_value = trial.base_params.objects.get(name) if trial.base_params else None
                mu = scene_value.friction if scene_value else None
                names.setdefault(name, mu if mu is not None else odb.get(trial.world.objects[name].type).physics.friction)
    if not names:
        raise FitError("no observed object moves in the trials, so there is no friction to fit; pass --params")
    lo, hi = FRICTION_BOUNDS
    entries = tuple(ParamSpec(PARAMETER_KINDS["friction"], name, bounds=FRICTION_BOUNDS,
                              start=min(hi, max(lo, start))) for name, start in names.items())
    return ParameterSpec(entries, source="default parameters (friction of the moved objects and what they touch)")
