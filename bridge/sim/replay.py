"""Replay recorded joint telemetry in a built scene and collect what inference and fitting need.

Returns final poses, pose tracks at a chosen rate, contacts over time, the objects that moved and those the
robot touched. A replay that produces garbage (NaN, an object through a support, a robot that cannot follow its
telemetry) raises `SimulationFailure` instead of handing garbage to the SIEs.
"""
from __future__ import annotations

import math
import time as wallclock
from dataclasses import dataclass, field
from typing import Callable, Mapping, Sequence

import numpy as np
from pydrake.systems.analysis import Simulator

from ..errors import SimulationFailure
from ..odb.geometry import contains_xy, z_range
from ..recording.telemetry import Telemetry, validate_telemetry
from ..values import Contact, Pose
from ..world import WorldState
from .scene import Scene, SceneParams, from_drake

MOVED_TRANSLATION = 0.005  # m
MOVED_ROTATION = math.radians(3.0)
PROXIMITY = 0.004  # m: bodies this close count as touching for the final state


@dataclass(frozen=True)
class ReplayOptions:
    sample_rate: float = 50.0  # Hz of the pose tracks and contact log
    settle: float = 0.5  # s simulated after the telemetry ends, so objects come to rest
    max_tracking_error: float = 0.25  # rad (or m) a joint may lag its telemetry ...
    max_tracking_time: float = 0.3  # ... for at most this long
    check_tracking: bool = True


@dataclass(frozen=True, eq=False)
class ReplayResult:
    times: np.ndarray  # (T,) sample times, s
    tracks: Mapping[str, np.ndarray]  # object -> (T, 7): x, y, z, qw, qx, qy, qz
    final_contacts: tuple[Contact, ...]
    contact_log: tuple[Contact, ...]  # every contact at every sample time
    moved: tuple[str, ...]
    touched_by_robot: tuple[str, ...]
    max_tracking_error: float
    sim_time: float
    wall_time: float
    robot: str | None = None
    joint_track: np.ndarray | None = field(default=None)  # (T, J) simulated robot positions
    robot_force: np.ndarray | None = field(default=None)  # (T, 3) N on the robot from what it touches, world

    @property
    def final_poses(self) -> dict[str, Pose]:
        return {n: track_pose(t[-1]) for n, t in self.tracks.items()}

    def pose_at(self, name: str, t: float) -> Pose:
        i = int(np.clip(np.searchsorted(self.times, t), 0, len(self.times) - 1))
        return track_pose(self.tracks[name][i])

    @property
    def realtime_factor(self) -> float:
        return self.sim_time / self.wall_time if self.wall_time > 0 else float("inf")

    def contact_pairs(self) -> frozenset[tuple[str, str]]:
        return frozenset((c.body_a, c.body_b) for c in self.contact_log)


def track_pose(row: np.ndarray) -> Pose:
    q = row[3:7] / np.linalg.norm(row[3:7])
    return Pose(tuple(row[:3]), tuple(q))


class ContactReader:
    """Names the bodies of Drake's contact results: object names, or 'robot/link' for robot links."""

    def __init__(self, scene: Scene):
        self.scene = scene
        inspector = scene.scene_graph.model_inspector()
        self.geometry_names = {gid: name for name, gids in scene.geometries.items() for gid in gids}
        for gid in inspector.GetAllGeometryIds():
            if gid not in self.geometry_names:
                body = scene.plant.GetBodyFromFrameId(inspector.GetFrameId(gid))
                if body is not None and body.index() in scene.body_names:
                    self.geometry_names[gid] = scene.body_names[body.index()]

    def name(self, gid) -> str:
        return self.geometry_names.get(gid, "world")

    def read(self, context, t: float, proximity: float = 0.0) -> list[Contact]:
        plant = self.scene.plant
        plant_ctx = plant.GetMyContextFromRoot(context)
        results = plant.get_contact_results_output_port().Eval(plant_ctx)
        contacts = []
        for i in range(results.num_hydroelastic_contacts()):
            info = results.hydroelastic_contact_info(i)
            surface = info.contact_surface()
            force = info.F_Ac_W().translational()
            contacts.append(Contact(self.name(surface.id_M()), self.name(surface.id_N()), tuple(-force),
                                    tuple(surface.centroid()), t))
        for i in range(results.num_point_pair_contacts()):
            info = results.point_pair_contact_info(i)
            pair = info.point_pair()
            contacts.append(Contact(self.name(pair.id_A), self.name(pair.id_B), tuple(info.contact_force()),
                                    tuple(info.contact_point()), t))
        if proximity > 0:
            seen = {frozenset((c.body_a, c.body_b)) for c in contacts}
            query = self.scene.scene_graph.get_query_output_port().Eval(self.scene.scene_graph.GetMyContextFromRoot(context))
            for pair in self._near_pairs(query, proximity):
                a, b = self.name(pair.id_A), self.name(pair.id_B)
                if a != b and frozenset((a, b)) not in seen:
                    contacts.append(Contact(a, b, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), t))
        return [c for c in contacts if c.body_a != c.body_b]

    def force_on(self, contacts: Sequence[Contact], robot: str) -> np.ndarray:
        """The net contact force (world frame, N) on the robot's links from everything that is not the robot:
        what a force-torque sensor between the robot and its tool would read."""
        total = np.zeros(3)
        for c in contacts:
            a_robot, b_robot = (b == robot or b.startswith(robot + "/") for b in (c.body_a, c.body_b))
            if b_robot and not a_robot:
                total += c.force
            elif a_robot and not b_robot:
                total -= c.force
        return total

    def _near_pairs(self, query, proximity: float) -> list:
        """Signed distances of the pairs closer than `proximity`. Drake has no distance query for some shape
        pairs (a convex mesh and the floor's half space): then pair by pair, skipping the unsupported ones."""
        try:
            return list(query.ComputeSignedDistancePairwiseClosestPoints(proximity))
        except RuntimeError:
            pass
        pairs = []
        for id_a, id_b in self.scene.scene_graph.model_inspector().GetCollisionCandidates():
            try:
                pair = query.ComputeSignedDistancePairClosestPoints(id_a, id_b)
            except RuntimeError:
                continue
            if pair.distance <= proximity:
                pairs.append(pair)
        return pairs


def _supports(scene: Scene, world: WorldState):
    """Fixtures (tables) whose footprint an object must not fall through."""
    return [(n, scene.odb.get(o.type).geometry, o.pose) for n, o in world.objects.items() if scene.odb.get(o.type).fixed]


def replay(
    scene: Scene,
    telemetry: Telemetry,
    *,
    world: WorldState | None = None,
    params: SceneParams | None = None,
    options: ReplayOptions = ReplayOptions(),
    on_sample: Callable[[float, Mapping[str, Pose], list[Contact]], None] | None = None,
    progress: Callable[[float, float], None] | None = None,
) -> ReplayResult:
    """Simulate `telemetry` (joint positions by name) from the world's initial state."""
    world = world or scene.world
    plant = scene.plant
    context = scene.new_context(world, params)
    plant_ctx = plant.GetMyMutableContextFromRoot(context)
    q_cols = None
    if scene.robot_instance is not None:
        validate_telemetry(telemetry, scene.robot_joints)
        q_cols = scene.actuator_columns(telemetry.joint_names)
        desired = telemetry.positions[:, q_cols]
        scene.set_desired(telemetry.times, desired)
        start = dict(zip(telemetry.joint_names, telemetry.positions[0]))
        plant.SetPositions(plant_ctx, scene.robot_instance, scene.robot_positions(start))
        actuated = [plant.get_joint_actuator(a).joint() for a in plant.GetJointActuatorIndices(scene.robot_instance)]
    end = telemetry.duration + options.settle
    n_samples = max(2, int(math.floor(end * options.sample_rate)) + 1)
    times = np.linspace(0.0, end, n_samples)
    names = list(scene.bodies)
    tracks = {n: np.zeros((n_samples, 7)) for n in names}
    joint_track = np.zeros((n_samples, len(q_cols))) if q_cols is not None else None
    reader = ContactReader(scene)
    supports = _supports(scene, world)
    log: list[Contact] = []
    worst, lag_since = 0.0, None
    simulator = Simulator(scene.diagram, context)
    simulator.Initialize()
    started = wallclock.perf_counter()
    for k, t in enumerate(times):
        if t > 0:
            try:
                simulator.AdvanceTo(float(t))
            except RuntimeError as exc:
                raise SimulationFailure(f"Drake stopped at t = {context.get_time():.3f} s: {exc}") from None
        state = plant.GetPositions(plant_ctx)
        if not np.all(np.isfinite(state)):
            raise SimulationFailure(f"the simulation produced NaN at t = {t:.3f} s (try a smaller time step)")
        poses = {}
        for n in names:
            X = plant.EvalBodyPoseInWorld(plant_ctx, scene.bodies[n])
            pose = from_drake(X)
            poses[n] = pose
            tracks[n][k] = (*pose.xyz, *pose.quat)
            _check_not_through(n, pose, scene, world, supports, t)
        if q_cols is not None:
            q_now = np.array([j.GetOnePosition(plant_ctx) for j in actuated])
            joint_track[k] = q_now
            if options.check_tracking and t <= telemetry.duration:
                err = np.abs(q_now - telemetry.sample(t)[q_cols])
                j = int(np.argmax(err))
                worst = max(worst, float(err[j]))
                if err[j] > options.max_tracking_error:
                    lag_since = t if lag_since is None else lag_since
                    if t - lag_since > options.max_tracking_time:
                        raise SimulationFailure(
                            f"the robot cannot follow its telemetry: joint {actuated[j].name()!r} is {err[j]:.3f} off "
                            f"at t = {t:.2f} s (blocked by a collision, or telemetry too fast for the PD gains)")
                else:
                    lag_since = None
        contacts = reader.read(context, float(t))
        log.extend(contacts)
        if on_sample is not None:
            on_sample(float(t), poses, contacts)
        if progress is not None:
            progress(float(t), end)
    wall = wallclock.perf_counter() - started
    final = tuple(reader.read(context, float(times[-1]), proximity=PROXIMITY))
    moved = tuple(n for n in names if _moved(tracks[n]))
    robot = world.robot.name if world.robot else None
    touched = tuple(sorted({c.other(robot) for c in log if robot and c.involves(robot) and not c.other(robot).startswith(robot + "/")}
                           - {"world"}))
    return ReplayResult(times, tracks, final, tuple(log), moved, touched, worst, float(end), wall, robot, joint_track)


def _moved(track: np.ndarray) -> bool:
    start = track_pose(track[0])
    translation = np.max(np.linalg.norm(track[:, :3] - track[0, :3], axis=1))
    if translation > MOVED_TRANSLATION:
        return True
    dots = np.abs(track[:, 3:7] @ np.asarray(start.quat))
    return bool(2 * np.arccos(np.clip(np.min(dots), -1, 1)) > MOVED_ROTATION)


def _check_not_through(name: str, pose: Pose, scene: Scene, world: WorldState, supports, t: float) -> None:
    for support, geometry, support_pose in supports:
        low, _ = z_range(geometry, support_pose)
        if pose.xyz[2] < low and contains_xy(geometry, support_pose, pose.position, margin=0.02):
            raise SimulationFailure(f"object {name!r} went through {support!r} at t = {t:.2f} s (contact too soft, or time step too large)")
    if pose.xyz[2] < -5.0:
        raise SimulationFailure(f"object {name!r} fell out of the world at t = {t:.2f} s")
