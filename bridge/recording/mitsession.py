"""An MIT planar push (`mitpush.load_push`) as a session bridge can replay and fit: world state, telemetry,
observed track (Yu, Bauza, Fazeli, Rodriguez, IROS 2016).

Frames: the dataset's world frame is kept (x, y in metres, z up, the surface's top at z = 0). The object is the
mesh of its shape; its recorded yaw plus the shape's frame offset (`estimate_frame_yaw`) is the mesh's yaw,
and the observed track is expressed the same way, so simulated and observed poses compare directly.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import RecordingError
from ..names import build_name_map
from ..odb import ObjectDatabase
from ..odb.geometry import z_range
from ..values import Pose
from ..world import ObjectState, RobotState, WorldState
from .adjustments import StartClearance
from .mitpush import PUSHER_RADIUS, PushRecording, load_outline, pushed_samples, signed_distance, touching
from .forces import ObservedForce
from .observations import ObservedPoses, ObservedTrack
from .telemetry import Telemetry

SURFACE_TYPE = "push_surface"
SHAPE_TYPE = "mit_shape"  # the abstract type of the dataset's shapes (odb/types/mit_push.yaml)
ROBOT_TYPE = "planar_pusher"
SURFACE_NAME, ROBOT_NAME = "surface", "pusher"
OBSERVATION_RATE = 25.0  # Hz of the observed track kept for the error (the file has about 250 Hz)
SPIKY = 0.1  # a force whose 90th percentile is below this share of its peak is spikes, not a push
START_CLEARANCE = 1e-4  # m between rod and outline at t = 0 when the recorded start would penetrate


@dataclass(frozen=True, eq=False)
class PushSession:
    """A push as a world state before it, pusher telemetry (`pusher_x`, `pusher_y` = rod centre, m) and the
    object's observed track in the mesh frame. `tip_shift` (m, world x y) was added to every tip sample to
    start the rod out of the object; `start` keeps the recorded start clearance and that shift as data (the
    diagnosis reads it as evidence), `notes` say so in words."""

    world: WorldState
    telemetry: Telemetry
    observations: ObservedPoses
    frame_yaw: float
    tip_shift: tuple[float, float] = (0.0, 0.0)
    notes: tuple[str, ...] = ()
    force: ObservedForce | None = None  # ft_wrench's fx, fy (fz not measured), when it can be trusted
    start: StartClearance | None = None  # None: no outline to measure against


def push_session(push: PushRecording, odb: ObjectDatabase, *, frame_yaw: float = 0.0, observation_rate: float = OBSERVATION_RATE,
                 outline: np.ndarray | None = None, start_clearance: float = START_CLEARANCE) -> PushSession:
    """World, telemetry and observations of one push, in the dataset's world frame.

    The `push_surface` fixture is centred under the object's start, its top at z = 0; the object (type = the
    shape) stands on it at its recorded start pose, turned by `frame_yaw` into the mesh frame
    (`estimate_frame_yaw`); the `planar_pusher` base is welded at the object's mid-height so its joints are the
    rod centre's x and y. If the recorded rod starts inside the outline (`outline`, default the shape's), the
    whole tip track is moved out along the outline's normal to `start_clearance` (a rod already touching would
    otherwise kick the object at t = 0); the recorded clearance and the shift are kept in `start`, never only
    in the note: a rod that starts millimetres inside is evidence of a pusher calibration offset or a wrong
    object model, which the diagnosis weighs.
    The object's half height comes from its mesh (0.00635 m for the dataset's meshes).
    """
    shape, src = push.spec.shape, str(push.path)
    for type_name in (shape, SURFACE_TYPE, ROBOT_TYPE):
        if type_name not in odb.types:
            raise RecordingError(f"the object database has no type {type_name!r} (odb/types/mit_push.yaml)",
                                 source=src)
    if not (math.isfinite(observation_rate) and observation_rate > 0):
        raise RecordingError(f"observation_rate must be > 0 Hz, got {observation_rate!r}", source=src)
    surface_geometry = odb.get(SURFACE_TYPE).geometry
    half_height = -z_range(odb.get(shape).geometry, Pose())[0]  # the mesh is centred: 0.0064 m
    x0, y0, yaw0 = (float(v) for v in push.object_pose[0])
    surface_z = -z_range(surface_geometry, Pose())[1]

    tip, notes, shift, start = np.array(push.tip_xy), [], np.zeros(2), None
    if outline is None and odb.get(shape).geometry.mesh is not None:
        outline = load_outline(shape, odb.get(shape).geometry.mesh.parent.parent)
    if outline is not None:
        outline = np.asarray(outline, dtype=float)
        clearance, normal = _start_clearance(push, outline, frame_yaw)
        if clearance < 0:
            shift = (start_clearance - clearance) * normal
            tip = tip + shift
        gap, spread, gap_normal, gap_speed = _contact_gap(push, outline, frame_yaw)
        start = StartClearance(shape, float(clearance), (float(normal[0]), float(normal[1])),
                               (float(shift[0]), float(shift[1])), float(start_clearance),
                               float(np.hypot(*(push.tip_xy[0] - push.object_pose[0, :2]))), spread,
                               contact_gap=gap, contact_normal=gap_normal, contact_speed=gap_speed)
        if start.moved:
            notes.append(start.text())
    if np.any(np.abs(tip) >= 1.0):
        raise RecordingError("the rod leaves the planar pusher's reach (|x|, |y| < 1 m)", source=src, field="tip_pose")

    objects = {SURFACE_NAME: ObjectState(SURFACE_NAME, SURFACE_TYPE, Pose((x0, y0, surface_z))),
               shape: ObjectState(shape, shape, Pose.from_rpy((x0, y0, half_height), (0.0, 0.0, yaw0 + frame_yaw)))}
    robot = RobotState(ROBOT_NAME, ROBOT_TYPE, Pose((0.0, 0.0, half_height)),
                       (("pusher_x", float(tip[0, 0])), ("pusher_y", float(tip[0, 1]))))
    world = WorldState(objects=objects, robot=robot, name=push.path.stem,
                       names=build_name_map([*objects, ROBOT_NAME], source=src, error=RecordingError))
    telemetry = Telemetry(push.t, ("pusher_x", "pusher_y"), tip, source=src, t0=push.start_time)

    times = np.arange(0.0, push.duration, 1.0 / observation_rate)
    if push.duration - times[-1] > 1e-9:
        times = np.append(times, push.duration)
    pose = np.column_stack([np.interp(times, push.t, push.object_pose[:, k]) for k in range(3)])
    poses = tuple(Pose.from_rpy((x, y, half_height), (0.0, 0.0, yaw + frame_yaw)) for x, y, yaw in pose)
    observations = ObservedPoses((ObservedTrack(shape, times, poses),), source=src)
    force, why = _force(push)
    if why:
        notes.append(why)
    return PushSession(world, telemetry, observations, float(frame_yaw), (float(shift[0]), float(shift[1])),
                       tuple(notes), force, start)


def _contact_gap(push: PushRecording, outline: np.ndarray, frame_yaw: float
                 ) -> tuple[float | None, float | None, tuple[float, float] | None, float | None]:
    """The rod-to-outline gap (m) while the rod pushes the object, where the true gap is zero: its median, its
    scatter (1.4826 MAD about the median: what the outline's mismatch and the motion capture leave), the
    outline's mean outward normal there (world frame, unit) and the rod's median speed into the object along it
    (m/s). A constant calibration offset D moves the median by -D.n, not the scatter; a latency tau (the recorded
    rod ahead of the real one by tau x its velocity) by -tau x the speed. Where the push's force is trusted
    (`_force`), only the samples where the rod touches (`touching`: an object kicked ahead of the rod moves without
    it). Nones with fewer than 10 pushed samples."""
    pushed = pushed_samples(push)
    if _force(push)[0] is not None and len(pushed):
        touch = pushed[touching(np.hypot(push.wrench[pushed, 0], push.wrench[pushed, 1]))]
        pushed = touch if len(touch) >= 10 else pushed
    if len(pushed) < 10:
        return None, None, None, None
    heading = push.object_pose[pushed, 2] + frame_yaw
    rel = push.tip_xy[pushed] - push.object_pose[pushed, :2]
    c, s = np.cos(heading), np.sin(heading)
    local = np.column_stack([c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1]])
    gap = signed_distance(local, outline) - PUSHER_RADIUS
    h = 1e-5  # the outward normal: the signed distance's gradient (central differences)
    grad = np.column_stack([signed_distance(local + d, outline) - signed_distance(local - d, outline)
                            for d in (np.array([h, 0.0]), np.array([0.0, h]))]) / (2 * h)
    normals = np.column_stack([c * grad[:, 0] - s * grad[:, 1], s * grad[:, 0] + c * grad[:, 1]])
    world = normals.mean(axis=0)
    norm = float(np.linalg.norm(world))
    median = float(np.median(gap))
    into = -np.sum(np.gradient(push.tip_xy, push.t, axis=0)[pushed] * normals, axis=1)
    return (median, float(1.4826 * np.median(np.abs(gap - median))),
            (float(world[0] / norm), float(world[1] / norm)) if norm > 1e-9 else None, float(np.median(into)))


def _force(push: PushRecording) -> tuple[ObservedForce | None, str]:
    """The pusher force (fx, fy) as an ObservedForce, unless it is absent or spikes over a near-zero signal
    (then it measures something else than the push: rect1's trials); the text says why it was left out."""
    if push.wrench is None:
        return None, ""
    magnitude = np.hypot(push.wrench[:, 0], push.wrench[:, 1])
    if float(np.percentile(magnitude, 90)) < SPIKY * float(magnitude.max()):
        return None, (f"ft_wrench not used: near zero ({np.percentile(magnitude, 90):.2f} N at the 90th "
                      f"percentile) with spikes to {magnitude.max():.1f} N")
    return ObservedForce(push.t, np.column_stack([push.wrench[:, :2], np.zeros(len(push.t))]),
                         source=f"{push.path}:ft_wrench"), ""


def _start_clearance(push: PushRecording, outline: np.ndarray, frame_yaw: float) -> tuple[float, np.ndarray]:
    """Gap (m) between the rod's surface and the outline at t = 0 (negative: inside) and the world-frame
    outward normal of the outline at the nearest point."""
    heading = float(push.object_pose[0, 2]) + frame_yaw
    c, s = math.cos(heading), math.sin(heading)
    rel = push.tip_xy[0] - push.object_pose[0, :2]
    local = np.array([c * rel[0] + s * rel[1], -s * rel[0] + c * rel[1]])
    distance = float(signed_distance(local[None, :], outline)[0])
    a, b = outline, np.roll(outline, -1, axis=0)
    ab = b - a
    u = np.clip(np.sum((local - a) * ab, axis=1) / np.maximum(np.sum(ab * ab, axis=1), 1e-300), 0.0, 1.0)
    nearest = a + u[:, None] * ab
    k = int(np.argmin(np.linalg.norm(local - nearest, axis=1)))
    away = (local - nearest[k]) * (1.0 if distance >= 0 else -1.0)
    if np.linalg.norm(away) < 1e-12:  # on the outline: the edge's outward normal (counter-clockwise outline)
        edge = ab[k] / np.linalg.norm(ab[k])
        area = 0.5 * float(np.sum(a[:, 0] * b[:, 1] - b[:, 0] * a[:, 1]))
        away = np.array([edge[1], -edge[0]]) * (1.0 if area > 0 else -1.0)
    n_local = away / np.linalg.norm(away)
    normal = np.array([c * n_local[0] - s * n_local[1], s * n_local[0] + c * n_local[1]])
    return distance - PUSHER_RADIUS, normal
