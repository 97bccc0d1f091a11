"""A lean replay for fitting and diagnosis: object pose tracks at a fixed rate, optional contact log, and context
hooks that may change the context between samples (position-dependent friction).

`replay` (replay.py) is the replay inference uses; this one skips its per-sample checks and final-contact query,
lets the caller choose the simulated span (observations may outlast the telemetry), and runs `hooks`.
It returns the same `ReplayResult`, so its tracks and contact log read the same way.
"""
from __future__ import annotations

import math
import time as wallclock
from typing import Protocol, Sequence

import numpy as np
from pydrake.systems.analysis import Simulator

from ..errors import SimulationFailure
from ..recording.telemetry import Telemetry, validate_telemetry
from .replay import ContactReader, ReplayResult, _moved
from .scene import Scene, SceneParams, from_drake


class ContextHook(Protocol):
    """Changes a running context between samples. `start` returns the hook's state; `update` gets it back."""

    def start(self, scene: Scene, context, params: SceneParams) -> object: ...

    def update(self, scene: Scene, context, t: float, poses: dict, state: object) -> None: ...


def simulate_tracks(scene: Scene, telemetry: Telemetry | None, *, world=None, params: SceneParams | None = None,
                    end: float | None = None, sample_rate: float = 50.0, hooks: Sequence[ContextHook] = (),
                    contacts: bool = False, robot_force: bool = False, max_speed: float = 20.0) -> ReplayResult:
    """Simulate from t = 0 to `end` (default: the telemetry's last time + 0.3 s) and sample every object's pose.

    Telemetry times may start after 0 or before it (a latency shift): the robot holds the first sample before
    and the last sample after the recording. `max_speed` (m/s) turns an exploding simulation into a
    `SimulationFailure` instead of garbage. `robot_force` samples the contact force on the robot
    (`ReplayResult.robot_force`), what its force sensor would read.
    """
    world = world or scene.world
    plant = scene.plant
    context = scene.new_context(world, params)
    plant_ctx = plant.GetMyMutableContextFromRoot(context)
    if scene.robot_instance is not None and telemetry is not None:
        validate_telemetry(telemetry, scene.robot_joints)
        cols = scene.actuator_columns(telemetry.joint_names)
        times = np.concatenate([[min(0.0, telemetry.times[0]) - 1.0], telemetry.times, [telemetry.times[-1] + 1e3]])
        q = telemetry.positions[:, cols]
        scene.set_desired(times, np.vstack([q[:1], q, q[-1:]]))
        start = dict(zip(telemetry.joint_names, telemetry.sample(0.0)))
        plant.SetPositions(plant_ctx, scene.robot_instance, scene.robot_positions(start))
    if end is None:
        end = (telemetry.times[-1] if telemetry is not None else 0.0) + 0.3
    n = max(2, int(math.floor(end * sample_rate + 1e-9)) + 1)
    sample_times = np.linspace(0.0, (n - 1) / sample_rate, n)
    names = list(scene.bodies)
    tracks = {name: np.zeros((n, 7)) for name in names}
    robot_name = world.robot.name if world.robot is not None else None
    want_force = robot_force and robot_name is not None
    reader = ContactReader(scene) if contacts or want_force else None
    force = np.zeros((n, 3)) if want_force else None
    log = []
    states = [hook.start(scene, context, params or SceneParams()) for hook in hooks]
    simulator = Simulator(scene.diagram, context)
    simulator.Initialize()
    started = wallclock.perf_counter()
    for k, t in enumerate(sample_times):
        if t > 0:
            try:
                simulator.AdvanceTo(float(t))
            except RuntimeError as exc:
                raise SimulationFailure(f"Drake stopped at t = {context.get_time():.3f} s: {exc}") from None
        poses = {}
        for name in names:
            pose = from_drake(plant.EvalBodyPoseInWorld(plant_ctx, scene.bodies[name]))
            poses[name] = pose
            tracks[name][k] = (*pose.xyz, *pose.quat)
        if names:
            v = plant.GetVelocities(plant_ctx)
            if not np.all(np.isfinite(v)) or float(np.max(np.abs(v))) > 1e3:
                raise SimulationFailure(f"the simulation diverged at t = {t:.3f} s")
            speeds = [np.linalg.norm(plant.EvalBodySpatialVelocityInWorld(plant_ctx, scene.bodies[m]).translational())
                      for m in names]
            if max(speeds) > max_speed:
                raise SimulationFailure(f"an object moves at {max(speeds):.1f} m/s at t = {t:.3f} s (diverged)")
        for hook, state in zip(hooks, states):
            hook.update(scene, context, float(t), poses, state)
        if reader is not None:
            now = reader.read(context, float(t))
            if contacts:
                log.extend(now)
            if force is not None:
                force[k] = reader.force_on(now, robot_name)
    wall = wallclock.perf_counter() - started
    moved = tuple(name for name in names if _moved(tracks[name]))
    robot = world.robot.name if world.robot else None
    touched = tuple(sorted({c.other(robot) for c in log if robot and c.involves(robot)
                            and not c.other(robot).startswith(robot + "/")} - {"world"}))
    return ReplayResult(sample_times, tracks, (), tuple(log), moved, touched, 0.0, float(sample_times[-1]), wall,
                        robot, None, force)
