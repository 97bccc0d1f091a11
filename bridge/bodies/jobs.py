"""What every action body shares: the job (world, arm, arguments, start), the demo gripper's dimensions, trying
alternatives until one works, and small geometry helpers."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Mapping, Sequence

import numpy as np

from ..errors import ActionError
from ..odb import ObjectDatabase
from ..recording.telemetry import Telemetry
from ..values import Pose, rotation_to_quat
from ..world import WorldState
from ..sim.friction import combined_friction
from .layout import Layout, horizontal
from ..sim.kinematics import Arm, arm_for, clearance_for
from .motion import MotionBuilder

# the demo arm's finger pads (models/arm7): half width across the fingers' faces, and how far closed fingers reach
PAD_HALF_WIDTH = 0.01
PAD_HALF_SPAN = 0.012
PAD_FRICTION = 1.0  # the pads' friction coefficient (arm7.sdf)
FINGER_BELOW_TCP = 0.015  # m the finger ends reach beyond the tcp
TABLE_CLEARANCE = 0.004  # m between the lowest finger point and the support while pushing
STANDOFF = 0.02  # m between the fingertips and the face before a push
NEAR_SPEED = 0.04  # m/s of the tool near objects
CARRY_SPEED = 0.06  # m/s while carrying or retreating
PRESS = 0.004  # m push_against presses beyond the first touch
GRASP_DEPTH = 0.03  # m the tcp goes below an object's top to grasp it
LIFT = 0.12  # m pick lifts the object
MAX_GRASP_WIDTH = 0.06  # m: the fingers open 8 cm

Body = Callable[..., Telemetry]


@dataclass(frozen=True, eq=False)
class Job:
    """What every body works with: the world, the arm, who is who, and the start of the motion."""

    world: WorldState
    odb: ObjectDatabase
    layout: Layout
    arm: Arm
    action: str
    args: tuple[str, ...]
    home: np.ndarray
    start: np.ndarray
    fingers: tuple[int, ...]
    open: float
    closed: float
    push_frame: str
    tcp: str
    rng: np.random.Generator | None

    @property
    def call(self) -> str:
        return f"{self.action}({', '.join(self.args)})"

    def builder(self, *, go_home: bool = True) -> MotionBuilder:
        """A motion starting at the world's robot joints (then home, when `go_home`)."""
        mb = MotionBuilder(self.arm, self.start, self.fingers, self.call)
        if go_home:
            mb.joint_move(self.home, "move home")
        return mb

    def finish(self, mb: MotionBuilder, *after: Mapping[str, Pose]) -> Telemetry:
        """Check the motion's clearance (stage 0 against the world, stage k against the world with the poses
        of `after[k - 1]`, where the body expects the objects then) and sample it."""
        worlds = [self.world]
        for poses in after:
            worlds.append(worlds[-1].with_poses(poses))
        mb.check_clearance([clearance_for(w, self.odb) for w in worlds])
        return mb.telemetry(source=f"<body {self.call}>")

    def moved_pose(self, obj: str, shift: np.ndarray, R: np.ndarray | None = None, centre: np.ndarray | None = None) -> dict[str, Pose]:
        """`obj` translated by `shift`, or put with rotation `R` (applied to its current one) at `centre`."""
        pose = self.layout.pose(obj)
        if R is None:
            return {obj: Pose(tuple(pose.position + shift), pose.quat)}
        return {obj: Pose(tuple(centre), rotation_to_quat(R @ pose.rotation()))}

    def fail(self, message: str) -> ActionError:
        return ActionError(f"{self.call}: {message}")

    def jitter(self, value: float, scale: float) -> float:
        """`value` varied by a normal deviate of `scale` when a generator is given (teleoperation varies)."""
        return value if self.rng is None else float(value + self.rng.normal(0.0, scale))

    def friction(self, obj: str, support: str) -> float:
        return combined_friction(self.odb.get(self.world.objects[obj].type).physics.friction,
                                 self.odb.get(self.world.objects[support].type).physics.friction)

    def clear_height(self) -> float:
        """The top of the highest movable object: above it the hand may turn freely."""
        return max([self.layout.top(n) for n in self.layout.movables()] or [self.layout.top(n) for n in self.world.objects])

    def radial(self, obj: str) -> np.ndarray:
        """Horizontal unit vector from the robot's base to `obj`."""
        return horizontal(self.layout.centre(obj) - np.asarray(self.world.robot.base_pose.xyz))


def start_job(world: WorldState, odb: ObjectDatabase, action: str, args: Sequence[str], roles: Sequence[str],
              rng=None) -> Job:
    """Check the arguments (robot first, then objects) and set up the arm."""
    call = f"{action}({', '.join(args)})"
    if len(args) != len(roles):
        raise ActionError(f"{call}: {action} takes {len(roles)} arguments ({', '.join(roles)}), got {len(args)}")
    if world.robot is None:
        raise ActionError(f"{call}: the world {world.name!r} has no robot")
    names = []
    for arg, role in zip(args, roles):
        name = arg if arg in world.all_names() else world.names.original(arg.lower())
        if role == "robot":
            if name != world.robot.name:
                raise ActionError(f"{call}: {arg!r} is not the world's robot; the robot is {world.robot.name!r}")
        elif name not in world.objects:
            raise ActionError(f"{call}: unknown object {arg!r} for the {role}; objects: {', '.join(world.objects)}")
        names.append(name)
    spec = odb.get(world.robot.type).robot
    if spec.gripper is None:
        raise ActionError(f"{call}: robot type {world.robot.type!r} has no gripper; the bodies need one")
    arm = arm_for(world, odb)
    joints = world.robot.joint_positions()
    home = spec.home_positions()
    fingers = tuple(spec.joints.index(j) for j in spec.gripper.joints)
    push_frame = "fingertip" if arm.has_frame("fingertip") else spec.gripper.tcp_frame
    return Job(world, odb, Layout(world, odb), arm, action, tuple(names),
               np.array([home[j] for j in spec.joints]), np.array([joints[j] for j in spec.joints]), fingers,
               spec.gripper.open_position, spec.gripper.closed_position, push_frame, spec.gripper.tcp_frame, rng)


def first_working(job: Job, attempts, what: str):
    """Run each attempt (a callable returning telemetry) until one works; otherwise one error listing why not."""
    reasons = []
    for attempt in attempts:
        try:
            return attempt()
        except ActionError as exc:
            reason = str(exc).removeprefix(f"{job.call}: ")
            if reason not in reasons:
                reasons.append(reason)
    raise job.fail(f"no way to {what}: " + ("; ".join(reasons) if reasons else "no candidate"))



def refuse(job: Job, reason: str):
    def attempt():
        raise job.fail(reason)
    return attempt


def rotation_about(axis: np.ndarray, angle: float) -> np.ndarray:
    k = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def fmt_dir(d) -> str:
    x, y = (float(v) + 0.0 for v in np.round(np.asarray(d, dtype=float)[:2], 2))
    return f"({x:.2f}, {y:.2f})"


def fmt_point(p) -> str:
    return "(" + ", ".join(f"{v:.3f}" for v in np.asarray(p, dtype=float)) + ")"
