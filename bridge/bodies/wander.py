"""Operator free motion: the arm wandering through joint-space waypoints in free air, touching nothing.

A real teleoperation session is mostly this (looking around, lining up the next action, waiting); the action
bodies are the short stretches near objects. `wander` makes such a stretch of telemetry for a session
(`bridge.session`): from where the robot stands, through random tool poses above everything on the table, back
home, then idle until `duration` is filled. Every move is checked against the world's objects along its
joint-space path, so the arm keeps `MOVABLE_CLEARANCE` from every movable object and `FIXTURE_CLEARANCE` from
fixtures; deterministic for a given generator.
"""
from __future__ import annotations

import math

import numpy as np

from ..odb import ObjectDatabase
from ..recording.telemetry import Telemetry
from ..sim.kinematics import Clearance, clearance_for
from ..world import WorldState
from .jobs import start_job
from .layout import UP
from .motion import frame_rotation

MOVABLE_CLEARANCE = 0.08  # m from every movable object: free motion stays out of any contact margin
FIXTURE_CLEARANCE = 0.03  # m from the table (the arm's lower links pass near its edge at home)
ABOVE = (0.12, 0.35)  # m the tool goes above the highest object
RADIUS = (0.32, 0.70)  # m from the robot's base, horizontally
BEARING = math.radians(80.0)  # either side of straight ahead (beyond the table's sides: over the floor)
MAX_TILT = math.radians(40.0)  # of the tool's approach axis from straight down
SPEED = (0.35, 0.8)  # rad/s average joint speed of a move
PAUSE_CHANCE = 0.35  # an operator stops between moves this often ...
PAUSE = (0.4, 2.5)  # ... for this many seconds
PATH_STEP = 0.04  # rad: the clearance is checked at least this often along a joint-space move
TRIES = 40  # random waypoints tried before giving up on one more


def wander(world: WorldState, odb: ObjectDatabase, duration: float, rng: np.random.Generator) -> Telemetry:
    """About `duration` s (at least the way home) of free motion from the world's robot joints, ending home."""
    job = start_job(world, odb, "wander", [world.robot.name], ("robot",), rng)
    clearance = clearance_for(world, odb)
    margins = {name: FIXTURE_CLEARANCE if job.layout.is_fixed(name) else MOVABLE_CLEARANCE for name in world.objects}
    mb = job.builder(go_home=False)
    if not _clear_path(clearance, mb.q, job.home, margins):
        raise job.fail("the arm cannot go home from where it stands without passing near an object")
    while True:
        goal = _waypoint(job, mb.q, clearance, margins)
        if goal is None:
            break
        speed = float(rng.uniform(*SPEED))
        back = _move_time(goal, job.home, SPEED[1])
        if mb.t + _move_time(mb.q, goal, speed) + back > duration:
            break
        mb.joint_move(goal, "wander", speed=speed)
        if rng.random() < PAUSE_CHANCE:
            pause = min(float(rng.uniform(*PAUSE)), duration - mb.t - back)  # the way home still fits
            if pause > 0.05:
                mb.wait(pause, "pause")
    mb.joint_move(job.home, "return home", speed=SPEED[1])
    if duration - mb.t > 1e-3:
        mb.wait(duration - mb.t, "idle at home")
    return mb.telemetry(source=f"<free motion {duration:.1f} s>")


def _waypoint(job, q: np.ndarray, clearance: Clearance, margins: dict[str, float]) -> np.ndarray | None:
    """Joint positions putting the tool at a random pose in free air, reachable from `q` and from which home is
    reachable, both along clear joint-space paths; None when TRIES draws found none."""
    rng = job.rng
    base = np.asarray(job.world.robot.base_pose.xyz)
    top = max(job.layout.top(n) for n in job.world.objects)
    for _ in range(TRIES):
        r, bearing = rng.uniform(*RADIUS), rng.uniform(-BEARING, BEARING)
        p = base + r * np.array([math.cos(bearing), math.sin(bearing), 0.0])
        p[2] = top + rng.uniform(*ABOVE)
        tilt, azimuth, yaw = rng.uniform(0.0, MAX_TILT), rng.uniform(-math.pi, math.pi), rng.uniform(-math.pi, math.pi)
        approach = -math.cos(tilt) * UP + math.sin(tilt) * np.array([math.cos(azimuth), math.sin(azimuth), 0.0])
        R = frame_rotation(approach, [math.cos(yaw), math.sin(yaw), 0.0])  # the approach is never horizontal
        goal = job.arm.solve(p, R, job.tcp, seed=q, nominal=job.home, fingers=float(q[job.fingers[0]]),
                             finger_joints=job.fingers, min_distance=0.02, tolerance=0.05)
        if goal is None:
            continue
        if _clear_path(clearance, q, goal, margins) and _clear_path(clearance, goal, job.home, margins):
            return goal
    return None


def _clear_path(clearance: Clearance, q0: np.ndarray, q1: np.ndarray, margins: dict[str, float]) -> bool:
    """The straight joint-space path q0 -> q1 (what `joint_move` follows) keeps every object's margin."""
    n = max(1, int(math.ceil(float(np.max(np.abs(q1 - q0))) / PATH_STEP)))
    for s in np.linspace(0.0, 1.0, n + 1):
        for name, (distance, _) in clearance.distances(q0 + s * (q1 - q0)).items():
            if distance < margins.get(name, MOVABLE_CLEARANCE):
                return False
    return True


def _move_time(q0: np.ndarray, q1: np.ndarray, speed: float) -> float:
    """How long `MotionBuilder.joint_move` takes between q0 and q1 at `speed`."""
    return max(1.0, 1.5 * float(np.max(np.abs(q1 - q0))) / speed)
