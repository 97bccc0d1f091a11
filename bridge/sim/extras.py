"""Scene extras: geometry and bodies that are not in the world model, added by `build_scene(..., extras=...)`.

Each extra is a frozen (hashable, picklable) value with ``add_to(plant, world, odb, config)``, called before
Finalize, so a scene built with the same extras can be cached and reused. Diagnosis uses them twice: to *model*
an effect (a welded obstacle post) and, in the proof, to *conceal* one by a physical mechanism that differs from
the model (a dense slug welded inside an object, a thin sheet of another material on a surface).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydrake.geometry import (AddCompliantHydroelasticProperties, AddContactMaterial, AddRigidHydroelasticProperties, Box,
                              Cylinder, ProximityProperties)
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.plant import CoulombFriction
from pydrake.multibody.tree import SpatialInertia

from ..errors import SceneError


def _props(friction: float, modulus: float | None, resolution: float, dissipation: float = 3.0) -> ProximityProperties:
    props = ProximityProperties()
    AddContactMaterial(dissipation=dissipation, friction=CoulombFriction(friction, friction), properties=props)
    if modulus is not None:
        AddCompliantHydroelasticProperties(resolution, modulus, props)
    else:  # rigid, like the scene's fixtures: compliant objects press into it
        AddRigidHydroelasticProperties(resolution, props)
    return props


@dataclass(frozen=True)
class WeldedShape:
    """A box (size x, y, z) or an upright cylinder (radius, length) welded to the world at `xyz` / `rpy`;
    rigid hydroelastic (like the scene's fixtures) unless a `modulus` makes it compliant."""

    name: str
    shape: str
    size: tuple[float, ...]
    xyz: tuple[float, float, float]
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    friction: float = 0.5
    modulus: float | None = None
    color: tuple[float, float, float, float] = (0.8, 0.3, 0.2, 1.0)
    resolution: float | None = None  # hydroelastic mesh resolution; default: the scene's resolution hint

    def add_to(self, plant, world, odb, config) -> None:
        if self.shape == "box" and len(self.size) == 3:
            shape = Box(*self.size)
        elif self.shape == "cylinder" and len(self.size) == 2:
            shape = Cylinder(*self.size)
        else:
            raise SceneError(f"extra {self.name!r}: shape must be 'box' (3 sizes) or 'cylinder' (radius, length), "
                             f"got {self.shape!r} with {len(self.size)} sizes")
        X = RigidTransform(RollPitchYaw(*self.rpy), np.asarray(self.xyz, dtype=float))
        resolution = self.resolution or config.resolution_hint
        plant.RegisterCollisionGeometry(plant.world_body(), X, shape, f"{self.name}/collision",
                                        _props(self.friction, self.modulus, resolution))
        plant.RegisterVisualGeometry(plant.world_body(), X, shape, f"{self.name}/visual", np.array(self.color))


@dataclass(frozen=True)
class Slug:
    """A dense block welded inside a free object (no collision geometry): it adds `mass` at `offset` (object
    frame, m), which moves the centre of mass and changes the inertia the way a real insert does."""

    object: str
    mass: float
    offset: tuple[float, float, float]
    edge: float = 0.01  # m, cube edge of the slug (its own inertia)

    def add_to(self, plant, world, odb, config) -> None:
        if not plant.HasBodyNamed(self.object):
            raise SceneError(f"slug: no free object {self.object!r} in the scene")
        if not self.mass > 0:
            raise SceneError(f"slug in {self.object!r}: mass must be > 0, got {self.mass!r}")
        body = plant.GetBodyByName(self.object)
        slug = plant.AddRigidBody(f"{self.object}__slug", body.model_instance(),
                                  SpatialInertia.SolidBoxWithMass(self.mass, self.edge, self.edge, self.edge))
        plant.WeldFrames(body.body_frame(), slug.body_frame(), RigidTransform(np.asarray(self.offset, dtype=float)))


@dataclass(frozen=True)
class SurfacePatch:
    """A sheet of another material lying on a support surface over the rectangle `region` = (x0, x1, y0, y1),
    turned by `yaw` about its centre (real regions of another friction, a mat's edge, tape, a wet spot, lie at
    any angle to the world's axes): a rigid box whose top is `raised` above the surface's top `top_z`. With
    `raised` = 0 (the default) the sheet and the surface share the plane: an object over the sheet presses on
    both, each carries half of its weight, so the friction there is the mean of the two pairs' coefficients;
    outside the region the surface's contact is exactly what it was (same geometry), and crossing the sheet's
    edge meets no step."""

    name: str
    region: tuple[float, float, float, float]
    top_z: float
    friction: float
    raised: float = 0.0
    thickness: float = 0.004
    yaw: float = 0.0

    def add_to(self, plant, world, odb, config) -> None:
        x0, x1, y0, y1 = self.region
        if not (x1 > x0 and y1 > y0):
            raise SceneError(f"surface patch {self.name!r}: region must have x1 > x0 and y1 > y0, got {self.region}")
        z = self.top_z + self.raised - self.thickness / 2
        sheet = WeldedShape(self.name, "box", (x1 - x0, y1 - y0, self.thickness), ((x0 + x1) / 2, (y0 + y1) / 2, z),
                            (0.0, 0.0, float(self.yaw)), friction=self.friction, color=(0.75, 0.85, 0.75, 1.0))
        sheet.add_to(plant, world, odb, config)


@dataclass(frozen=True)
class RobotGains:
    """The robot's PD gains scaled (every actuator's p by `p_scale`, d by `d_scale`): a stiffer or softer servo
    than the model's, for generated worlds whose pusher dynamics differ from the model a diagnosis is given."""

    p_scale: float = 1.0
    d_scale: float = 1.0

    def add_to(self, plant, world, odb, config) -> None:
        from pydrake.multibody.tree import JointActuatorIndex, PdControllerGains

        if not (self.p_scale > 0 and self.d_scale > 0):
            raise SceneError(f"robot gains: scales must be > 0, got p x {self.p_scale!r}, d x {self.d_scale!r}")
        for k in range(plant.num_actuators()):
            actuator = plant.get_joint_actuator(JointActuatorIndex(k))
            if actuator.has_controller():
                gains = actuator.get_controller_gains()
                actuator.set_controller_gains(PdControllerGains(p=gains.p * self.p_scale, d=gains.d * self.d_scale))


@dataclass(frozen=True)
class ObjectScale:
    """Free object `object` is `scale` times the size its type says (an error of the object model: a mesh or
    outline drawn at another size, another instance of the part). Its whole geometry (collision, footprint,
    visual) is scaled about the centre of its bottom, so it still rests where the world puts it; its mass stays
    the database's (the object weighs what it weighs) and its inertia scales with the size (`shapes.scaled_type`).
    Applied where the object is added (`scene.add_object`); `add_to` checks that the object is there."""

    object: str
    scale: float = 1.0

    def add_to(self, plant, world, odb, config) -> None:
        if self.object not in world.objects or odb.get(world.objects[self.object].type).fixed:
            free = [n for n, o in world.objects.items() if not odb.get(o.type).fixed]
            raise SceneError(f"object scale: no free object {self.object!r} in world {world.name!r}; free objects: "
                             f"{', '.join(free) or 'none'}")
        if not (np.isfinite(self.scale) and 0.5 <= self.scale <= 2.0):
            raise SceneError(f"object scale of {self.object!r} must be in [0.5, 2], got {self.scale!r}")
