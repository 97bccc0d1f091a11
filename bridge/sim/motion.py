"""Arm kinematics for action bodies: an IK-only plant per robot (the arm and the fixtures), inverse kinematics,
a clearance check against a world's objects, and a builder that turns joint-space and Cartesian moves into
joint telemetry.

The IK plant holds no movable object, so it is built once per robot placement and fixture layout and cached; the
clearance checker holds the world's objects as fixed geometry and is cached per object layout.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Iterable, Sequence

import numpy as np
from pydrake.math import RotationMatrix
from pydrake.multibody.inverse_kinematics import InverseKinematics
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.solvers import Solve
from pydrake.systems.framework import DiagramBuilder

from ..errors import ActionError
from ..odb import ObjectDatabase
from ..recording.telemetry import Telemetry
from ..values import Pose
from ..world import WorldState
from .scene import to_drake
from .shapes import drake_shape

RATE = 50.0  # Hz of generated telemetry
IK_STEP = 0.005  # m between IK solutions along a Cartesian line
IK_ANGLE_STEP = math.radians(3.0)  # rad between IK solutions along a rotation
MAX_JOINT_STEP = 0.2  # rad one IK step may change a joint by (more means the arm flipped)
ACCEL_TIME = 0.25  # s to reach cruise speed on a Cartesian line
DECIMALS = 6  # telemetry is written to a micro-radian


def frame_rotation(approach: Sequence[float], finger_axis: Sequence[float]) -> np.ndarray:
    """The tool frame's rotation: z along `approach`, y along `finger_axis` (made orthogonal to z)."""
    z = np.asarray(approach, dtype=float)
    z = z / np.linalg.norm(z)
    y = np.asarray(finger_axis, dtype=float)
    y = y - (y @ z) * z
    if np.linalg.norm(y) < 1e-6:
        raise ValueError(f"finger axis {list(finger_axis)} is parallel to the approach {list(approach)}")
    y = y / np.linalg.norm(y)
    return np.column_stack([np.cross(y, z), y, z])


# --- the IK plant ---------------------------------------------------------------------------------
class Arm:
    """A robot arm alone with the fixtures (no movable object): forward and inverse kinematics."""

    def __init__(self, model: str, base_link: str, base: Pose, joints: tuple[str, ...],
                 fixtures: tuple[tuple[str, object, Pose], ...]):
        builder = DiagramBuilder()
        plant, _ = AddMultibodyPlant(MultibodyPlantConfig(time_step=0.0), builder)
        (instance,) = Parser(plant, "ik_arm").AddModels(model)
        plant.WeldFrames(plant.world_frame(), plant.GetFrameByName(base_link, instance), to_drake(base))
        for name, shape, pose in fixtures:
            plant.RegisterCollisionGeometry(plant.world_body(), to_drake(pose), shape, f"{name}/ik",
                                            _proximity())
        plant.Finalize()
        self.diagram = builder.Build()
        self.plant = plant
        self.instance = instance
        self.joints = joints
        self.model, self.base_link, self.base = model, base_link, base
        self.context = self.diagram.CreateDefaultContext()
        self.plant_context = plant.GetMyMutableContextFromRoot(self.context)
        starts = [plant.GetJointByName(j, instance).position_start() for j in joints]
        if sorted(starts) != list(range(plant.num_positions())):
            raise ActionError(f"robot model {model}: the joints {list(joints)} are not all its positions")
        self.index = np.asarray(starts)  # plant position of each joint in telemetry order
        self.lower = plant.GetPositionLowerLimits()[self.index]
        self.upper = plant.GetPositionUpperLimits()[self.index]

    def has_frame(self, name: str) -> bool:
        return self.plant.HasFrameNamed(name, self.instance)

    def frame(self, name: str):
        return self.plant.GetFrameByName(name, self.instance)

    def to_plant(self, q: np.ndarray) -> np.ndarray:
        out = np.zeros(self.plant.num_positions())
        out[self.index] = q
        return out

    def from_plant(self, q_plant: np.ndarray) -> np.ndarray:
        return np.asarray(q_plant)[self.index]

    def pose(self, q: np.ndarray, frame: str) -> tuple[np.ndarray, np.ndarray]:
        """Position and rotation matrix of `frame` at joint positions `q` (telemetry order)."""
        self.plant.SetPositions(self.plant_context, self.to_plant(q))
        X = self.frame(frame).CalcPoseInWorld(self.plant_context)
        return X.translation().copy(), X.rotation().matrix().copy()

    def solve(self, p: Sequence[float], R: np.ndarray, frame: str, *, seed: np.ndarray, nominal: np.ndarray,
              fingers: float, finger_joints: Sequence[int], min_distance: float | None = None,
              tolerance: float = 0.01, weights: np.ndarray | None = None) -> np.ndarray | None:
        """Joint positions putting `frame` at `p` with rotation `R` (within `tolerance` rad), fingers at
        `fingers`, close to `nominal`; None when the solver fails."""
        ik = InverseKinematics(self.plant, self.plant_context)
        W = self.plant.world_frame()
        target = np.asarray(p, dtype=float)
        ik.AddPositionConstraint(self.frame(frame), np.zeros(3), W, target - 1e-4, target + 1e-4)
        ik.AddOrientationConstraint(W, RotationMatrix(R), self.frame(frame), RotationMatrix(), tolerance)
        if min_distance is not None:
            ik.AddMinimumDistanceLowerBoundConstraint(min_distance, 0.05)
        q = ik.q()
        prog = ik.prog()
        for i in finger_joints:
            prog.AddBoundingBoxConstraint(fingers, fingers, q[self.index[i]])
        w = np.ones(len(self.joints)) if weights is None else weights
        for i in finger_joints:
            w[i] = 0.0
        W_plant = np.zeros(self.plant.num_positions())
        W_plant[self.index] = w
        prog.AddQuadraticErrorCost(np.diag(W_plant), self.to_plant(nominal), q)
        prog.SetInitialGuess(q, self.to_plant(seed))
        result = Solve(prog)
        if not result.is_success():
            return None
        return self.from_plant(result.GetSolution(q))


def _proximity():
    from pydrake.geometry import ProximityProperties

    return ProximityProperties()


def arm_for(world: WorldState, odb: ObjectDatabase) -> Arm:
    """The cached IK plant of the world's robot at its base pose, with the world's fixtures."""
    if world.robot is None:
        raise ActionError(f"world {world.name!r} has no robot to move")
    spec = odb.get(world.robot.type).robot
    fixtures = tuple(sorted((n, o.type, o.pose) for n, o in world.objects.items() if odb.get(o.type).fixed))
    return _arm(str(spec.model), spec.base_link, world.robot.base_pose, spec.joints, fixtures, odb)


@lru_cache(maxsize=8)
def _arm(model: str, base_link: str, base: Pose, joints: tuple[str, ...], fixtures, odb: ObjectDatabase) -> Arm:
    return Arm(model, base_link, base, joints, tuple((n, drake_shape(odb.get(t)), p) for n, t, p in fixtures))


# --- clearance -----------------------------------------------------------------------------------
class Clearance:
    """The arm among a world's objects (all fixed where the world has them): distances from the arm to each."""

    def __init__(self, arm: Arm, objects: tuple[tuple[str, object, Pose], ...], reach: float = 0.1):
        builder = DiagramBuilder()
        plant, scene_graph = AddMultibodyPlant(MultibodyPlantConfig(time_step=0.0), builder)
        (instance,) = Parser(plant, "clearance_arm").AddModels(arm.model)
        plant.WeldFrames(plant.world_frame(), plant.GetFrameByName(arm.base_link, instance), to_drake(arm.base))
        self.names = {}
        for name, shape, pose in objects:
            gid = plant.RegisterCollisionGeometry(plant.world_body(), to_drake(pose), shape, f"{name}/clearance",
                                                  _proximity())
            self.names[gid] = name
        plant.Finalize()
        self.diagram = builder.Build()
        self.plant, self.scene_graph = plant, scene_graph
        self.context = self.diagram.CreateDefaultContext()
        self.plant_context = plant.GetMyMutableContextFromRoot(self.context)
        self.sg_context = scene_graph.GetMyContextFromRoot(self.context)
        self.arm = arm
        self.reach = reach
        self.link_of = {}
        inspector = scene_graph.model_inspector()
        for gid in inspector.GetAllGeometryIds():
            body = plant.GetBodyFromFrameId(inspector.GetFrameId(gid))
            if body is not None and body.model_instance() == instance:
                self.link_of[gid] = body.name()

    def distances(self, q: np.ndarray) -> dict[str, tuple[float, str]]:
        """Per object (within `reach`): the smallest distance to the arm and the link that comes closest."""
        self.plant.SetPositions(self.plant_context, self.arm.to_plant(q))
        query = self.scene_graph.get_query_output_port().Eval(self.sg_context)
        found: dict[str, tuple[float, str]] = {}
        for pair in query.ComputeSignedDistancePairwiseClosestPoints(self.reach):
            ids = (pair.id_A, pair.id_B)
            obj = next((self.names[i] for i in ids if i in self.names), None)
            link = next((self.link_of[i] for i in ids if i in self.link_of), None)
            if obj is None or link is None:
                continue
            if obj not in found or pair.distance < found[obj][0]:
                found[obj] = (float(pair.distance), link)
        return found


def clearance_for(world: WorldState, odb: ObjectDatabase) -> Clearance:
    arm = arm_for(world, odb)
    objects = tuple(sorted((n, o.type, o.pose) for n, o in world.objects.items()))
    return _clearance(arm, objects, odb)


@lru_cache(maxsize=8)
def _clearance(arm: Arm, objects, odb: ObjectDatabase) -> Clearance:
    return Clearance(arm, tuple((n, drake_shape(odb.get(t)), p) for n, t, p in objects))


# --- trajectories --------------------------------------------------------------------------------
@dataclass(frozen=True)
class Segment:
    """A stretch of the motion: its name (for messages), its times, and the objects it may touch."""

    label: str
    start: float
    end: float
    may_touch: frozenset[str] = frozenset()
    stage: int = 0  # which predicted arrangement of the objects the segment is checked against


class MotionBuilder:
    """Accumulates joint knots (time, positions in telemetry order) from moves; `telemetry()` samples them."""

    def __init__(self, arm: Arm, q0: np.ndarray, finger_joints: Sequence[int], what: str):
        self.arm = arm
        self.fingers = tuple(finger_joints)
        self.what = what  # "push_over(arm, big_box, table)", for messages
        self.times: list[float] = [0.0]
        self.knots: list[np.ndarray] = [np.asarray(q0, dtype=float).copy()]
        self.segments: list[Segment] = []
        self.stage = 0

    def next_stage(self) -> None:
        """Later segments are checked against the next arrangement of objects (after a push, a release)."""
        self.stage += 1

    @property
    def q(self) -> np.ndarray:
        return self.knots[-1].copy()

    @property
    def t(self) -> float:
        return self.times[-1]

    def finger_value(self) -> float:
        return float(self.knots[-1][self.fingers[0]]) if self.fingers else 0.0

    def _add(self, times: Iterable[float], qs: Iterable[np.ndarray], label: str, may_touch: Iterable[str]) -> None:
        start = self.t
        for t, q in zip(times, qs):
            self.times.append(float(t))
            self.knots.append(np.asarray(q, dtype=float))
        self.segments.append(Segment(label, start, self.t, frozenset(may_touch), self.stage))

    # --- moves ------------------------------------------------------------------------------------
    def wait(self, duration: float, label: str = "wait", may_touch: Iterable[str] = ()) -> None:
        self._add([self.t + duration], [self.q], label, may_touch)

    def set_fingers(self, value: float, duration: float, label: str = "gripper", may_touch: Iterable[str] = ()) -> None:
        """Move the fingers to `value` over `duration` seconds, the arm still."""
        q = self.q
        if abs(self.finger_value() - value) < 1e-9:
            return
        n = max(1, int(math.ceil(duration * RATE)))
        start = q.copy()
        goal = q.copy()
        goal[list(self.fingers)] = value
        s = _smooth(np.arange(1, n + 1) / n)
        self._add(self.t + duration * np.arange(1, n + 1) / n, [start + si * (goal - start) for si in s], label, may_touch)

    def joint_move(self, goal: np.ndarray, label: str, *, speed: float = 0.9, min_duration: float = 1.0,
                   may_touch: Iterable[str] = ()) -> None:
        """A smooth joint-space move (all joints start and stop together) at most `speed` rad/s on average."""
        start = self.q
        goal = np.asarray(goal, dtype=float)
        span = float(np.max(np.abs(goal - start)))
        if span < 1e-6:
            return
        duration = max(min_duration, 1.5 * span / speed)
        n = max(2, int(math.ceil(duration * RATE)))
        s = _smooth(np.arange(1, n + 1) / n)
        self._add(self.t + duration * np.arange(1, n + 1) / n, [start + si * (goal - start) for si in s], label, may_touch)

    def move_to(self, p: Sequence[float], R: np.ndarray, frame: str, label: str, *, nominal: np.ndarray,
                min_distance: float | None = 0.01, speed: float = 0.9, may_touch: Iterable[str] = ()) -> None:
        """Solve IK for the pose (fingers as they are), then a joint-space move there."""
        q = self.solve(p, R, frame, seed=self.q, nominal=nominal, min_distance=min_distance, label=label)
        self.joint_move(q, label, speed=speed, may_touch=may_touch)

    def line(self, p: Sequence[float], R: np.ndarray | None, frame: str, label: str, *, speed: float = 0.05,
             angular_speed: float = 0.6, min_distance: float | None = 0.005, may_touch: Iterable[str] = (),
             fingers: float | None = None) -> None:
        """Move `frame` along a straight line to `p` while turning to `R` (None: keep the rotation), with a
        trapezoidal speed profile; IK every few millimetres, each seeded with the last."""
        p0, R0 = self.arm.pose(self.q, frame)
        p1 = np.asarray(p, dtype=float)
        R1 = R0 if R is None else np.asarray(R, dtype=float)
        distance = float(np.linalg.norm(p1 - p0))
        angle = float(RotationMatrix(R0.T @ R1).ToAngleAxis().angle())
        n = max(1, int(math.ceil(max(distance / IK_STEP, angle / IK_ANGLE_STEP))))
        f0 = self.finger_value()
        f1 = f0 if fingers is None else fingers
        q = self.q
        qs = []
        for k in range(1, n + 1):
            s = k / n
            R_k = _slerp(R0, R1, s)
            p_k = p0 + s * (p1 - p0)
            f_k = f0 + s * (f1 - f0)
            q_k = self.solve(p_k, R_k, frame, seed=q, nominal=q, min_distance=min_distance, label=label,
                             fingers=f_k)
            if np.max(np.abs(q_k - q)) > MAX_JOINT_STEP:
                raise ActionError(f"{self.what}: {label}: the arm cannot follow the line to "
                                  f"{_point(p1)} (it would flip its joints near {_point(p_k)})")
            qs.append(q_k)
            q = q_k
        cruise = max(distance / speed, angle / angular_speed, 1e-3)
        fractions = np.arange(1, n + 1) / n
        times = self.t + _trapezoid_times(fractions, cruise, ACCEL_TIME)
        self._add(times, qs, label, may_touch)

    def solve(self, p, R, frame: str, *, seed, nominal, label: str, min_distance: float | None = 0.01,
              fingers: float | None = None) -> np.ndarray:
        fingers = self.finger_value() if fingers is None else fingers
        weights = np.ones(len(self.arm.joints))
        weights[6] = 0.1  # the last wrist joint is free to turn
        for tol in (0.01, 0.03):
            q = self.arm.solve(p, R, frame, seed=seed, nominal=nominal, fingers=fingers,
                               finger_joints=self.fingers, min_distance=min_distance, tolerance=tol, weights=weights)
            if q is not None:
                return q
        raise ActionError(f"{self.what}: {label}: no arm configuration puts the {frame} at {_point(p)} "
                          f"pointing {_point(np.asarray(R)[:, 2])} (out of reach, or the arm would hit a fixture)")

    # --- output -----------------------------------------------------------------------------------
    def telemetry(self, source: str = "<generated>") -> Telemetry:
        times = np.asarray(self.times)
        knots = np.vstack(self.knots)
        grid = np.arange(0.0, times[-1], 1.0 / RATE)
        grid = np.append(grid, times[-1]) if times[-1] - grid[-1] > 1e-6 else grid
        positions = np.column_stack([np.interp(grid, times, knots[:, j]) for j in range(knots.shape[1])])
        positions = np.round(positions, DECIMALS)
        return Telemetry(np.round(grid, 6), self.arm.joints, positions, source=source)

    def check_clearance(self, stages: Sequence[Clearance], margin: float = 0.005) -> None:
        """Every sample keeps `margin` from every object its segment may not touch, the objects where its stage's
        arrangement has them (the last arrangement serves the later stages)."""
        times = np.asarray(self.times)
        knots = np.vstack(self.knots)
        for seg in self.segments:
            clearance = stages[min(seg.stage, len(stages) - 1)]
            grid = np.arange(seg.start, seg.end, 0.05)
            grid = np.append(grid, seg.end)
            for t in grid:
                q = np.array([np.interp(t, times, knots[:, j]) for j in range(knots.shape[1])])
                for obj, (d, link) in clearance.distances(q).items():
                    if obj in seg.may_touch or d >= margin:
                        continue
                    raise ActionError(f"{self.what}: {seg.label}: the arm's {link} would come within {d * 1000:.0f} mm "
                                      f"of {obj!r} at t = {t:.1f} s (keep it {margin * 1000:.0f} mm away)")


def _smooth(s: np.ndarray) -> np.ndarray:
    """Quintic smoothstep: zero velocity and acceleration at both ends."""
    s = np.clip(s, 0.0, 1.0)
    return s * s * s * (10 - 15 * s + 6 * s * s)


def _trapezoid_times(fractions: np.ndarray, cruise: float, ramp: float) -> np.ndarray:
    """Times at which a trapezoidal profile (cruise time `cruise` at full speed, `ramp` s to accelerate and to
    brake) reaches each path fraction."""
    ramp = min(ramp, cruise)
    total = cruise + ramp
    t = np.linspace(0.0, total, 2000)
    v = np.minimum(1.0, np.minimum(t / ramp, (total - t) / ramp)) if ramp > 0 else np.ones_like(t)
    s = np.concatenate([[0.0], np.cumsum((v[1:] + v[:-1]) / 2 * np.diff(t))])
    s /= s[-1]
    return np.interp(fractions, s, t)


def _slerp(R0: np.ndarray, R1: np.ndarray, s: float) -> np.ndarray:
    aa = RotationMatrix(R0.T @ R1).ToAngleAxis()
    from pydrake.common.eigen_geometry import AngleAxis

    return R0 @ RotationMatrix(AngleAxis(aa.angle() * s, aa.axis())).matrix()


def _point(p) -> str:
    return "(" + ", ".join(f"{v:.3f}" for v in np.asarray(p, dtype=float)) + ")"


__all__ = ["Arm", "Clearance", "MotionBuilder", "RATE", "arm_for", "clearance_for", "frame_rotation"]
