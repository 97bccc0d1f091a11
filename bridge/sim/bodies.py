"""Action bodies (paper, Section III-A): the motion that grounds each action template, as joint telemetry.

Every body has one signature, ``body(world, odb, args, *, rng=None) -> Telemetry``: all the robot's joints at
50 Hz, starting where the world's robot stands, passing through its home posture, and (except for `pick`, which
ends holding the object up) ending at home. Near objects the tool moves at most 5 cm/s. The bodies aim at what
the templates' effects say (see pddl/templates/*.yaml and the SIEs in odb/sies/):

- push_over(r, o, s): push o high on a side (80 % of its height, above the tipping height w / (2 mu)) until
  it tips; it ends lying on s, clear of everything else.
- push(r, o, s): push o low (half the tipping height) ~9 cm along s, away from every other object.
- push_against(r, o, t, s): slide o low until it meets t, press 4 mm further, retreat.
- pick(r, o, s): grasp o from above, 3 cm below its top, close, lift 12 cm and hold it there.
- place(r, o, s): from a world where r holds o (`world_after_replay` of a pick), carry o over a free spot of s,
  lower it until it nearly rests, open, retreat.
- stand_up(r, o, s): o lies on s; grasp it near the end that must go up, lift, turn it upright about the grasp
  axis, set it down, release, retreat. (The gripper opens 8 cm: a box wider than 6 cm across cannot be stood up.)

Failures (unknown object, nothing reachable, no free spot, IK failure) raise `ActionError` naming the action,
the object and the target point. Motions are checked against the world's objects (`Clearance`) before they are
returned: the arm keeps 5 mm from everything it is not meant to touch.
"""
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
from .layout import UP, Footprint, Layout, combined_friction, horizontal
from .motion import Arm, MotionBuilder, arm_for, clearance_for, frame_rotation

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


# --- shared setup ---------------------------------------------------------------------------------
@dataclass
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


def _first(job: Job, attempts, what: str):
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


# --- pushing ----------------------------------------------------------------------------------------
def push_tool_pose(job: Job, obj: str, d: np.ndarray, height: float, tilt: float, side: float):
    """Where the pushing frame starts (STANDOFF before the face) and its rotation, for a push along `d` whose
    leading pad edge meets the face `height` above the object's bottom; None when the fingers would scrape the
    support."""
    approach = math.cos(tilt) * d - math.sin(tilt) * UP
    e = np.cross(UP, d)
    R = frame_rotation(approach, side * e)
    corners = [R @ np.array([sx * PAD_HALF_WIDTH, sy * PAD_HALF_SPAN, 0.0]) for sx in (-1, 1) for sy in (-1, 1)]
    ahead = max(c @ d for c in corners)
    lead = np.mean([c for c in corners if c @ d > ahead - 1e-6], axis=0)
    low = min(c[2] for c in corners)
    bottom, _ = job.layout.z_range(obj)
    centre = job.layout.centre(obj)
    near_face = float(centre @ d) - job.layout.half_extent(obj, d)
    p = centre - (centre @ d) * d  # the object's centre line across d
    p = p + (near_face - STANDOFF - ahead) * d
    p[2] = bottom + height - lead[2]
    if p[2] + low < bottom + TABLE_CLEARANCE:
        return None
    return p, R


def plan_push(job: Job, obj: str, d: np.ndarray, height: float, travel: float, after: Mapping[str, Pose], *,
              retreat_up: float = 0.08, speed: float = NEAR_SPEED) -> Telemetry:
    """Approach behind `obj`, push it `travel` m along `d` with the pad edge `height` above its bottom, back
    off, rise and go home. Tries tool tilts (horizontal for high pushes, 25-40 deg down for low ones) and both
    wrist sides. `after`: where the object is expected to end (the retreat keeps clear of it there)."""
    bottom, _ = job.layout.z_range(obj)
    base_z = job.world.robot.base_pose.xyz[2]
    high = bottom + height >= base_z + 0.10
    tilts = [0.0, 15.0, 25.0] if high else [25.0, 40.0, 15.0]
    attempts = []
    for tilt in tilts:
        for side in (1.0, -1.0):
            attempts.append(lambda tilt=tilt, side=side: _push_once(job, obj, d, height, travel, math.radians(tilt),
                                                                      side, retreat_up, speed, after))
    return _first(job, attempts, f"push {obj!r} along {_dir(d)} at {height * 100:.0f} cm")


def _push_once(job: Job, obj: str, d, height, travel, tilt, side, retreat_up, speed, after) -> Telemetry:
    start = push_tool_pose(job, obj, d, height, tilt, side)
    if start is None:
        raise job.fail(f"a {math.degrees(tilt):.0f} deg tool tilt would scrape the support")
    p0, R = start
    mb = job.builder()
    mb.set_fingers(job.closed, 0.6, "close the fingers to push")
    before = p0 - 0.06 * d + 0.06 * UP
    high = max(before[2], job.clear_height() + 0.04)  # above everything: turn the wrist up there
    mb.move_to([before[0], before[1], high], R, job.push_frame, f"move high behind {obj!r}", nominal=job.home)
    mb.line(before, None, job.push_frame, f"descend behind {obj!r}", speed=CARRY_SPEED)
    mb.line(p0, None, job.push_frame, f"approach {obj!r}", speed=CARRY_SPEED)
    p1 = p0 + (STANDOFF + travel) * d
    mb.line(p1, None, job.push_frame, f"push {obj!r} to {_pt(p1)}", speed=speed, may_touch={obj})
    back = p1 - 0.05 * d
    mb.line(back, None, job.push_frame, f"back off from {obj!r}", speed=CARRY_SPEED, may_touch={obj})
    mb.next_stage()
    mb.line([back[0], back[1], max(back[2] + retreat_up, high)], None, job.push_frame, "rise", speed=CARRY_SPEED)
    mb.joint_move(job.home, "return home")
    mb.set_fingers(job.open, 0.6, "open the fingers")
    return job.finish(mb, after)


def push_at(world: WorldState, odb: ObjectDatabase, args: Sequence[str], direction: Sequence[float], height: float,
            travel: float, *, speed: float = NEAR_SPEED) -> Telemetry:
    """A push of object `args[1]` (on `args[2]`, by robot `args[0]`) along `direction` for `travel` m, the pads'
    leading edge `height` above the object's bottom: whatever the physics makes of it (physics tests, benchmarks)."""
    job = start_job(world, odb, "push_at", args, ("robot", "object", "support"))
    d = horizontal(direction)
    return plan_push(job, job.args[1], d, height, travel, job.moved_pose(job.args[1], travel * d), speed=speed)


def _directions(job: Job, obj: str) -> list[np.ndarray]:
    """Side normals of `obj`, pushing away from the robot first."""
    r = job.radial(obj)
    return sorted(job.layout.side_normals(obj), key=lambda d: -float(d @ r))


def tipping_height(job: Job, obj: str, support: str, d: np.ndarray, *, pad_friction: bool = False) -> float:
    """Quasi-static tipping: a frictionless push at height h tips the object when h > w / (2 mu). The pads'
    friction may hold the near edge down while the face turns up past them, which adds up to mu_pad * w."""
    w = 2.0 * job.layout.half_extent(obj, d)
    height = w / (2.0 * job.friction(obj, support))
    if pad_friction:
        height += combined_friction(PAD_FRICTION, job.odb.get(job.world.objects[obj].type).physics.friction) * w
    return height


def push_over(world: WorldState, odb: ObjectDatabase, args: Sequence[str], *, rng=None) -> Telemetry:
    job = start_job(world, odb, "push_over", args, ("robot", "object", "support"), rng)
    _, obj, support = job.args
    lo, hi = job.layout.z_range(obj)
    H = hi - lo
    attempts = []
    for d in _directions(job, obj):
        w = 2.0 * job.layout.half_extent(obj, d)
        needed = 1.15 * tipping_height(job, obj, support, d, pad_friction=True)
        height = job.jitter(max(0.8 * H, needed), 0.003)
        if height > 0.92 * H:
            attempts.append(_refuse(job, f"{obj!r} is too squat to tip along {_dir(d)}: it would "
                                         f"slide unless pushed {needed * 100:.1f} cm up, and it is {H * 100:.1f} cm high"))
            continue
        far = job.layout.centre(obj) + d * (w / 2)
        lying = Footprint(np.append(far[:2], 0.0) + d * (H / 2 + 0.01), d, H / 2 + 0.02,
                          job.layout.half_extent(obj, np.cross(UP, d)) + 0.01)
        problem = _region_problem(job, lying, support, (obj, support), f"{obj!r} falling along {_dir(d)}")
        if problem:
            attempts.append(_refuse(job, problem))
            continue
        phi = math.atan2(w, H)
        tip_travel = height * math.tan(phi) - w * (1.0 / math.cos(phi) - 1.0)
        travel = 1.4 * tip_travel + 0.02
        edge = np.append(far[:2], lo)
        lying_pose = job.moved_pose(obj, None, _rotation(np.cross(UP, d), math.pi / 2), edge + d * (H / 2) + UP * (w / 2))
        attempts.append(lambda d=d, height=height, travel=travel, after=lying_pose:
                        plan_push(job, obj, d, height, travel, after, speed=0.05))
    return _first(job, attempts, f"push {obj!r} over")


def push(world: WorldState, odb: ObjectDatabase, args: Sequence[str], *, rng=None) -> Telemetry:
    job = start_job(world, odb, "push", args, ("robot", "object", "support"), rng)
    _, obj, support = job.args
    distance = job.jitter(0.09, 0.005)
    attempts = []
    for d in _directions(job, obj):
        fp = job.layout.footprint(obj, d)
        after = Footprint(fp.centre + distance * d, d, fp.a, fp.b)
        problem = _region_problem(job, after, support, (obj, support), f"{obj!r} slid along {_dir(d)}")
        if problem:
            attempts.append(_refuse(job, problem))
            continue
        height = _slide_height(job, obj, support, d)
        attempts.append(lambda d=d, height=height: plan_push(job, obj, d, height, distance,
                                                             job.moved_pose(obj, distance * d)))
    return _first(job, attempts, f"slide {obj!r} {distance * 100:.0f} cm along {support!r}")


def push_against(world: WorldState, odb: ObjectDatabase, args: Sequence[str], *, rng=None) -> Telemetry:
    job = start_job(world, odb, "push_against", args, ("robot", "object", "target", "support"), rng)
    _, obj, target, support = job.args
    if obj == target:
        raise job.fail(f"cannot push {obj!r} against itself")
    towards = horizontal(job.layout.centre(target) - job.layout.centre(obj))
    attempts = []
    for d in sorted(job.layout.side_normals(obj), key=lambda d: -float(d @ towards)):
        where = f"along {_dir(d)}"
        if d @ towards <= 0.0:
            continue
        overlap = job.layout.lateral_overlap(obj, target, d)
        if overlap < 0.01:
            attempts.append(_refuse(job, f"{obj!r} pushed {where} would pass {target!r} by ({overlap * 100:.1f} cm overlap)"))
            continue
        gap = job.layout.gap(obj, target, d)
        if gap < 0.0:
            attempts.append(_refuse(job, f"{obj!r} and {target!r} overlap {where}"))
            continue
        fp = job.layout.footprint(obj, d)
        swept = Footprint(fp.centre + (gap / 2) * d, d, fp.a + gap / 2, fp.b)
        problem = _region_problem(job, swept, support, (obj, target, support), f"the path of {obj!r} {where}")
        if problem:
            attempts.append(_refuse(job, problem))
            continue
        height = _slide_height(job, obj, support, d)
        travel = gap + job.jitter(PRESS, 0.0005)
        attempts.append(lambda d=d, height=height, travel=travel: plan_push(job, obj, d, height, travel,
                                                                            job.moved_pose(obj, travel * d), speed=0.04))
    return _first(job, attempts, f"push {obj!r} against {target!r}")


def _slide_height(job: Job, obj: str, support: str, d: np.ndarray) -> float:
    """Half the tipping height, at most 40 % of the object's height, at least what the fingers allow."""
    lo, hi = job.layout.z_range(obj)
    return job.jitter(max(0.022, min(0.5 * tipping_height(job, obj, support, d), 0.4 * (hi - lo))), 0.002)


def _region_problem(job: Job, fp: Footprint, support: str, ignore, what: str) -> str | None:
    if not job.layout.on_support(fp, support):
        return f"{what} would leave {support!r} (near {_pt(fp.centre[:2])})"
    blocked = job.layout.blocking(fp, ignore)
    if blocked:
        return f"{what} would come within {100 * 0.03:.0f} cm of {', '.join(map(repr, blocked))}"
    return None


def _refuse(job: Job, reason: str):
    def attempt():
        raise job.fail(reason)
    return attempt


# --- grasping -------------------------------------------------------------------------------------
def grasp_axes(job: Job, obj: str) -> list[np.ndarray]:
    """Horizontal finger axes across which `obj` fits between the open fingers, narrowest first."""
    axes = []
    for d in job.layout.side_normals(obj):
        if d @ np.array([0.3, 1.0, 0.0]) < 0:  # one of each opposite pair; the wrist side is tried separately
            continue
        width = 2 * job.layout.half_extent(obj, d)
        if width <= MAX_GRASP_WIDTH:
            axes.append((width, d))
    return [d for _, d in sorted(axes, key=lambda a: a[0])]


def pick(world: WorldState, odb: ObjectDatabase, args: Sequence[str], *, rng=None) -> Telemetry:
    job = start_job(world, odb, "pick", args, ("robot", "object", "support"), rng)
    _, obj, _ = job.args
    axes = grasp_axes(job, obj)
    if not axes:
        raise job.fail(f"{obj!r} is wider than {MAX_GRASP_WIDTH * 100:.0f} cm on every side; the gripper cannot hold it")
    attempts = [lambda axis=axis, side=side: _pick_once(job, obj, axis * side)[0]
                for axis in axes for side in (1.0, -1.0)]
    return _first(job, attempts, f"grasp {obj!r} from above")


def grasp_point(job: Job, obj: str) -> np.ndarray:
    bottom, top = job.layout.z_range(obj)
    depth = min(GRASP_DEPTH, (top - bottom) - FINGER_BELOW_TCP - 0.008)
    if depth < 0.01:
        raise job.fail(f"{obj!r} is too flat to grasp from above ({(top - bottom) * 100:.1f} cm high)")
    p = job.layout.centre(obj)
    p[2] = top - depth
    return p


def _pick_once(job: Job, obj: str, finger_axis: np.ndarray, mb: MotionBuilder | None = None):
    R = frame_rotation(-UP, finger_axis)
    grasp = grasp_point(job, obj)
    mb = mb or job.builder()
    mb.set_fingers(job.open, 0.5, "open the fingers")
    above = grasp + 0.10 * UP
    mb.move_to(above, R, job.tcp, f"move above {obj!r}", nominal=job.home)
    mb.line(grasp, None, job.tcp, f"reach down to {obj!r} at {_pt(grasp)}", speed=NEAR_SPEED, may_touch={obj})
    mb.set_fingers(job.closed, 1.0, f"close on {obj!r}", may_touch={obj})
    mb.wait(0.5, "hold", may_touch={obj})
    lifted = grasp + job.jitter(LIFT, 0.005) * UP
    mb.line(lifted, None, job.tcp, f"lift {obj!r} to {_pt(lifted)}", speed=NEAR_SPEED, may_touch={obj})
    mb.wait(0.5, "hold it up", may_touch={obj})
    return job.finish(mb), mb


def place(world: WorldState, odb: ObjectDatabase, args: Sequence[str], *, rng=None) -> Telemetry:
    job = start_job(world, odb, "place", args, ("robot", "object", "support"), rng)
    robot, obj, support = job.args
    if obj == support:
        raise job.fail(f"cannot place {obj!r} on itself")
    held = _held_offset(job, obj)
    spots = _place_spots(job, obj, support)
    if not spots:
        raise job.fail(f"no free spot on {support!r} for {obj!r} (everything within 3 cm of another object)")
    attempts = [lambda spot=spot: _place_once(job, obj, support, spot, held) for spot in spots[:6]]
    return _first(job, attempts, f"place {obj!r} on {support!r}")


def _held_offset(job: Job, obj: str) -> np.ndarray:
    """The object's pose in the tcp frame (4x4) from the world's robot joints and object pose; the object must be
    between the fingers."""
    p, R = job.arm.pose(job.start, job.tcp)
    X_tcp = np.eye(4)
    X_tcp[:3, :3], X_tcp[:3, 3] = R, p
    X_obj = job.world.objects[obj].pose.matrix()
    X = np.linalg.inv(X_tcp) @ X_obj
    if np.linalg.norm(X[:3, 3]) > 0.08:
        raise job.fail(f"{obj!r} at {_pt(X_obj[:3, 3])} is not in the gripper (tcp at {_pt(p)}); place starts "
                       f"from the world after a pick (see world_after_replay)")
    return X


def _place_spots(job: Job, obj: str, support: str) -> list[np.ndarray]:
    if job.layout.is_fixed(support):
        near = job.layout.centre(obj)
    else:
        near = job.layout.centre(support)
    return job.layout.free_spots(obj, support, near)


def _place_once(job: Job, obj: str, support: str, spot: np.ndarray, X_tcp_obj: np.ndarray) -> Telemetry:
    mb = job.builder(go_home=False)
    mb.set_fingers(job.closed, 0.02, f"keep holding {obj!r}", may_touch={obj})
    p_tcp, R_tcp = job.arm.pose(mb.q, job.tcp)
    offset = R_tcp @ X_tcp_obj[:3, 3]  # tcp -> object origin, world frame
    lo, hi = job.layout.z_range(obj)
    below = job.layout.pose(obj).position[2] - lo  # object origin above its lowest point
    top = job.layout.top(support)
    rest = np.array([spot[0], spot[1], top + below + 0.003]) - offset  # tcp when the object is 3 mm up
    path = job.layout.corridor(p_tcp + offset, rest + offset, 2 * max(job.layout.half_extent(obj, e) for e in np.eye(3)[:2]))
    others = [job.layout.top(n) for n in path if n != obj]
    carry_bottom = max([top, *others]) + 0.04
    lift_z = max(p_tcp[2], carry_bottom + below - offset[2])
    up = np.array([p_tcp[0], p_tcp[1], lift_z])
    over = np.array([rest[0], rest[1], lift_z])
    mb.line(up, None, job.tcp, f"lift {obj!r}", speed=NEAR_SPEED, may_touch={obj})
    mb.line(over, None, job.tcp, f"carry {obj!r} over {support!r} at {_pt(spot[:2])}", speed=CARRY_SPEED, may_touch={obj})
    mb.line(rest + 0.03 * UP, None, job.tcp, f"lower {obj!r} over {support!r}", speed=CARRY_SPEED, may_touch={obj})
    mb.line(rest, None, job.tcp, f"set {obj!r} down on {support!r} at {_pt(rest)}", speed=0.02, may_touch={obj, support})
    mb.wait(0.3, "settle", may_touch={obj, support})
    mb.set_fingers(job.open, 1.0, f"release {obj!r}", may_touch={obj, support})
    mb.wait(0.3, "let go", may_touch={obj, support})
    mb.line(rest + 0.04 * UP, None, job.tcp, "draw the fingers up", speed=NEAR_SPEED, may_touch={obj, support})
    mb.next_stage()
    mb.line(rest + 0.12 * UP, None, job.tcp, "retreat up", speed=CARRY_SPEED)
    mb.joint_move(job.home, "return home")
    placed = rest + offset - 0.003 * UP
    return job.finish(mb, job.moved_pose(obj, placed - job.layout.pose(obj).position))


def stand_up(world: WorldState, odb: ObjectDatabase, args: Sequence[str], *, rng=None) -> Telemetry:
    job = start_job(world, odb, "stand_up", args, ("robot", "object", "support"), rng)
    _, obj, support = job.args
    z_axis = job.layout.pose(obj).rotation()[:, 2]
    if abs(z_axis[2]) > math.cos(math.radians(45)):
        raise job.fail(f"{obj!r} is not lying on its side (its axis is {math.degrees(math.acos(min(1, abs(z_axis[2])))):.0f} deg from vertical)")
    u = horizontal(z_axis)  # the end that must go up
    across = np.cross(UP, u)
    width = 2 * job.layout.half_extent(obj, across)
    if width > MAX_GRASP_WIDTH:
        raise job.fail(f"{obj!r} is {width * 100:.0f} cm across; the gripper holds at most {MAX_GRASP_WIDTH * 100:.0f} cm, "
                       f"so it cannot be lifted and turned upright")
    length = 2 * job.layout.half_extent(obj, u)
    r = job.radial(obj)
    headings = [_rotation(UP, math.radians(a)) @ r for a in (0.0, 35.0, -35.0)]
    attempts = [lambda side=side, heading=heading: _stand_up_once(job, obj, support, u, side * across, length, heading)
                for heading in headings for side in (1.0, -1.0)]
    return _first(job, attempts, f"stand {obj!r} up")


def _stand_up_once(job: Job, obj: str, support: str, u: np.ndarray, finger_axis: np.ndarray, length: float,
                   heading: np.ndarray) -> Telemetry:
    """Grasp from above near the `u` end, turn the hand until it points along `heading` (horizontal) with the
    `u` end up, set the object down under the tcp."""
    grasp = grasp_point(job, obj)
    delta = length / 2 - PAD_HALF_WIDTH - 0.015  # grasp near the upper end: the tcp stays high when upright
    grasp = grasp + delta * u
    R0 = frame_rotation(-UP, finger_axis)
    x1 = UP * np.sign((R0.T @ u)[0])  # the hand's x axis ends vertical, so u (along it) ends up
    R1 = np.column_stack([x1, np.cross(heading, x1), heading])
    mb = job.builder()
    mb.set_fingers(job.open, 0.5, "open the fingers")
    mb.move_to(grasp + 0.10 * UP, R0, job.tcp, f"move above {obj!r}", nominal=job.home)
    mb.line(grasp, None, job.tcp, f"reach down to {obj!r} at {_pt(grasp)}", speed=NEAR_SPEED, may_touch={obj})
    mb.set_fingers(job.closed, 1.0, f"close on {obj!r}", may_touch={obj})
    mb.wait(0.4, "hold", may_touch={obj})
    top = job.layout.top(support)
    standing_tcp_z = top + length / 2 + delta  # tcp height with the object upright on the support
    clear = max(grasp[2], standing_tcp_z) + 0.05
    lifted = np.array([grasp[0], grasp[1], clear])
    mb.line(lifted, None, job.tcp, f"lift {obj!r}", speed=NEAR_SPEED, may_touch={obj, support})
    mb.line(lifted, R1, job.tcp, f"turn {obj!r} upright", angular_speed=0.5, may_touch={obj, support})
    down = np.array([grasp[0], grasp[1], standing_tcp_z + 0.004])
    mb.line(down, None, job.tcp, f"set {obj!r} down at {_pt(down[:2])}", speed=0.03, may_touch={obj, support})
    mb.wait(0.3, "settle", may_touch={obj, support})
    mb.set_fingers(job.open, 1.0, f"release {obj!r}", may_touch={obj, support})
    mb.wait(0.3, "let go", may_touch={obj, support})
    approach = R1[:, 2]
    back = down - 0.08 * approach
    mb.line(back, None, job.tcp, f"back off from {obj!r}", speed=NEAR_SPEED, may_touch={obj, support})
    mb.next_stage()
    mb.line(back + 0.12 * UP, None, job.tcp, "rise", speed=CARRY_SPEED)
    mb.joint_move(job.home, "return home")
    # the object turned with the hand about the tcp, then dropped the last 4 mm
    centre = down + (R1 @ R0.T) @ (job.layout.pose(obj).position - grasp) - 0.004 * UP
    return job.finish(mb, job.moved_pose(obj, None, R1 @ R0.T, centre))


# --- worlds between actions ----------------------------------------------------------------------------
def world_after_replay(before: WorldState, scene, result, facts) -> WorldState:
    """The world a replay ends in: the simulated objects' final poses, the robot's joints where the simulated
    robot stood at the end (fingers squeezing a held object stay where the object stopped them), and `facts`
    (e.g. the inferred ones). Starting a replay from it puts a held object between the fingers again."""
    from dataclasses import replace

    world = before.with_poses(result.final_poses).with_facts(facts)
    if before.robot is None or result.joint_track is None:
        return world
    plant = scene.plant
    names = [plant.get_joint_actuator(a).joint().name() for a in plant.GetJointActuatorIndices(scene.robot_instance)]
    joints = dict(before.robot.joints)
    joints.update({n: float(v) for n, v in zip(names, result.joint_track[-1])})
    return replace(world, robot=replace(before.robot, joints=tuple(joints.items())))


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    k = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def _dir(d) -> str:
    x, y = (float(v) + 0.0 for v in np.round(np.asarray(d, dtype=float)[:2], 2))
    return f"({x:.2f}, {y:.2f})"


def _pt(p) -> str:
    return "(" + ", ".join(f"{v:.3f}" for v in np.asarray(p, dtype=float)) + ")"


BODIES: Mapping[str, Body] = {
    "push_over": push_over,
    "push": push,
    "push_against": push_against,
    "pick": pick,
    "place": place,
    "stand_up": stand_up,
}
