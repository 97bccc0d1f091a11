"""What the object database knows about a type, as frozen values.

The loader (`loader.py`) builds these from YAML after resolving inheritance, so every field here is final:
a subtype's `ObjectType` already carries what it inherited.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

SHAPES = ("box", "cylinder", "sphere", "mesh")


@dataclass(frozen=True)
class Geometry:
    """Collision and visual shape in the object's own frame (origin at the geometric centre for primitives).

    box: `size` = (x, y, z) full lengths; cylinder: (radius, length) along z; sphere: (radius,);
    mesh: `mesh` path (OBJ), scaled by `scale`, `convex` collision hull when True.
    A mesh given as ``dataset://NAME/...`` whose dataset root is unknown has `mesh` None and `unresolved` set.
    `contact` ("prism" | "hull" | "drake") and `footprint_vertices` choose a compliant mesh prism's contact
    geometry for this type (None: the simulator's settings, `SimConfig.mesh_contact` / `footprint_vertices`;
    docs/rollout.md).
    `plane_top` (fixture boxes): the top carries mesh prisms (their soles, sim/prisms.py) as an unbounded plane
    (a Drake `HalfSpace`): for a sheet wider than anything on it travels, whose box faces' triangles would only
    split the contact polygons (docs/rollout.md, "The sheet as a plane").
    """

    shape: str
    size: tuple[float, ...] = ()
    mesh: Path | None = None
    scale: float = 1.0
    convex: bool = True
    unresolved: str | None = None
    color: tuple[float, float, float, float] = (0.6, 0.6, 0.6, 1.0)
    contact: str | None = None
    footprint_vertices: int | None = None
    plane_top: bool = False


@dataclass(frozen=True)
class Physics:
    """Mass properties and contact parameters.

    Exactly one of `mass` and `density` drives the mass; `com` and `inertia` (about the centre of mass,
    [ixx, iyy, izz, ixy, ixz, iyz]) are computed from the geometry when not given.
    """

    mass: float | None = None
    density: float | None = None
    com: tuple[float, float, float] | None = None
    inertia: tuple[float, ...] | None = None
    friction: float = 0.5
    dynamic_friction: float | None = None  # defaults to `friction`
    hydroelastic_modulus: float | None = None  # Pa; None = rigid (or point contact for meshes)
    dissipation: float = 3.0  # Hunt-Crossley dissipation, s/m
    # how well the values above are known (1 sigma), for sampling when no fit or diagnosis says better
    friction_sd: float = 0.15  # relative
    mass_sd: float = 0.05  # relative
    com_sd: float = 0.003  # m, per horizontal axis of the object's frame

    @property
    def mu_dynamic(self) -> float:
        return self.friction if self.dynamic_friction is None else self.dynamic_friction


@dataclass(frozen=True)
class SIERef:
    """Where an SIE lives: ``module:Class`` under the database root, plus keyword parameters."""

    module: str
    cls: str
    params: tuple[tuple[str, Any], ...] = ()
    source: str = ""  # "file: field" for messages
    file: str = ""  # the YAML file that names it ...
    entry: str = ""  # ... and where in it: "<type>.predicates.<predicate>.sie"

    def __str__(self) -> str:
        return f"{self.module}:{self.cls}"


@dataclass(frozen=True)
class PredicateDecl:
    """A predicate a type provides: its PDDL parameter types and which argument is the providing object."""

    name: str
    params: tuple[str, ...]
    subject: int = 0
    sie: SIERef | None = None
    declared_by: str = ""  # the type that first declared the signature

    @property
    def arity(self) -> int:
        return len(self.params)


@dataclass(frozen=True)
class Gripper:
    joints: tuple[str, ...]
    tcp_frame: str
    open_position: float
    closed_position: float
    finger_links: tuple[str, ...] = ()


@dataclass(frozen=True)
class RobotSpec:
    """A robot type's model and how telemetry drives it."""

    model: Path
    base_link: str
    joints: tuple[str, ...]  # every actuated joint, in telemetry order (arm then gripper)
    gripper: Gripper | None = None
    home: tuple[tuple[str, float], ...] = ()
    kp: float = 400.0
    kd: float = 40.0
    joint_types: tuple[tuple[str, str], ...] = ()  # joint -> 'prismatic' | 'revolute' | ..., from the model file
    joint_limits: tuple[tuple[str, float, float], ...] = ()  # joint, lower, upper (rad or m), from the model file
    links: tuple[str, ...] = ()  # the model's links, from its file (empty when the file includes other models)
    contact_links: tuple[str, ...] = ()  # those with collision geometry: what a contact parameter may target
    link_friction: tuple[tuple[str, float], ...] = ()  # (link, dynamic coefficient) where the model file gives one

    @property
    def joint_type(self) -> dict[str, str]:
        return dict(self.joint_types)

    @property
    def limits(self) -> dict[str, tuple[float, float]]:
        """Each joint's position limits (-inf, inf where the model gives none)."""
        return {j: (lo, hi) for j, lo, hi in self.joint_limits}

    def home_positions(self) -> dict[str, float]:
        base = {j: 0.0 for j in self.joints}
        base.update(dict(self.home))
        return base


@dataclass(frozen=True)
class ObjectType:
    name: str
    parent: str | None
    pddl_type: str
    ancestors: tuple[str, ...]  # self first, then parent, ..., root
    source: Path
    abstract: bool = False
    fixed: bool = False  # welded to the world (tables, shelves)
    geometry: Geometry | None = None
    physics: Physics = field(default_factory=Physics)
    predicates: Mapping[str, PredicateDecl] = field(default_factory=dict)
    robot: RobotSpec | None = None

    def is_a(self, type_name: str) -> bool:
        return type_name in self.ancestors

    @property
    def is_robot(self) -> bool:
        return self.robot is not None
