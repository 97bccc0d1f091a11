"""What one simulation runs (`Rollout`), the scene cache (one per thread), and running a rollout in this process.

Every replay in bridge goes through here: `bridge infer`, the demo, the viewer's scene, a fit's candidates, a
diagnosis' models, the proof's generated recordings. A `Rollout` is a plain value (picklable, sent to worker
processes as it is): the world before, the scene values written into a context, the telemetry the robot follows,
extra geometry, context hooks and the simulator's settings. Parameter kinds (`bridge.params`) turn parameter
values into a rollout; nothing else decides what is simulated.

The scene cache is keyed on structure only: the objects and their types, where the fixtures stand, the robot and
its base, the extras and the simulator's settings. Free objects' poses, scene values and telemetry go into a
fresh context per replay, so recordings of one scene share one diagram however their objects start.
"""
from __future__ import annotations

import math
import threading
import time as wallclock
from collections import OrderedDict
from dataclasses import dataclass, field, replace
from typing import Callable, Mapping

from ..errors import SimulationFailure
from ..odb import ObjectDatabase
from ..recording.telemetry import Telemetry
from ..sim.contacts import contacts_at_start
from ..sim.scene import Scene, SceneValues, SimConfig, build_scene
from ..sim.simulate import ReplayResult, SimOptions, simulate, start_replay
from ..values import Contact, Pose
from ..world import WorldState

SCENE_CACHE = 32  # diagrams kept per thread (a tilted surface or a moved post is a new structure)


@dataclass(frozen=True, eq=False)
class Rollout:
    """What is simulated. `name` says where it comes from (a trial, a recording) for messages."""

    world: WorldState
    telemetry: Telemetry | None
    values: SceneValues = field(default_factory=SceneValues)
    extras: tuple = ()
    hooks: tuple = ()
    config: SimConfig = field(default_factory=SimConfig)
    name: str = ""
    # (object, X_BR): the pose of the frame the recording tracks on an object, in the object's body frame (a
    # tracker's markers off the object's centre, turned); the replay reports it beside the body's poses
    # (`ReplayResult.observed_track`), the world's poses stay the bodies'
    frames: tuple[tuple[str, Pose], ...] = ()
    # quasi-static replay: the telemetry played this many times faster and every output put back on the
    # recording's clock (`run_rollout`); 1 simulates the recording as it ran
    time_scale: float = 1.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.time_scale) and self.time_scale >= 1.0):
            raise ValueError(f"Rollout.time_scale must be a finite number >= 1, got {self.time_scale!r}")

    def with_world(self, world: WorldState) -> "Rollout":
        return replace(self, world=world)

    def with_values(self, values: SceneValues) -> "Rollout":
        return replace(self, values=values)

    def with_telemetry(self, telemetry: Telemetry) -> "Rollout":
        return replace(self, telemetry=telemetry)

    def with_extras(self, *extras) -> "Rollout":
        return replace(self, extras=self.extras + tuple(extras))

    def with_hooks(self, *hooks) -> "Rollout":
        return replace(self, hooks=self.hooks + tuple(hooks))

    def with_frame(self, name: str, frame: Pose) -> "Rollout":
        return replace(self, frames=tuple((n, f) for n, f in self.frames if n != name) + ((name, frame),))


def structure(world: WorldState, odb: ObjectDatabase) -> tuple:
    """What a diagram depends on: objects and their types, fixtures' poses, the robot and its base."""
    objects = tuple(sorted((n, o.type, o.pose if odb.get(o.type).fixed else None) for n, o in world.objects.items()))
    robot = None if world.robot is None else (world.robot.name, world.robot.type, world.robot.base_pose)
    return objects, robot


_LOCAL = threading.local()  # each thread its own scenes: a scene runs one replay at a time (`sim.sources`)


def scene_for(rollout: Rollout, odb: ObjectDatabase) -> Scene:
    """The diagram for the rollout's structure, built on first use in this thread and kept (least recently used
    first out)."""
    scenes: "OrderedDict[tuple, Scene]" = _LOCAL.__dict__.setdefault("scenes", OrderedDict())
    key = (id(odb), str(odb.root), structure(rollout.world, odb), rollout.extras, rollout.config)
    scene = scenes.get(key)
    if scene is not None:
        scenes.move_to_end(key)
        return scene
    scene = build_scene(rollout.world, odb, rollout.config, extras=rollout.extras)
    scenes[key] = scene
    while len(scenes) > SCENE_CACHE:
        scenes.popitem(last=False)
    return scene


def run_rollout(rollout: Rollout, odb: ObjectDatabase, options: SimOptions = SimOptions(), *,
                on_sample: Callable[[float, Mapping[str, Pose], list[Contact]], None] | None = None,
                progress: Callable[[float, float], None] | None = None) -> ReplayResult:
    """Simulate `rollout` in this process (its scene from the cache). Raises `SimulationFailure` when the replay
    fails (see `bridge.sim.simulate.FailurePolicy`) and any other `BridgeError` for bad input. Times given to
    `on_sample` and `progress`, and every time in the result, are the recording's (see `quasi_static`)."""
    k = rollout.time_scale
    telemetry = rollout.telemetry
    if k != 1.0:
        telemetry, options = quasi_static(telemetry, options, k)
        on_sample = (lambda t, poses, contacts, f=on_sample: f(t * k, poses, contacts)) if on_sample else None
        progress = (lambda t, end, f=progress: f(t * k, end * k)) if progress else None
    result = simulate(scene_for(rollout, odb), telemetry, world=rollout.world, values=rollout.values,
                      hooks=rollout.hooks, options=options, on_sample=on_sample, progress=progress)
    if k != 1.0:
        result = on_recording_clock(result, k)
    return replace(result, frames=rollout.frames) if rollout.frames else result


def quasi_static(telemetry: Telemetry | None, options: SimOptions, k: float) -> tuple[Telemetry | None, SimOptions]:
    """The telemetry played `k` times faster (its clock from 0 divided by k) and the options that sample it at
    the same points of the motion.

    Why: a slow push is quasi-static. Its path is set by friction and geometry, not by speed, as long as the
    inertial forces stay small against friction: m v^2 / L against mu m g, a few thousandths at 25 mm/s on a
    path that turns over L = 5 cm with mu = 0.3. Most of a slow recording's cost is steps in which nothing
    dynamic happens; played faster, the same motion takes 1/k of the steps. What it changes: the robot's servo
    lags k times as far behind its telemetry while it moves, and an object coasts (k v)^2 / (2 mu g) after it
    stops (measured on real 10 mm/s MIT pushes of ellip3: 0.15 mm at most along the track at k = 2, 0.2 mm at
    2.5, against the dataset's ~0.1 mm pose noise and millimetres of model error); the diagnosis takes it only
    where that is small against what it explains (`diagnosis.runs.choose_time_scales`). A latency or any other
    telemetry change is applied before, on the recording's clock."""
    if telemetry is not None:
        telemetry = replace(telemetry, times=telemetry.times / k)
    end = options.end / k if options.end is not None else None
    return telemetry, replace(options, sample_rate=options.sample_rate * k, settle=options.settle / k, end=end)


def on_recording_clock(result: ReplayResult, k: float) -> ReplayResult:
    """A replay of telemetry played `k` times faster (`quasi_static`) with its times put back on the recording's
    clock; positions, poses and forces stay as simulated."""
    def later(contacts):
        return tuple(replace(c, time=c.time * k) for c in contacts)
    return replace(result, times=result.times * k, contact_log=later(result.contact_log),
                   final_contacts=later(result.final_contacts), sim_time=result.sim_time * k,
                   awake=tuple((a * k, b * k) for a, b in result.awake))


def check_rollout(rollout: Rollout, odb: ObjectDatabase) -> Scene:
    """Everything `run_rollout` does before its first step (the scene built, the context made, the telemetry
    checked against the robot, the hooks started), without simulating: a rollout that passes starts replaying."""
    scene = scene_for(rollout, odb)
    start_replay(scene, rollout.telemetry, world=rollout.world, values=rollout.values, hooks=rollout.hooks)
    return scene


def start_contacts(rollout: Rollout, odb: ObjectDatabase) -> list[Contact]:
    """What touches what in the rollout's world before anything moves (contacts and near pairs)."""
    return contacts_at_start(scene_for(rollout, odb), rollout.world, rollout.values)


# --- jobs for executors -----------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Job:
    """One rollout to simulate somewhere, and what to record."""

    rollout: Rollout
    options: SimOptions = field(default_factory=SimOptions)


@dataclass(frozen=True, eq=False)
class Outcome:
    """A job's result: the replay, or why it failed (a `SimulationFailure`: counted and reported by the caller,
    never mistaken for a result). Times are those of the process that ran it; an outcome from the rollout cache
    (`cached`) cost none."""

    name: str
    result: ReplayResult | None
    failure: str | None = None
    wall_time: float = 0.0
    cpu_time: float = 0.0
    cached: bool = False

    @property
    def failed(self) -> bool:
        return self.failure is not None


def job_key(job: Job) -> str | None:
    """A stable key of what a job simulates and records: the SHA-256 of its pickle, the rollout's `name` (a label
    for messages) left out. Equal keys mean equal jobs (the pickle determines the value), so a cached outcome is
    the outcome; two equal jobs built differently may get different keys (a dictionary in another order), which
    only costs a simulation. None when the job cannot be pickled (it could not go to a worker process either)."""
    import hashlib
    import pickle

    try:
        data = pickle.dumps(Job(replace(job.rollout, name=""), job.options), protocol=pickle.HIGHEST_PROTOCOL)
    except Exception:  # noqa: BLE001 - e.g. a hook holding a lock or a Drake object: not cached, simulated
        return None
    return hashlib.sha256(data).hexdigest()


def outcome_bytes(outcome: Outcome) -> int:
    """About how much memory an outcome holds (its arrays and contacts), for the cache's bound."""
    r = outcome.result
    if r is None:
        return 512
    arrays = [r.times, *r.tracks.values(), r.joint_track, r.robot_force]
    return 1024 + sum(a.nbytes for a in arrays if a is not None) + 160 * (len(r.contact_log) + len(r.final_contacts))


class RolloutCache:
    """Outcomes of jobs already simulated, by `job_key`: least recently used first out once more than
    `max_bytes` (approximate, `outcome_bytes`) or `max_entries` are held. Simulations are deterministic, so a
    repeated job (the nominal model in several stages of a diagnosis, an optimiser evaluating its start again)
    gets the outcome of the first. Counts what was simulated and what came from here."""

    def __init__(self, max_bytes: int = 256 * 2 ** 20, max_entries: int = 4096):
        self.max_bytes, self.max_entries = max_bytes, max_entries
        self._entries: "OrderedDict[str, tuple[Outcome, int]]" = OrderedDict()
        self.bytes = 0
        self.simulated = 0  # jobs simulated through the executor that owns this cache
        self.cached = 0  # jobs answered from here

    def get(self, key: str | None) -> Outcome | None:
        if key is None or key not in self._entries:
            return None
        self._entries.move_to_end(key)
        return self._entries[key][0]

    def put(self, key: str | None, outcome: Outcome) -> None:
        if key is None or key in self._entries or self.max_entries <= 0:
            return
        size = outcome_bytes(outcome)
        if size > self.max_bytes:
            return
        _freeze(outcome)
        self._entries[key] = (outcome, size)
        self.bytes += size
        while self._entries and (self.bytes > self.max_bytes or len(self._entries) > self.max_entries):
            _, (_, dropped) = self._entries.popitem(last=False)
            self.bytes -= dropped

    def __len__(self) -> int:
        return len(self._entries)

    def counts(self) -> dict[str, int]:
        return {"simulated": self.simulated, "cached": self.cached}


def _freeze(outcome: Outcome) -> None:
    """A cached outcome is shared by every job that asks for it: its arrays become read-only."""
    r = outcome.result
    if r is None:
        return
    for a in (r.times, *r.tracks.values(), r.joint_track, r.robot_force):
        if a is not None:
            a.setflags(write=False)


def served(outcome: Outcome, job: Job) -> Outcome:
    """A cached outcome as the answer to `job`: its name, no time spent."""
    return replace(outcome, name=job.rollout.name, wall_time=0.0, cpu_time=0.0, cached=True)


def run_job(job: Job, odb: ObjectDatabase) -> Outcome:
    """Run one job; a failed simulation is an `Outcome` with its message, every other error propagates (bad input
    must reach the user, not be scored)."""
    started, cpu = wallclock.perf_counter(), wallclock.process_time()
    try:
        result = run_rollout(job.rollout, odb, job.options)
    except SimulationFailure as exc:
        return Outcome(job.rollout.name, None, str(exc), wallclock.perf_counter() - started,
                       wallclock.process_time() - cpu)
    return Outcome(job.rollout.name, result, None, result.wall_time, result.cpu_time)
