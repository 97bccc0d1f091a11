"""Recordings with a concealed effect, for the proof: scenes, push designs and the physical mechanisms that
conceal each effect.

The generator makes every effect by a mechanism that differs from the model the diagnosis fits wherever it can:

| effect          | concealed by (generator)                                   | modelled by (diagnosis)                     |
|-----------------|------------------------------------------------------------|---------------------------------------------|
| friction        | the surface's coefficient (another surface material)       | the object's coefficient                     |
| mass            | a dense slug welded at the object's centre                  | the body's mass parameter                    |
| com_offset      | a dense slug welded off-centre (moves COM, adds mass)       | the body's centre-of-mass parameter          |
| surface_tilt    | the support fixture really rotated (object placed on it)    | a constant force m g sin(theta)              |
| friction_patch  | a sheet of another material welded flush on the surface     | a 1 um sheet over a square that carries      |
|                 | (a rectangle; objects on it press on sheet and surface)     | what stands on it alone                      |
| latency         | telemetry stamped dt early (resampled at the recorder's    | telemetry shifted by dt                      |
| (cont.)         | clock, 100 Hz)                                              |                                              |
| pusher_offset   | the robot's base mounted off by (dx, dy)                   | offsets added to the joint readings          |
| hidden_obstacle | a welded box of random size and yaw                         | a welded post of radius 15 mm                |

Observations are the true simulation sampled at 50 Hz with Gaussian measurement noise (position and a small
random rotation), and the contact force on the rod as a planar force sensor reads it (fx, fy, with noise); the world state written with each recording is what a careful user would write: the object
flat on the modelled surface at the first observed x, y, yaw (mean of the first five samples).
The truth of each case is written beside the recordings (truth.json), never inside them.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import DiagnosisError
from ..names import build_name_map
from ..odb import ObjectDatabase
from ..odb.geometry import half_extents
from ..recording.forces import ObservedForce
from ..recording.observations import ObservedPoses, ObservedTrack
from ..recording.recording import save_recording
from ..recording.telemetry import Telemetry
from ..sim.shapes import mass_properties
from ..values import Fact, Pose
from ..world import ObjectState, RobotState, WorldState, world_to_dict

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


@dataclass(frozen=True, eq=False)
class Truth:
    """What was concealed: effect, target, the parameters the diagnosis should recover, and how."""

    effect: str
    target: str
    params: dict[str, float]
    mechanism: str
    extra: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return {"effect": self.effect, "target": self.target, "params": self.params, "mechanism": self.mechanism,
                **({"extra": self.extra} if self.extra else {})}


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
    robot = RobotState("pusher", "planar_pusher", Pose((0.0, 0.0, spec.robot_z)),
                       (("pusher_x", 0.0), ("pusher_y", 0.0)))
    names = build_name_map([*objects, "pusher"])
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


# --- concealment ------------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class TrueSetup:
    world: WorldState
    extras: tuple
    params: Any  # SceneParams
    true_telemetry: Telemetry
    recorded_telemetry: Telemetry


def case_truth(case: Case, spec: SceneSpec, odb: ObjectDatabase, rng: np.random.Generator) -> Truth:
    """Draw the concealed effect's true values (same for every recording of the case)."""
    level = MAGNITUDES.index(case.magnitude)
    sign = 1.0 if rng.random() < 0.5 else -1.0
    m0 = mass_properties(odb, spec.object_type).mass
    mu_obj = odb.get(spec.object_type).physics.friction
    mu_surf = odb.get(spec.surface_type).physics.friction
    e = case.effect
    if e == "none":
        return Truth("none", "world", {}, "nothing concealed")
    if e == "friction":
        factor = (1.5, 2.2, 3.2)[level] ** sign
        mu = mu_surf * factor
        pair = 2 * mu_obj * mu / (mu_obj + mu)
        return Truth(e, spec.surface, {"mu": mu}, "the surface's coefficient", {"pair_mu": pair})
    if e == "mass":
        added = (0.5, 1.0, 2.0)[level] * m0
        return Truth(e, spec.object, {"mass": m0 + added}, "a dense slug welded at the centre",
                     {"slug_mass": added})
    if e == "com_offset":
        shift = (0.005, 0.010, 0.016)[level] if spec.name == "planar" else (0.003, 0.005, 0.008)[level]
        angle = rng.uniform(-math.pi, math.pi)
        slug = 0.8 * m0
        r = shift * (m0 + slug) / slug
        return Truth(e, spec.object, {"dx": shift * math.cos(angle), "dy": shift * math.sin(angle)},
                     "a dense slug welded off-centre", {"slug_mass": slug, "slug_offset": [r * math.cos(angle),
                                                                                           r * math.sin(angle)]})
    if e == "surface_tilt":
        theta = math.radians((0.5, 1.0, 2.0)[level])
        phi = rng.uniform(-math.pi, math.pi)
        sx, sy = theta * math.cos(phi), theta * math.sin(phi)
        # the fixture turns about a point of its top away from its centre: the model (which turns it about the
        # centre) has to find the height change there too
        pivot = (spec.centre[0] + rng.uniform(-0.05, 0.05), spec.centre[1] + rng.uniform(-0.05, 0.05))
        dz = -((spec.surface_xyz[0] - pivot[0]) * math.tan(sx) + (spec.surface_xyz[1] - pivot[1]) * math.tan(sy))
        return Truth(e, spec.surface, {"slope_x": sx, "slope_y": sy, "dz": dz},
                     "the support fixture rotated", {"tilt_deg": math.degrees(theta), "downhill_deg": math.degrees(phi),
                                                     "pivot": list(pivot)})
    if e == "friction_patch":
        # the sheet shares the surface's plane: over it the friction is the mean of the two pairs'
        pair0 = 2 * mu_obj * mu_surf / (mu_obj + mu_surf)
        pair = pair0 * ((1.2, 1.32, 1.44)[level] if sign > 0 else (0.78, 0.66, 0.56)[level])
        pair_sheet = 2 * pair - pair0
        mu_tile = pair_sheet * mu_obj / (2 * mu_obj - pair_sheet)
        # a rectangle ahead of the start area on one side: about half of the pushes run into it
        x0 = spec.centre[0] + rng.uniform(0.03, 0.06)
        x1 = x0 + rng.uniform(0.25, 0.35)
        edge = spec.centre[1] + rng.uniform(-0.02, 0.02)
        y0, y1 = (edge, edge + 0.4) if rng.random() < 0.5 else (edge - 0.4, edge)
        return Truth(e, spec.surface, {"mu": pair, "x0": x0}, "a thin sheet of another material on the surface",
                     {"region": [x0, x1, y0, y1], "tile_mu": mu_tile})
    if e == "latency":
        dt = sign * (0.03, 0.06, 0.12)[level]
        return Truth(e, "pusher", {"dt": dt}, "telemetry stamped early or late")
    if e == "pusher_offset":
        size = (0.002, 0.004, 0.008)[level]
        angle = rng.uniform(-math.pi, math.pi)
        return Truth(e, "pusher", {"pusher_x": size * math.cos(angle), "pusher_y": size * math.sin(angle)},
                     "the robot's base mounted off")
    if e == "hidden_obstacle":
        size = (0.02, 0.03, 0.045)[level]
        reach = half_extents(odb.get(spec.object_type).geometry)[0]
        x = spec.centre[0] + reach + 0.055 + size / 2 + rng.uniform(-0.01, 0.01)
        y = spec.centre[1] + rng.uniform(-0.025, 0.025)
        return Truth(e, spec.surface, {"x": x, "y": y}, "a welded box",
                     {"size": size, "yaw": rng.uniform(-0.8, 0.8)})
    raise DiagnosisError(f"cannot conceal effect {e!r}")


def conceal(truth: Truth, spec: SceneSpec, odb: ObjectDatabase, world: WorldState, push: Push) -> TrueSetup:
    """The true world, extras, scene values and telemetry of one recording (world = the exact start)."""
    from ..sim.extras import Slug, SurfacePatch, WeldedShape
    from ..sim.scene import ObjectParams, SceneParams

    tel = Telemetry(push.times, ("pusher_x", "pusher_y"), push.path)
    extras: tuple = ()
    params = SceneParams()
    true_world, true_tel, rec_tel = world, tel, tel
    e, p = truth.effect, truth.params
    if e == "friction":
        params = SceneParams(objects={spec.surface: ObjectParams(friction=p["mu"])})
    elif e == "mass":
        extras = (Slug(spec.object, truth.extra["slug_mass"], (0.0, 0.0, 0.0), 0.01),)
    elif e == "com_offset":
        ox, oy = truth.extra["slug_offset"]
        # the offset is in the object frame
        extras = (Slug(spec.object, truth.extra["slug_mass"], (ox, oy, 0.0), 0.01),)
    elif e == "surface_tilt":
        true_world = _tilted(world, spec, odb, p["slope_x"], p["slope_y"], truth.extra["pivot"])
    elif e == "friction_patch":
        top = spec.surface_xyz[2] + half_extents(odb.get(spec.surface_type).geometry)[2]
        extras = (SurfacePatch("sheet", tuple(truth.extra["region"]), top, truth.extra["tile_mu"]),)
    elif e == "latency":
        # the recorded samples read the true motion dt later than their stamps say (true(t) = recorded(t - dt))
        rec_tel = Telemetry(push.times, tel.joint_names, tel.sample(push.times + p["dt"]))
    elif e == "pusher_offset":
        base = world.robot.base_pose
        moved = Pose((base.xyz[0] + p["pusher_x"], base.xyz[1] + p["pusher_y"], base.xyz[2]), base.quat)
        true_world = replace(world, robot=replace(world.robot, base_pose=moved))
    elif e == "hidden_obstacle":
        top = spec.surface_xyz[2] + half_extents(odb.get(spec.surface_type).geometry)[2]
        s = truth.extra["size"]
        extras = (WeldedShape("obstacle", "box", (s, s, 0.06), (p["x"], p["y"], top + 0.03),
                              (0.0, 0.0, truth.extra["yaw"]), friction=0.5),)
    return TrueSetup(true_world, extras, params, true_tel, rec_tel)


def _tilted(world: WorldState, spec: SceneSpec, odb: ObjectDatabase, sx: float, sy: float,
            pivot_xy: Sequence[float]) -> WorldState:
    """The world with the surface (and the object on it) rotated about the point of the surface top at
    `pivot_xy`, so that it slopes downhill along (sx, sy) by hypot(sx, sy) rad."""
    theta = math.hypot(sx, sy)
    if theta == 0:
        return world
    axis = np.array([-sy, sx, 0.0]) / theta  # normal tilts toward downhill
    R = Rotation.from_rotvec(axis * theta)
    top = spec.surface_xyz[2] + half_extents(odb.get(spec.surface_type).geometry)[2]
    pivot = np.array([pivot_xy[0], pivot_xy[1], top])
    objects = dict(world.objects)
    for name in [spec.surface, spec.object]:
        o = objects[name]
        xyz = R.apply(np.asarray(o.pose.xyz) - pivot) + pivot
        Rm = R.as_matrix() @ o.pose.rotation()
        objects[name] = replace(o, pose=Pose.from_matrix(np.vstack([np.column_stack([Rm, xyz]), [0, 0, 0, 1]])))
    return replace(world, objects=objects)


# --- generation --------------------------------------------------------------------------------------------------
def simulate_truth(setup: TrueSetup, odb: ObjectDatabase, obj: str, end: float, scenes: dict
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Times, the true (T, 7) track of `obj` and the (T, 3) contact force on the rod, at OBS_RATE."""
    from ..sim.scene import build_scene
    from ..sim.tracks import simulate_tracks
    from .simulation import world_key

    key = (world_key(setup.world), setup.extras)
    if key not in scenes:
        if len(scenes) > 8:
            scenes.clear()
        scenes[key] = build_scene(setup.world, odb, extras=setup.extras)
    result = simulate_tracks(scenes[key], setup.true_telemetry, world=setup.world, params=setup.params, end=end,
                             sample_rate=OBS_RATE, robot_force=True)
    return result.times, result.tracks[obj], result.robot_force


def noisy_track(obj: str, times: np.ndarray, track: np.ndarray, rng: np.random.Generator,
                noise: tuple[float, float]) -> ObservedTrack:
    poses = []
    for row in track:
        xyz = row[:3] + rng.normal(0.0, noise[0], 3)
        R = Rotation.from_rotvec(rng.normal(0.0, noise[1], 3)) * Rotation.from_quat(row[[4, 5, 6, 3]])
        q = R.as_quat()
        poses.append(Pose(tuple(xyz), (q[3], q[0], q[1], q[2])))
    return ObservedTrack(obj, times, tuple(poses))


def generate_case(case: Case, odb: ObjectDatabase, folder: Path, n: int, *,
                  noise: tuple[float, float] = (NOISE_POSITION, NOISE_ROTATION), force_noise: float | None = NOISE_FORCE,
                  scenes: dict | None = None) -> tuple[list[Path], Truth]:
    """Write `n` recording folders under `folder` (rec_00, ...) with `case`'s effect concealed; truth.json beside.
    `force_noise` None leaves the rod's force sensor out (poses only)."""
    import json

    spec = scene_spec(case.scene, odb)
    rng = np.random.default_rng(case.seed)
    truth = case_truth(case, spec, odb, rng)
    pushes = design_pushes(spec, odb, rng, n)
    scenes = {} if scenes is None else scenes
    paths = []
    for k, push in enumerate(pushes):
        exact = nominal_world(spec, odb, push.start)
        setup = conceal(truth, spec, odb, exact, push)
        times, track, force = simulate_truth(setup, odb, spec.object, float(push.times[-1]), scenes)
        observed = noisy_track(spec.object, times, track, rng, noise)
        sensed = None
        if force_noise is not None:  # a planar force sensor on the rod: fx, fy
            sensed = force[:, :2] + rng.normal(0.0, force_noise, (len(times), 2))
            sensed = ObservedForce(times, np.column_stack([sensed, np.zeros(len(times))]))
        first = observed.poses[:5]
        x = float(np.mean([p.xyz[0] for p in first]))
        y = float(np.mean([p.xyz[1] for p in first]))
        yaw = float(np.angle(np.mean([np.exp(1j * p.yaw()) for p in first])))
        world = nominal_world(spec, odb, (x, y, yaw))
        path = folder / f"rec_{k:02d}"
        world_text = "# bridge world state\n" + _yaml(world_to_dict(world))
        save_recording(path, world_text, setup.recorded_telemetry, ObservedPoses((observed,)),
                       {"name": f"{case.scene}_rec_{k:02d}", "robot": "planar_pusher"}, force=sensed,
                       overwrite=True)
        paths.append(path)
    (folder / "truth.json").write_text(json.dumps({"case": case.name, **truth.to_json()}, indent=2))
    return paths, truth


def _yaml(data) -> str:
    import yaml

    return yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=120)
