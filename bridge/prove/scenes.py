"""The proof's worlds: the two scenes (a steel block pushed on a plate by the planar rod; a small box on the
tabletop), the world model the diagnosis is given, and the pushes each recording makes.

A case is one concealed effect (or `none`) in one scene, at one magnitude, with a seed for everything random.
The world model written with each recording is what a careful user would write: the object flat on the modelled
surface at the first observed x, y, yaw.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Sequence

import numpy as np

from ..errors import DiagnosisError
from ..names import build_name_map
from ..odb import ObjectDatabase
from ..odb.geometry import half_extents, z_range
from ..values import Fact, Pose
from ..world import ObjectState, RobotState, WorldState

OBS_RATE = 50.0  # Hz
TEL_RATE = 100.0  # Hz
NOISE_POSITION = 3e-4  # m, 1 sigma per axis
NOISE_ROTATION = 2e-3  # rad, 1 sigma per axis
NOISE_FORCE = 0.05  # N, 1 sigma per axis of the rod's force sensor
HOLD = 0.25  # s before the push starts (room for a latency shift)
AFTER = 0.45  # s after the pusher stops (slide-on, rest)
PUSHER_RADIUS = 0.00476
MAGNITUDES = ("small", "medium", "large")
PLANAR_EFFECTS = ("friction", "mass", "com_offset", "surface_tilt", "friction_patch", "latency", "pusher_offset",
                  "hidden_obstacle")
TABLETOP_EFFECTS = ("com_offset", "hidden_obstacle")


@dataclass(frozen=True)
class Case:
    """One concealed effect (or `none`) in one scene, at one magnitude, with a seed for everything random."""

    scene: str  # "planar" | "tabletop" | "mit_<shape>"
    effect: str
    magnitude: str = "medium"
    seed: int = 0
    world: str = "matched"  # "mismatched": the world differs from the model beneath the effect (`prove.mismatch`)

    @property
    def name(self) -> str:
        name = f"{self.scene}-{self.effect}-{self.magnitude}-{self.seed}"
        return name if self.world == "matched" else f"{name}-mismatched"


@dataclass(frozen=True, eq=False)
class Push:
    """One recording's design: the object's start (x, y, yaw) and the rod's path (times, xy)."""

    start: tuple[float, float, float]
    times: np.ndarray
    path: np.ndarray  # (n, 2) rod centre, world


@dataclass(frozen=True)
class SceneSpec:
    name: str
    object: str
    object_type: str
    surface: str
    surface_type: str
    surface_xyz: tuple[float, float, float]
    robot_z: float  # rod height (world z of the pusher base)
    centre: tuple[float, float]  # where objects start
    spread: tuple[float, float]  # +- x, y of the start
    others: tuple[tuple[str, str, tuple[float, float, float]], ...] = ()  # bystanders (name, type, xyz)
    robot: str = "pusher"
    recorder: str = "folder"  # "folder": bridge recording folders; "mit": h5 files of the MIT pushing dataset's format
    varied: bool = False  # effects concealed by mechanisms of varied geometry (the mismatched-world proof)

    @property
    def planar(self) -> bool:
        """A planar push of an object on a plate (not the arm's tabletop)."""
        return self.name != "tabletop"


MIT_PREFIX = "mit_"  # scene "mit_<shape>": the shape pushed on the plate, recorded as MIT pushing h5 files


def scene_spec(scene: str, odb: ObjectDatabase, *, varied: bool = False) -> SceneSpec:
    """The proof scene named `scene`: "planar", "tabletop", or "mit_<shape>" (a shape of the object database's
    MIT pushing types, in the world `bridge.recording.mitsession` builds for an MIT push: the plate's top at
    z = 0, the rod at the shape's mid-height)."""
    spec = _scene_spec(scene, odb)
    return replace(spec, varied=varied) if varied else spec


def _scene_spec(scene: str, odb: ObjectDatabase) -> SceneSpec:
    if scene.startswith(MIT_PREFIX):
        from ..recording.mitsession import ROBOT_NAME, SHAPE_TYPE, SURFACE_NAME, SURFACE_TYPE

        shape = scene[len(MIT_PREFIX):]
        if shape not in odb.types or not odb.get(shape).is_a(SHAPE_TYPE) or odb.get(shape).abstract:
            raise DiagnosisError(f"proof scene {scene!r}: {shape!r} is not a shape of the MIT pushing types "
                                 "(odb/types/mit_push.yaml, proof.yaml)")
        geometry = odb.get(shape).geometry
        if geometry.shape == "mesh" and geometry.mesh is None:
            raise DiagnosisError(f"proof scene {scene!r}: the mesh of {shape!r} is not available ({geometry.unresolved});"
                                 " pass --dataset mit-push=PATH")
        h = -z_range(geometry, Pose())[0]
        top = half_extents(odb.get(SURFACE_TYPE).geometry)[2]
        return SceneSpec(scene, shape, shape, SURFACE_NAME, SURFACE_TYPE, (0.0, 0.0, -top), h, (0.0, 0.0),
                         (0.02, 0.05), robot=ROBOT_NAME, recorder="mit")
    if scene == "planar":
        h = half_extents(odb.get("steel_block").geometry)[2]
        # the rod's centre 2 mm above the block's mid-height: its 10 mm collision cylinder clears a surface
        # that tilts up by a few millimetres under it
        return SceneSpec("planar", "block", "steel_block", "surface", "push_surface", (0.0, 0.0, -0.005), h + 0.002,
                         (0.0, 0.0), (0.02, 0.05))
    if scene == "tabletop":
        h = half_extents(odb.get("small_box").geometry)[2]
        return SceneSpec("tabletop", "small_box", "small_box", "table", "table", (0.75, 0.0, 0.725), 0.75 + 0.03,
                         (0.55, -0.1), (0.02, 0.04), (("big_box", "big_box", (0.55, 0.25, 0.875)),))
    raise DiagnosisError(f"unknown proof scene {scene!r}; scenes: planar, tabletop, {MIT_PREFIX}<shape>")


def _object_z(spec: SceneSpec, odb: ObjectDatabase) -> float:
    top = spec.surface_xyz[2] + half_extents(odb.get(spec.surface_type).geometry)[2]
    return top + half_extents(odb.get(spec.object_type).geometry)[2]


def nominal_world(spec: SceneSpec, odb: ObjectDatabase, start: Sequence[float]) -> WorldState:
    """The world model the diagnosis gets: object flat on the level surface at (x, y, yaw)."""
    x, y, yaw = start
    objects = {spec.surface: ObjectState(spec.surface, spec.surface_type, Pose(spec.surface_xyz)),
               spec.object: ObjectState(spec.object, spec.object_type,
                                        Pose.from_rpy((x, y, _object_z(spec, odb)), (0, 0, yaw)))}
    for name, type_name, xyz in spec.others:
        objects[name] = ObjectState(name, type_name, Pose(xyz))
    robot = RobotState(spec.robot, "planar_pusher", Pose((0.0, 0.0, spec.robot_z)),
                       (("pusher_x", 0.0), ("pusher_y", 0.0)))
    names = build_name_map([*objects, spec.robot])
    facts = frozenset(Fact("on", (n, spec.surface)) for n in objects if n != spec.surface)
    return WorldState(objects, facts, robot, name=f"{spec.name}_push", names=names)


# --- push designs -------------------------------------------------------------------------------------------
PUSH_SPEEDS = (0.06, 0.2)  # m/s: the rod's speeds of a proof's pushes (the MIT data's 10-150 mm/s, fast half)


def design_pushes(spec: SceneSpec, odb: ObjectDatabase, rng: np.random.Generator, n: int,
                  gap: tuple[float, float] = (0.004, 0.004), *, local: bool = False, scale: float = 1.0,
                  speeds: tuple[float, float] = PUSH_SPEEDS, hull: bool = False) -> list[Push]:
    """Pushes at varied contact points, speeds and lengths, each ending with the rod stopping dead so the object
    slides on: mostly along +x (within +-30 deg, the object within +-23 deg), or, in a scene of `varied`
    mechanisms, in any direction with the object at any yaw (within +-60 deg of +x for a `local` effect, whose
    place lies that way, so that most pushes pass it). The rod starts `gap` (drawn in the range) clear of the
    object's outline (`prisms.outline_of`; any prism, convex or not), of the real object `scale` times the model's
    size when the case conceals one (`object_scale`), and of its convex hull where the world's contact is the hull
    (`hull`: a mismatched world whose simulator takes a non-convex mesh as Drake does). A rod started in the
    hull's concavity starts inside a rigid body: the world's first step throws the object (the butter slid 15-40 mm
    before the rod moved, in each of the mismatched proof's 9 such cases). The rod's speed is drawn from `speeds`
    (m/s)."""
    yaw_range, push_range = (0.4, 0.5) if not spec.varied else (math.pi, 1.05 if local else math.pi)
    from ..sim.prisms import convex_hull, outline_of

    outline = scale * outline_of(odb.get(spec.object_type).geometry)
    if hull:
        outline = convex_hull(outline)
    half = scale * half_extents(odb.get(spec.object_type).geometry)[:2]
    pushes = []
    for _ in range(n):
        x0 = spec.centre[0] + rng.uniform(-spec.spread[0], spec.spread[0])
        y0 = spec.centre[1] + rng.uniform(-spec.spread[1], spec.spread[1])
        yaw = rng.uniform(-yaw_range, yaw_range)
        phi = rng.uniform(-push_range, push_range)
        d = np.array([math.cos(phi), math.sin(phi)])
        perp = np.array([-d[1], d[0]])
        s = rng.uniform(-0.55, 0.55) * float(np.min(half))
        v = rng.uniform(*speeds)
        travel = rng.uniform(0.06, 0.10)
        clearance = gap[0] if gap[1] <= gap[0] else rng.uniform(*gap)
        start = _rod_start(outline, (x0, y0, yaw), np.array([x0, y0]) + s * perp, d, clearance)
        length = clearance + travel
        t_move = length / v
        end = HOLD + t_move + AFTER
        times = np.round(np.arange(0.0, end + 1e-9, 1.0 / TEL_RATE), 6)
        u = np.clip((times - HOLD) / t_move, 0.0, 1.0)
        path = start + np.outer(u * length, d)
        pushes.append(Push((float(x0), float(y0), float(yaw)), times, path))
    return pushes


def _rod_start(outline: np.ndarray, pose: Sequence[float], point: np.ndarray, d: np.ndarray,
               clearance: float) -> np.ndarray:
    """Where the rod's centre starts on the line through `point` along `d` so that its surface is `clearance`
    from the object's outline (at `pose`) when it moves along d: behind where the line enters the outline, or,
    if the line misses it (a non-convex outline), behind the centre."""
    from ..recording.mitpush import signed_distance

    x0, y0, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    R = np.array([[c, -s], [s, c]])
    world = np.asarray(outline) @ R.T + np.array([x0, y0])
    entry = _entry(world, point, d)
    if entry is None:
        point, entry = np.array([x0, y0]), _entry(world, np.array([x0, y0]), d)
    start = point + (entry - PUSHER_RADIUS - clearance) * d
    # a rod that meets a corner before its centre line does: back off until it is clear
    for _ in range(200):
        if float(signed_distance(start[None, :], world)[0]) >= PUSHER_RADIUS + clearance - 1e-6:
            break
        start = start - 2e-4 * d
    return start


def _entry(polygon: np.ndarray, point: np.ndarray, d: np.ndarray) -> float | None:
    """Signed distance along d from `point` to where the line first meets the closed polygon, None if it misses."""
    a, b = polygon, np.roll(polygon, -1, axis=0)
    e = b - a
    denom = d[0] * e[:, 1] - d[1] * e[:, 0]
    ok = np.abs(denom) > 1e-12
    w = a - point
    t = np.where(ok, (w[:, 0] * e[:, 1] - w[:, 1] * e[:, 0]) / np.where(ok, denom, 1.0), np.inf)
    u = np.where(ok, (w[:, 0] * d[1] - w[:, 1] * d[0]) / np.where(ok, denom, 1.0), -1.0)
    hits = t[ok & (u >= 0.0) & (u <= 1.0)]
    return float(hits.min()) if hits.size else None
