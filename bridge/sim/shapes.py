"""Drake shapes of object types and their mass properties (Drake's CalcSpatialInertia, uniform density), as the
paper takes them from meshes. What the object database leaves out (mass from density, centre of mass, inertia)
comes from here, computed once per object database and type."""
from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np
from pydrake.geometry import Box, Convex, Cylinder, Mesh, Sphere
from pydrake.multibody.tree import CalcSpatialInertia

from ..errors import ObjectDatabaseError
from ..odb import ObjectDatabase, ObjectType


@dataclass(frozen=True, eq=False)
class MassProperties:
    mass: float
    com: np.ndarray  # (3,), object frame
    inertia: np.ndarray  # (3, 3) about the centre of mass, object frame


_CACHE: "weakref.WeakKeyDictionary[ObjectDatabase, dict[str, MassProperties]]" = weakref.WeakKeyDictionary()


def drake_shape(obj_type: ObjectType):
    """The pydrake Shape for a type's geometry."""
    g = obj_type.geometry
    if g is None:
        raise ObjectDatabaseError("has no geometry", source=str(obj_type.source), field=obj_type.name)
    if g.shape == "box":
        return Box(*g.size)
    if g.shape == "cylinder":
        return Cylinder(g.size[0], g.size[1])
    if g.shape == "sphere":
        return Sphere(g.size[0])
    if g.mesh is None:
        name = g.unresolved.split("://", 1)[1].split("/", 1)[0] if g.unresolved else "?"
        raise ObjectDatabaseError(
            f"mesh {g.unresolved} needs the dataset {name!r}: pass --dataset {name}=PATH or set "
            f"BRIDGE_DATASET_{name.upper().replace('-', '_')}", source=str(obj_type.source),
            field=f"{obj_type.name}.geometry.mesh")
    return Convex(str(g.mesh), g.scale) if g.convex else Mesh(str(g.mesh), g.scale)


def mass_properties(odb: ObjectDatabase, type_name: str) -> MassProperties:
    """Mass, centre of mass and inertia of a type; what its YAML leaves out comes from the geometry."""
    per_odb = _CACHE.setdefault(odb, {})
    if type_name not in per_odb:
        per_odb[type_name] = _compute(odb.get(type_name))
    return per_odb[type_name]


def _compute(obj_type: ObjectType) -> MassProperties:
    phys = obj_type.physics
    where = dict(source=str(obj_type.source), field=f"{obj_type.name}.physics")
    if obj_type.geometry is None:
        raise ObjectDatabaseError("mass properties need a geometry", **where)
    try:
        unit = CalcSpatialInertia(drake_shape(obj_type), 1.0)  # mass == volume at unit density
    except RuntimeError as exc:  # Drake's own reading of a mesh: say which file
        mesh = obj_type.geometry.mesh
        raise ObjectDatabaseError(f"Drake cannot compute the volume of {f'mesh {mesh}' if mesh else 'the shape'}: "
                                  f"{str(exc).splitlines()[0] if str(exc) else type(exc).__name__}",
                                  source=str(obj_type.source), field=f"{obj_type.name}.geometry") from None
    volume = unit.get_mass()
    if volume <= 0:
        raise ObjectDatabaseError("geometry has no volume (is the mesh closed?)", **where)
    if phys.mass is not None:
        mass = phys.mass
    elif phys.density is not None:
        mass = phys.density * volume
    else:
        raise ObjectDatabaseError("needs mass or density", **where)
    geometric_com = np.array(unit.get_com())
    com = np.array(phys.com) if phys.com is not None else geometric_com
    if phys.inertia is not None:
        ixx, iyy, izz, ixy, ixz, iyz = phys.inertia
        inertia = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    else:
        # unit-density inertia about the geometric centroid, scaled to the mass
        about_com = unit.Shift(geometric_com).CalcRotationalInertia().CopyToFullMatrix3()
        inertia = about_com * (mass / volume)
    return MassProperties(mass, com, inertia)
