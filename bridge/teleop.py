"""One teleoperation session, end to end: recording -> replay in Drake -> SIEs -> new world state -> PDDL.

This is the paper's loop (Fig. 2). `infer_recording` runs it after the fact; with `events` it also emits the
symbolic changes while the replay runs (time-stamped JSON lines), the paper's on-line estimates.
"""
from __future__ import annotations

import json
import time as wallclock
from dataclasses import dataclass, replace
from typing import Callable, Mapping, TextIO

from .inference import InferenceResult, infer_state
from .odb import ObjectDatabase
from .recording.recording import Recording, recording_world
from .rollout.rollout import Rollout, run_rollout
from .sim.simulate import MOVED_ROTATION, MOVED_TRANSLATION, ReplayResult, SimOptions
from .values import Contact, Pose
from .world import WorldState


@dataclass(frozen=True)
class SessionResult:
    before: WorldState
    replay: ReplayResult
    inference: InferenceResult
    events: tuple[dict, ...] = ()
    seconds_to_state: float = 0.0  # wall time from the end of the replay to the inferred state


class _Follower:
    """Re-infers the state every `period` seconds of simulated time and reports what changed."""

    def __init__(self, before: WorldState, odb: ObjectDatabase, period: float, sink: Callable[[dict], None] | None):
        self.before, self.odb, self.period, self.sink = before, odb, period, sink
        self.facts = before.facts
        self.next_t = 0.0
        self.moved: set[str] = set()
        self.pairs: set[tuple[str, str]] = set()
        self.started = wallclock.perf_counter()
        self.events: list[dict] = []

    def __call__(self, t: float, poses: Mapping[str, Pose], contacts: list[Contact]) -> None:
        for name, pose in poses.items():
            start = self.before.objects[name].pose
            if start.translation_to(pose) > MOVED_TRANSLATION or start.rotation_to(pose) > MOVED_ROTATION:
                self.moved.add(name)
        self.pairs.update((c.body_a, c.body_b) for c in contacts)
        if t + 1e-9 < self.next_t:
            return
        self.next_t = t + self.period
        result = infer_state(self.before, self.odb, poses, contacts, self.moved, self.pairs, time=t)
        added, removed = result.world.facts - self.facts, self.facts - result.world.facts
        if added or removed:
            self.facts = result.world.facts
            wall = wallclock.perf_counter() - self.started
            event = {"t": round(t, 3), "wall_s": round(wall, 3), "ahead_s": round(t - wall, 3),
                     "added": sorted(map(str, added)), "removed": sorted(map(str, removed))}
            self.events.append(event)
            if self.sink is not None:
                self.sink(event)


def run_session(rollout: Rollout, odb: ObjectDatabase, *, options: SimOptions = SimOptions(),
                event_period: float | None = None, on_event: Callable[[dict], None] | None = None,
                progress: Callable[[float, float], None] | None = None) -> SessionResult:
    """Replay `rollout` (a recording's world before and telemetry, with any parameters applied) and infer the
    state after it."""
    before = rollout.world
    follower = _Follower(before, odb, event_period, on_event) if event_period else None
    options = replace(options, contacts=True, final_contacts=True, joint_track=True)
    result = run_rollout(rollout, odb, options, on_sample=follower, progress=progress)
    started = wallclock.perf_counter()
    inference = infer_state(before, odb, result.final_poses, result.final_contacts, result.moved,
                            result.contact_pairs(), time=result.sim_time)
    elapsed = wallclock.perf_counter() - started
    return SessionResult(before, result, inference, tuple(follower.events) if follower else (), elapsed)


def infer_recording(recording: Recording, odb: ObjectDatabase, *, config=None, **kwargs) -> SessionResult:
    """`run_session` on a recording folder (its world state before, its telemetry; `config` a `SimConfig`)."""
    rollout = Rollout(recording_world(recording, odb), recording.telemetry, name=recording.name)
    if config is not None:
        rollout = replace(rollout, config=config)
    return run_session(rollout, odb, **kwargs)


def json_lines(stream: TextIO) -> Callable[[dict], None]:
    def write(event: dict) -> None:
        stream.write(json.dumps(event) + "\n")
        stream.flush()

    return write
