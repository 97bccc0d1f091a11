"""A bridge scene as MuJoCo MJCF, converted from the same models Drake loads: the robot's SDF (links, joints,
inertias, collision primitives, frictions, `drake:controller_gains`) and the world state with the object
database's geometry, masses and frictions. Benchmark-only (benchmarks/session_benchmark.py); needs no MuJoCo
itself, only to write the XML.

What carries over, and how:
- Robot: one MJCF body per SDF link, nested along the joints (a fixed joint: a body without a joint), the base
  link welded where the world puts the robot. Link, inertial and collision poses are read in the model frame
  (SDF 1.9 without `relative_to`) and made relative to the parent body.
- Actuators: Drake's PD-controlled actuators apply u = clamp(Kp (q_d - q) + Kd (v_d - v), +-effort). One MuJoCo
  `general` actuator per joint gives the same law: gain Kp, bias (0, -Kp, -Kd), control q_d + (Kd / Kp) v_d,
  force range +-effort.
- Joint limits, damping: as in the SDF. Objects: free bodies with bridge's mass properties (the mass, centre of
  mass and inertia Drake gets); fixtures welded; the floor a plane at bridge's floor height.
- Contact: MuJoCo's default soft contact (the naive replay keeps MuJoCo's defaults: no hydroelastic moduli or
  dissipation carried over), pairs listed explicitly with Drake's friction rule 2 a b / (a + b) of the
  dynamic coefficients (Drake's discrete solvers use only those); the same pairs collide as in Drake (the robot
  not with itself).
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from itertools import combinations
from pathlib import Path
from typing import Mapping

import numpy as np
from scipy.spatial.transform import Rotation

from bridge.errors import SceneError
from bridge.odb import ObjectDatabase
from bridge.sim.friction import combined_friction
from bridge.sim.scene import floor_height
from bridge.sim.shapes import mass_properties
from bridge.world import WorldState

DRAKE_NS = "{http://drake.mit.edu}"
FLOOR_FRICTION = 0.5  # bridge's floor: CoulombFriction(0.6, 0.5), dynamic 0.5 (bridge/sim/scene.py add_floor)
TORSION, ROLLING = 0.005, 0.0001  # MuJoCo's default torsional and rolling friction


@dataclass(frozen=True)
class MujocoScene:
    """The MJCF text and what a replay needs to drive and read it."""

    xml: str
    robot: str  # the robot's name in the world (contacts name its links 'robot/link')
    actuated: tuple[str, ...]  # joints with an actuator, in actuator order
    kp: tuple[float, ...]
    kd: tuple[float, ...]
    free: tuple[str, ...]  # free objects (MJCF bodies of the same name)
    owners: Mapping[str, str]  # geom name -> bridge body name ('table', 'arm/hand', 'world' for the floor)


@dataclass(frozen=True)
class _Link:
    name: str
    X: np.ndarray  # 4x4 pose in the model frame
    mass: float
    inertial: np.ndarray  # 4x4 pose of the inertial frame in the link frame
    inertia: tuple[float, ...]  # ixx iyy izz ixy ixz iyz
    geoms: tuple[tuple[str, tuple[float, ...], np.ndarray, float], ...]  # type, MJCF size, pose in link, friction


@dataclass(frozen=True)
class _Joint:
    name: str
    kind: str  # revolute, prismatic, fixed
    parent: str
    child: str
    axis: tuple[float, float, float]
    limits: tuple[float, float] | None
    effort: float | None
    damping: float
    gains: tuple[float, float] | None  # Kp, Kd


def scene_xml(world: WorldState, odb: ObjectDatabase, *, time_step: float = 0.002) -> MujocoScene:
    """MJCF of `world`: its robot from the model file the object database names, its objects from their types."""
    if world.robot is None:
        raise SceneError(f"world {world.name!r} has no robot; the MuJoCo converter replays robot telemetry")
    spec = odb.get(world.robot.type).robot
    links, joints = read_sdf(Path(spec.model))
    root = ET.Element("mujoco", model=world.name)
    ET.SubElement(root, "compiler", angle="radian", autolimits="true")
    ET.SubElement(root, "option", timestep=_f(time_step), integrator="implicitfast")
    ET.SubElement(root, "size", memory="64M")
    assets = ET.SubElement(root, "asset")
    worldbody = ET.SubElement(root, "worldbody")
    owners: dict[str, str] = {}
    robot_geoms: list[tuple[str, float]] = []
    fixed_geoms: list[tuple[str, float]] = []
    free_geoms: list[tuple[str, float]] = []

    ET.SubElement(worldbody, "geom", name="floor", type="plane", size="0 0 1",
                  pos=_v([0, 0, floor_height(world, odb)]), contype="0", conaffinity="0")
    owners["floor"] = "world"
    fixed_geoms.append(("floor", FLOOR_FRICTION))

    free = []
    for name, obj in world.objects.items():
        obj_type = odb.get(obj.type)
        g = obj_type.geometry
        if g is None:
            raise SceneError(f"object {name!r} of type {obj_type.name!r} has no geometry")
        geom = _object_geom(name, g, assets)
        mu = obj_type.physics.mu_dynamic
        X = obj.pose.matrix()
        if obj_type.fixed:
            ET.SubElement(worldbody, "geom", **geom, pos=_v(X[:3, 3]), quat=_quat(X[:3, :3]))
            fixed_geoms.append((geom["name"], mu))
        else:
            body = ET.SubElement(worldbody, "body", name=name, pos=_v(X[:3, 3]), quat=_quat(X[:3, :3]))
            ET.SubElement(body, "freejoint", name=f"{name}_free")
            mp = mass_properties(odb, obj_type.name)
            I = mp.inertia
            ET.SubElement(body, "inertial", pos=_v(mp.com), mass=_f(mp.mass),
                          fullinertia=_v([I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]))
            ET.SubElement(body, "geom", **geom)
            free_geoms.append((geom["name"], mu))
            free.append(name)
        owners[geom["name"]] = name

    robot = world.robot.name
    base = world.robot.base_pose.matrix()
    children: dict[str, list[_Joint]] = {}
    for joint in joints.values():
        children.setdefault(joint.parent, []).append(joint)
    if spec.base_link not in links:
        raise SceneError(f"robot model has no link {spec.base_link!r} (robot.base_link)", source=str(spec.model))

    def add_link(parent_el, link: _Link, X_rel: np.ndarray, joint: _Joint | None) -> None:
        """`link` as a body at `X_rel` in its parent body, then its children."""
        body = ET.SubElement(parent_el, "body", name=link.name, pos=_v(X_rel[:3, 3]), quat=_quat(X_rel[:3, :3]))
        if joint is not None and joint.kind != "fixed":
            attrs = {"name": joint.name, "type": "hinge" if joint.kind == "revolute" else "slide",
                     "axis": _v(joint.axis), "damping": _f(joint.damping)}
            if joint.limits is not None:
                attrs["range"] = _v(joint.limits)
            ET.SubElement(body, "joint", **attrs)
        ixx, iyy, izz, ixy, ixz, iyz = link.inertia
        R = link.inertial[:3, :3]  # MJCF takes a full inertia in the body frame, not with a rotation
        I = R @ np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]]) @ R.T
        ET.SubElement(body, "inertial", pos=_v(link.inertial[:3, 3]), mass=_f(link.mass),
                      fullinertia=_v([I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]))
        for k, (kind, size, X_geom, mu) in enumerate(link.geoms):
            gname = f"{link.name}/{k}"
            ET.SubElement(body, "geom", name=gname, type=kind, size=_v(size), pos=_v(X_geom[:3, 3]),
                          quat=_quat(X_geom[:3, :3]), contype="0", conaffinity="0")
            owners[gname] = f"{robot}/{link.name}"
            robot_geoms.append((gname, mu))
        for child in children.get(link.name, ()):
            add_link(body, links[child.child], np.linalg.inv(link.X) @ links[child.child].X, child)

    add_link(worldbody, links[spec.base_link], base, None)  # the base link's frame welded at the robot's pose

    contact = ET.SubElement(root, "contact")
    pairs = ([(a, b) for a, b in combinations(free_geoms, 2)]
             + [(a, b) for a in free_geoms for b in fixed_geoms + robot_geoms]
             + [(a, b) for a in robot_geoms for b in fixed_geoms if b[0] != "floor"])
    for (ga, mua), (gb, mub) in pairs:
        mu = combined_friction(mua, mub)
        ET.SubElement(contact, "pair", geom1=ga, geom2=gb, friction=_v([mu, mu, TORSION, ROLLING, ROLLING]))

    actuator = ET.SubElement(root, "actuator")
    actuated, kps, kds = [], [], []
    for name in spec.joints:
        joint = joints.get(name)
        if joint is None:
            raise SceneError(f"robot model has no joint {name!r} listed in the object database", source=str(spec.model))
        if joint.gains is None:
            continue
        kp, kd = joint.gains
        attrs = {"name": f"{name}_pd", "joint": name, "gaintype": "fixed", "biastype": "affine",
                 "gainprm": _f(kp), "biasprm": _v([0.0, -kp, -kd])}
        if joint.effort is not None:
            attrs["forcerange"] = _v([-joint.effort, joint.effort])
        ET.SubElement(actuator, "general", **attrs)
        actuated.append(name)
        kps.append(kp)
        kds.append(kd)
    ET.indent(root)
    return MujocoScene(ET.tostring(root, encoding="unicode"), robot, tuple(actuated), tuple(kps), tuple(kds),
                       tuple(free), owners)


def read_sdf(path: Path) -> tuple[dict[str, _Link], dict[str, _Joint]]:
    """The links and joints of the first model of an SDF file (poses in the model frame)."""
    try:
        model = ET.parse(path).getroot().find("model")
    except (OSError, ET.ParseError) as exc:
        raise SceneError(f"cannot read the robot model: {exc}", source=str(path)) from None
    if model is None:
        raise SceneError("no <model> in the SDF file", source=str(path))
    links = {}
    for el in model.findall("link"):
        name = el.get("name")
        inertial = el.find("inertial")
        if inertial is None:
            raise SceneError(f"link {name!r} has no <inertial>", source=str(path))
        i = inertial.find("inertia")
        inertia = tuple(float(i.findtext(k, "0")) for k in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz"))
        geoms = []
        for col in el.findall("collision"):
            geoms.append((*_primitive(col.find("geometry"), path, name), _pose(col, path), _friction(col)))
        links[name] = _Link(name, _pose(el, path), float(inertial.findtext("mass")), _pose(inertial, path), inertia,
                            tuple(geoms))
    joints = {}
    for el in model.findall("joint"):
        kind = el.get("type")
        if kind not in ("revolute", "prismatic", "fixed"):
            raise SceneError(f"joint {el.get('name')!r}: type {kind!r} is not converted (revolute, prismatic, "
                             "fixed)", source=str(path))
        if el.find("pose") is not None:
            raise SceneError(f"joint {el.get('name')!r}: a joint <pose> is not converted (the joint frame must be "
                             "the child link's)", source=str(path))
        axis_el = el.find("axis")
        axis, limits, effort, damping = (0.0, 0.0, 1.0), None, None, 0.0
        if axis_el is not None:
            axis = tuple(float(v) for v in axis_el.findtext("xyz", "0 0 1").split())
            limit = axis_el.find("limit")
            if limit is not None:
                lower, upper = limit.findtext("lower"), limit.findtext("upper")
                if lower is not None and upper is not None:
                    limits = (float(lower), float(upper))
                if limit.findtext("effort") is not None:
                    effort = float(limit.findtext("effort"))
            dynamics = axis_el.find("dynamics")
            if dynamics is not None:
                damping = float(dynamics.findtext("damping", "0"))
        gains_el = el.find(f"{DRAKE_NS}controller_gains")
        gains = None if gains_el is None else (float(gains_el.get("p")), float(gains_el.get("d")))
        joints[el.get("name")] = _Joint(el.get("name"), kind, el.findtext("parent"), el.findtext("child"), axis,
                                        limits, effort, damping, gains)
    return links, joints


def _pose(el, path: Path) -> np.ndarray:
    pose = el.find("pose")
    X = np.eye(4)
    if pose is None:
        return X
    if pose.get("relative_to"):
        raise SceneError(f"<pose relative_to={pose.get('relative_to')!r}> is not converted (model-frame poses only)",
                         source=str(path))
    x, y, z, roll, pitch, yaw = (float(v) for v in pose.text.split())
    X[:3, :3] = Rotation.from_euler("xyz", [roll, pitch, yaw]).as_matrix()
    X[:3, 3] = (x, y, z)
    return X


def _primitive(geometry, path: Path, link: str) -> tuple[str, tuple[float, ...]]:
    box, cylinder, sphere = (geometry.find(k) for k in ("box", "cylinder", "sphere"))
    if box is not None:
        return "box", tuple(0.5 * float(v) for v in box.findtext("size").split())
    if cylinder is not None:
        return "cylinder", (float(cylinder.findtext("radius")), 0.5 * float(cylinder.findtext("length")))
    if sphere is not None:
        return "sphere", (float(sphere.findtext("radius")),)
    raise SceneError(f"link {link!r}: only box, cylinder and sphere collisions are converted", source=str(path))


def _friction(collision) -> float:
    props = collision.find(f"{DRAKE_NS}proximity_properties")
    if props is None:
        return 0.5
    text = props.findtext(f"{DRAKE_NS}mu_dynamic") or props.findtext(f"{DRAKE_NS}mu_static")
    return float(text) if text else 0.5


def _object_geom(name: str, g, assets) -> dict[str, str]:
    geom = {"name": name, "contype": "0", "conaffinity": "0"}
    if g.shape == "box":
        return {**geom, "type": "box", "size": _v(0.5 * np.asarray(g.size))}
    if g.shape == "cylinder":
        return {**geom, "type": "cylinder", "size": _v([g.size[0], 0.5 * g.size[1]])}
    if g.shape == "sphere":
        return {**geom, "type": "sphere", "size": _v([g.size[0]])}
    if g.shape == "mesh":
        if g.mesh is None:
            raise SceneError(f"object {name!r}: mesh {g.unresolved!r} not found (its dataset root is unknown)")
        ET.SubElement(assets, "mesh", name=f"{name}_mesh", file=str(g.mesh), scale=_v([g.scale] * 3))
        return {**geom, "type": "mesh", "mesh": f"{name}_mesh"}  # MuJoCo collides a mesh's convex hull
    raise SceneError(f"object {name!r}: shape {g.shape!r} is not converted")


def _quat(R: np.ndarray) -> str:
    x, y, z, w = Rotation.from_matrix(R).as_quat()
    return _v([w, x, y, z])


def _v(values) -> str:
    return " ".join(_f(v) for v in np.asarray(values, dtype=float).ravel())


def _f(value: float) -> str:
    return f"{float(value):.9g}" if math.isfinite(float(value)) else str(value)
