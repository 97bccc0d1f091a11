"""`mass`: an object is heavier or lighter than the object database says.

Friction forces scale with the weight as well, so with a stiff, position-controlled pusher the motion barely
depends on the mass: it shows in the force the robot feels (scaled by the mass, while the path stays), through
compliance (an arm's finite PD gains lag more behind a heavier load) and through momentum (collisions). Without
a force sensor it is often not identifiable, and the diagnosis says `none` rather than guess.
"""
from __future__ import annotations

import math

from ...params.surfaces import support_of
from ...sim.extras import Slug
from ...sim.shapes import mass_properties
from ...params import Parameter
from .base import Effect, Evidence, Recovery, Truth, movable_observed, pname

ADDED = (0.5, 1.0, 2.0)  # the proof's slug, in masses of the object (small, medium, large)


class Mass(Effect):
    name = "mass"
    summary = "an object's mass differs from the object database's"
    mechanism = ("scene values: the body's mass written into the context, its rotational inertia scaled as "
                 "`mass_spread` says")
    signature_text = ("the robot's force scaled by a constant factor while the path barely changes (no slide-on "
                      "change); small along-push lag growing with the push force")
    smooth = False  # the friction fit takes up a force ratio first: start from the ratio instead
    kinds = ("mass", "mass_spread")

    def targets(self, world, odb, observed):
        return movable_observed(world, odb, observed)

    def seeds(self, evidence: Evidence, target: str) -> list[dict[str, float]]:
        """The mass scaled by the force ratio r (observed / simulated) when a force was recorded, and by its
        square root; and, since a sliding object's force is its weight times the pair's coefficient, r split
        between the two: mass x r^s with the sliding pair's coefficient x r^(1 - s), for
        s = 1/3, 1/2, 2/3 (the slide-on after the rod stops, which the coefficient alone sets, then tells them
        apart). Without a force, the null and a third more or less."""
        world, odb = evidence.world, evidence.odb
        mass = next(p for p in self.parameters(world, odb, target) if p.kind.name == "mass")
        scale = evidence.force_scale
        factors = (scale, math.sqrt(scale)) if scale is not None else (1.0, 1.35, 0.75)
        lo, hi = mass.bounds
        seeds = [{mass.name: float(min(max(f * mass.start, lo), hi)), pname("mass_spread", target): spread}
                 for f in factors for spread in (1.0, 0.0)]
        surface = support_of(world, odb, target)
        if scale is None or surface is None or abs(math.log(scale)) < 0.1:
            return seeds
        sliding = Parameter.of("sliding_friction", target, world, odb)
        for share in (1 / 3, 1 / 2, 2 / 3):
            wanted = float(min(max(sliding.start * scale ** (1 - share), sliding.bounds[0]), sliding.bounds[1]))
            seeds.append({mass.name: float(min(max(scale ** share * mass.start, lo), hi)),
                          pname("mass_spread", target): 0.0, sliding.name: wanted})
        return seeds

    def signature(self, evidence: Evidence, target: str) -> float:
        off = 0.0 if evidence.force_scale is None else min(1.0, abs(math.log(evidence.force_scale)) / 0.3)
        return 0.25 + 0.3 * evidence.mean("along") + 0.45 * off

    # --- the proof: a dense slug welded at the centre; the model changes the body's mass -----------------------
    def draw_truth(self, scene, odb, rng, magnitude, sign):
        m0 = mass_properties(odb, scene.object_type).mass
        added = ADDED[magnitude] * m0
        return Truth(self.name, scene.object, {pname("mass", scene.object): m0 + added},
                     "a dense slug welded at the centre", {"slug_mass": added})

    def conceal(self, truth, scene, odb, rollout):
        return rollout.with_extras(Slug(scene.object, truth.extra["slug_mass"], (0.0, 0.0, 0.0), 0.01)), \
            rollout.telemetry

    def recovered(self, truth, found, model, world, odb):
        name = pname("mass", truth.target)
        err = abs(found[name] - truth.params[name])
        return Recovery(err <= 0.3 * truth.params[name], err, "kg",
                        f"mass {found[name]:.3f} vs {truth.params[name]:.3f} kg (30 %)")
