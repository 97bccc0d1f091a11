"""`mass`: an object is heavier or lighter than the object database says.

Friction forces scale with the weight as well, so with a stiff, position-controlled pusher the motion barely
depends on the mass: it shows in the force the robot feels (scaled by the mass, while the path stays), through
compliance (an arm's finite PD gains lag more behind a heavier load) and through momentum (collisions). Without
a force sensor it is often not identifiable, and the diagnosis says `none` rather than guess.
"""
from __future__ import annotations

import math

from ...sim.scene import ObjectParams
from ...sim.shapes import mass_properties
from .base import Contribution, Effect, Evidence, ParamSpec, movable_objects


class Mass(Effect):
    name = "mass"
    summary = "an object's mass differs from the object database's"
    mechanism = ("scene values: the body's mass written into the context, its rotational inertia scaled as "
                 "`spread` says")
    signature_text = ("the robot's force scaled by a constant factor while the path barely changes (no slide-on "
                      "change); small along-push lag growing with the push force")
    smooth = False  # the friction fit takes up a force ratio first: start from the ratio instead

    def targets(self, world, odb, observed):
        return tuple(n for n in observed if n in movable_objects(world, odb))

    def params(self, world, odb, target):
        m = mass_properties(odb, world.objects[target].type).mass
        return (ParamSpec("mass", 0.2 * m, 5.0 * m, m, 0.3 * m, "kg", negligible=0.05 * m),
                ParamSpec("spread", 0.0, 1.5, 1.0, 0.5, "",
                          "where the extra mass sits: 1 spread like the object's own (uniform density), 0 at "
                          "the centre of mass (a compact weight inside: no added rotational inertia)"))

    def contribute(self, world, odb, target, values):
        m0 = mass_properties(odb, world.objects[target].type).mass
        mass, spread = values["mass"], values.get("spread", 1.0)
        return Contribution(objects=((target, ObjectParams(
            mass=mass, inertia_scale=max(0.05, 1.0 + spread * (mass / m0 - 1.0)))),))

    def seeds(self, evidence: Evidence, target: str) -> list[dict[str, float]]:
        """The mass scaled by the force ratio (observed / simulated) when a force was recorded, and its square
        root (friction may share the ratio); without a force, the null and a third more or less."""
        spec = self.params(evidence.world, evidence.odb, target)[0]
        scale = evidence.force_scale
        factors = (scale, math.sqrt(scale)) if scale is not None else (1.0, 1.35, 0.75)
        return [{"mass": float(min(max(f * spec.null, spec.lower), spec.upper)), "spread": spread}
                for f in factors for spread in (1.0, 0.0)]

    def signature(self, evidence: Evidence, target: str) -> float:
        off = 0.0 if evidence.force_scale is None else min(1.0, abs(math.log(evidence.force_scale)) / 0.3)
        return 0.25 + 0.3 * evidence.mean("along") + 0.45 * off
