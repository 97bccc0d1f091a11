"""The pushing bodies: push_over, push (slide) and push_against, and `push_at` for physics tests.

The fingers close and their end faces push the object's side at a chosen height: high above the tipping height
w / (2 mu) to topple it, low below it to slide it. Horizontal pushes need the wrist at least 10 cm above the
robot's base; lower pushes tilt the tool 25-40 deg down so the wrist stays clear of the table.
"""
from __future__ import annotations

import math
from typing import Mapping, Sequence

import numpy as np

from ..odb import ObjectDatabase
from ..recording.telemetry import Telemetry
from ..values import Pose
from ..world import WorldState
from .jobs import (CARRY_SPEED, NEAR_SPEED, PAD_FRICTION, PAD_HALF_SPAN, PAD_HALF_WIDTH, PRESS, STANDOFF,
                   TABLE_CLEARANCE, Job, first_working, fmt_dir, fmt_point, refuse, rotation_about, start_job)
from ..sim.friction import combined_friction
from .layout import UP, Footprint, horizontal
from .motion import frame_rotation


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
    return first_working(job, attempts, f"push {obj!r} along {fmt_dir(d)} at {height * 100:.0f} cm")


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
    mb.line(p1, None, job.push_frame, f"push {obj!r} to {fmt_point(p1)}", speed=speed, may_touch={obj})
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
            attempts.append(refuse(job, f"{obj!r} is too squat to tip along {fmt_dir(d)}: it would "
                                         f"slide unless pushed {needed * 100:.1f} cm up, and it is {H * 100:.1f} cm high"))
            continue
        far = job.layout.centre(obj) + d * (w / 2)
        lying = Footprint(np.append(far[:2], 0.0) + d * (H / 2 + 0.01), d, H / 2 + 0.02,
                          job.layout.half_extent(obj, np.cross(UP, d)) + 0.01)
        problem = _region_problem(job, lying, support, (obj, support), f"{obj!r} falling along {fmt_dir(d)}")
        if problem:
            attempts.append(refuse(job, problem))
            continue
        phi = math.atan2(w, H)
        tip_travel = height * math.tan(phi) - w * (1.0 / math.cos(phi) - 1.0)
        travel = 1.4 * tip_travel + 0.02
        edge = np.append(far[:2], lo)
        lying_pose = job.moved_pose(obj, None, rotation_about(np.cross(UP, d), math.pi / 2), edge + d * (H / 2) + UP * (w / 2))
        attempts.append(lambda d=d, height=height, travel=travel, after=lying_pose:
                        plan_push(job, obj, d, height, travel, after, speed=0.05))
    return first_working(job, attempts, f"push {obj!r} over")


def push(world: WorldState, odb: ObjectDatabase, args: Sequence[str], *, rng=None) -> Telemetry:
    job = start_job(world, odb, "push", args, ("robot", "object", "support"), rng)
    _, obj, support = job.args
    distance = job.jitter(0.09, 0.005)
    attempts = []
    for d in _directions(job, obj):
        fp = job.layout.footprint(obj, d)
        after = Footprint(fp.centre + distance * d, d, fp.a, fp.b)
        problem = _region_problem(job, after, support, (obj, support), f"{obj!r} slid along {fmt_dir(d)}")
        if problem:
            attempts.append(refuse(job, problem))
            continue
        height = _slide_height(job, obj, support, d)
        attempts.append(lambda d=d, height=height: plan_push(job, obj, d, height, distance,
                                                             job.moved_pose(obj, distance * d)))
    return first_working(job, attempts, f"slide {obj!r} {distance * 100:.0f} cm along {support!r}")


def push_against(world: WorldState, odb: ObjectDatabase, args: Sequence[str], *, rng=None) -> Telemetry:
    job = start_job(world, odb, "push_against", args, ("robot", "object", "target", "support"), rng)
    _, obj, target, support = job.args
    if obj == target:
        raise job.fail(f"cannot push {obj!r} against itself")
    towards = horizontal(job.layout.centre(target) - job.layout.centre(obj))
    attempts = []
    for d in sorted(job.layout.side_normals(obj), key=lambda d: -float(d @ towards)):
        where = f"along {fmt_dir(d)}"
        if d @ towards <= 0.0:
            continue
        overlap = job.layout.lateral_overlap(obj, target, d)
        if overlap < 0.01:
            attempts.append(refuse(job, f"{obj!r} pushed {where} would pass {target!r} by ({overlap * 100:.1f} cm overlap)"))
            continue
        gap = job.layout.gap(obj, target, d)
        if gap < 0.0:
            attempts.append(refuse(job, f"{obj!r} and {target!r} overlap {where}"))
            continue
        fp = job.layout.footprint(obj, d)
        swept = Footprint(fp.centre + (gap / 2) * d, d, fp.a + gap / 2, fp.b)
        problem = _region_problem(job, swept, support, (obj, target, support), f"the path of {obj!r} {where}")
        if problem:
            attempts.append(refuse(job, problem))
            continue
        height = _slide_height(job, obj, support, d)
        travel = gap + job.jitter(PRESS, 0.0005)
        attempts.append(lambda d=d, height=height, travel=travel: plan_push(job, obj, d, height, travel,
                                                                            job.moved_pose(obj, travel * d), speed=0.04))
    return first_working(job, attempts, f"push {obj!r} against {target!r}")


def _slide_height(job: Job, obj: str, support: str, d: np.ndarray) -> float:
    """Half the tipping height, at most 40 % of the object's height, at least what the fingers allow."""
    lo, hi = job.layout.z_range(obj)
    return job.jitter(max(0.022, min(0.5 * tipping_height(job, obj, support, d), 0.4 * (hi - lo))), 0.002)


def _region_problem(job: Job, fp: Footprint, support: str, ignore, what: str) -> str | None:
    if not job.layout.on_support(fp, support):
        return f"{what} would leave {support!r} (near {fmt_point(fp.centre[:2])})"
    blocked = job.layout.blocking(fp, ignore)
    if blocked:
        return f"{what} would come within {100 * 0.03:.0f} cm of {', '.join(map(repr, blocked))}"
    return None
