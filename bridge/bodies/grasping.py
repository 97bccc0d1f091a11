"""The grasping bodies: pick, place and stand_up.

The gripper closes on an object from above, 3 cm below its top, across its narrowest horizontal side (at most
6 cm: the fingers open 8 cm). The PD-driven fingers squeeze with about 25 N on a 5 cm box.
"""
from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from ..odb import ObjectDatabase
from ..recording.telemetry import Telemetry
from ..world import WorldState
from .jobs import (CARRY_SPEED, FINGER_BELOW_TCP, GRASP_DEPTH, LIFT, MAX_GRASP_WIDTH, NEAR_SPEED, PAD_HALF_WIDTH,
                   Job, first_working, fmt_point, rotation_about, start_job)
from .layout import UP, horizontal
from .motion import MotionBuilder, frame_rotation


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
    return first_working(job, attempts, f"grasp {obj!r} from above")


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
    mb.line(grasp, None, job.tcp, f"reach down to {obj!r} at {fmt_point(grasp)}", speed=NEAR_SPEED, may_touch={obj})
    mb.set_fingers(job.closed, 1.0, f"close on {obj!r}", may_touch={obj})
    mb.wait(0.5, "hold", may_touch={obj})
    lifted = grasp + job.jitter(LIFT, 0.005) * UP
    mb.line(lifted, None, job.tcp, f"lift {obj!r} to {fmt_point(lifted)}", speed=NEAR_SPEED, may_touch={obj})
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
    return first_working(job, attempts, f"place {obj!r} on {support!r}")


def _held_offset(job: Job, obj: str) -> np.ndarray:
    """The object's pose in the tcp frame (4x4) from the world's robot joints and object pose; the object must be
    between the fingers."""
    p, R = job.arm.pose(job.start, job.tcp)
    X_tcp = np.eye(4)
    X_tcp[:3, :3], X_tcp[:3, 3] = R, p
    X_obj = job.world.objects[obj].pose.matrix()
    X = np.linalg.inv(X_tcp) @ X_obj
    if np.linalg.norm(X[:3, 3]) > 0.08:
        raise job.fail(f"{obj!r} at {fmt_point(X_obj[:3, 3])} is not in the gripper (tcp at {fmt_point(p)}); place starts "
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
    mb.line(over, None, job.tcp, f"carry {obj!r} over {support!r} at {fmt_point(spot[:2])}", speed=CARRY_SPEED, may_touch={obj})
    mb.line(rest + 0.03 * UP, None, job.tcp, f"lower {obj!r} over {support!r}", speed=CARRY_SPEED, may_touch={obj})
    mb.line(rest, None, job.tcp, f"set {obj!r} down on {support!r} at {fmt_point(rest)}", speed=0.02, may_touch={obj, support})
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
    headings = [rotation_about(UP, math.radians(a)) @ r for a in (0.0, 35.0, -35.0)]
    attempts = [lambda side=side, heading=heading: _stand_up_once(job, obj, support, u, side * across, length, heading)
                for heading in headings for side in (1.0, -1.0)]
    return first_working(job, attempts, f"stand {obj!r} up")


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
    mb.line(grasp, None, job.tcp, f"reach down to {obj!r} at {fmt_point(grasp)}", speed=NEAR_SPEED, may_touch={obj})
    mb.set_fingers(job.closed, 1.0, f"close on {obj!r}", may_touch={obj})
    mb.wait(0.4, "hold", may_touch={obj})
    top = job.layout.top(support)
    standing_tcp_z = top + length / 2 + delta  # tcp height with the object upright on the support
    clear = max(grasp[2], standing_tcp_z) + 0.05
    lifted = np.array([grasp[0], grasp[1], clear])
    mb.line(lifted, None, job.tcp, f"lift {obj!r}", speed=NEAR_SPEED, may_touch={obj, support})
    mb.line(lifted, R1, job.tcp, f"turn {obj!r} upright", angular_speed=0.5, may_touch={obj, support})
    down = np.array([grasp[0], grasp[1], standing_tcp_z + 0.004])
    mb.line(down, None, job.tcp, f"set {obj!r} down at {fmt_point(down[:2])}", speed=0.03, may_touch={obj, support})
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
