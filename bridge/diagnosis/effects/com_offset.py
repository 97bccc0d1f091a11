"""`com_offset`: the centre of mass is not where uniform density puts it (an insert, a hollow, a load).

It changes where friction's pressure is centred, so a push turns the object more or less than simulated
(quasi-static pushing), and a tall object tips at a different push height. A hidden weight also adds mass,
which shows in the robot's force: the effect fits the mass with the offset.
"""
from __future__ import annotations

import math

from ...sim.scene import ObjectParams
from ...sim.shapes import mass_properties
from .base import Contribution, Effect, Evidence, ParamSpec, footprint_half, movable_objects


class ComOffset(Effect):
    name = "com_offset"
    summary = "an object's centre of mass is off its geometric centre"
    mechanism = "scene values: the body's centre of mass written into the context"
    signature_text = "yaw residual from the first contact on, its sign set by which side of the centre is pushed"

    def targets(self, world, odb, observed):
        return tuple(n for n in observed if n in movable_objects(world, odb))

    def params(self, world, odb, target):
        hx, hy, _ = footprint_half(world, odb, target)
        m = mass_properties(odb, world.objects[target].type).mass
        return (ParamSpec("dx", -0.6 * hx, 0.6 * hx, 0.0, 0.1 * hx, "m", "object frame", negligible=0.001),
                ParamSpec("dy", -0.6 * hy, 0.6 * hy, 0.0, 0.1 * hy, "m", "object frame", negligible=0.001),
                ParamSpec("mass", 0.2 * m, 5.0 * m, m, 0.3 * m, "kg", "the object with what moved its centre"))

    def contribute(self, world, odb, target, values):
        props = mass_properties(odb, world.objects[target].type)
        com = props.com
        return Contribution(objects=((target, ObjectParams(
            com=(float(com[0] + values["dx"]), float(com[1] + values["dy"]), float(com[2])),
            mass=values.get("mass", props.mass), inertia_scale=1.0)),))  # a compact weight: inertia stays

    def describe(self, world, odb, target, values):
        return {"offset_mm": 1e3 * math.hypot(values["dx"], values["dy"])}

    def seeds(self, evidence: Evidence, target: str) -> list[dict[str, float]]:
        """No offset, at the database's mass and, when a force was recorded, at the mass the force ratio says."""
        null = self.null_values(evidence.world, evidence.odb, target)
        out = [null]
        if evidence.force_scale is not None and abs(evidence.force_scale - 1.0) > 0.1:
            spec = self.params(evidence.world, evidence.odb, target)[2]
            out.append({**null, "mass": float(min(max(evidence.force_scale * spec.null, spec.lower), spec.upper))})
        return out

    def signature(self, evidence: Evidence, target: str) -> float:
        early = 1.0 - min(1.0, max(0.0, evidence.mean("onset_rel", 0.0)))
        return 0.2 + 0.6 * evidence.mean("yaw") * early + 0.1 * early
