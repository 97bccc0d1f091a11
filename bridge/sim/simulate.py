"""The one simulation loop: replay joint telemetry in a built scene and record what inference, fitting and
diagnosis read (object pose tracks, contacts, the force on the robot, the robot's joints).

The robot starts where its telemetry is at t = 0 and follows it through its PD gains; before the first and after
the last sample it holds that sample (telemetry shifted by a latency may start before t = 0). The scene is
sampled every 1/`sample_rate` s from t = 0 and at `end` (default: the telemetry's end + `settle`, so objects
come to rest). Context hooks may change the running context between samples.

One failure policy (`FailurePolicy`) for every caller: a replay that produces garbage raises `SimulationFailure`
with what happened and when, instead of handing garbage on: Drake stopping, NaN or diverging velocities, an
object faster than `max_speed`, an object through its support or out of the world, and (unless switched off) a
robot that cannot follow its telemetry.
"""
from __future__ import annotations

import math
import time as wallclock
from dataclasses import dataclass, field, replace
from typing import Callable, Mapping, Protocol, Sequence

import numpy as np
from pydrake.systems.analysis import Simulator

from ..errors import SimulationFailure
from ..odb.geometry import contains_xy, z_range
from ..recording.telemetry import Telemetry, validate_telemetry
from ..values import Contact, Pose
from ..world import WorldState
from .contacts import PROXIMITY, ContactReader
from .scene import Scene, SceneValues, from_drake
from .sleep import Sleepers
from .stillness import Stillness

MOVED_TRANSLATION = 0.005  # m
MOVED_ROTATION = math.radians(3.0)


class ContextHook(Protocol):
    """Changes a running context between samples. `start` returns the hook's state; `update` gets it back."""

    def start(self, scene: Scene, context, values: SceneValues) -> object: ...

    def update(self, scene: Scene, context, t: float, poses: dict, state: object) -> None: ...


@dataclass(frozen=True)
class FailurePolicy:
    """When a replay counts as failed. The speed limits turn an exploding simulation into a failure; the
    tracking limits catch a simulated robot held back by something the real one did not meet."""

    max_speed: float = 20.0  # m/s of any object
    max_velocity: float = 1e3  # any generalized velocity (m/s or rad/s): diverged
    max_tracking_error: float = 0.25  # rad (or m) a joint may lag its telemetry ...
    max_tracking_time: float = 0.3  # ... for at most this long (s)
    check_tracking: bool = True


@dataclass(frozen=True)
class SimOptions:
    """What to simulate and record. Contacts, the robot's force and its joints cost time: ask for what you use."""

    sample_rate: float = 50.0  # Hz of the tracks and the contact log
    settle: float = 0.5  # s simulated after the telemetry ends (when `end` is not given)
    end: float | None = None  # s: simulate from 0 to here instead
    contacts: bool = False  # every contact at every sample (`contact_log`, `touched_by_robot`)
    final_contacts: bool = False  # contacts and near pairs (PROXIMITY) at the end, for inference
    robot_force: bool = False  # the contact force on the robot at every sample (what its force sensor reads)
    joint_track: bool = False  # the simulated robot's actuated joints at every sample
    sleep: bool = True  # objects at rest and out of reach are held, not simulated (docs/rollout.md, sleeping)
    policy: FailurePolicy = field(default_factory=FailurePolicy)


@dataclass(frozen=True, eq=False)
class ReplayResult:
    times: np.ndarray  # (T,) sample times, s
    tracks: Mapping[str, np.ndarray]  # free object -> (T, 7): x, y, z, qw, qx, qy, qz
    final_contacts: tuple[Contact, ...]
    contact_log: tuple[Contact, ...]  # every contact at every sample time (when recorded)
    moved: tuple[str, ...]
    touched_by_robot: tuple[str, ...]
    max_tracking_error: float
    sim_time: float
    wall_time: float
    cpu_time: float = 0.0
    robot: str | None = None
    joint_names: tuple[str, ...] = ()  # the robot's actuated joints, the columns of joint_track
    joint_track: np.ndarray | None = None  # (T, J) simulated robot positions
    robot_force: np.ndarray | None = None  # (T, 3) N on the robot from what it touches, world frame
    awake: tuple[tuple[float, float], ...] = ()  # sim-time spans stepped with contact dynamics (the rest: all asleep)
    awake_wall: float = 0.0  # wall seconds spent in those spans
    # (object, pose of its recorded frame in its body frame): where the recording's tracker put the object's frame
    # (`Rollout.frames`); poses are compared with a recording in that frame (`observed_track`)
    frames: tuple[tuple[str, Pose], ...] = ()

    @property
    def final_poses(self) -> dict[str, Pose]:
        return {n: track_pose(t[-1]) for n, t in self.tracks.items()}

    def observed_track(self, name: str) -> np.ndarray:
        """The (T, 7) track of `name` as its recording reports it: the pose of the recorded frame (X_WB X_BR, with
        X_BR from `frames`), the body's own where the rollout named none. The simulation and the world state stay
        in the body frame; only comparisons with a recording go through here."""
        track = self.tracks[name]
        frame = dict(self.frames).get(name)
        return track if frame is None else frame_track(track, frame)

    def pose_at(self, name: str, t: float) -> Pose:
        i = int(np.clip(np.searchsorted(self.times, t), 0, len(self.times) - 1))
        return track_pose(self.tracks[name][i])

    @property
    def realtime_factor(self) -> float:
        return self.sim_time / self.wall_time if self.wall_time > 0 else float("inf")

    def contact_pairs(self) -> frozenset[tuple[str, str]]:
        return frozenset((c.body_a, c.body_b) for c in self.contact_log)


def frame_track(track: np.ndarray, frame: Pose) -> np.ndarray:
    """A (T, 7) track of a body's poses X_WB turned into those of a frame fixed on it at X_BR = `frame`."""
    from scipy.spatial.transform import Rotation

    R_WB = Rotation.from_quat(track[:, [4, 5, 6, 3]])
    xyz = track[:, :3] + R_WB.apply(np.asarray(frame.xyz))
    q = (R_WB * Rotation.from_quat(np.asarray(frame.quat)[[1, 2, 3, 0]])).as_quat()
    return np.column_stack([xyz, q[:, 3], q[:, :3]])


def track_pose(row: np.ndarray) -> Pose:
    q = row[3:7] / np.linalg.norm(row[3:7])
    return Pose(tuple(row[:3]), tuple(q))


def sample_times(end: float, rate: float) -> np.ndarray:
    """0, 1/rate, 2/rate, ... up to `end`, and `end` itself when it falls between two (at least two samples).
    Multiples of 1/rate are multiples of the time step at the usual rates: each sample reads the state right
    after a discrete update."""
    n = max(2, int(math.floor(end * rate + 1e-9)) + 1)
    times = np.arange(n) / rate
    return np.append(times, end) if end - times[-1] > 1e-9 else times


def simulate(scene: Scene, telemetry: Telemetry | None, *, world: WorldState | None = None,
             values: SceneValues | None = None, hooks: Sequence[ContextHook] = (), options: SimOptions = SimOptions(),
             on_sample: Callable[[float, Mapping[str, Pose], list[Contact]], None] | None = None,
             progress: Callable[[float, float], None] | None = None) -> ReplayResult:
    """Replay `telemetry` from `world` (default: the scene's) with `values` written into a fresh context.
    `on_sample(t, poses, contacts)` sees every sample (the on-line estimates); `progress(t, end)` too."""
    started, cpu = wallclock.perf_counter(), wallclock.process_time()
    world = world or scene.world
    values = values or SceneValues()
    policy = options.policy
    plant = scene.plant
    context, actuated, cols, states = start_replay(scene, telemetry, world=world, values=values, hooks=hooks)
    plant_ctx = plant.GetMyMutableContextFromRoot(context)
    end = options.end if options.end is not None else (telemetry.end if telemetry is not None else 0.0) + options.settle
    times = sample_times(end, options.sample_rate)
    # where the telemetry has the robot at each sample, for the tracking check (one vectorised lookup)
    commanded = telemetry.sample(times)[:, cols] if cols is not None else None
    names = list(scene.bodies)
    tracks = {name: np.zeros((len(times), 7)) for name in names}
    robot = world.robot.name if world.robot is not None else None
    want_force = options.robot_force and robot is not None
    read_contacts = options.contacts or on_sample is not None or want_force
    sleeping = options.sleep and bool(scene.bodies) and not hooks  # a hook may change anything: simulate all
    reader = ContactReader(scene) if read_contacts or options.final_contacts or sleeping else None
    force = np.zeros((len(times), 3)) if want_force else None
    joints = np.zeros((len(times), len(actuated))) if options.joint_track and actuated else None
    # each fixture with the height of its bottom (`_check_support`)
    supports = [(n, g, o.pose, z_range(g, o.pose)[0]) for n, o in world.objects.items()
                if scene.odb.get(o.type).fixed and (g := scene.odb.get(o.type).geometry) is not None]
    log: list[Contact] = []
    worst, lag_since = 0.0, None
    simulator = Simulator(scene.diagram, context)
    simulator.Initialize()
    sleepers = Sleepers(scene, context, options.sample_rate) if sleeping else None
    follower = _Kinematic(scene, context) if sleeping else None
    kinematic = False  # every object asleep: the robot follows its telemetry, nothing is stepped
    # nothing moves and nothing is commanded to move: samples up to `held_to` are held as they were (stillness.py)
    still = (Stillness.of(telemetry.times, telemetry.positions[:, cols]) if cols is not None
             else Stillness.of(None, None)) if sleeping else None
    held_to, held_contacts = -1, []
    spans, span_start, awake_wall, span_wall = [], 0.0, 0.0, wallclock.perf_counter()
    poses: dict[str, Pose] = {}
    for k, t in enumerate(times):
        t = float(t)
        if k <= held_to:
            for name in names:
                tracks[name][k] = tracks[name][k - 1]
            for series in (joints, force):
                if series is not None:
                    series[k] = series[k - 1]
            contacts = [replace(c, time=t) for c in held_contacts]
            if options.contacts:
                log.extend(contacts)
            if on_sample is not None:
                on_sample(t, poses, contacts)
            if progress is not None:
                progress(t, float(times[-1]))
            if k == held_to:  # the robot is commanded to move after the next step: step again from here
                context.SetTime(t)
                simulator.Initialize()
                still.resumed()
                span_start, span_wall = t, wallclock.perf_counter()
            continue
        if t > 0 and kinematic:
            follower.move_to(t)
        elif t > 0:
            try:
                simulator.AdvanceTo(t)
            except RuntimeError as exc:
                raise SimulationFailure(f"Drake stopped at t = {context.get_time():.3f} s: "
                                        f"{str(exc).splitlines()[0]}") from None
        v = plant.GetVelocities(plant_ctx)
        if not np.all(np.isfinite(v)) or not np.all(np.isfinite(plant.GetPositions(plant_ctx))):
            raise SimulationFailure(f"the simulation produced NaN at t = {t:.3f} s (try a smaller time step)")
        if v.size and float(np.max(np.abs(v))) > policy.max_velocity:
            raise SimulationFailure(f"the simulation diverged at t = {t:.3f} s")
        held = poses if sleepers is not None else {}
        poses = {}
        for name in names:
            if name in held and name in sleepers.asleep:  # held where it fell asleep
                poses[name] = held[name]
                tracks[name][k] = tracks[name][k - 1]
                continue
            pose = from_drake(plant.EvalBodyPoseInWorld(plant_ctx, scene.bodies[name]))
            poses[name] = pose
            tracks[name][k] = (*pose.xyz, *pose.quat)
            _check_support(name, pose, supports, t)
            speed = float(np.linalg.norm(plant.EvalBodySpatialVelocityInWorld(plant_ctx, scene.bodies[name])
                                         .translational()))
            if speed > policy.max_speed:
                raise SimulationFailure(f"object {name!r} moves at {speed:.1f} m/s at t = {t:.3f} s (diverged)")
        if actuated:
            q_now = np.array([j.GetOnePosition(plant_ctx) for j in actuated])
            if joints is not None:
                joints[k] = q_now
            if cols is not None and t <= telemetry.end and not kinematic:  # kinematic: on its desired trajectory
                err = np.abs(q_now - commanded[k])
                j = int(np.argmax(err))
                worst = max(worst, float(err[j]))
                if not policy.check_tracking:
                    pass
                elif err[j] > policy.max_tracking_error:
                    lag_since = t if lag_since is None else lag_since
                    if t - lag_since > policy.max_tracking_time:
                        raise SimulationFailure(
                            f"the robot cannot follow its telemetry: joint {actuated[j].name()!r} is {err[j]:.3f} off "
                            f"at t = {t:.2f} s (blocked by a collision, or telemetry too fast for the PD gains)")
                else:
                    lag_since = None
        for hook, state in zip(hooks, states):
            hook.update(scene, context, t, poses, state)
        contacts: list[Contact] = []
        if read_contacts:
            contacts = ([] if kinematic else reader.read(context, t)) + (sleepers.held_contacts(t) if sleepers else [])
        if sleepers is not None and k < len(times) - 1:
            now = (lambda: contacts) if read_contacts else (lambda: reader.read(context, t) + sleepers.held_contacts(t))
            # the last interval is stepped with everything awake: Drake's contact results are sampled at the
            # last step, and the final contacts must be the full simulation's
            sleepers.wake_all() if k == len(times) - 2 else sleepers.update(t, now)
            free = sleepers.robot_free()  # nothing to step: every object asleep, no fixture in the robot's reach
            if kinematic and not free:  # something woke, or the robot nears a fixture: step again from here
                kinematic = False
                span_start, span_wall = t, wallclock.perf_counter()
                follower.move_to(t)
                simulator.Initialize()
            elif free and not kinematic:
                kinematic = True
                spans.append((span_start, t))
                awake_wall += wallclock.perf_counter() - span_wall
        if read_contacts:
            if options.contacts:
                log.extend(contacts)
            if force is not None:
                force[k] = reader.force_on(contacts, robot)
        if on_sample is not None:
            on_sample(t, poses, contacts)
        if progress is not None:
            progress(t, float(times[-1]))
        if still is not None and not kinematic and k < len(times) - 3:
            until = still.update(t, float(np.max(sleepers.speeds(), initial=0.0)))
            # held at most to the sample before the last interval, which is always stepped
            last = -1 if until is None else min(int(np.searchsorted(times, until + 1e-9)) - 1, len(times) - 3)
            if last > k:
                held_to, held_contacts = last, contacts
                spans.append((span_start, t))
                awake_wall += wallclock.perf_counter() - span_wall
    if not kinematic:
        spans.append((span_start, float(times[-1])))
        awake_wall += wallclock.perf_counter() - span_wall
    final = tuple(reader.read(context, float(times[-1]), proximity=PROXIMITY)) if options.final_contacts else ()
    moved = tuple(name for name in names if _moved(tracks[name]))
    touched = tuple(sorted({c.other(robot) for c in log if robot and c.involves(robot)
                            and not c.other(robot).startswith(robot + "/")} - {"world"}))
    return ReplayResult(times, tracks, final, tuple(log), moved, touched, worst, float(times[-1]),
                        wallclock.perf_counter() - started, wallclock.process_time() - cpu, robot,
                        tuple(j.name() for j in actuated), joints, force, tuple(spans), awake_wall)


def start_replay(scene: Scene, telemetry: Telemetry | None, *, world: WorldState, values: SceneValues,
                 hooks: Sequence[ContextHook] = ()) -> tuple[object, list, np.ndarray | None, list]:
    """What `simulate` does before its first step: a context with the world, the values and the robot where its
    telemetry starts (or holding still without one), the telemetry checked against the robot's joints, the hooks
    started. Returns the context, the actuated joints, their telemetry columns and the hooks' states.
    `bridge check` runs it alone: whatever a replay would refuse at its start, without simulating."""
    plant = scene.plant
    context = scene.new_context(world, values)
    plant_ctx = plant.GetMyMutableContextFromRoot(context)
    actuated, cols = [], None
    if scene.robot_instance is not None and telemetry is not None:
        validate_telemetry(telemetry, scene.robot_joints)
        cols = scene.actuator_columns(telemetry.joint_names)
        scene.set_desired(context, telemetry.times, telemetry.positions[:, cols])
        start = dict(zip(telemetry.joint_names, telemetry.sample(0.0)))
        plant.SetPositions(plant_ctx, scene.robot_instance, scene.robot_positions(start))
        actuated = scene.actuated_joints()
    elif scene.robot_instance is not None and scene.desired_source is not None:  # no telemetry: hold still
        held = [plant.GetPositions(plant_ctx, scene.robot_instance)[j.position_start() - scene.robot_q0()]
                for j in scene.actuated_joints()]
        scene.set_desired(context, np.array([0.0]), np.array([held]))
    states = [hook.start(scene, context, values) for hook in hooks]
    return context, actuated, cols, states


class _Kinematic:
    """Moves the robot along its desired trajectory without stepping the plant: while every object sleeps no
    contact can happen, and the desired state (telemetry through any latency) is where the robot goes. Also the
    state the dynamic replay resumes from when something wakes."""

    def __init__(self, scene: Scene, context):
        plant = scene.plant
        self.context, self.plant = context, plant
        self.publish = scene.diagram.ForcedPublish if scene.visualized else None
        self.plant_ctx = plant.GetMyMutableContextFromRoot(context)
        self.source = scene.desired_source if scene.robot_instance is not None else None
        if self.source is None:
            return
        self.source_ctx = self.source.GetMyContextFromRoot(context)
        self.instance = scene.robot_instance
        q0 = scene.robot_q0()
        v0 = min(plant.get_joint(j).velocity_start() for j in plant.GetJointIndices(self.instance)
                 if plant.get_joint(j).num_velocities() > 0)
        joints = scene.actuated_joints()
        self.q_index = np.array([j.position_start() - q0 for j in joints])
        self.v_index = np.array([j.velocity_start() - v0 for j in joints])

    def move_to(self, t: float) -> None:
        self.context.SetTime(t)
        if self.source is not None:
            self._follow()
        if self.publish is not None:  # the viewer's recording sees the kinematic stretch too
            self.publish(self.context)

    def _follow(self) -> None:
        desired = self.source.get_output_port().Eval(self.source_ctx)
        n = len(self.q_index)
        q = self.plant.GetPositions(self.plant_ctx, self.instance)
        v = self.plant.GetVelocities(self.plant_ctx, self.instance)
        q[self.q_index], v[self.v_index] = desired[:n], desired[n:]
        self.plant.SetPositions(self.plant_ctx, self.instance, q)
        self.plant.SetVelocities(self.plant_ctx, self.instance, v)


def _moved(track: np.ndarray) -> bool:
    start = track_pose(track[0])
    translation = np.max(np.linalg.norm(track[:, :3] - track[0, :3], axis=1))
    if translation > MOVED_TRANSLATION:
        return True
    dots = np.abs(track[:, 3:7] @ np.asarray(start.quat))
    return bool(2 * np.arccos(np.clip(np.min(dots), -1, 1)) > MOVED_ROTATION)


def _check_support(name: str, pose: Pose, supports, t: float) -> None:
    """An object below a fixture's bottom inside its footprint went through it; below -5 m it fell out."""
    for support, geometry, support_pose, low in supports:
        if pose.xyz[2] < low and contains_xy(geometry, support_pose, pose.position, margin=0.02):
            raise SimulationFailure(f"object {name!r} went through {support!r} at t = {t:.2f} s (contact too soft, "
                                    "or time step too large)")
    if pose.xyz[2] < -5.0:
        raise SimulationFailure(f"object {name!r} fell out of the world at t = {t:.2f} s")
