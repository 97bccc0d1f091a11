"""Recordings made by the simulator itself with known parameters: recovery problems for the fit.

`synthesize_trial` replays telemetry with given parameter values and keeps the objects' simulated tracks as
the "observed" poses, so a fit that starts elsewhere should find those values again. `push_scenario` is the
cheap scene the tests and the benchmark use, built from bundled types only: the planar pusher on the
tabletop shoves a lying `big_box` (1 kg) so that it slides into a lying `small_box` (0.3 kg), and turns the
big box by pushing it sideways near one end. Probed sensitivities (rms track change): 0.1 of either
friction ~8-10 mm, 0.1 kg of the small box ~4.6 mm, 2 cm of the big box's centre of mass along its long
axis (its frame's z, world +x when lying) ~11 mm and 6 deg.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

from ..names import build_name_map
from ..odb import ObjectDatabase
from ..params import KINDS, Parameter, ParameterSet, apply_model
from ..recording.observations import ObservedPoses, ObservedTrack
from ..recording.telemetry import Telemetry
from ..rollout.compare import sample_track
from ..rollout.rollout import Rollout, run_rollout
from ..rollout.trials import Trial
from ..sim.simulate import SimOptions
from ..values import Pose, rotation_to_quat
from ..world import ObjectState, RobotState, WorldState
from .evaluate import SAMPLE_RATE

TABLE_TOP = 0.75
ROD_RADIUS = 0.00476
BIG_X, BIG_HALF_LENGTH = 0.6, 0.125
SMALL_GAP = 0.0005  # m between the lying boxes: they slide off together (an impact would be chaotic, see below)
ROD_GAP = 0.001  # m between the rod and the big box at the start
TRUE_VALUES = {"friction[big_box]": 0.35, "friction[table]": 0.6, "mass[small_box]": 0.45, "com_z[big_box]": 0.03}
FIXED_VALUES = {"friction[small_box]": 0.9}  # grips the table harder than the big box, so the pair stays pressed


def synthesize_trial(name: str, world: WorldState, telemetry: Telemetry, odb: ObjectDatabase, *,
                     spec: ParameterSet | None = None, values: Sequence[float] | None = None,
                     objects: Sequence[str] | None = None, rate: float = 25.0, settle: float = 0.0) -> Trial:
    """A trial whose observations are the simulation's own tracks of `objects` (default: every free object),
    every `1/rate` s until `settle` s after the telemetry, with `spec` at `values` (None: start values)."""
    rollout = Rollout(world, telemetry, name=name)
    if spec is not None:
        rollout = apply_model(spec.model(values), rollout, odb)
    result = run_rollout(rollout, odb, SimOptions(sample_rate=SAMPLE_RATE, settle=settle))
    names = list(objects) if objects is not None else list(result.tracks)
    times = np.arange(0.0, result.times[-1] + 1e-9, 1.0 / rate)
    tracks = []
    for obj in names:
        xyz, R = sample_track(result.times, result.observed_track(obj), times)
        tracks.append(ObservedTrack(obj, times, tuple(Pose(tuple(p), rotation_to_quat(r)) for p, r in zip(xyz, R))))
    return Trial(name, world, telemetry, ObservedPoses(tuple(tracks), source=f"<synthetic {name}>"),
                 Path(f"<synthetic {name}>"), (f"synthetic: observations simulated with {_describe(spec, values)}",))


def _describe(spec: ParameterSet | None, values) -> str:
    if spec is None:
        return "the object database's values"
    values = spec.start_values() if values is None else values
    return ", ".join(f"{n} = {v:g}" for n, v in zip(spec.names, values))


# --- the push scenario ----------------------------------------------------------------------------------------
def push_world() -> WorldState:
    """Table, a lying big box, a lying small box ahead of it, the planar pusher 3 cm above the table top."""
    small_x = BIG_X + BIG_HALF_LENGTH + 0.06 + SMALL_GAP
    objects = {
        "table": ObjectState("table", "table", Pose((0.75, 0.0, TABLE_TOP - 0.025))),
        "big_box": ObjectState("big_box", "big_box", Pose.from_rpy((BIG_X, 0.0, TABLE_TOP + 0.05), (0, math.pi / 2, 0))),
        "small_box": ObjectState("small_box", "small_box",
                                 Pose.from_rpy((small_x, 0.0, TABLE_TOP + 0.025), (0, math.pi / 2, 0))),
    }
    robot = RobotState("pusher", "planar_pusher", Pose((0.0, 0.0, TABLE_TOP + 0.03)),
                       (("pusher_x", BIG_X - BIG_HALF_LENGTH - ROD_RADIUS - ROD_GAP), ("pusher_y", 0.0)))
    return WorldState(objects, robot=robot, name="synthetic_push", names=build_name_map([*objects, "pusher"]))


def push_profile(start: Sequence[float], direction: Sequence[float], speed: float, accelerate: float, hold: float,
                 brake: float, *, back: float = 0.0, duration: float, dt: float = 0.01) -> Telemetry:
    """Pusher telemetry: speed ramps up over `accelerate` s, holds `hold` s, ramps down over `brake` s, then
    the rod backs off at `back` m/s (so a sliding box leaves it)."""
    t = np.arange(0.0, duration + 1e-9, dt)
    v = np.select([t < accelerate, t < accelerate + hold, t < accelerate + hold + brake],
                  [speed * t / accelerate, np.full_like(t, speed), speed * (1 - (t - accelerate - hold) / brake)],
                  -back)
    s = np.concatenate([[0.0], np.cumsum(v[1:] * dt)])
    d = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
    return Telemetry(t, ("pusher_x", "pusher_y"), np.asarray(start, dtype=float) + s[:, None] * d, source="<synthetic>")


def push_telemetries() -> dict[str, Telemetry]:
    """'slide': a fast straight shove (the big box slides into the small one); 'turn': a sideways push 11 cm
    from the big box's centre, which turns it."""
    behind = BIG_X - BIG_HALF_LENGTH - ROD_RADIUS - ROD_GAP
    return {
        "slide": push_profile((behind, 0.0), (1, 0), 0.9, 0.15, 0.05, 0.02, back=0.4, duration=0.6),
        "turn": push_profile((BIG_X + 0.11, -0.05 - ROD_RADIUS - ROD_GAP), (0, 1), 0.25, 0.1, 0.32, 0.05,
                             duration=0.6),
    }


def recovery_spec(names: Sequence[str] = tuple(TRUE_VALUES), *, start: dict[str, float] | None = None) -> ParameterSet:
    """The paper-like problem: two frictions and two other parameters. Those in `names` are free, with bounds
    and wrong starts (or `start`); the others are fixed at their true values."""
    table = {
        "friction[big_box]": ("friction", "big_box", (0.1, 1.0), 0.7),
        "friction[table]": ("friction", "table", (0.1, 1.0), 0.3),
        "mass[small_box]": ("mass", "small_box", (0.1, 1.0), 0.2),
        "com_z[big_box]": ("com_z", "big_box", (-0.08, 0.08), -0.03),
    }
    unknown = [n for n in names if n not in table]
    if unknown:
        raise ValueError(f"unknown recovery parameter {unknown[0]!r}; valid: {', '.join(table)}")
    entries = []
    for name, (kind, target, bounds, default_start) in table.items():
        if name in names:
            entries.append(Parameter(KINDS[kind], target, bounds=bounds, start=(start or {}).get(name, default_start)))
        else:
            entries.append(Parameter(KINDS[kind], target, value=TRUE_VALUES[name]))
    for name, value in FIXED_VALUES.items():
        kind, target = name[:-1].split("[")
        entries.append(Parameter(KINDS[kind], target, value=value))
    return ParameterSet(tuple(entries), source="synthetic recovery problem")


def push_trials(odb: ObjectDatabase, *, cases: Sequence[str] = ("slide", "turn")) -> list[Trial]:
    """The scenario's trials observed with `TRUE_VALUES` (every one of them, whichever are fitted)."""
    truth = recovery_spec(tuple(TRUE_VALUES))
    values = [TRUE_VALUES[n] for n in truth.names]
    world = push_world()
    telemetries = push_telemetries()
    return [synthesize_trial(case, world, telemetries[case], odb, spec=truth, values=values,
                             objects=("big_box", "small_box")) for case in cases]


@dataclass(frozen=True)
class Recovery:
    """How far fitted values are from the truth."""

    errors: dict[str, float]

    def within(self, tolerances: dict[str, float]) -> bool:
        return all(abs(self.errors[n]) <= tolerances[n] for n in self.errors)


def recovery(values: dict[str, float]) -> Recovery:
    return Recovery({n: float(v - TRUE_VALUES[n]) for n, v in values.items()})
