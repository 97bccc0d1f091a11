"""Build the Drake diagram of a world state: table and objects from the object database, the robot tracking
telemetry through PD-controlled actuators.

The diagram is built once per scene *structure* (which objects, of which types, where the fixtures stand, which
robot, which extras): initial poses and scene values (friction, contact stiffness, mass, centre of mass,
external forces) are written into a fresh context for every replay (`Scene.new_context`), the robot's desired
trajectory into the diagram's source at the replay's start (`Scene.set_desired`, `sources`), so a fit never
rebuilds the diagram; one diagram serves one replay at a time.
"""
from __future__ import annotations

import logging
import re
from collections import OrderedDict
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np
from pydrake.geometry import (
    AddCompliantHydroelasticProperties,
    AddContactMaterial,
    AddRigidHydroelasticProperties,
    ProximityProperties,
    RoleAssign,
)
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlant, CoulombFriction, MultibodyPlantConfig
from pydrake.multibody.tree import BodyIndex, SpatialInertia, UnitInertia
from pydrake.systems.framework import DiagramBuilder

from ..errors import SceneError
from ..odb import ObjectDatabase, ObjectType
from ..values import Pose
from ..world import WorldState
from .extras import ObjectScale
from .shapes import check_shape, drake_shape, mass_properties, scaled_type
from .sources import ConstantForces, desired_state_source, set_desired
from .support import SupportPressure


class _FloorNotice(logging.Filter):
    """Drops Drake's notice that the floor's half space takes no part in deformable contact (there is none here);
    it is printed for every context otherwise."""

    def filter(self, record: logging.LogRecord) -> bool:
        return "half spaces are not currently supported for deformable contact" not in record.getMessage()


logging.getLogger("drake").addFilter(_FloorNotice())


@dataclass(frozen=True)
class SimConfig:
    """Simulator settings. The defaults were probed on this project's scenes (README, "Simulation defaults";
    docs/speed.md, "Simulator settings against the session")."""

    time_step: float = 0.002
    contact_model: str = "hydroelastic_with_fallback"
    discrete_contact_approximation: str = "lagged"
    resolution_hint: float = 0.01  # m, hydroelastic mesh resolution for compliant primitives
    robot_modulus: float = 1.0e7  # Pa, robot links' compliance (fingers need it to grasp)
    # compliant mesh prisms (an outline extruded along z): "prism" = the exact outline against the robot and other
    # objects, a footprint of at most `footprint_vertices` vertices fanned from its centre against what carries
    # them (fixtures, the floor); "drake" = the mesh as Drake takes it (a compliant .obj becomes its convex hull).
    # A type's `geometry.contact` / `footprint_vertices` override these (docs/rollout.md, sim/prisms.py)
    mesh_contact: str = "prism"
    footprint_vertices: int = 16


@dataclass(frozen=True)
class ObjectValues:
    """Per-object values written into a context. None keeps the object database's value.

    `spread` says where a changed mass sits: 1 (the default) spread like the object's own (uniform density: the
    rotational inertia scales with the mass), 0 at the centre of mass (a compact weight: the inertia stays);
    the inertia about the centre of mass is the database's times 1 + spread (mass / database mass - 1).
    """

    friction: float | None = None
    dynamic_friction: float | None = None
    hydroelastic_modulus: float | None = None
    dissipation: float | None = None
    mass: float | None = None
    com: tuple[float, float, float] | None = None
    spread: float | None = None

    def merged(self, other: "ObjectValues") -> "ObjectValues":
        """`other`'s values where it has them, these elsewhere."""
        return replace(self, **{k: v for k, v in vars(other).items() if v is not None})


@dataclass(frozen=True)
class SceneValues:
    """Everything a replay may vary without rebuilding the diagram."""

    objects: Mapping[str, ObjectValues] = field(default_factory=dict)
    external_forces: Mapping[str, tuple[float, float, float]] = field(default_factory=dict)  # N, world frame, at the COM

    def with_object(self, name: str, **changes: float | tuple | None) -> "SceneValues":
        objects = dict(self.objects)
        objects[name] = replace(objects.get(name, ObjectValues()), **changes)
        return replace(self, objects=objects)

    def with_force(self, name: str, force: tuple[float, float, float]) -> "SceneValues":
        forces = dict(self.external_forces)
        forces[name] = tuple(float(f) for f in force)
        return replace(self, external_forces=forces)


VALUED_CONTEXTS = 8  # per scene (`Scene.new_context`): about 0.6 MB each for an MIT shape


def _values_key(values: SceneValues) -> tuple:
    """A hashable key equal for equal values (floats exactly)."""
    def plain(v):
        return None if v is None else tuple(float(x) for x in np.ravel(v))
    objects = tuple(sorted((name, tuple(plain(getattr(p, f.name)) for f in fields(p)))
                           for name, p in values.objects.items()))
    return objects, tuple(sorted((name, plain(f)) for name, f in values.external_forces.items()))


def to_drake(pose: Pose) -> RigidTransform:
    w, x, y, z = pose.quat
    from pydrake.common.eigen_geometry import Quaternion

    return RigidTransform(Quaternion(w, x, y, z), np.asarray(pose.xyz))


def from_drake(X: RigidTransform) -> Pose:
    q = X.rotation().ToQuaternion()
    return Pose(tuple(X.translation()), (q.w(), q.x(), q.y(), q.z()))


def proximity(obj_type: ObjectType, config: SimConfig, values: ObjectValues | None = None) -> ProximityProperties:
    phys = obj_type.physics
    values = values or ObjectValues()
    mu_s = values.friction if values.friction is not None else phys.friction
    mu_d = values.dynamic_friction if values.dynamic_friction is not None else (
        mu_s if values.friction is not None else phys.mu_dynamic)
    props = ProximityProperties()
    AddContactMaterial(
        dissipation=values.dissipation if values.dissipation is not None else phys.dissipation,
        friction=CoulombFriction(mu_s, min(mu_d, mu_s)), properties=props)
    modulus = values.hydroelastic_modulus if values.hydroelastic_modulus is not None else phys.hydroelastic_modulus
    if modulus is not None:
        AddCompliantHydroelasticProperties(config.resolution_hint, modulus, props)
    elif obj_type.fixed:  # rigid fixtures against compliant objects: cheaper than compliant-compliant, same motion
        AddRigidHydroelasticProperties(config.resolution_hint, props)
    return props


@dataclass
class Scene:
    """A built diagram and the handles a replay needs. Build with `build_scene`."""

    world: WorldState
    odb: ObjectDatabase
    config: SimConfig
    diagram: object
    plant: object
    scene_graph: object
    bodies: dict[str, object]  # free objects' bodies
    geometries: dict[str, list]  # object name -> collision geometry ids (free and fixed)
    robot_instance: object | None
    robot_joints: tuple[str, ...]
    desired_source: "TrajectorySource | None"  # the robot's desired state (`sources.set_desired`)
    force_source: "ConstantForces | None"
    body_names: dict[object, str]  # BodyIndex -> 'box' or 'robot/link'
    footprints: dict[str, tuple] = field(default_factory=dict)  # object -> (outline ids, footprint id, sole id
    #                                                              or None): `filter_footprints`
    visualized: bool = False  # a Meshcat visualizer publishes from the diagram
    # contexts with values written in and nothing else changed, by the values (`new_context`), least recently
    # used first; never simulated, only cloned
    valued: "OrderedDict[tuple, object]" = field(default_factory=OrderedDict, repr=False)

    # --- contexts -------------------------------------------------------------------------------
    def new_context(self, world: WorldState | None = None, values: SceneValues | None = None):
        """A fresh context with the world's initial poses and robot joints, and `values` written in.

        Writing contact values costs 4 ms per geometry (Drake rebuilds its hydroelastic representation on
        `AssignRole`; 13 ms for a mesh prism with its footprint and sole), a tenth of a short push's replay, and
        a fit replays every recording of a scene with the same values: the context with the values written is
        kept (VALUED_CONTEXTS of them) and cloned (0.6 ms). Poses and joints are set on the clone; values do not
        depend on them."""
        world = world or self.world
        values = values or SceneValues()
        key = _values_key(values)
        base = self.valued.get(key)
        if base is None:
            base = self.diagram.CreateDefaultContext()
            self.apply_values(base, values)
            self.valued[key] = base
            while len(self.valued) > VALUED_CONTEXTS:
                self.valued.popitem(last=False)
        else:
            self.valued.move_to_end(key)
        context = base.Clone()
        plant_ctx = self.plant.GetMyMutableContextFromRoot(context)
        for name, body in self.bodies.items():
            self.plant.SetFreeBodyPose(plant_ctx, body, to_drake(world.objects[name].pose))
        if self.robot_instance is not None and world.robot is not None:
            self.plant.SetPositions(plant_ctx, self.robot_instance, self.robot_positions(world.robot.joint_positions()))
        return context

    def robot_positions(self, joints: Mapping[str, float]) -> np.ndarray:
        """Joint values (by name) in the plant's position order of the robot instance."""
        q = np.zeros(self.plant.num_positions(self.robot_instance))
        offset = self.robot_q0()
        for name, value in joints.items():
            q[self.plant.GetJointByName(name, self.robot_instance).position_start() - offset] = value
        return q

    def robot_q0(self) -> int:
        """The plant position index of the robot's first joint."""
        starts = [self.plant.get_joint(j).position_start() for j in self.plant.GetJointIndices(self.robot_instance)
                  if self.plant.get_joint(j).num_positions() > 0]
        return min(starts)

    def actuator_columns(self, joint_names: Sequence[str]) -> np.ndarray:
        """For each actuator of the robot (desired-state order), the column of that joint in `joint_names`."""
        index = {n: i for i, n in enumerate(joint_names)}
        columns = []
        for a in self.plant.GetJointActuatorIndices(self.robot_instance):
            joint = self.plant.get_joint_actuator(a).joint().name()
            if joint not in index:
                raise SceneError(f"telemetry has no column for the actuated joint {joint!r}")
            columns.append(index[joint])
        return np.asarray(columns)

    def set_desired(self, context, times: np.ndarray, positions: np.ndarray) -> None:
        """Make the robot track `positions` (rows: samples, columns: actuators in desired-state order) in the
        replay of `context`, the next to run on this scene (first-order hold; see `sources.set_desired`)."""
        set_desired(self.desired_source, context, times, positions)

    def actuated_joints(self) -> list:
        """The robot's actuated joints, in desired-state order."""
        return [self.plant.get_joint_actuator(a).joint() for a in self.plant.GetJointActuatorIndices(self.robot_instance)]

    def apply_values(self, context, values: SceneValues) -> None:
        plant_ctx = self.plant.GetMyMutableContextFromRoot(context)
        sg_ctx = self.scene_graph.GetMyMutableContextFromRoot(context)
        for name, p in values.objects.items():
            if name not in self.geometries and name in self.link_geometries():
                self._apply_link_values(sg_ctx, name, p)
                continue
            if name not in self.geometries:
                links = ", ".join(sorted(self.link_geometries()))
                raise SceneError(f"unknown object {name!r}; objects: {', '.join(sorted(self.geometries))}"
                                 + (f"; robot links with collision geometry: {links}" if links else ""), field="values")
            obj_type = self.odb.get(self.world.objects[name].type)
            if any(v is not None for v in (p.friction, p.dynamic_friction, p.hydroelastic_modulus, p.dissipation)):
                props = proximity(obj_type, self.config, p)
                for gid in self.geometries[name]:
                    self.scene_graph.AssignRole(sg_ctx, self.plant.get_source_id(), gid, props, RoleAssign.kReplace)
            if p.mass is not None or p.com is not None or p.spread is not None:
                if name not in self.bodies:
                    raise SceneError(f"{name!r} is a fixture: it has no mass to change, only contact values",
                                     field="values")
                body = self.bodies[name]
                mp = mass_properties(self.odb, obj_type.name)
                mass = p.mass if p.mass is not None else mp.mass
                com = np.asarray(p.com if p.com is not None else mp.com, dtype=float)
                spread = 1.0 if p.spread is None else p.spread
                I_com = mp.inertia * max(0.05, 1.0 + spread * (mass / mp.mass - 1.0))
                G = UnitInertia(*(np.diag(I_com) / mass), *(I_com[[0, 0, 1], [1, 2, 2]] / mass))
                M_com = SpatialInertia(mass, np.zeros(3), G)
                body.SetSpatialInertiaInBodyFrame(plant_ctx, M_com.Shift(-com))
        pushed = sorted(set(values.external_forces) - set(self.bodies))
        if pushed:
            raise SceneError(f"an external force on {pushed[0]!r}, which is no free object; free objects: "
                             f"{', '.join(sorted(self.bodies)) or 'none'}", field="values")
        if self.force_source is not None:  # at the centre of mass the values give, where they move it
            points = {n: p.com for n, p in values.objects.items() if p.com is not None and n in self.bodies}
            self.force_source.set_forces(self.force_source.GetMyMutableContextFromRoot(context), values.external_forces,
                                         points)

    def link_geometries(self) -> dict[str, list]:
        """Collision geometries of the robot's links by 'robot/link' name (the names contacts use)."""
        found: dict[str, list] = {}
        for index, name in self.body_names.items():
            if name not in self.bodies:
                gids = self.plant.GetCollisionGeometriesForBody(self.plant.get_body(index))
                if gids:
                    found[name] = list(gids)
        return found

    def _apply_link_values(self, sg_ctx, name: str, p: ObjectValues) -> None:
        """Friction and dissipation of a robot link, on top of its model's contact properties."""
        if any(v is not None for v in (p.hydroelastic_modulus, p.mass, p.com, p.spread)):
            raise SceneError(f"robot link {name!r}: only friction, dynamic_friction and dissipation can be set",
                             field="values")
        inspector = self.scene_graph.model_inspector()
        for gid in self.link_geometries()[name]:
            props = ProximityProperties(inspector.GetProximityProperties(gid))
            old = props.GetPropertyOrDefault("material", "coulomb_friction", CoulombFriction(0.5, 0.5))
            mu_s = p.friction if p.friction is not None else old.static_friction()
            mu_d = p.dynamic_friction if p.dynamic_friction is not None else (
                mu_s if p.friction is not None else old.dynamic_friction())
            props.UpdateProperty("material", "coulomb_friction", CoulombFriction(mu_s, min(mu_d, mu_s)))
            if p.dissipation is not None:
                props.UpdateProperty("material", "hunt_crossley_dissipation", float(p.dissipation))
            self.scene_graph.AssignRole(sg_ctx, self.plant.get_source_id(), gid, props, RoleAssign.kReplace)


def _spatial_inertia(odb: ObjectDatabase, type_name: str, scale: float = 1.0, lift: float = 0.0) -> SpatialInertia:
    """The type's mass properties about the body origin; of its geometry `scale` times as large and raised by
    `lift` (`shapes.scaled_type`): the same mass, the centre of mass moved with the geometry, the inertia about
    it times scale^2."""
    mp = mass_properties(odb, type_name)
    I = mp.inertia * scale ** 2
    G = UnitInertia(I[0, 0] / mp.mass, I[1, 1] / mp.mass, I[2, 2] / mp.mass,
                    I[0, 1] / mp.mass, I[0, 2] / mp.mass, I[1, 2] / mp.mass)
    com = scale * np.asarray(mp.com) + np.array([0.0, 0.0, lift])
    return SpatialInertia(mp.mass, np.zeros(3), G).Shift(-com)  # about the body origin


def add_object(plant, name: str, obj_type: ObjectType, pose: Pose, odb: ObjectDatabase, config: SimConfig,
               footprints: dict | None = None, support=None, scale: float = 1.0, planes: dict | None = None):
    """A free body (or anchored geometry for fixtures) with collision and visual geometry. A compliant mesh prism
    gets its outline and, when it has more vertices than the footprint may, a footprint as a second collision
    geometry (`contact_shapes`); so does any free object resting on a `support` (`sim/support.py`);
    `footprints[name]` then says which is which, for `filter_footprints`. A free object's geometry may be
    `scale` times its type's (`extras.ObjectScale`). A fixture box whose type says `plane_top` gets its top as
    a `HalfSpace` beside the box (`planes[name]` = (box id, plane id)): the plane carries the mesh prisms' soles,
    the box everything else (`filter_footprints`)."""
    g = obj_type.geometry
    if g is None:
        raise SceneError(f"object {name!r} of type {obj_type.name!r} has no geometry", source=str(obj_type.source))
    if obj_type.fixed:  # a mesh Drake cannot read names the type (a free body's does in mass_properties)
        check_shape(obj_type)
    if obj_type.fixed:
        body, X_BG = plant.world_body(), to_drake(pose)
    else:
        lift = 0.0
        if scale != 1.0:
            obj_type, lift = scaled_type(obj_type, scale)
        body = plant.AddRigidBody(name, _spatial_inertia(odb, obj_type.name, scale, lift))
        X_BG = RigidTransform([0.0, 0.0, lift])
    shape = drake_shape(obj_type)
    props = proximity(obj_type, config)
    outline, footprint, sole = contact_shapes(obj_type, config, support) if not obj_type.fixed else (shape, None, None)
    gid = plant.RegisterCollisionGeometry(body, X_BG, outline, f"{name}/collision", props)
    gids = [gid]
    if obj_type.fixed and g.plane_top:
        from pydrake.geometry import HalfSpace

        top = X_BG @ RigidTransform([0.0, 0.0, g.size[2] / 2])  # the half-space's boundary: its frame's z = 0
        pid = plant.RegisterCollisionGeometry(body, top, HalfSpace(), f"{name}/plane", props)
        gids.append(pid)
        if planes is not None:
            planes[name] = (gid, pid)
    if footprint is not None:
        fid = plant.RegisterCollisionGeometry(body, X_BG, footprint, f"{name}/footprint", props)
        gids.append(fid)
        sid = None
        if sole is not None:
            sid = plant.RegisterCollisionGeometry(body, X_BG, sole, f"{name}/sole", props)
            gids.append(sid)
        if footprints is not None:
            footprints[name] = ((gid,), fid, sid)
    plant.RegisterVisualGeometry(body, X_BG, shape, f"{name}/visual", np.array(g.color))
    return (None if obj_type.fixed else body), gids


def contact_mode(obj_type: ObjectType, config: SimConfig) -> tuple[str, int]:
    """The contact representation of a type's mesh and its footprint's vertex limit: the type's own
    (`geometry.contact`, `geometry.footprint_vertices`) or the simulator's."""
    from .prisms import MODES

    g = obj_type.geometry
    mode = g.contact or config.mesh_contact
    vertices = g.footprint_vertices or config.footprint_vertices
    if mode not in MODES:
        raise SceneError(f"mesh_contact {mode!r} is not one of {', '.join(MODES)}", field="config.mesh_contact")
    if not isinstance(vertices, int) or vertices < 3:
        raise SceneError(f"footprint_vertices must be a whole number >= 3, got {vertices!r}",
                         field="config.footprint_vertices")
    return mode, vertices


def contact_shapes(obj_type: ObjectType, config: SimConfig, support=None):
    """(outline, footprint or None, sole or None): the collision shapes of a free object. Only compliant mesh
    prisms differ from `drake_shape` (modes "prism" and "hull", sim/prisms.py): a convex outline keeps Drake's
    `Convex` of the file, a non-convex one (`convex: false`) becomes a tetrahedral mesh of its own, or in mode
    "hull" its convex hull (Drake's `Convex`: the object a simulator that takes every mesh as its hull pushes); a
    footprint (at most `footprint_vertices` vertices, the outline's (or hull's) area and centroid, fanned from its
    centre) is added when the outline has more, and a sole, the pyramid over the footprint
    (`prisms.sole_tetrahedra`), for a plane top to carry (`filter_footprints`). A `support` (`sim/support.py`)
    replaces the footprint by the one it describes, for any flat-bottomed object, and the sole by its pyramid where
    the object has a footprint of its own."""
    from .prisms import centroid, contact_outlines, is_star, mesh_prism, prism_mesh
    from .support import support_polygon

    g = obj_type.geometry
    shape = drake_shape(obj_type)
    mode, vertices = contact_mode(obj_type, config)
    prism = mesh_prism(g.mesh, g.scale) if g.shape == "mesh" and mode != "drake" else None
    exact, poly, name = shape, None, f"{obj_type.name}_footprint"
    own = False  # the object has a footprint of its own: a plane top carries it, or its support's
    if prism is not None and obj_type.physics.hydroelastic_modulus is not None:
        outline, footprint = contact_outlines(g.mesh, g.scale, g.convex or mode == "hull", vertices)
        if outline is not None:
            exact = prism_mesh(outline, prism.z0, prism.z1, f"{obj_type.name}_outline")
        if footprint is not None:
            own, poly, z0, z1 = True, footprint, prism.z0, prism.z1
    if support is not None:
        poly, z0, z1 = support_polygon(obj_type, support, vertices, mode == "hull")
        name = f"{obj_type.name}_support"
    if poly is None:
        return exact, None, None
    # the pyramid needs a polygon star-shaped from its centroid; another (a non-convex outline simplified) is its
    # own sole, a prism
    sole = prism_mesh(poly, z0, z1, f"{name}_sole", sole=is_star(poly, centroid(poly))) if own else None
    return exact, prism_mesh(poly, z0, z1, name), sole


def filter_footprints(plant, scene_graph, footprints: dict, planes: dict | None = None) -> None:
    """Each object's outline touches only what moves (the robot, other objects), its footprint only what is
    anchored (fixtures, the floor, geometry welded to the world): one support contact, not two. A fixture's
    plane top (`planes`: name -> (box id, plane id)) touches only the soles (`footprints`: name -> (outline ids,
    footprint id, sole id or None)), and a sole only the plane tops, where the footprint does not meet their
    boxes: posts and other fixtures meet the footprint's upright sides, not the sole's sloping ones. After
    Finalize."""
    from pydrake.geometry import CollisionFilterDeclaration, GeometrySet

    planes = planes or {}
    if not footprints and not planes:
        return
    anchored_bodies = {b.index() for b in plant.GetBodiesWeldedTo(plant.world_body())} | {plant.world_body().index()}
    anchored, moving = [], []
    for i in range(plant.num_bodies()):
        body = plant.get_body(BodyIndex(i))
        (anchored if body.index() in anchored_bodies else moving).extend(plant.GetCollisionGeometriesForBody(body))
    manager = scene_graph.collision_filter_manager()

    def exclude(a: list, b: list) -> None:
        if a and b:
            manager.Apply(CollisionFilterDeclaration().ExcludeBetween(GeometrySet(a), GeometrySet(b)))
    boxes, plane_ids = [b for b, _ in planes.values()], [p for _, p in planes.values()]
    soles = [s for *_, s in footprints.values() if s is not None]
    for outline, footprint, sole in footprints.values():
        exclude(list(outline), anchored)
        exclude([footprint], [g for g in moving if g != footprint] + (boxes if sole is not None else []))
        if sole is not None:
            exclude([sole], [g for g in moving + anchored if g != sole and g not in plane_ids])
    exclude(plane_ids, [g for g in moving if g not in soles])


def floor_height(world: WorldState, odb: ObjectDatabase) -> float:
    """z of the floor: 0, or the bottom of the lowest fixture when one reaches below 0 (a push surface whose
    top is at z = 0), so the floor never shares a plane with a fixture's top and touches objects on it."""
    from ..odb.geometry import z_range

    bottoms = [z_range(odb.get(o.type).geometry, o.pose)[0] for o in world.objects.values()
               if odb.get(o.type).fixed and odb.get(o.type).geometry is not None]
    return min([0.0, *bottoms])


def add_floor(plant, config: SimConfig, height: float = 0.0) -> None:
    """A floor at z = `height` so an object pushed off the table lands instead of falling forever."""
    from pydrake.geometry import AddCompliantHydroelasticPropertiesForHalfSpace, HalfSpace

    props = ProximityProperties()
    AddContactMaterial(dissipation=3.0, friction=CoulombFriction(0.6, 0.5), properties=props)
    AddCompliantHydroelasticPropertiesForHalfSpace(0.1, 1.0e7, props)
    plant.RegisterCollisionGeometry(plant.world_body(), RigidTransform([0.0, 0.0, height]), HalfSpace(), "floor",
                                    props)


# a model that names another file (a mesh, an included model, a package) is parsed from its file, where Drake
# resolves those names against the file's folder
_NAMES_FILES = re.compile(r"<uri|<include|filename\s*=|package://|file://|model://")
_TEXT_NAME = re.compile(r"<(?:data|literal)-string>(?:\.\w+)?")  # what Drake calls a model parsed from text


def add_models(parser: Parser, path: str | Path) -> list:
    """`parser.AddModels(path)`, 50 times faster for a self-contained SDF or URDF. Drake fact (1.51): parsing an
    SDFormat *file* rebuilds libsdformat's whole schema (`sdf::init`) on every call, 25-33 ms for the 3 kB
    pusher2d.sdf; the same text parsed from a string takes 0.4 ms after the first in a process. A diagnosis
    builds a scene for every new structure (a tilt, a post, a patch: about a thousand on 8 real ellip3 pushes),
    so this was 4 % of its CPU."""
    path = Path(path)
    suffix = path.suffix.lower().lstrip(".")
    if suffix in ("sdf", "urdf"):
        try:
            text = path.read_text()
        except (OSError, UnicodeDecodeError):
            text = None  # Drake says what is wrong with the file
        if text is not None and not _NAMES_FILES.search(text):
            try:
                return parser.AddModelsFromString(text, suffix)
            except RuntimeError as exc:  # Drake calls the text "<data-string>": the file, as AddModels would say
                raise RuntimeError(_TEXT_NAME.sub(str(path), str(exc))) from None
    return parser.AddModels(str(path))


def add_robot(plant, world: WorldState, odb: ObjectDatabase):
    robot_type = odb.get(world.robot.type)
    spec = robot_type.robot
    parser = Parser(plant, world.robot.name)
    try:
        (instance,) = add_models(parser, spec.model)
    except Exception as exc:  # named by the database's entry, as `bridge check` names it (`checks.check_type`)
        raise SceneError(f"cannot load robot model {spec.model}: {str(exc).splitlines()[0] if str(exc) else exc!r}",
                         source=str(robot_type.source), field=f"{robot_type.name}.robot.model") from None
    try:
        base = plant.GetBodyByName(spec.base_link, instance)
    except Exception:
        raise SceneError(f"robot model has no link {spec.base_link!r} (robot.base_link)", source=str(spec.model)) from None
    plant.WeldFrames(plant.world_frame(), base.body_frame(), to_drake(world.robot.base_pose))
    for joint in spec.joints:
        if not plant.HasJointNamed(joint, instance):
            raise SceneError(f"robot model has no joint {joint!r} listed in the object database", source=str(spec.model))
    return instance, spec


def _slip_friction(builder, plant, world: WorldState, odb: ObjectDatabase, config: SimConfig, bodies: dict,
                   extras: Sequence):
    """The system adding anisotropic friction, friction fields and rate-dependent friction (`sim/anisotropy.py`) for
    the extras that ask for them, or None."""
    from .anisotropy import SlipExtra, SlipFriction, footprint_points
    from .support import bottom_polygon

    wanted = [e for e in extras if isinstance(e, SlipExtra)]
    if not wanted:
        return None
    entries = []
    for extra in wanted:
        obj_type = odb.get(world.objects[extra.object].type)
        mode, vertices = contact_mode(obj_type, config)
        polygon, z0, _ = bottom_polygon(obj_type, vertices, mode == "hull")
        points, weights = footprint_points(polygon)
        entries.append((extra, bodies[extra.object], points, weights, z0))
    slip = builder.AddSystem(SlipFriction(plant, entries))
    builder.Connect(plant.get_state_output_port(), slip.get_input_port(0))
    return slip


def build_scene(world: WorldState, odb: ObjectDatabase, config: SimConfig = SimConfig(),
                extras: Sequence = (), meshcat=None) -> Scene:
    """Assemble the diagram in a fixed order: plant and scene graph, objects, robot, extras, sources. Drake's own
    failures while building (a mesh it cannot read, a geometry it cannot make hydroelastic) become one
    `SceneError` naming what was being built."""
    try:
        return _build(world, odb, config, extras, meshcat)
    except RuntimeError as exc:
        what = f"world {world.name!r}" + (f" with extras {', '.join(type(e).__name__ for e in extras)}" if extras else "")
        raise SceneError(f"Drake cannot build the scene of {what}: {str(exc).splitlines()[0]}") from None


def _build(world: WorldState, odb: ObjectDatabase, config: SimConfig, extras: Sequence, meshcat) -> Scene:
    builder = DiagramBuilder()
    plant_config = MultibodyPlantConfig(
        time_step=config.time_step, contact_model=config.contact_model,
        discrete_contact_approximation=config.discrete_contact_approximation)
    plant, scene_graph = AddMultibodyPlant(plant_config, builder)
    bodies, geometries, footprints, planes = {}, {}, {}, {}
    supports = {e.object: e for e in extras if isinstance(e, SupportPressure)}
    scales = {e.object: e.scale for e in extras if isinstance(e, ObjectScale)}
    for name, obj in world.objects.items():
        body, gids = add_object(plant, name, odb.get(obj.type), obj.pose, odb, config, footprints, supports.get(name),
                                scales.get(name, 1.0), planes)
        geometries[name] = gids
        if body is not None:
            bodies[name] = body
    instance, joints = None, ()
    if world.robot is not None:
        instance, spec = add_robot(plant, world, odb)
        joints = spec.joints
    add_floor(plant, config, floor_height(world, odb))
    for extra in extras:
        extra.add_to(plant, world, odb, config)
    plant.Finalize()
    filter_footprints(plant, scene_graph, footprints, planes)
    body_names = {b.index(): n for n, b in bodies.items()}
    if instance is not None:
        for index in plant.GetBodyIndices(instance):
            body_names[index] = f"{world.robot.name}/{plant.get_body(index).name()}"
    desired = forces = None
    if instance is not None and plant.num_actuated_dofs(instance) > 0:
        desired = builder.AddSystem(desired_state_source(plant.num_actuated_dofs(instance)))
        builder.Connect(desired.get_output_port(), plant.get_desired_state_input_port(instance))
    if bodies:
        forces = builder.AddSystem(ConstantForces(list(bodies.items())))
        slip = _slip_friction(builder, plant, world, odb, config, bodies, extras)
        if slip is None:
            builder.Connect(forces.get_output_port(), plant.get_applied_spatial_force_input_port())
        else:  # Drake fact: one applied-force input port; several sources meet in a multiplexer
            from pydrake.multibody.plant import ExternallyAppliedSpatialForceMultiplexer

            mux = builder.AddSystem(ExternallyAppliedSpatialForceMultiplexer(2))
            builder.Connect(forces.get_output_port(), mux.get_input_port(0))
            builder.Connect(slip.get_output_port(), mux.get_input_port(1))
            builder.Connect(mux.get_output_port(), plant.get_applied_spatial_force_input_port())
    if meshcat is not None:
        from pydrake.geometry import MeshcatVisualizer, MeshcatVisualizerParams

        MeshcatVisualizer.AddToBuilder(builder, scene_graph, meshcat, MeshcatVisualizerParams(publish_period=1 / 30))
    diagram = builder.Build()
    return Scene(world, odb, config, diagram, plant, scene_graph, bodies, geometries, instance, joints,
                 desired, forces, body_names, footprints, meshcat is not None)
