"""`mass`: an object is heavier or lighter than the object database says.

Friction forces scale with the weight as well, so with a stiff, position-controlled pusher the motion barely
depends on the mass: it shows in the force the robot feels (scaled by the mass, while the path stays), through
compliance (an arm's finite PD gains lag more behind a heavier load) and through momentum (collisions). Without
a force sensor it is often not identifiable, and the diagnosis says `none` rather than guess.
"""
from __future__ import annotations

import math

from .base import Contribution, Effect, Evidence, ParamSpec, movable_objects
from ...sim.scene import ObjectParams


class Mass(Effect):
    name = "mass"
    summary = "an object's mass differs from the object database's"
    mechanism = "scene values: the body's mass written into the context (inertia scaled with it)"
    signature_text = ("the robot's force scaled by a constant factor while the path barely changes (no slide-on "
                      "change); small along-push lag growing with the push force")

    def targets(self, world, odb, observed):
        return tuple(n for n in observed if n in movable_objects(world, odb))

    def params(self, world, odb, target):
        m = odb.mass_properties(world.objects[target].type).mass
        return (ParamSpec("mass", 0.2 * m, 5.0 * m, m, 0.3 * m, "kg"),)

    def contribute(self, world, odb, target, values):
        return Contribution(objects=((target, ObjectParams(mass=values["mass"])),))

    def signature(self, evidence: Evidence, target: str) -> float:
        off = 0.0 if evidence.force_scale is None else min(1.0, abs(math.log(evidence.force_scale)) / 0.3)
        return 0.25 + 0.3 * evidence.mean("along") + 0.45 * off
