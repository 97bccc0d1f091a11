"""`friction`: a friction coefficient is off (a parameter error, not missing physics).

Target: a free object (its coefficient enters every pair it is in) or the fixture it slides on (only that pair).
Quasi-static pushing hardly depends on the surface coefficient's size; it shows after the pusher stops (the
object slides on by v^2 / (2 mu g)) and in how the pusher slips along the object's face.
"""
from __future__ import annotations

from ...params.surfaces import supported_by, surfaces_under
from ...sim.friction import combined_friction
from .base import Effect, Evidence, Recovery, Truth, model_friction, movable_observed, pname

FACTORS = (1.5, 2.2, 3.2)  # the proof's surface coefficient, times or divided by this (small, medium, large)


class Friction(Effect):
    name = "friction"
    summary = "a friction coefficient differs from the object database's"
    mechanism = "scene values: the coefficient written into the context (no rebuild)"
    signature_text = ("residual grows mostly after the pusher stops (slide-on distance) and as slip along the "
                      "pushed face; the onset is at the first contact or at the end of the push")
    kinds = ("friction",)

    def targets(self, world, odb, observed):
        names = movable_observed(world, odb, observed)
        return tuple(dict.fromkeys([*names, *surfaces_under(world, odb, names)]))

    def signature(self, evidence: Evidence, target: str) -> float:
        return 0.35 + 0.5 * evidence.mean("slide_share")

    # --- the proof: the surface's coefficient (another surface material); the model may fit the object's ---------
    def draw_truth(self, scene, odb, rng, magnitude, sign):
        mu_obj = odb.get(scene.object_type).physics.friction
        mu = odb.get(scene.surface_type).physics.friction * FACTORS[magnitude] ** sign
        return Truth(self.name, scene.surface, {pname("friction", scene.surface): mu}, "the surface's coefficient",
                     {"pair_mu": combined_friction(mu_obj, mu)})

    def conceal(self, truth, scene, odb, rollout):
        mu = truth.params[pname("friction", scene.surface)]
        return rollout.with_values(rollout.values.with_object(scene.surface, friction=mu)), rollout.telemetry

    def target_matches(self, concealed, found, world, odb):
        """The surface's coefficient or the object's on it: either changes the pair's."""
        return found == concealed or found in supported_by(world, odb, concealed)

    def recovered(self, truth, found, model, world, odb):
        obj = next(n for n, o in world.objects.items() if not odb.get(o.type).fixed)
        pair = combined_friction(model_friction(model, world, odb, obj),
                                 model_friction(model, world, odb, truth.target))
        true_pair = truth.extra["pair_mu"]
        err = abs(pair - true_pair)
        return Recovery(err <= 0.25 * true_pair, err, "", f"pair mu {pair:.3f} vs {true_pair:.3f} (tolerance 25 %)")
