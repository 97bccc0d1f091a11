"""The world state: objects with poses, the robot, and the facts the planner believes.

File format (YAML)::

    name: kitchen_table                     # optional
    objects:
      table:   {type: table, pose: {xyz: [0.75, 0, 0.725]}}
      big_box: {type: big_box, pose: {xyz: [0.6, 0.1, 0.875], rpy: [0, 0, 0.3]}}   # rpy in radians
      cup:     {type: cup, pose: {xyz: [...], quat: [1, 0, 0, 0]}}                     # quat is w, x, y, z
    robot: {name: justin, type: demo_arm, pose: {xyz: [0, 0, 0.75]}, joints: {arm_joint1: 0.0, ...}}
    facts: ["(on big_box table)", "(upright big_box)"]
    goal: "(and (on big_box tray))"         # optional, PDDL
    probabilities:                          # optional: facts whose truth varied over parameter samples
      samples: 24                           #   (bridge infer --samples); a fact not listed is certain
      facts: {"(upright big_box)": 0.625, "(on big_box table)": 0.625}

Loading validates everything against the object database; saving writes a temp file and renames it, so a
world-state file is never half-written.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Iterable, Mapping

from .errors import BridgeError, WorldStateError
from .files import dump_yaml, read_yaml, write_atomic
from .names import NameMap, build_name_map
from .odb import ObjectDatabase
from .odb.ranges import joint_problem
from .values import Fact, Pose

WORLD_KEYS = {"name", "objects", "robot", "facts", "goal", "probabilities"}
PROBABILITY_KEYS = {"samples", "facts"}
OBJECT_KEYS = {"type", "pose"}
ROBOT_KEYS = {"name", "type", "pose", "joints"}
POSE_KEYS = {"xyz", "rpy", "quat"}


@dataclass(frozen=True)
class ObjectState:
    name: str
    type: str
    pose: Pose


@dataclass(frozen=True)
class RobotState:
    name: str
    type: str
    base_pose: Pose = Pose()
    joints: tuple[tuple[str, float], ...] = ()

    def joint_positions(self) -> dict[str, float]:
        return dict(self.joints)


@dataclass(frozen=True)
class WorldState:
    objects: Mapping[str, ObjectState]
    facts: frozenset[Fact] = frozenset()
    robot: RobotState | None = None
    goal: str | None = None
    name: str = "world"
    names: NameMap = field(default_factory=NameMap, compare=False)
    probabilities: Mapping[Fact, float] = field(default_factory=dict)  # facts that held in only some samples
    samples: int = 0  # how many parameter samples the probabilities come from (0: none)

    def probability(self, fact: Fact) -> float:
        """The share of samples in which `fact` held; 1 or 0 for a fact no sample disagreed on."""
        return self.probabilities.get(fact, 1.0 if fact in self.facts else 0.0)

    def all_names(self) -> list[str]:
        """Objects, then the robot: everything a fact may name."""
        return list(self.objects) + ([self.robot.name] if self.robot else [])

    def type_name(self, name: str) -> str:
        if self.robot is not None and name == self.robot.name:
            return self.robot.type
        return self.objects[name].type

    def with_facts(self, facts: Iterable[Fact]) -> "WorldState":
        return replace(self, facts=frozenset(facts))

    def with_poses(self, poses: Mapping[str, Pose]) -> "WorldState":
        objects = {n: replace(o, pose=poses.get(n, o.pose)) for n, o in self.objects.items()}
        return replace(self, objects=objects)


# --- validation ---------------------------------------------------------------------------------
def parse_pose(body: Any, source: str | None, fld: str, error: type[BridgeError] = WorldStateError) -> Pose:
    """``{xyz: [x, y, z], rpy: [r, p, y]}`` or ``{xyz: [...], quat: [w, x, y, z]}``."""
    if not isinstance(body, dict):
        raise error("a pose is a mapping {xyz: [x, y, z], rpy: [r, p, y]} or {xyz, quat: [w, x, y, z]}", source=source, field=fld)
    unknown = set(body) - POSE_KEYS
    if unknown:
        raise error(f"unknown key {sorted(unknown)[0]!r}; valid keys: xyz, rpy, quat", source=source, field=fld)
    if "rpy" in body and "quat" in body:
        raise error("give rpy or quat, not both", source=source, field=fld)
    try:
        xyz = _vector(body.get("xyz", [0, 0, 0]), 3)
        if "quat" in body:
            return Pose(xyz, _vector(body["quat"], 4))  # type: ignore[arg-type]
        return Pose.from_rpy(xyz, _vector(body.get("rpy", [0, 0, 0]), 3))
    except (BridgeError, TypeError, ValueError) as exc:
        raise error(str(exc), source=source, field=fld) from None


def _vector(value: Any, n: int) -> tuple[float, ...]:
    if not isinstance(value, (list, tuple)) or len(value) != n or not all(
        isinstance(v, (int, float)) and not isinstance(v, bool) for v in value
    ):
        raise ValueError(f"expected a list of {n} numbers, got {value!r}")
    if not all(v == v and abs(v) != float("inf") for v in value):
        raise ValueError(f"expected finite numbers, got {value!r}")
    return tuple(float(v) for v in value)


def check_fact(fact: Fact, world: WorldState, odb: ObjectDatabase, source: str | None, fld: str,
               error: type[BridgeError] = WorldStateError) -> None:
    """Declared predicate, right arity, known objects of the right PDDL types."""
    decl = odb.predicates.get(fact.predicate)
    if decl is None:
        raise error(f"undeclared predicate {fact.predicate!r} in {fact}; declared: {', '.join(sorted(odb.predicates))}",
                    source=source, field=fld)
    if len(fact.args) != decl.arity:
        raise error(f"{fact}: {fact.predicate} takes {decl.arity} argument(s) ({' '.join(decl.params)}), got {len(fact.args)}",
                    source=source, field=fld)
    known = set(world.all_names())
    for arg, param in zip(fact.args, decl.params):
        if arg not in known:
            raise error(f"{fact}: unknown object {arg!r}; objects: {', '.join(sorted(known))}", source=source, field=fld)
        actual = odb.get(world.type_name(arg)).pddl_type
        if not odb.pddl_is_a(actual, param):
            raise error(f"{fact}: {arg!r} is a {actual}, but {fact.predicate} expects a {param} there", source=source, field=fld)


def world_from_dict(data: Any, odb: ObjectDatabase, source: str | None = None) -> WorldState:
    if not isinstance(data, dict):
        raise WorldStateError("a world state is a mapping with 'objects' (and 'robot', 'facts', 'goal')", source=source)
    unknown = set(data) - WORLD_KEYS
    if unknown:
        raise WorldStateError(f"unknown key {sorted(unknown)[0]!r}; valid keys: {', '.join(sorted(WORLD_KEYS))}", source=source)
    objects: dict[str, ObjectState] = {}
    raw_objects = data.get("objects") or {}
    if not isinstance(raw_objects, dict):
        raise WorldStateError("must map object names to {type, pose}", source=source, field="objects")
    for name, body in raw_objects.items():
        fld = f"objects.{name}"
        if not isinstance(name, str) or not name.strip():
            raise WorldStateError(f"object name {name!r} must be a non-empty string", source=source, field="objects")
        if not isinstance(body, dict):
            raise WorldStateError("must be a mapping {type, pose}", source=source, field=fld)
        bad = set(body) - OBJECT_KEYS
        if bad:
            raise WorldStateError(f"unknown key {sorted(bad)[0]!r}; valid keys: type, pose", source=source, field=fld)
        type_name = body.get("type")
        if type_name not in odb.types or odb.types[type_name].abstract or odb.types[type_name].is_robot:
            objects_ok = sorted(n for n in odb.concrete_types() if not odb.types[n].is_robot)
            raise WorldStateError(f"unknown object type {type_name!r}; known types: {', '.join(objects_ok)}", source=source, field=f"{fld}.type")
        objects[name] = ObjectState(name, type_name, parse_pose(body.get("pose", {}), source, f"{fld}.pose"))
    robot = None
    if data.get("robot") is not None:
        robot = _robot(data["robot"], odb, source)
        if robot.name in objects:
            raise WorldStateError(f"robot name {robot.name!r} is also an object's name", source=source, field="robot.name")
    names = build_name_map(list(objects) + ([robot.name] if robot else []), source=source, error=WorldStateError)
    goal = data.get("goal")
    if goal is not None and not isinstance(goal, str):
        raise WorldStateError("goal must be a PDDL formula written as text", source=source, field="goal")
    world = WorldState(objects=objects, robot=robot, goal=goal, name=str(data.get("name", "world")), names=names)
    raw_facts = data.get("facts") or []
    if not isinstance(raw_facts, list):
        raise WorldStateError("must be a list of facts like '(on box table)'", source=source, field="facts")
    facts = []
    for i, text in enumerate(raw_facts):
        fld = f"facts[{i}]"
        try:
            fact = Fact.parse(text)
        except BridgeError as exc:
            raise WorldStateError(str(exc), source=source, field=fld) from None
        # a name like "Cup 1" cannot stand in a fact as written: facts may use its PDDL name (cup_1)
        known = set(world.all_names())
        fact = Fact(fact.predicate, tuple(a if a in known else names.original(a.lower()) for a in fact.args))
        check_fact(fact, world, odb, source, fld)
        facts.append(fact)
    world = replace(world, facts=frozenset(facts))
    if data.get("probabilities") is not None:
        world = _probabilities(data["probabilities"], world, odb, source)
    return world


def _probabilities(body: Any, world: WorldState, odb: ObjectDatabase, source: str | None) -> WorldState:
    fld = "probabilities"
    if not isinstance(body, dict):
        raise WorldStateError("must be a mapping {samples: N, facts: {'(fact)': p}}", source=source, field=fld)
    bad = set(body) - PROBABILITY_KEYS
    if bad:
        raise WorldStateError(f"unknown key {sorted(bad)[0]!r}; valid keys: facts, samples", source=source, field=fld)
    samples = body.get("samples")
    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 1:
        raise WorldStateError(f"must be a whole number >= 1, got {samples!r}", source=source, field=f"{fld}.samples")
    raw = body.get("facts") or {}
    if not isinstance(raw, dict):
        raise WorldStateError("must map facts like '(on box table)' to probabilities", source=source,
                              field=f"{fld}.facts")
    known = set(world.all_names())
    probabilities = {}
    for text, p in raw.items():
        where = f"{fld}.facts[{text!r}]"
        try:
            fact = Fact.parse(text)
        except BridgeError as exc:
            raise WorldStateError(str(exc), source=source, field=where) from None
        fact = Fact(fact.predicate, tuple(a if a in known else world.names.original(a.lower()) for a in fact.args))
        check_fact(fact, world, odb, source, where)
        if isinstance(p, bool) or not isinstance(p, (int, float)) or not 0.0 <= p <= 1.0:
            raise WorldStateError(f"a probability is a number in [0, 1], got {p!r}", source=source, field=where)
        probabilities[fact] = float(p)
    return replace(world, probabilities=probabilities, samples=samples)


def _robot(body: Any, odb: ObjectDatabase, source: str | None) -> RobotState:
    if not isinstance(body, dict):
        raise WorldStateError("must be a mapping {name, type, pose, joints}", source=source, field="robot")
    bad = set(body) - ROBOT_KEYS
    if bad:
        raise WorldStateError(f"unknown key {sorted(bad)[0]!r}; valid keys: {', '.join(sorted(ROBOT_KEYS))}", source=source, field="robot")
    type_name = body.get("type")
    if type_name not in odb.robot_types():
        raise WorldStateError(f"unknown robot type {type_name!r}; robot types: {', '.join(sorted(odb.robot_types()))}", source=source, field="robot.type")
    spec = odb.types[type_name].robot
    assert spec is not None
    joints = body.get("joints") or {}
    if not isinstance(joints, dict):
        raise WorldStateError("must map joint names to positions", source=source, field="robot.joints")
    positions = spec.home_positions()
    limits = spec.limits
    for joint, value in joints.items():
        if joint not in spec.joints:
            raise WorldStateError(f"robot type {type_name!r} has no joint {joint!r}; joints: {', '.join(spec.joints)}", source=source, field=f"robot.joints.{joint}")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise WorldStateError(f"must be a finite number, got {value!r}", source=source, field=f"robot.joints.{joint}")
        problem = joint_problem(float(value), limits.get(joint, (-math.inf, math.inf)), joint, spec.model.name)
        if problem:  # the robot cannot be there: a wrong unit (degrees) or a wrong joint
            raise WorldStateError(problem, source=source, field=f"robot.joints.{joint}")
        positions[joint] = float(value)
    name = body.get("name", "robot")
    if not isinstance(name, str) or not name:
        raise WorldStateError("must be a non-empty string", source=source, field="robot.name")
    return RobotState(name, type_name, parse_pose(body.get("pose", {}), source, "robot.pose"), tuple(positions.items()))


def load_world_state(path: str | Path, odb: ObjectDatabase) -> WorldState:
    path = Path(path)
    return world_from_dict(read_yaml(path, "world-state file", WorldStateError), odb, str(path))


# --- saving -------------------------------------------------------------------------------------
def _pose_dict(pose: Pose) -> dict[str, list[float]]:
    return {"xyz": [round(v, 9) for v in pose.xyz], "quat": [round(v, 12) for v in pose.quat]}


def world_to_dict(world: WorldState) -> dict[str, Any]:
    data: dict[str, Any] = {"name": world.name, "objects": {
        n: {"type": o.type, "pose": _pose_dict(o.pose)} for n, o in world.objects.items()}}
    if world.robot is not None:
        r = world.robot
        data["robot"] = {"name": r.name, "type": r.type, "pose": _pose_dict(r.base_pose),
                         "joints": {j: round(v, 9) for j, v in r.joints}}
    data["facts"] = [str(Fact(f.predicate, tuple(world.names.pddl(a) for a in f.args))) for f in sorted(world.facts)]
    if world.goal:
        data["goal"] = world.goal
    if world.probabilities:
        data["probabilities"] = {"samples": world.samples, "facts": {
            str(Fact(f.predicate, tuple(world.names.pddl(a) for a in f.args))): round(p, 4)
            for f, p in sorted(world.probabilities.items())}}
    return data


def world_text(world: WorldState) -> str:
    """The world-state file's text (what `save_world_state` writes; `write_set` publishes it with its problem)."""
    return "# bridge world state\n" + dump_yaml(world_to_dict(world))


def save_world_state(world: WorldState, path: str | Path) -> None:
    write_atomic(path, world_text(world), WorldStateError)
