"""The proof's worlds: the two scenes (a steel block pushed on a plate by the planar rod; a small box on the
tabletop), the world model the diagnosis is given, and the pushes each recording makes.

A case is one concealed effect (or `none`) in one scene, at one magnitude, with a seed for everything random.
The world model written with each recording is what a careful user would write: the object flat on the modelled
surface at the first observed x, y, yaw.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..errors import DiagnosisError
from ..names import build_name_map
from ..odb import ObjectDatabase
from ..odb.geometry import half_extents
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

    scene: str  # "planar" | "tabletop"
    effect: str
    magnitude: str = "medium"
    seed: int = 0

    @property
    def name(self) -> str:
        return f"{self.scene}-{self.effect}-{self.magnitude}-{self.seed}"


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


def scene_spec(scene: str, odb: ObjectDatabase) -> SceneSpec:
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
    raise DiagnosisError(f"unknown proof scene {scene!r}; scenes: planar, tabletop")


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
def design_pushes(spec: SceneSpec, odb: ObjectDatabase, rng: np.random.Generator, n: int) -> list[Push]:
    """Pushes mostly along +x (within +-30 deg), at varied contact points, speeds and lengths, each ending with
    the rod stopping dead so the object slides on."""
    half = half_extents(odb.get(spec.object_type).geometry)[:2]
    pushes = []
    for _ in range(n):
        x0 = spec.centre[0] + rng.uniform(-spec.spread[0], spec.spread[0])
        y0 = spec.centre[1] + rng.uniform(-spec.spread[1], spec.spread[1])
        yaw = rng.uniform(-0.4, 0.4)
        phi = rng.uniform(-0.5, 0.5)
        d = np.array([math.cos(phi), math.sin(phi)])
        perp = np.array([-d[1], d[0]])
        s = rng.uniform(-0.55, 0.55) * float(np.min(half))
        entry = _entry(np.array([x0, y0]) + s * perp, d, (x0, y0, yaw), half)
        gap = 0.004
        start = np.array([x0, y0]) + s * perp + (entry - PUSHER_RADIUS - gap) * d
        v = rng.uniform(0.06, 0.2)
        length = gap + rng.uniform(0.06, 0.10)
        t_move = length / v
        end = HOLD + t_move + AFTER
        times = np.round(np.arange(0.0, end + 1e-9, 1.0 / TEL_RATE), 6)
        u = np.clip((times - HOLD) / t_move, 0.0, 1.0)
        path = start + np.outer(u * length, d)
        pushes.append(Push((float(x0), float(y0), float(yaw)), times, path))
    return pushes


def _entry(point: np.ndarray, d: np.ndarray, pose: Sequence[float], half: np.ndarray) -> float:
    """Signed distance along d from `point` to where the line enters the object's rectangle (negative: behind)."""
    x0, y0, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    R = np.array([[c, -s], [s, c]])
    p = R.T @ (point - np.array([x0, y0]))
    q = R.T @ d
    lo, hi = -math.inf, math.inf
    for k in range(2):
        if abs(q[k]) < 1e-12:
            continue
        a, b = (-half[k] - p[k]) / q[k], (half[k] - p[k]) / q[k]
        lo, hi = max(lo, min(a, b)), min(hi, max(a, b))
    return lo
