"""Scripted teleoperation sessions: a plan of actions on a table with the operator's free motion between them,
enacted from the action templates' bodies (`bridge.enactment`) and written as a recording folder.

A real session is mostly free motion with short contact phases; this is what the session benchmark
(benchmarks/session_benchmark.py) replays, and what tests make short versions of. Free motion
(`bridge.bodies.wander`) comes before the first action (`lead_in` s) and after every action that does not leave
an object in the hand, and fills the time the actions leave so that the telemetry lasts about `duration` s.
Everything is drawn from one generator seeded with `seed`: the same plan gives the same files.

The contact phases are read from a replay's contact log (`contact_phases`): the spans in which the robot touches
anything, gaps shorter than `MERGE_GAP` closed (a push that loses the face for a moment is one phase).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from .bodies import wander
from .enactment import STEP_PAUSE, Enactment, enact, save_enactment
from .odb import ObjectDatabase
from .planning.apply import PlanStep
from .planning.templates import ActionTemplate
from .recording.recording import Recording, check_recording_folder
from .recording.telemetry import Telemetry
from .sim.simulate import ReplayResult
from .world import WorldState, load_world_state

WORLDS = Path(__file__).resolve().parents[1] / "demo" / "worlds"
SESSION_WORLD = WORLDS / "session.yaml"
MERGE_GAP = 0.5  # s: contact gaps shorter than this do not end a contact phase
MIN_FREE = 3.0  # s of free motion at least, wherever there is some

Span = tuple[float, float]


@dataclass(frozen=True)
class SessionPlan:
    """What a session does: its actions in order on `world`, about how long it lasts, and its seed."""

    steps: tuple[PlanStep, ...]
    duration: float  # s of telemetry in all: free motion fills what the actions leave
    world: Path = SESSION_WORLD
    seed: int = 0
    lead_in: float = 5.0  # s of free motion before the first action
    name: str = "session"

    def __post_init__(self):
        object.__setattr__(self, "steps", tuple(s if isinstance(s, PlanStep) else PlanStep(s[0], tuple(s[1]))
                                                for s in self.steps))


def _plan(*steps: tuple[str, tuple[str, ...]]) -> tuple[PlanStep, ...]:
    return tuple(PlanStep(action, args) for action, args in steps)


# The benchmark's session: 11 actions, 9 contact phases (a pick and its place are one), 5 minutes.
FULL_SESSION = SessionPlan(_plan(
    ("push_over", ("arm", "big_a", "table")),
    ("push", ("arm", "cup", "table")),
    ("push_against", ("arm", "small_a", "big_c", "table")),
    ("pick", ("arm", "small_b", "table")),
    ("place", ("arm", "small_b", "tray")),
    ("stand_up", ("arm", "small_c", "table")),
    ("push", ("arm", "big_b", "table")),
    ("push", ("arm", "bottle", "table")),
    ("push", ("arm", "small_c", "table")),
    ("pick", ("arm", "small_c", "table")),
    ("place", ("arm", "small_c", "table")),
), duration=300.0, name="session")

# Three actions, two contact phases, under a minute, on the demo's table of three objects (nine resting objects
# cost a replay three times what three do): what tests make and replay.
SHORT_SESSION = SessionPlan(_plan(
    ("push_over", ("arm", "big_box", "table")),
    ("pick", ("arm", "small_box", "table")),
    ("place", ("arm", "small_box", "tray")),
), duration=55.0, world=WORLDS / "tabletop.yaml", name="short_session")


@dataclass(frozen=True, eq=False)
class Session:
    """A session made: the recording folder, its enactment (the replay that checked it), where the free motion
    lies in its telemetry, and the contact phases of that replay."""

    plan: SessionPlan
    recording: Recording
    enactment: Enactment
    free_motion: tuple[Span, ...]  # telemetry time spans of inserted free motion
    phases: tuple[Span, ...]  # contact phases of the enactment's replay

    @property
    def free_share(self) -> float:
        """The share of the replayed time in which the robot touches nothing."""
        return free_share(self.phases, self.enactment.replay.sim_time)


def make_session(plan: SessionPlan, out_folder: str | Path, odb: ObjectDatabase,
                 templates: Mapping[str, ActionTemplate], *, overwrite: bool = False) -> Session:
    """Enact `plan` with free motion and write it as a recording folder (refused before any work if the folder
    cannot be written; see `bridge.enactment.make_plan_recording`)."""
    check_recording_folder(out_folder, overwrite)
    world = load_world_state(plan.world, odb)
    rng = np.random.default_rng(plan.seed)
    budget = _FreeMotionBudget(plan, odb, rng)
    done = enact(world, odb, templates, plan.steps, rng=rng, free_motion=budget)
    phases = contact_phases(done.replay, world.robot.name)
    note = (f"A scripted session (bridge.session, seed {plan.seed}): operator free motion before the first action "
            f"and after every action that leaves the hand empty; {len(phases)} contact phases, the robot touches "
            f"nothing {100 * free_share(phases, done.replay.sim_time):.0f} % of the time.")
    recording = save_enactment(done, plan.world, out_folder, odb, name=plan.name, overwrite=overwrite, note=note)
    return Session(plan, recording, done, tuple(budget.spans), phases)


class _FreeMotionBudget:
    """The `FreeMotion` of a plan: the lead-in first, then shares of the time left after each action that leaves
    the hand empty, the last one filling the telemetry to the plan's duration."""

    def __init__(self, plan: SessionPlan, odb: ObjectDatabase, rng: np.random.Generator):
        self.plan, self.odb, self.rng = plan, odb, rng
        self.spans: list[Span] = []
        self.free = 0.0  # s of free motion so far, pauses included

    def __call__(self, world: WorldState, done: int, elapsed: float) -> Telemetry | None:
        steps = self.plan.steps
        if done == 0:
            seconds = self.plan.lead_in
        elif _holds_something(world):
            return None
        elif done == len(steps):
            seconds = self.plan.duration - elapsed - STEP_PAUSE
        else:
            acting = elapsed - self.free  # the actions so far and the pauses between pieces
            later = steps[done:]
            gaps = 1 + sum(1 for s in later if s.action != "pick")  # gaps still to come, this one included
            seconds = (self.plan.duration - elapsed - acting / done * len(later)) / gaps
        telemetry = wander(world, self.odb, max(seconds, MIN_FREE), self.rng)
        start = elapsed + (STEP_PAUSE if elapsed > 0 else 0.0)
        self.spans.append((round(float(start), 6), round(float(start + telemetry.duration), 6)))
        self.free += telemetry.duration + (STEP_PAUSE if elapsed > 0 else 0.0)
        return telemetry


def _holds_something(world: WorldState) -> bool:
    robot = world.robot.name
    return any(f.predicate == "holding" and f.args[0] == robot for f in world.facts)


def contact_phases(result: ReplayResult, robot: str, merge_gap: float = MERGE_GAP) -> tuple[Span, ...]:
    """The spans (first, last sample time) in which `robot` touches anything but itself, from the replay's
    contact log (`SimOptions(contacts=True)`); gaps up to `merge_gap` s do not end a phase."""
    times = sorted({c.time for c in result.contact_log
                    if c.involves(robot) and not (c.other(robot) == robot or c.other(robot).startswith(robot + "/"))})
    spans: list[list[float]] = []
    for t in times:
        if spans and t - spans[-1][1] <= merge_gap + 1e-9:
            spans[-1][1] = t
        else:
            spans.append([t, t])
    return tuple((float(a), float(b)) for a, b in spans)


def free_share(phases: Sequence[Span], total: float) -> float:
    """1 - the contact phases' share of `total` s."""
    return 1.0 - sum(b - a for a, b in phases) / total if total > 0 else 1.0


def overlap(spans: Sequence[Span], others: Sequence[Span]) -> float:
    """Seconds that two sets of spans share."""
    return sum(max(0.0, min(b, d) - max(a, c)) for a, b in spans for c, d in others)


__all__ = ["FULL_SESSION", "SHORT_SESSION", "Session", "SessionPlan", "contact_phases", "free_share",
           "make_session", "overlap"]
