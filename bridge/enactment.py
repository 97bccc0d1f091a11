"""Enact action templates in simulation: their bodies' telemetry, replayed in Drake, written as recordings.

This is `bridge act` and how the demo's recordings are made (demo/make_demo.py). A plan of several actions
becomes ONE telemetry: each body is planned from the world the simulation reached after the previous one (poses
and inferred facts), starting where the previous telemetry ended, so e.g. a place starts with the object between
the fingers that picked it. The simulated poses before and after are stored as sparse observations, so fitting
has something to compare with, and the notes say which actions were enacted.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable, Mapping, Sequence

import numpy as np

from .errors import ActionError
from .inference import infer_state
from .odb import ObjectDatabase
from .planning.apply import PlanStep, apply_action
from .planning.templates import ActionTemplate
from .recording.observations import ObservedPoses, ObservedTrack
from .recording.recording import Recording, check_recording_folder, save_recording
from .recording.telemetry import Telemetry
from .bodies import BODIES, world_after_replay
from .rollout.rollout import Rollout, run_rollout
from .sim.simulate import ReplayResult, SimOptions
from .values import Pose
from .world import WorldState, load_world_state

STEP_PAUSE = 0.2  # s between two actions' telemetry
REPLAY = SimOptions(contacts=True, final_contacts=True, joint_track=True)  # what inference and the next body read

FreeMotion = Callable[[WorldState, int, float], "Telemetry | None"]
"""Operator free motion between actions: called with the world (its robot where the telemetry so far ends), the
number of steps done (0: before the first) and the seconds of telemetry so far; returns telemetry to insert
there (starting at the robot's joints), or None. Free motion changes no object, so nothing is replayed for it."""


@dataclass(frozen=True)
class Enactment:
    """A plan enacted in simulation: the telemetry, the replay of all of it, and the worlds along the way."""

    telemetry: Telemetry
    replay: ReplayResult
    before: WorldState
    after: WorldState  # simulated poses, inferred facts
    expected: WorldState  # the templates' effects applied to `before`
    steps: tuple[PlanStep, ...]

    @property
    def matches(self) -> bool:
        """The inferred facts are exactly the templates' effects."""
        return self.after.facts == self.expected.facts


def body_for(templates: Mapping[str, ActionTemplate], action: str):
    """The body (motion generator) of an action template."""
    template = templates.get(action.lower()) or templates.get(action)
    if template is None:
        raise ActionError(f"unknown action {action!r}; actions: {', '.join(sorted(templates))}")
    if template.body is None:
        raise ActionError(f"action {template.name!r} has no body (no 'body:' in {template.source})")
    if template.body not in BODIES:
        raise ActionError(f"action {template.name!r}: unknown body {template.body!r} ({template.source}); bodies: "
                          f"{', '.join(BODIES)}")
    return template, BODIES[template.body]


def enact(world: WorldState, odb: ObjectDatabase, templates: Mapping[str, ActionTemplate],
          steps: Sequence[PlanStep | tuple[str, Sequence[str]]], *, rng=None,
          free_motion: FreeMotion | None = None) -> Enactment:
    """`plan_telemetry`, then replay all of it from `world` and infer the world after."""
    steps = _steps(steps)
    telemetry, expected = plan_telemetry(world, odb, templates, steps, rng=rng, free_motion=free_motion)
    result, after = _replay(world, telemetry, odb)
    return Enactment(telemetry, result, world, after, expected, steps)


def _replay(world: WorldState, telemetry: Telemetry, odb: ObjectDatabase) -> tuple[ReplayResult, WorldState]:
    """Replay `telemetry` from `world` and the world it ends in (simulated poses, inferred facts, the robot's
    joints where it stood at the end)."""
    result = run_rollout(Rollout(world, telemetry), odb, REPLAY)
    inferred = infer_state(world, odb, result.final_poses, result.final_contacts, result.moved,
                           result.contact_pairs(), time=result.sim_time)
    return result, world_after_replay(world, result, inferred.world.facts)


def plan_telemetry(world: WorldState, odb: ObjectDatabase, templates: Mapping[str, ActionTemplate],
                   steps: Sequence[PlanStep | tuple[str, Sequence[str]]], *, rng=None,
                   free_motion: FreeMotion | None = None) -> tuple[Telemetry, WorldState]:
    """The joined telemetry of the steps' bodies and the world the templates' effects lead to. Each body after the
    first is planned from the world the simulation reached after the one before (simulated poses, inferred facts,
    the robot's joints where the last telemetry ended). Preconditions are checked on the expected states.
    `free_motion` may insert operator free motion before the first step and after each (see `FreeMotion`)."""
    steps = _steps(steps)
    if not steps:
        raise ActionError("nothing to enact: the plan has no steps")
    expected = world
    current = world
    pieces: list[Telemetry] = []

    def add_free_motion(done: int) -> None:
        if free_motion is not None:
            piece = free_motion(_with_joints(current, pieces[-1]) if pieces else current, done, _joined_end(pieces))
            if piece is not None:
                pieces.append(piece)

    add_free_motion(0)
    for number, step in enumerate(steps, start=1):
        _, body = body_for(templates, step.action)
        expected = apply_action(expected, odb, templates, step.action, step.args)  # checks the precondition
        if pieces:
            current = _with_joints(current, pieces[-1])  # start where the last telemetry ended
        pieces.append(body(current, odb, list(step.args), rng=rng))
        if number < len(steps) or free_motion is not None:  # free motion keeps clear of where objects went
            current = _replay(current, pieces[-1], odb)[1]
        add_free_motion(number)
    source = " then ".join(map(str, steps)) + (" with free motion" if free_motion is not None else "")
    return join_telemetry(pieces, source=source), expected


def _steps(steps) -> tuple[PlanStep, ...]:
    return tuple(s if isinstance(s, PlanStep) else PlanStep(s[0], tuple(s[1])) for s in steps)


def _joined_end(pieces: Sequence[Telemetry]) -> float:
    """Where `join_telemetry(pieces)` would end (0 for none)."""
    return sum(p.times[-1] - p.times[0] for p in pieces) + STEP_PAUSE * max(0, len(pieces) - 1)


def join_telemetry(pieces: Sequence[Telemetry], source: str = "<joined>") -> Telemetry:
    """One telemetry from several, each starting `STEP_PAUSE` after the last ended (same joints, same order)."""
    times, rows = [pieces[0].times], [pieces[0].positions]
    for piece in pieces[1:]:
        if piece.joint_names != pieces[0].joint_names:
            raise ActionError(f"cannot join telemetry of joints {list(piece.joint_names)} to {list(pieces[0].joint_names)}")
        offset = times[-1][-1] + STEP_PAUSE - piece.times[0]
        times.append(piece.times + offset)
        rows.append(piece.positions)
    return Telemetry(np.round(np.concatenate(times), 6), pieces[0].joint_names, np.vstack(rows), source=source)


def _with_joints(world: WorldState, telemetry: Telemetry) -> WorldState:
    """`world` with its robot's joints at the telemetry's last sample (the commanded end of the last action)."""
    joints = dict(world.robot.joints)
    joints.update({n: float(v) for n, v in zip(telemetry.joint_names, telemetry.positions[-1])})
    return replace(world, robot=replace(world.robot, joints=tuple(joints.items())))


def observed_poses(world: WorldState, result: ReplayResult, odb: ObjectDatabase) -> ObservedPoses:
    """Sparse observations of every movable object: its pose before and its simulated pose at the end."""
    final = {n: Pose(tuple(np.round(p.xyz, 6)), tuple(np.round(p.quat, 6))) for n, p in result.final_poses.items()}
    tracks = [ObservedTrack(name, np.array([0.0, round(result.sim_time, 6)]), (obj.pose, final[name]))
              for name, obj in world.objects.items() if name in final and not odb.get(obj.type).fixed]
    return ObservedPoses(tuple(tracks), source="simulated")


def make_recording(world_path: str | Path, action: str, args: Sequence[str], out_folder: str | Path,
                   odb: ObjectDatabase, templates: Mapping[str, ActionTemplate], *, overwrite: bool = False,
                   rng=None) -> Recording:
    """`bridge act`: one action's body as a recording folder (world.yaml copied, telemetry.csv, observed.csv with
    the simulated poses before and after, recording.yaml naming the action). The folder is checked before the
    simulation and written as a whole (an interrupted run leaves the old folder or none); a non-empty one is
    refused unless `overwrite`."""
    return make_plan_recording(world_path, [(action, tuple(args))], out_folder, odb, templates, overwrite=overwrite,
                               rng=rng)


def make_plan_recording(world_path: str | Path, steps: Sequence[PlanStep | tuple[str, Sequence[str]]],
                        out_folder: str | Path, odb: ObjectDatabase, templates: Mapping[str, ActionTemplate], *,
                        name: str | None = None, overwrite: bool = False, rng=None,
                        free_motion: FreeMotion | None = None) -> Recording:
    """Several actions in one telemetry, written as a recording folder (see `make_recording`)."""
    check_recording_folder(out_folder, overwrite)  # before the simulation, not after it
    world_path = Path(world_path)
    world = load_world_state(world_path, odb)
    done = enact(world, odb, templates, steps, rng=rng, free_motion=free_motion)
    return save_enactment(done, world_path, out_folder, odb, name=name, overwrite=overwrite)


def save_enactment(done: Enactment, world_path: str | Path, out_folder: str | Path, odb: ObjectDatabase, *,
                   name: str | None = None, overwrite: bool = False, note: str = "") -> Recording:
    """An enactment as a recording folder: `world_path` (the world it started from) copied, its telemetry, the
    simulated poses before and after as observations, the actions and whether the facts came out as the templates
    say in the notes (with `note` after them)."""
    plan = " ".join(map(str, done.steps))
    verdict = ("the inferred facts equal the templates' effects" if done.matches else
               f"WARNING: the inferred facts differ from the templates' effects (missing "
               f"{' '.join(map(str, sorted(done.expected.facts - done.after.facts))) or 'none'}, extra "
               f"{' '.join(map(str, sorted(done.after.facts - done.expected.facts))) or 'none'})")
    notes = (f"actions: {plan}. Generated by bridge act from the action templates' bodies; observed.csv holds the "
             f"simulated poses before and after (not a real observation). In simulation {verdict}."
             + (f" {note}" if note else ""))
    world = done.before
    metadata = {"name": name or Path(out_folder).name, "robot": world.robot.type if world.robot else None,
                "notes": notes}
    return save_recording(out_folder, Path(world_path), done.telemetry, observed_poses(world, done.replay, odb),
                          {k: v for k, v in metadata.items() if v is not None}, overwrite=overwrite)
