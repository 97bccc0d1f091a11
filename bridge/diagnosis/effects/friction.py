"""`friction`: a friction coefficient is off (a parameter error, not missing physics).

Target: a free object (its coefficient enters every pair it is in) or the fixture it slides on (only that pair).
Quasi-static pushing hardly depends on the surface coefficient's size; it shows after the pusher stops (the
object slides on by v^2 / (2 mu g)) and in how the pusher slips along the object's face.
"""
from __future__ import annotations

from .base import Contribution, Effect, Evidence, ParamSpec, movable_objects, support_of
from ...sim.scene import ObjectParams


class Friction(Effect):
    name = "friction"
    summary = "a friction coefficient differs from the object database's"
    mechanism = "scene values: the coefficient written into the context (no rebuild)"
    signature_text = ("residual grows mostly after the pusher stops (slide-on distance) and as slip along the "
                      "pushed face; the onset is at the first contact or at the end of the push")

    def targets(self, world, odb, observed):
        names = [n for n in observed if n in movable_objects(world, odb)]
        surfaces = [s for s in (support_of(world, odb, n) for n in names) if s]
        return tuple(dict.fromkeys([*names, *surfaces]))

    def params(self, world, odb, target):
        mu = odb.get(world.objects[target].type).physics.friction
        return (ParamSpec("mu", 0.02, max(1.5, 3 * mu), mu, 0.3 * mu, "", "Coulomb coefficient (static = dynamic)"),)

    def contribute(self, world, odb, target, values):
        return Contribution(objects=((target, ObjectParams(friction=values["mu"])),))

    def signature(self, evidence: Evidence, target: str) -> float:
        return 0.35 + 0.5 * evidence.mean("slide_share")
