"""Read the object database: YAML object types with single inheritance, SIE modules beside them.

Layout of a database root (``odb/`` in this repository)::

    odb/types/*.yaml    each file maps type names to definitions
    odb/sies/*.py       SIE classes, referenced as ``sies.<module>:<Class>``

A definition (every key optional; see docs/object_database.md)::

    small_box:
      parent: box                 # single inheritance
      pddl_type: box              # defaults to the parent's
      abstract: false             # not inherited
      fixed: false                # welded to the world
      geometry: {shape: box, size: [0.06, 0.06, 0.12]}   # replaced whole by a subtype
      physics: {mass: 0.3, friction: 0.5}                # merged key by key
      predicates:                                        # merged by predicate name
        upright: {params: [movable], sie: {class: sies.pose:Upright, params: {max_tilt_deg: 20}}}
      robot: {...}                # robots only: model, joints, gripper

Mesh paths are relative to the YAML file, or ``dataset://NAME/path`` for data kept outside the project.
"""
from __future__ import annotations

import hashlib
import importlib
import importlib.util
import math
import os
import sys
import types as pytypes
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping
from xml.etree import ElementTree

import yaml

from ..errors import ObjectDatabaseError
from ..files import load_yaml_text, read_yaml
from ..values import is_identifier
from .geometry import mesh_vertices
from .ranges import RANGES, joint_problem
from .types import SHAPES, Geometry, Gripper, ObjectType, Physics, PredicateDecl, RobotSpec, SIERef

TYPE_KEYS = {"parent", "pddl_type", "abstract", "fixed", "geometry", "physics", "predicates", "robot", "doc"}
GEOMETRY_KEYS = {"shape", "size", "mesh", "scale", "convex", "color", "contact", "footprint_vertices", "plane_top"}
CONTACT_MODES = ("prism", "hull", "drake")  # bridge.sim.prisms.MODES
PHYSICS_KEYS = {"mass", "density", "com", "inertia", "friction", "dynamic_friction", "hydroelastic_modulus", "dissipation",
                "friction_sd", "mass_sd", "com_sd"}
PREDICATE_KEYS = {"params", "subject", "sie"}
ROBOT_KEYS = {"model", "base_link", "joints", "gripper", "home", "kp", "kd"}
GRIPPER_KEYS = {"joints", "tcp_frame", "open", "closed", "finger_links"}
SIZE_LENGTH = {"box": 3, "cylinder": 2, "sphere": 1}
DATASET_SCHEME = "dataset://"


@dataclass(frozen=True)
class _RawType:
    name: str
    body: Mapping[str, Any]
    source: Path


def dataset_env_names(name: str) -> tuple[str, str]:
    """The variables that may name dataset NAME's root, first wins: BRIDGE_DATASET_<NAME> and the short
    BRIDGE_<NAME> (e.g. BRIDGE_MIT_PUSH, the one the recording loaders and the docs use), so one variable set
    for the recordings also resolves the object database's meshes."""
    key = name.upper().replace("-", "_")
    return f"BRIDGE_DATASET_{key}", f"BRIDGE_{key}"


def dataset_roots_from_env(names: set[str], repo_root: Path | None) -> dict[str, Path]:
    """Roots of datasets named in ``dataset://NAME/...`` paths, from the environment (`dataset_env_names`) or
    ../shared/datasets beside the repository."""
    roots: dict[str, Path] = {}
    for name in names:
        env = next((os.environ[v] for v in dataset_env_names(name) if os.environ.get(v)), None)
        if env:
            roots[name] = Path(env)
        elif repo_root is not None and (repo_root.parent / "shared" / "datasets" / name).is_dir():
            roots[name] = repo_root.parent / "shared" / "datasets" / name
    return roots


class _Reader:
    """Turns raw YAML definitions into resolved `ObjectType`s; collects nothing global besides its inputs."""

    def __init__(self, root: Path, datasets: Mapping[str, Path]):
        self.root = root
        self.datasets = dict(datasets)
        self.package = _sie_package(root)

    # --- files --------------------------------------------------------------------------------
    def read_raw(self) -> dict[str, _RawType]:
        folder = self.root / "types"
        if not folder.is_dir():
            raise ObjectDatabaseError("no 'types' folder with object type YAML files", source=str(self.root))
        raw: dict[str, _RawType] = {}
        for path in sorted(folder.rglob("*.yaml")):
            data = read_yaml(path, "object type file", ObjectDatabaseError)
            if data is None:
                continue
            if not isinstance(data, dict):
                raise ObjectDatabaseError("must map type names to definitions", source=str(path))
            for name, body in data.items():
                if not isinstance(name, str) or not is_identifier(name):
                    raise ObjectDatabaseError(
                        f"type name {name!r} is not an identifier (letters, digits, '_' and '-')", source=str(path))
                if body is None:
                    body = {}
                if not isinstance(body, dict):
                    raise ObjectDatabaseError("definition must be a mapping", source=str(path), field=name)
                unknown = set(body) - TYPE_KEYS
                if unknown:
                    raise ObjectDatabaseError(
                        f"unknown key {sorted(unknown)[0]!r}; valid keys: {', '.join(sorted(TYPE_KEYS))}",
                        source=str(path), field=name)
                if name in raw:
                    raise ObjectDatabaseError(
                        f"type {name!r} is defined twice (also in {raw[name].source})", source=str(path), field=name)
                raw[name] = _RawType(name, body, path)
        if not raw:
            raise ObjectDatabaseError("no object types found in types/*.yaml", source=str(self.root))
        return raw

    # --- inheritance --------------------------------------------------------------------------
    def lineage(self, raw: Mapping[str, _RawType], name: str) -> tuple[str, ...]:
        chain = [name]
        while True:
            parent = raw[chain[-1]].body.get("parent")
            if parent is None:
                return tuple(chain)
            if not isinstance(parent, str) or parent not in raw:
                t = raw[chain[-1]]
                raise ObjectDatabaseError(
                    f"unknown parent type {parent!r}; known types: {', '.join(sorted(raw))}",
                    source=str(t.source), field=f"{t.name}.parent")
            if parent in chain:
                cycle = " -> ".join(chain[chain.index(parent):] + [parent])
                t = raw[name]
                raise ObjectDatabaseError(f"inheritance cycle {cycle}", source=str(t.source), field=f"{name}.parent")
            chain.append(parent)

    def resolve(self, raw: Mapping[str, _RawType]) -> dict[str, ObjectType]:
        resolved: dict[str, ObjectType] = {}
        for name in raw:
            lineage = self.lineage(raw, name)
            for type_name in reversed(lineage):  # root first, so parents are ready
                if type_name not in resolved:
                    parent = raw[type_name].body.get("parent")
                    resolved[type_name] = self.resolve_one(raw[type_name], resolved.get(parent), lineage[lineage.index(type_name):])
        return resolved

    def resolve_one(self, raw: _RawType, parent: ObjectType | None, ancestors: tuple[str, ...]) -> ObjectType:
        body, src = raw.body, str(raw.source)
        pddl_type = body.get("pddl_type", parent.pddl_type if parent else "object")
        if not isinstance(pddl_type, str) or not is_identifier(pddl_type):
            raise ObjectDatabaseError(f"pddl_type {pddl_type!r} is not a PDDL identifier", source=src, field=f"{raw.name}.pddl_type")
        geometry = parent.geometry if parent else None
        if "geometry" in body:
            geometry = self.geometry(body["geometry"], raw)
        physics = self.physics(body.get("physics") or {}, parent.physics if parent else Physics(), raw)
        predicates = dict(parent.predicates) if parent else {}
        for pname, pbody in (body.get("predicates") or {}).items():
            predicates[pname] = self.predicate(pname, pbody, predicates.get(pname), raw)
        robot = parent.robot if parent else None
        if "robot" in body:
            robot = self.robot(body["robot"], raw)
        abstract = self.flag(body, "abstract", False, raw)
        fixed = self.flag(body, "fixed", parent.fixed if parent else False, raw)
        if geometry is not None and geometry.plane_top and not fixed:
            raise ObjectDatabaseError("plane_top applies to fixtures only (a free object's top carries nothing as a "
                                      "plane)", source=src, field=f"{raw.name}.geometry.plane_top")
        if not abstract and robot is None:
            if geometry is None:
                raise ObjectDatabaseError("a concrete type needs a geometry (or 'abstract: true')", source=src, field=f"{raw.name}.geometry")
            if physics.mass is None and physics.density is None and not fixed:
                raise ObjectDatabaseError("a concrete movable type needs physics.mass or physics.density", source=src, field=f"{raw.name}.physics")
        return ObjectType(
            name=raw.name, parent=body.get("parent"), pddl_type=pddl_type, ancestors=ancestors, source=raw.source,
            abstract=abstract, fixed=fixed, geometry=geometry, physics=physics, predicates=predicates, robot=robot)

    # --- sections -----------------------------------------------------------------------------
    @staticmethod
    def flag(body: Mapping[str, Any], key: str, default: bool, raw: _RawType) -> bool:
        value = body.get(key, default)
        if not isinstance(value, bool):
            raise ObjectDatabaseError(f"must be true or false, got {value!r}", source=str(raw.source), field=f"{raw.name}.{key}")
        return value

    def geometry(self, body: Any, raw: _RawType) -> Geometry:
        src, fld = str(raw.source), f"{raw.name}.geometry"
        if not isinstance(body, dict):
            raise ObjectDatabaseError("must be a mapping with 'shape'", source=src, field=fld)
        _no_unknown(body, GEOMETRY_KEYS, src, fld)
        shape = body.get("shape")
        if shape not in SHAPES:
            raise ObjectDatabaseError(f"shape {shape!r} is not one of {', '.join(SHAPES)}", source=src, field=f"{fld}.shape")
        color = tuple(_numbers(body.get("color", [0.6, 0.6, 0.6, 1.0]), 4, src, f"{fld}.color", positive=False))
        if shape == "mesh":
            if "plane_top" in body:
                raise ObjectDatabaseError("plane_top applies to box geometry only, not mesh", source=src,
                                          field=f"{fld}.plane_top")
            mesh, unresolved = self.mesh_path(body.get("mesh"), raw)
            scale = _number(body.get("scale", 1.0), src, f"{fld}.scale", positive=True)
            contact = body.get("contact")
            if contact is not None and contact not in CONTACT_MODES:
                raise ObjectDatabaseError(f"contact {contact!r} is not one of {', '.join(CONTACT_MODES)}", source=src,
                                          field=f"{fld}.contact")
            vertices = body.get("footprint_vertices")
            if vertices is not None and (not isinstance(vertices, int) or isinstance(vertices, bool) or vertices < 3):
                raise ObjectDatabaseError(f"footprint_vertices must be a whole number >= 3, got {vertices!r}",
                                          source=src, field=f"{fld}.footprint_vertices")
            return Geometry(shape, (), mesh, scale, bool(body.get("convex", True)), unresolved, color,  # type: ignore[arg-type]
                            contact, vertices)
        for key in ("contact", "footprint_vertices"):
            if key in body:
                raise ObjectDatabaseError(f"{key} applies to mesh geometry only", source=src, field=f"{fld}.{key}")
        plane_top = body.get("plane_top", False)
        if not isinstance(plane_top, bool):
            raise ObjectDatabaseError(f"must be true or false, got {plane_top!r}", source=src, field=f"{fld}.plane_top")
        if plane_top and shape != "box":
            raise ObjectDatabaseError(f"plane_top applies to box geometry only, not {shape}", source=src,
                                      field=f"{fld}.plane_top")
        size = tuple(_numbers(body.get("size"), SIZE_LENGTH[shape], src, f"{fld}.size", positive=True))
        return Geometry(shape, size, color=color, plane_top=plane_top)  # type: ignore[arg-type]

    def mesh_path(self, value: Any, raw: _RawType) -> tuple[Path | None, str | None]:
        src, fld = str(raw.source), f"{raw.name}.geometry.mesh"
        if not isinstance(value, str) or not value:
            raise ObjectDatabaseError("a mesh geometry needs 'mesh': a path to an OBJ file", source=src, field=fld)
        if value.startswith(DATASET_SCHEME):
            dataset, _, rest = value[len(DATASET_SCHEME):].partition("/")
            if dataset not in self.datasets:
                return None, value
            path = self.datasets[dataset] / rest
        else:
            path = (raw.source.parent / value).resolve()
        if not path.is_file():
            raise ObjectDatabaseError(f"mesh file {path} not found", source=src, field=fld)
        try:
            mesh_vertices(path, 1.0)  # read now: a file that is no OBJ mesh is named here, not by Drake later
        except ObjectDatabaseError as exc:
            raise ObjectDatabaseError(f"mesh file {exc}", source=src, field=fld) from None
        return path, None

    def physics(self, body: Any, base: Physics, raw: _RawType) -> Physics:
        src, fld = str(raw.source), f"{raw.name}.physics"
        if not isinstance(body, dict):
            raise ObjectDatabaseError("must be a mapping", source=src, field=fld)
        _no_unknown(body, PHYSICS_KEYS, src, fld)
        values = dict(base.__dict__)
        if "mass" in body and "density" in body:
            raise ObjectDatabaseError("give mass or density, not both", source=src, field=fld)
        if "mass" in body:
            values.update(mass=_number(body["mass"], src, f"{fld}.mass", positive=True), density=None)
        if "density" in body:
            values.update(density=_number(body["density"], src, f"{fld}.density", positive=True), mass=None)
        for key in ("friction", "dynamic_friction", "dissipation", "friction_sd", "mass_sd", "com_sd"):
            if key in body:
                values[key] = _number(body[key], src, f"{fld}.{key}", positive=False)
        if "hydroelastic_modulus" in body:
            values["hydroelastic_modulus"] = None if body["hydroelastic_modulus"] is None else _number(
                body["hydroelastic_modulus"], src, f"{fld}.hydroelastic_modulus", positive=True)
        if "com" in body:
            values["com"] = tuple(_numbers(body["com"], 3, src, f"{fld}.com", positive=False))
        if "inertia" in body:
            values["inertia"] = tuple(_numbers(body["inertia"], 6, src, f"{fld}.inertia", positive=False))
        return Physics(**values)

    def predicate(self, name: Any, body: Any, inherited: PredicateDecl | None, raw: _RawType) -> PredicateDecl:
        src, fld = str(raw.source), f"{raw.name}.predicates.{name}"
        if not isinstance(name, str) or not is_identifier(name):
            raise ObjectDatabaseError(f"predicate name {name!r} is not a PDDL identifier", source=src, field=f"{raw.name}.predicates")
        if not isinstance(body, dict):
            raise ObjectDatabaseError("must be a mapping with 'params' and 'sie'", source=src, field=fld)
        _no_unknown(body, PREDICATE_KEYS, src, fld)
        if "params" in body:
            params = body["params"]
            if not isinstance(params, list) or not all(isinstance(p, str) and is_identifier(p) for p in params):
                raise ObjectDatabaseError("params must be a list of PDDL type names", source=src, field=f"{fld}.params")
            params = tuple(params)
            if inherited is not None and params != inherited.params:
                raise ObjectDatabaseError(
                    f"redeclares the signature {list(params)} of a predicate inherited from {inherited.declared_by!r} "
                    f"as {list(inherited.params)}; override only 'sie'", source=src, field=f"{fld}.params")
        elif inherited is not None:
            params = inherited.params
        else:
            raise ObjectDatabaseError("a new predicate needs 'params' (its argument types)", source=src, field=fld)
        subject = body.get("subject", inherited.subject if inherited else 0)
        if not isinstance(subject, int) or isinstance(subject, bool) or not 0 <= subject < max(len(params), 1):
            raise ObjectDatabaseError(f"subject must index one of the {len(params)} params", source=src, field=f"{fld}.subject")
        sie = inherited.sie if inherited else None
        if "sie" in body:
            sie = self.sie_ref(body["sie"], src, f"{fld}.sie")
        return PredicateDecl(name, params, subject, sie, inherited.declared_by if inherited else raw.name)

    def sie_ref(self, body: Any, src: str, fld: str) -> SIERef | None:
        if body is None:
            return None
        params: dict[str, Any] = {}
        if isinstance(body, dict):
            _no_unknown(body, {"class", "params"}, src, fld)
            params = body.get("params") or {}
            if not isinstance(params, dict):
                raise ObjectDatabaseError("params must be a mapping", source=src, field=f"{fld}.params")
            body = body.get("class")
        if not isinstance(body, str) or body.count(":") != 1:
            raise ObjectDatabaseError(f"SIE reference {body!r} must look like 'sies.module:ClassName'", source=src, field=fld)
        module, cls = body.split(":")
        ref = SIERef(module, cls, tuple(sorted(params.items())), f"{src}: {fld}", src, fld)
        load_sie_class(self.package, ref)  # a bad reference fails now, not during a teleoperation session
        return ref

    def robot(self, body: Any, raw: _RawType) -> RobotSpec:
        src, fld = str(raw.source), f"{raw.name}.robot"
        if not isinstance(body, dict):
            raise ObjectDatabaseError("must be a mapping", source=src, field=fld)
        _no_unknown(body, ROBOT_KEYS, src, fld)
        model = body.get("model")
        if not isinstance(model, str):
            raise ObjectDatabaseError("needs 'model': a path to the robot's SDF/URDF", source=src, field=f"{fld}.model")
        model_path = (raw.source.parent / model).resolve()
        if not model_path.is_file():
            raise ObjectDatabaseError(f"robot model {model_path} not found", source=src, field=f"{fld}.model")
        joints = body.get("joints")
        if not isinstance(joints, list) or not joints or not all(isinstance(j, str) for j in joints):
            raise ObjectDatabaseError("joints must be a non-empty list of joint names", source=src, field=f"{fld}.joints")
        gripper = None
        if body.get("gripper") is not None:
            g = body["gripper"]
            gfld = f"{fld}.gripper"
            if not isinstance(g, dict):
                raise ObjectDatabaseError("must be a mapping", source=src, field=gfld)
            _no_unknown(g, GRIPPER_KEYS, src, gfld)
            gjoints = tuple(g.get("joints") or ())
            missing = [j for j in gjoints if j not in joints]
            if missing:
                raise ObjectDatabaseError(f"gripper joint {missing[0]!r} is not in the robot's joints", source=src, field=f"{gfld}.joints")
            gripper = Gripper(
                gjoints, str(g.get("tcp_frame", "tcp")),
                _number(g.get("open", 0.04), src, f"{gfld}.open", positive=False),
                _number(g.get("closed", 0.0), src, f"{gfld}.closed", positive=False),
                tuple(g.get("finger_links") or ()))
        model_xml = _model_names(model_path, src, f"{fld}.model")
        joint_types = model_xml.joints
        missing = [j for j in joints if j not in joint_types]
        if missing:
            raise ObjectDatabaseError(f"robot model {model_path.name} has no joint {missing[0]!r}; its joints: "
                                      f"{', '.join(joint_types)}", source=src, field=f"{fld}.joints")
        base_link = body.get("base_link", "base")
        if model_xml.links:  # the links a model file names itself; one that includes others is checked by Drake
            named = {f"{fld}.base_link": [base_link]}
            if gripper is not None:
                named[f"{fld}.gripper.finger_links"] = list(gripper.finger_links)
            for where, links in named.items():
                unknown = [link for link in links if link not in model_xml.links]
                if unknown:
                    raise ObjectDatabaseError(f"robot model {model_path.name} has no link {unknown[0]!r}; its links: "
                                              f"{', '.join(model_xml.links)}", source=src, field=where)
            if gripper is not None and gripper.tcp_frame not in model_xml.links + model_xml.frames:
                raise ObjectDatabaseError(f"robot model {model_path.name} has no frame or link {gripper.tcp_frame!r}; "
                                          f"its frames: {', '.join(model_xml.frames) or 'none'}; its links: "
                                          f"{', '.join(model_xml.links)}", source=src, field=f"{fld}.gripper.tcp_frame")
        home = body.get("home") or {}
        if not isinstance(home, dict) or any(j not in joints for j in home):
            raise ObjectDatabaseError("home must map the robot's joints to positions", source=src, field=f"{fld}.home")
        home_positions = tuple((j, _number(v, src, f"{fld}.home.{j}", positive=False)) for j, v in home.items())
        for j, v in home_positions:
            problem = joint_problem(v, joint_types[j][1:], j, model_path.name)
            if problem:
                raise ObjectDatabaseError(problem, source=src, field=f"{fld}.home.{j}")
        return RobotSpec(
            model=model_path, base_link=str(base_link), joints=tuple(joints), gripper=gripper,
            home=home_positions,
            kp=_number(body.get("kp", 400.0), src, f"{fld}.kp", positive=True),
            kd=_number(body.get("kd", 40.0), src, f"{fld}.kd", positive=True),
            joint_types=tuple((j, joint_types[j][0]) for j in joints),
            joint_limits=tuple((j, *joint_types[j][1:]) for j in joints),
            links=model_xml.links, contact_links=model_xml.contact_links, link_friction=model_xml.link_friction)


@dataclass(frozen=True)
class _ModelNames:
    joints: dict[str, tuple[str, float, float]]  # name -> (type, lower, upper); continuous joints: infinite limits
    links: tuple[str, ...]  # () when the model includes or nests others (their names are scoped: Drake checks them)
    contact_links: tuple[str, ...]
    frames: tuple[str, ...]
    link_friction: tuple[tuple[str, float], ...] = ()


DRAKE_XML = "http://drake.mit.edu"  # the namespace of <drake:...> tags in SDF and URDF files


def _model_names(model: Path, src: str, fld: str) -> _ModelNames:
    """The joints (with their types and limits), links and frames an SDF/URDF names, read from its XML: what the
    diagnosis needs to know of a joint (a calibration offset in metres or radians), what positions a world state
    or a recording may give it, and what the database and parameter files may name, known without building a
    simulation."""
    try:
        root = ElementTree.parse(model).getroot()
    except (ElementTree.ParseError, OSError) as exc:
        raise ObjectDatabaseError(f"cannot read robot model {model}: {exc}", source=src, field=fld) from None
    joints = {}
    for j in root.iter("joint"):
        name, kind = j.get("name"), j.get("type")
        if not name or not kind:
            continue
        lo, hi = _limit(j, "lower", -math.inf), _limit(j, "upper", math.inf)
        if kind == "continuous" or not lo <= hi:
            lo, hi = -math.inf, math.inf
        joints[name] = (kind, lo, hi)
    nested = any(True for _ in root.iter("include")) or sum(1 for _ in root.iter("model")) > 1
    links = [] if nested else [link for link in root.iter("link") if link.get("name")]
    return _ModelNames(joints, tuple(link.get("name") for link in links),
                       tuple(link.get("name") for link in links if link.find("collision") is not None),
                       () if nested else tuple(f.get("name") for f in root.iter("frame") if f.get("name")),
                       tuple((link.get("name"), mu) for link in links if (mu := _link_friction(link)) is not None))


def _link_friction(link: ElementTree.Element) -> float | None:
    """The dynamic Coulomb coefficient a link's first collision gives in ``drake:proximity_properties``
    (``drake:mu_dynamic``, else ``drake:mu_static``): the one Drake's discrete solvers use. None when the file gives
    none."""
    for collision in link.iter("collision"):
        props = collision.find(f"{{{DRAKE_XML}}}proximity_properties")
        for tag in ("mu_dynamic", "mu_static"):
            text = props.findtext(f"{{{DRAKE_XML}}}{tag}") if props is not None else None
            try:
                value = float(text) if text is not None else math.nan
            except ValueError:
                value = math.nan
            if math.isfinite(value) and value >= 0:
                return value
    return None


def _limit(joint: ElementTree.Element, which: str, default: float) -> float:
    """A joint's `which` limit: SDF ``<axis><limit><lower>``, URDF ``<limit lower=...>``; `default` when absent,
    unreadable or beyond 1e15 (SDF's "unlimited")."""
    text = joint.findtext(f"axis/limit/{which}")
    if text is None:
        limit = joint.find("limit")
        text = limit.get(which) if limit is not None else None
    try:
        value = float(text) if text is not None else default
    except ValueError:
        return default
    return value if math.isfinite(value) and abs(value) < 1e15 else default


def _no_unknown(body: Mapping[str, Any], valid: set[str], src: str, fld: str) -> None:
    unknown = set(body) - valid
    if unknown:
        raise ObjectDatabaseError(f"unknown key {sorted(unknown)[0]!r}; valid keys: {', '.join(sorted(valid))}", source=src, field=fld)


def _number(value: Any, src: str, fld: str, *, positive: bool) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or value != value or value in (float("inf"), float("-inf")):
        raise ObjectDatabaseError(f"must be a finite number, got {value!r}", source=src, field=fld)
    if positive and value <= 0:
        raise ObjectDatabaseError(f"must be positive, got {value!r}", source=src, field=fld)
    key = fld.rsplit(".", 1)[-1]
    if not positive and key in ("friction", "dynamic_friction", "dissipation", "friction_sd", "mass_sd",
                                "com_sd") and value < 0:
        raise ObjectDatabaseError(f"must not be negative, got {value!r}", source=src, field=fld)
    if ".physics." in fld and key in RANGES:
        problem = RANGES[key].problem(float(value), key)
        if problem:
            raise ObjectDatabaseError(problem, source=src, field=fld)
    return float(value)


def _numbers(value: Any, count: int, src: str, fld: str, *, positive: bool) -> list[float]:
    if not isinstance(value, (list, tuple)) or len(value) != count:
        raise ObjectDatabaseError(f"must be a list of {count} numbers, got {value!r}", source=src, field=fld)
    return [_number(v, src, f"{fld}[{i}]", positive=positive) for i, v in enumerate(value)]


# --- SIE modules ------------------------------------------------------------------------------
def _sie_package(root: Path) -> str:
    """Register the database root as a package so SIE modules can import each other relatively."""
    name = "_bridge_odb_" + hashlib.sha1(str(root.resolve()).encode()).hexdigest()[:10]
    if name not in sys.modules:
        package = pytypes.ModuleType(name)
        package.__path__ = [str(root)]  # type: ignore[attr-defined]
        sys.modules[name] = package
    return name


def load_sie_class(package: str, ref: SIERef) -> type:
    """The class `ref` names. An SIE is any class with ``evaluate(obj, ctx)`` (usually a subclass of
    `bridge.inference.SIE`); the database checks the shape, not the ancestry, so it needs nothing of the
    inference layer above it."""
    name = f"{package}.{ref.module}"
    try:
        module = importlib.import_module(name)
    except ModuleNotFoundError as exc:
        if exc.name is not None and not name.startswith(exc.name):  # the module exists; what it imports does not
            raise ObjectDatabaseError(f"SIE module {ref.module!r} failed to import: {exc}", source=ref.source) from None
        raise ObjectDatabaseError(f"SIE module {ref.module!r} not found ({exc.msg})", source=ref.source) from None
    except Exception as exc:  # the module itself is broken
        raise ObjectDatabaseError(f"SIE module {ref.module!r} failed to import: {type(exc).__name__}: {exc}", source=ref.source) from None
    cls = getattr(module, ref.cls, None)
    if not isinstance(cls, type) or not callable(getattr(cls, "evaluate", None)):
        raise ObjectDatabaseError(f"{ref} is not an SIE class (a class with evaluate(obj, ctx), e.g. a subclass of "
                                  "bridge.inference.SIE)", source=ref.source)
    return cls


def read_types(root: Path, datasets: Mapping[str, Path]) -> tuple[dict[str, ObjectType], str]:
    """Resolve every type under `root`; returns the types and the SIE package name."""
    reader = _Reader(root, datasets)
    return reader.resolve(reader.read_raw()), reader.package


def dataset_names(root: Path) -> set[str]:
    """Datasets referenced by ``dataset://`` mesh paths, found without resolving anything."""
    names: set[str] = set()

    def walk(node: Any) -> None:
        if isinstance(node, str) and node.startswith(DATASET_SCHEME):
            names.add(node[len(DATASET_SCHEME):].split("/", 1)[0])
        elif isinstance(node, dict):
            for value in node.values():
                walk(value)
        elif isinstance(node, list):
            for value in node:
                walk(value)

    for path in (root / "types").rglob("*.yaml"):
        try:
            walk(load_yaml_text(path.read_text(encoding="utf-8", errors="replace")))
        except yaml.YAMLError:
            continue  # read_types reports the file
    return names
