"""What one simulation runs (`Rollout`), the process's scene cache, and running a rollout in this process.

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

SCENE_CACHE = 32  # diagrams kept per process (a tilted surface or a moved post is a new structure)


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


_SCENES: "OrderedDict[tuple, Scene]" = OrderedDict()


def scene_for(rollout: Rollout, odb: ObjectDatabase) -> Scene:
    """The diagram for the rollout's structure, built on first use in this process and kept (least recently used
    first out)."""
    key = (id(odb), str(odb.root), structure(rollout.world, odb), rollout.extras, rollout.config)
    scene = _SCENES.get(key)
    if scene is not None:
        _SCENES.move_to_end(key)
        return scene
    scene = build_scene(rollout.world, odb, rollout.config, extras=rollout.extras)
    _SCENES[key] = scene
    while len(_SCENES) > SCENE_CACHE:
        _SCENES.popitem(last=False)
    return scene


def run_rollout(rollout: Rollout, odb: ObjectDatabase, options: SimOptions = SimOptions(), *,
                on_sample: Callable[[float, Mapping[str, Pose], list[Contact]], None] | None = None,
                progress: Callable[[float, float], None] | None = None) -> ReplayResult:
    """Simulate `rollout` in this process (its scene from the cache). Raises `SimulationFailure` when the replay
    fails (see `bridge.sim.simulate.FailurePolicy`) and any other `BridgeError` for bad input."""
    result = simulate(scene_for(rollout, odb), rollout.telemetry, world=rollout.world, values=rollout.values,
                      hooks=rollout.hooks, options=options, on_sample=on_sample, progress=progress)
    return replace(result, frames=rollout.frames) if rollout.frames else result


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
