"""`com_offset`: the centre of mass is not where uniform density puts it (an insert, a hollow, a load).

It changes where friction's pressure is centred, so a push turns the object more or less than simulated
(quasi-static pushing), and a tall object tips at a different push height. A hidden weight also adds mass,
which shows in the robot's force: the effect fits the mass with the offset; the weight is compact, so the
rotational inertia stays (`mass_spread` 0).
"""
from __future__ import annotations

import math

from ...sim.extras import Slug
from ...sim.shapes import mass_properties
from .base import Effect, Evidence, Recovery, Truth, movable_observed, pname

SHIFT_PLANAR = (0.005, 0.010, 0.016)  # m: the proof's offsets in the planar scene (small, medium, large)
SHIFT_TABLETOP = (0.003, 0.005, 0.008)


class ComOffset(Effect):
    name = "com_offset"
    summary = "an object's centre of mass is off its geometric centre"
    mechanism = "scene values: the body's centre of mass (and mass) written into the context, its inertia kept"
    signature_text = "yaw residual from the first contact on, its sign set by which side of the centre is pushed"
    kinds = ("com_x", "com_y", "mass")
    fixed = {"mass_spread": 0.0}
    judged_by = ("com_x", "com_y")  # the mass is `mass`'s business ...
    reduces_to = "mass"  # ... and a fit on the centre with another mass is a fit of `mass`

    def targets(self, world, odb, observed):
        return movable_observed(world, odb, observed)

    def describe(self, world, odb, target, values):
        com = mass_properties(odb, world.objects[target].type).com
        return {"offset_mm": 1e3 * math.hypot(values[pname("com_x", target)] - com[0],
                                              values[pname("com_y", target)] - com[1])}

    def seeds(self, evidence: Evidence, target: str) -> list[dict[str, float]]:
        """No offset, at the database's mass and, when a force was recorded, at the mass the force ratio says."""
        null = self.null_values(evidence.world, evidence.odb, target)
        out = [null]
        if evidence.force_scale is not None and abs(evidence.force_scale - 1.0) > 0.1:
            mass = next(p for p in self.parameters(evidence.world, evidence.odb, target) if p.kind.name == "mass")
            out.append({**null, mass.name: float(min(max(evidence.force_scale * mass.start, mass.bounds[0]),
                                                     mass.bounds[1]))})
        return out

    def signature(self, evidence: Evidence, target: str) -> float:
        early = 1.0 - min(1.0, max(0.0, evidence.mean("onset_rel", 0.0)))
        return 0.2 + 0.6 * evidence.mean("yaw") * early + 0.1 * early

    # --- the proof: a dense slug welded off-centre (moves the centre of mass, adds mass) -----------------------
    def draw_truth(self, scene, odb, rng, magnitude, sign):
        shift = (SHIFT_PLANAR if scene.planar else SHIFT_TABLETOP)[magnitude]
        angle = rng.uniform(-math.pi, math.pi)
        props = mass_properties(odb, scene.object_type)
        slug = 0.8 * props.mass
        r = shift * (props.mass + slug) / slug
        dx, dy = shift * math.cos(angle), shift * math.sin(angle)
        return Truth(self.name, scene.object, {pname("com_x", scene.object): float(props.com[0] + dx),
                                               pname("com_y", scene.object): float(props.com[1] + dy)},
                     "a dense slug welded off-centre",
                     {"offset": [dx, dy], "slug_mass": slug, "slug_offset": [r * math.cos(angle), r * math.sin(angle)]})

    def conceal(self, truth, scene, odb, rollout):
        ox, oy = truth.extra["slug_offset"]  # object frame
        return rollout.with_extras(Slug(scene.object, truth.extra["slug_mass"], (ox, oy, 0.0), 0.01)), \
            rollout.telemetry

    def recovered(self, truth, found, model, world, odb):
        x, y = pname("com_x", truth.target), pname("com_y", truth.target)
        d = math.hypot(found[x] - truth.params[x], found[y] - truth.params[y])
        size = math.hypot(*truth.extra["offset"])
        com = mass_properties(odb, world.objects[truth.target].type).com
        fx, fy = 1e3 * (found[x] - com[0]), 1e3 * (found[y] - com[1])
        tx, ty = (1e3 * v for v in truth.extra["offset"])
        return Recovery(d <= 0.35 * size + 0.002, d, "m",
                        f"offset ({fx:.1f}, {fy:.1f}) vs ({tx:.1f}, {ty:.1f}) mm (35 % + 2 mm)")
