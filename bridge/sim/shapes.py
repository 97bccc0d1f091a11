"""Drake shapes of object types and their mass properties (Drake's CalcSpatialInertia, uniform density), as the
paper takes them from meshes. What the object database leaves out (mass from density, centre of mass, inertia)
comes from here, computed once per object database and type."""
from __future__ import annotations

import logging
import re
import weakref
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
from pydrake.geometry import Box, Convex, Cylinder, Mesh, Sphere
from pydrake.multibody.tree import CalcSpatialInertia, RotationalInertia, SpatialInertia, UnitInertia

from ..errors import ObjectDatabaseError
from ..odb import ObjectDatabase, ObjectType
from ..odb.loader import dataset_env_names


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
            f"{dataset_env_names(name)[1]}", source=str(obj_type.source),
            field=f"{obj_type.name}.geometry.mesh")
    return Convex(str(g.mesh), g.scale) if g.convex else Mesh(str(g.mesh), g.scale)


def mass_properties(odb: ObjectDatabase, type_name: str) -> MassProperties:
    """Mass, centre of mass and inertia of a type; what its YAML leaves out comes from the geometry. Values no
    body can have (an inertia that breaks the triangle inequality, a mesh Drake cannot read or whose volume or
    inertia is degenerate) are an `ObjectDatabaseError` naming the file and the type's field, here rather than
    as Drake's error when a scene is built."""
    per_odb = _CACHE.setdefault(odb, {})
    if type_name not in per_odb:
        per_odb[type_name] = _compute(odb.get(type_name))
    return per_odb[type_name]


def check_shape(obj_type: ObjectType) -> None:
    """That Drake can read a type's mesh (a fixture's: it has no mass properties to compute); primitives always."""
    g = obj_type.geometry
    if g is not None and g.shape == "mesh":
        with _drake_log(obj_type):
            drake_shape(obj_type).GetConvexHull()


@contextmanager
def _drake_log(obj_type: ObjectType):
    """Runs Drake on a type's geometry: what Drake logs (a warning per bad line of an OBJ file) is kept back, and
    an error becomes an `ObjectDatabaseError` naming the type's mesh, with the first warning as the reason."""
    logger = logging.getLogger("drake")
    kept: list[logging.LogRecord] = []

    class _Keep(logging.Filter):
        def filter(self, record: logging.LogRecord) -> bool:
            kept.append(record)
            return False

    keep = _Keep()
    logger.addFilter(keep)
    g = obj_type.geometry
    where = dict(source=str(obj_type.source), field=f"{obj_type.name}.geometry" + (".mesh" if g and g.mesh else ""))
    try:
        yield where
    except (RuntimeError, ValueError) as exc:
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        warning = next((re.sub(r"^warning:\s*", "", r.getMessage().strip()) for r in kept
                        if r.levelno >= logging.WARNING), None)
        reason = f"{first}" + (f" ({warning.strip()})" if warning else "")
        raise ObjectDatabaseError(f"Drake cannot use {'mesh ' + str(g.mesh) if g and g.mesh else 'this shape'}: "
                                  f"{reason}", **where) from None
    finally:
        logger.removeFilter(keep)
    for record in kept:  # it worked: what Drake said goes out as it would have
        logger.handle(record)


def _compute(obj_type: ObjectType) -> MassProperties:
    phys = obj_type.physics
    where = dict(source=str(obj_type.source), field=f"{obj_type.name}.physics")
    if obj_type.geometry is None:
        raise ObjectDatabaseError("mass properties need a geometry", **where)
    with _drake_log(obj_type) as geometry:
        unit = CalcSpatialInertia(drake_shape(obj_type), 1.0)  # mass == volume at unit density
    volume = unit.get_mass()
    if not volume > 0 or not np.isfinite(volume):
        raise ObjectDatabaseError(f"geometry has no volume ({volume:g} m^3; is the mesh closed?)", **geometry)
    if phys.mass is not None:
        mass = phys.mass
    elif phys.density is not None:
        mass = phys.density * volume
    else:
        raise ObjectDatabaseError("needs mass or density", **where)
    if not mass > 0 or not np.isfinite(mass):
        raise ObjectDatabaseError(f"mass {mass:g} kg is not a positive finite number", **where)
    geometric_com = np.array(unit.get_com())
    com = np.array(phys.com) if phys.com is not None else geometric_com
    if phys.inertia is not None:
        ixx, iyy, izz, ixy, ixz, iyz = phys.inertia
        inertia = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
        told = dict(source=where["source"], field=f"{where['field']}.inertia")
    else:
        # unit-density inertia about the geometric centroid, scaled to the mass
        about_com = unit.Shift(geometric_com).CalcRotationalInertia().CopyToFullMatrix3()
        inertia = about_com * (mass / volume)
        told = geometry
    _check_inertia(mass, inertia, told, given=phys.inertia is not None)
    return MassProperties(mass, com, inertia)


def _check_inertia(mass: float, inertia: np.ndarray, where: dict, *, given: bool) -> None:
    """What Drake asks of a body's inertia (`CouldBePhysicallyValid`: real, non-negative principal moments, each
    at most the sum of the other two), asked before Drake is, so the message names the type."""
    moments = np.linalg.eigvalsh(inertia) if np.all(np.isfinite(inertia)) else np.array([np.nan] * 3)
    valid = bool(np.all(np.isfinite(inertia))) and RotationalInertia(
        inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2], inertia[1, 2]).CouldBePhysicallyValid()
    if valid:
        try:
            valid = SpatialInertia(mass, np.zeros(3), UnitInertia(*(np.diag(inertia) / mass),
                                   *(inertia[[0, 0, 1], [1, 2, 2]] / mass))).IsPhysicallyValid()
        except RuntimeError:
            valid = False
    if not valid:
        text = ", ".join(f"{m:.4g}" for m in moments)
        if given:
            reason = (f"the inertia about the centre of mass is not physically valid: its principal moments ({text} "
                      "kg m^2) must be non-negative and each at most the sum of the other two")
        else:
            reason = (f"the inertia computed from the geometry is degenerate (principal moments {text} kg m^2): is the "
                      "mesh closed, with its faces pointing outwards?")
        raise ObjectDatabaseError(reason, **where)


def scaled_type(obj_type: ObjectType, scale: float) -> tuple[ObjectType, float]:
    """(the type with its geometry `scale` times as large, the height (m) by which the scaled geometry is raised
    in the body frame so that its bottom stays where the type's is). Primitives scale their sizes, meshes their
    scale factor; everything in the body frame scales about its origin, then rises by (1 - scale) z_bottom."""
    from dataclasses import replace

    from ..odb.geometry import z_range
    from ..values import Pose

    g = obj_type.geometry
    bottom = z_range(g, Pose())[0]
    if g.shape == "mesh":
        geometry = replace(g, scale=g.scale * scale)
    else:
        geometry = replace(g, size=tuple(scale * v for v in g.size))
    return replace(obj_type, geometry=geometry), (1.0 - scale) * bottom
