"""Run a model (a tuple of applied effects) on trials and return residuals against the observations.

A model resolves, per trial, to a `Setup`: scene values, a telemetry transform, scene extras and context hooks.
Scenes are cached per process by (world structure, extras), so only effects that add geometry build new ones.
`Engine` runs (model, trial) tasks serially or on a pool of worker processes, each with its own scene cache;
trials and observed series are sent to the workers once, when the pool starts.
"""
from __future__ import annotations

import math
import multiprocessing
import os
from collections import OrderedDict
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np

from ..errors import BridgeError, DiagnosisError
from ..odb import ObjectDatabase
from ..recording.telemetry import Telemetry
from ..sim.scene import SceneParams, SimConfig
from ..values import Contact
from ..world import WorldState
from .effects import Applied, get_effect
from .effects.base import Contribution, scene_params
from .residuals import (ForceSeries, ObservedSeries, force_normalised, force_residual, force_series, normalised,
                        observed_series, residual, sample_track)

Model = tuple[Applied, ...]
FAILED_RESIDUAL = 1.0e3  # per normalised component of a replay that failed: far worse than any fit
SCENE_CACHE = 6


@dataclass(frozen=True)
class TelemetryTransform:
    """Shift (s, positive = the robot moved later) and per-joint offsets added to recorded telemetry."""

    time_shift: float = 0.0
    joint_offsets: tuple[tuple[str, float], ...] = ()

    def apply(self, telemetry: Telemetry) -> Telemetry:
        out = telemetry
        offsets = {j: v for j, v in self.joint_offsets if v != 0.0}
        if offsets:
            out = out.with_offsets(offsets)
        if self.time_shift != 0.0:
            out = out.shifted(self.time_shift)
        return out

    @property
    def is_identity(self) -> bool:
        return self.time_shift == 0.0 and not any(v for _, v in self.joint_offsets)


@dataclass(frozen=True)
class Setup:
    """What a model does to one replay."""

    params: SceneParams = field(default_factory=SceneParams)
    telemetry: TelemetryTransform = TelemetryTransform()
    extras: tuple = ()
    hooks: tuple = ()
    poses: tuple = ()  # (name, Pose) overrides of the world before the replay

    def world(self, world: WorldState) -> WorldState:
        return world.with_poses(dict(self.poses)) if self.poses else world


def combine(contributions: Sequence[Contribution]) -> Setup:
    offsets: dict[str, float] = {}
    for c in contributions:
        for j, v in c.joint_offsets:
            offsets[j] = offsets.get(j, 0.0) + v
    return Setup(scene_params(contributions),
                 TelemetryTransform(sum(c.time_shift for c in contributions), tuple(offsets.items())),
                 tuple(e for c in contributions for e in c.extras), tuple(h for c in contributions for h in c.hooks),
                 tuple(p for c in contributions for p in c.poses))


def resolve(model: Model, world: WorldState, odb: ObjectDatabase) -> Setup:
    """The setup of `model` for a trial of `world`."""
    return combine([get_effect(a.effect).contribute(world, odb, a.target, a.values()) for a in model])


# --- trials prepared for residuals -------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Prepared:
    """A trial with its observed series (per observed object that the world has as a free body) and, when the
    robot's force was recorded, its force series."""

    name: str
    world: WorldState
    telemetry: Telemetry
    series: tuple[ObservedSeries, ...]
    end: float  # s simulated
    force: ForceSeries | None = None

    @property
    def objects(self) -> tuple[str, ...]:
        return tuple(s.object for s in self.series)


def prepare(trial: Any, odb: ObjectDatabase, rate: float = 25.0) -> Prepared:
    """`trial` has name, world, telemetry, observations (a `bridge.fit.trials.Trial`)."""
    series = []
    for track in trial.observations:
        if track.object not in trial.world.objects:
            raise DiagnosisError(f"observed object {track.object!r} is not in the world state",
                                 source=str(getattr(trial, "source", trial.name)))
        if odb.get(trial.world.objects[track.object].type).fixed:
            continue
        series.append(observed_series(track, rate))
    if not series:
        raise DiagnosisError("no observed free object to compare with", source=str(getattr(trial, "source", trial.name)))
    force = getattr(trial, "force", None)
    force = force_series(force, rate) if force is not None and trial.world.robot is not None else None
    last_obs = max(float(s.times[-1]) for s in series)
    end = max(last_obs, float(trial.telemetry.times[-1])) + 0.02
    return Prepared(trial.name, trial.world, trial.telemetry, tuple(series), end, force)


@dataclass(frozen=True, eq=False)
class Run:
    """One model on one trial: residual (n, 6) per observed object and (n, 3) of the robot's force when it was
    recorded, optionally the simulated tracks and contacts."""

    trial: str
    residuals: Mapping[str, np.ndarray]
    normalised: np.ndarray  # every object's measured components / sigma, then the force's, flattened
    failed: str | None = None
    sim_times: np.ndarray | None = None
    tracks: Mapping[str, np.ndarray] | None = None
    contacts: tuple[Contact, ...] = ()
    wall: float = 0.0
    force_residual: np.ndarray | None = None
    force_chi2: float = 0.0  # the force rows' share of chi2
    force_n: int = 0

    @property
    def chi2(self) -> float:
        return float(self.normalised @ self.normalised)


# --- the per-process worker ---------------------------------------------------------------------------------------
class _Worker:
    """Holds the object database, the prepared trials and a small scene cache."""

    def __init__(self, odb: ObjectDatabase, prepared: Sequence[Prepared], config: SimConfig, sample_rate: float):
        self.odb, self.prepared, self.config, self.sample_rate = odb, list(prepared), config, sample_rate
        self.scenes: OrderedDict = OrderedDict()

    def scene(self, world: WorldState, extras: tuple):
        from ..sim.scene import build_scene

        key = (world_key(world), extras)
        if key in self.scenes:
            self.scenes.move_to_end(key)
            return self.scenes[key]
        scene = build_scene(world, self.odb, self.config, extras=extras)
        self.scenes[key] = scene
        while len(self.scenes) > SCENE_CACHE:
            self.scenes.popitem(last=False)
        return scene

    def run(self, index: int, model: Model, want_tracks: bool, want_contacts: bool) -> Run:
        from ..sim.tracks import simulate_tracks

        p = self.prepared[index]
        try:
            setup = resolve(model, p.world, self.odb)
            world = setup.world(p.world)
            scene = self.scene(world, setup.extras)
            telemetry = setup.telemetry.apply(p.telemetry)
            result = simulate_tracks(scene, telemetry, world=world, params=setup.params, end=p.end,
                                     sample_rate=self.sample_rate, hooks=setup.hooks, contacts=want_contacts,
                                     robot_force=p.force is not None)
        except BridgeError as exc:
            return _failed(p, str(exc))
        except RuntimeError as exc:  # Drake's own errors (e.g. a geometry it cannot mesh)
            return _failed(p, f"Drake: {exc}")
        residuals, parts = {}, []
        for s in p.series:
            xyz, R = sample_track(result.times, result.tracks[s.object], s.times)
            r = residual(s, xyz, R)
            residuals[s.object] = r
            parts.append(normalised(s, r))
        f_res, f_norm = None, np.zeros(0)
        if p.force is not None:
            f_res = force_residual(p.force, result.times, result.robot_force)
            f_norm = force_normalised(p.force, f_res)
            parts.append(f_norm)
        return Run(p.name, residuals, np.concatenate(parts), None,
                   result.times if want_tracks else None,
                   {k: v for k, v in result.tracks.items()} if want_tracks else None,
                   result.contact_log if want_contacts else (), result.wall_time, f_res, float(f_norm @ f_norm),
                   int(f_norm.size))


def _failed(p: Prepared, message: str) -> Run:
    n = sum(int(s.measured.sum()) * len(s.times) for s in p.series)
    n_force = 0 if p.force is None else int(p.force.measured.sum()) * len(p.force.times)
    residuals = {s.object: np.full((len(s.times), 6), np.nan) for s in p.series}
    return Run(p.name, residuals, np.full(n + n_force, FAILED_RESIDUAL), message,
               force_chi2=n_force * FAILED_RESIDUAL ** 2, force_n=n_force)


def world_key(world: WorldState) -> tuple:
    """What a scene's structure depends on: objects and their types, fixture poses, the robot and its base."""
    objects = tuple(sorted((n, o.type, o.pose.xyz + o.pose.quat) for n, o in world.objects.items()))
    robot = None if world.robot is None else (world.robot.name, world.robot.type,
                                              world.robot.base_pose.xyz + world.robot.base_pose.quat)
    return objects, robot


_WORKER: _Worker | None = None


def _init_worker(odb_root: str, datasets: Mapping[str, str], prepared, config, sample_rate) -> None:
    global _WORKER
    from ..odb import load_object_database

    odb = load_object_database(odb_root, datasets=datasets)
    _WORKER = _Worker(odb, prepared, config, sample_rate)


def _run_task(task) -> Run:
    return _WORKER.run(*task)


class Engine:
    """Runs models on prepared trials; `workers` > 1 uses a process pool (spawned once, reused)."""

    def __init__(self, prepared: Sequence[Prepared], odb: ObjectDatabase, *, config: SimConfig = SimConfig(),
                 sample_rate: float = 50.0, workers: int = 1):
        self.prepared = list(prepared)
        self.odb, self.config, self.sample_rate = odb, config, sample_rate
        self.workers = max(1, int(workers))
        self.local = _Worker(odb, self.prepared, config, sample_rate)
        self.pool: ProcessPoolExecutor | None = None
        self.simulations = 0
        self.wall = 0.0

    def index(self, name: str) -> int:
        for i, p in enumerate(self.prepared):
            if p.name == name:
                return i
        raise DiagnosisError(f"no trial named {name!r}")

    def _pool(self) -> ProcessPoolExecutor:
        if self.pool is None:
            ctx = multiprocessing.get_context("spawn")
            datasets = {k: str(v) for k, v in self.odb.datasets.items()}
            self.pool = ProcessPoolExecutor(self.workers, mp_context=ctx, initializer=_init_worker,
                                            initargs=(str(self.odb.root), datasets, self.prepared, self.config,
                                                      self.sample_rate))
        return self.pool

    def run_many(self, models: Sequence[Model], indices: Sequence[int], *, tracks: bool = False,
                 contacts: bool = False) -> list[list[Run]]:
        """runs[m][k]: model m on trial indices[k]."""
        tasks = [(i, tuple(m), tracks, contacts) for m in models for i in indices]
        self.simulations += len(tasks)
        if self.workers == 1 or len(tasks) == 1:
            results = [self.local.run(*t) for t in tasks]
        else:
            results = list(self._pool().map(_run_task, tasks, chunksize=1))
        self.wall += sum(r.wall for r in results)
        k = len(indices)
        return [results[m * k:(m + 1) * k] for m in range(len(models))]

    def run(self, model: Model, indices: Sequence[int], *, tracks: bool = False, contacts: bool = False) -> list[Run]:
        return self.run_many([model], indices, tracks=tracks, contacts=contacts)[0]

    def close(self) -> None:
        if self.pool is not None:
            self.pool.shutdown(cancel_futures=True)
            self.pool = None

    def __enter__(self) -> "Engine":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def default_workers() -> int:
    return max(1, min(2, os.cpu_count() or 1))


def chi2_of(runs: Sequence[Run]) -> tuple[float, int]:
    """Total chi^2 and number of normalised residual values over runs."""
    return float(sum(r.chi2 for r in runs)), int(sum(r.normalised.size for r in runs))


def vector_of(runs: Sequence[Run]) -> np.ndarray:
    return np.concatenate([r.normalised for r in runs]) if runs else np.zeros(0)


def isfinite_runs(runs: Sequence[Run]) -> bool:
    return all(r.failed is None for r in runs) and all(math.isfinite(r.chi2) for r in runs)
