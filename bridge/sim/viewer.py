"""A self-contained HTML replay (Drake's Meshcat recording), observed poses drawn as translucent ghosts.

This is the paper's Fig. 5 as a file you can open in a browser: the simulated scene moves, and where the real
object was observed (AprilTags, motion capture) a see-through copy of it stands. The page opens with the camera
on the scene (`camera_pose`: the bounding box of the objects and the robot's base), not on the whole floor.
"""
from __future__ import annotations

from pathlib import Path
import math
from typing import Mapping, Sequence

import numpy as np
from pydrake.geometry import Meshcat, Rgba

from ..files import write_atomic
from ..odb import ObjectDatabase
from ..odb.geometry import support
from ..recording.observations import ObservedPoses
from ..recording.telemetry import Telemetry
from ..values import Pose
from ..world import WorldState
from .scene import SceneValues, SimConfig, build_scene, to_drake
from .simulate import FailurePolicy, ReplayResult, SimOptions, simulate
from .shapes import drake_shape

GHOST_ALPHA = 0.3
SPREAD_ALPHA = 0.12
CAMERA_FOV = 75.0  # deg, Meshcat's default perspective camera
CAMERA_DIRECTION = (1.0, -1.0, 0.8)  # from the scene's centre towards the camera: front right, above
CAMERA_MARGIN = 1.3  # the scene's bounding sphere fills this much less than the view
MIN_CAMERA_DISTANCE = 0.25  # m


def write_replay_html(
    world: WorldState,
    telemetry: Telemetry,
    odb: ObjectDatabase,
    out: str | Path,
    *,
    observations: ObservedPoses | None = None,
    values: SceneValues | None = None,
    extras: Sequence = (),
    hooks: Sequence = (),
    config: SimConfig = SimConfig(),
    spread: Sequence[Mapping[str, Pose]] = (),
    sleep: bool = True,
) -> ReplayResult:
    """Replay with a Meshcat recording attached and save it as one HTML file (a robot that cannot follow its
    telemetry is shown, not refused: seeing where it got stuck is the point). `spread`: final poses of sampled
    replays (`bridge view --samples N`), drawn as faint ghosts of the objects that moved in them."""
    meshcat = Meshcat()  # serves on localhost only while we record
    scene = build_scene(world, odb, config, extras=extras, meshcat=meshcat)
    visualizer = scene.diagram.GetSubsystemByName(
        next(s.get_name() for s in scene.diagram.GetSystems() if type(s).__name__.startswith("MeshcatVisualizer")))
    visualizer.StartRecording(set_transforms_while_recording=False)
    result = simulate(scene, telemetry, world=world, values=values, hooks=hooks,
                      options=SimOptions(sleep=sleep, policy=FailurePolicy(check_tracking=False)))
    visualizer.StopRecording()
    if observations is not None:
        _add_ghosts(meshcat, visualizer.get_mutable_recording(), world, odb, observations, result.sim_time)
    _add_spread(meshcat, world, odb, spread)
    visualizer.PublishRecording()
    camera, target = camera_pose(*scene_bounds(world, odb))
    meshcat.SetCameraPose(camera, target)
    write_atomic(out, meshcat.StaticHtml())
    return result


def scene_bounds(world: WorldState, odb: ObjectDatabase) -> tuple[np.ndarray, np.ndarray]:
    """The world-frame box (lower, upper corner) around every object of `world` (its geometry, or its origin
    when the geometry is not available) and the robot's base."""
    points = []
    for obj in world.objects.values():
        geometry = odb.get(obj.type).geometry
        position = np.asarray(obj.pose.position, dtype=float)
        points.append(position)
        if geometry is None or (geometry.shape == "mesh" and geometry.mesh is None):
            continue
        for axis in np.eye(3):
            points.append(position + axis * (support(geometry, obj.pose, axis) - position @ axis))
            points.append(position - axis * (support(geometry, obj.pose, -axis) + position @ axis))
    if world.robot is not None:
        points.append(np.asarray(world.robot.base_pose.position, dtype=float))
    if not points:
        return np.zeros(3), np.zeros(3)
    cloud = np.array(points)
    return cloud.min(axis=0), cloud.max(axis=0)


def camera_pose(lower: np.ndarray, upper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(camera position, target) in the world frame: looking at the box's centre from `CAMERA_DIRECTION`, far
    enough that the box's bounding sphere fits Meshcat's field of view with a margin."""
    lower, upper = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
    target = (lower + upper) / 2
    radius = float(np.linalg.norm(upper - lower)) / 2
    distance = max(MIN_CAMERA_DISTANCE, CAMERA_MARGIN * radius / math.sin(math.radians(CAMERA_FOV) / 2))
    direction = np.asarray(CAMERA_DIRECTION, dtype=float)
    return target + distance * direction / np.linalg.norm(direction), target


def _add_ghosts(meshcat: Meshcat, animation, world: WorldState, odb: ObjectDatabase, observations: ObservedPoses,
                end: float) -> None:
    fps = animation.frames_per_second()
    for track in observations:
        if track.object not in world.objects:
            continue
        obj_type = odb.get(world.objects[track.object].type)
        color = obj_type.geometry.color if obj_type.geometry else (0.5, 0.5, 0.5, 1.0)
        path = f"/ghosts/{track.object}"
        meshcat.SetObject(path, drake_shape(obj_type), Rgba(color[0], color[1], color[2], GHOST_ALPHA))
        for frame in range(0, int(end * fps) + 1):
            # dense tracks move with time; sparse (before/after) ones show where the object ended, as in Fig. 5
            pose = track.at(frame / fps) if observations.is_dense else track.final()
            animation.SetTransform(frame, path, to_drake(pose))


def _add_spread(meshcat: Meshcat, world: WorldState, odb: ObjectDatabase, spread: Sequence[Mapping[str, Pose]]) -> None:
    """Each sample's final pose of every object that moved in it, faint, where it stays for the whole replay."""
    for k, poses in enumerate(spread):
        for name, pose in poses.items():
            start = world.objects[name].pose
            if start.translation_to(pose) < 0.005 and start.rotation_to(pose) < 0.05:
                continue
            obj_type = odb.get(world.objects[name].type)
            color = obj_type.geometry.color if obj_type.geometry else (0.5, 0.5, 0.5, 1.0)
            path = f"/samples/{k}/{name}"
            meshcat.SetObject(path, drake_shape(obj_type), Rgba(color[0], color[1], color[2], SPREAD_ALPHA))
            meshcat.SetTransform(path, to_drake(pose))
