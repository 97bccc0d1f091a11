"""`friction_field`: the surface's friction changes from place to place (a worn lane, a waxed or dusty region
whose edge the object crosses, a sheet of another material beside the first).

Modelled as the first-order field (`bridge.sim.anisotropy.FrictionField`): the pair's coefficient at the
object's start, changing by (g_x, g_y) per metre over the surface, added to Drake's isotropic friction as a
force from each footprint point's slip velocity. Two parameters that are zero where the surface is uniform and
enter smoothly, so no localisation has to say where a region begins: a Gauss-Newton step from zero finds the
direction. A square patch (`friction_patch`) is the sharp, local case; a field is what a half-plane or a strip
looks like to an object pushed a few centimetres across its edge, and what a real sheet's wear looks like.
Its signature: the object turns towards the rougher side and slows as it goes, more the further it travels, in
one world direction in every recording. Over a few short pushes a gradient moves the centre of friction as an
off-centre weight moves the centre of mass, and the two are hard to tell apart; they part as the object travels
(the field changes along the path) and turns (the weight turns with the body, the field stays in the world).
"""
from __future__ import annotations

import math

import numpy as np

from ...params.surfaces import support_of
from ...sim.anisotropy import FrictionField
from .anisotropic_friction import database_pair
from .base import Effect, Evidence, Recovery, Truth, movable_observed, pname

GRADIENTS = (2.0, 4.0, 6.0)  # 1/m: the proof's field (small, medium, large): 10, 20, 30 % over 5 cm


class FrictionFieldEffect(Effect):
    name = "friction_field"
    summary = "the surface's friction changes over the surface (a gradient)"
    mechanism = ("scene extra: a force from each footprint point's slip velocity, the coefficient where the point "
                 "is less Drake's coefficient at the start")
    signature_text = ("the residual grows with the distance travelled, in one world direction in every recording: "
                      "the object turns towards the rougher side and slows")
    kinds = ("field_gx", "field_gy")

    def targets(self, world, odb, observed):
        return tuple(n for n in movable_observed(world, odb, observed) if support_of(world, odb, n) is not None)

    def signature(self, evidence: Evidence, target: str) -> float:
        """Residuals that point one way in the world and start after the first contact (the field's share grows
        with the path; at the start the coefficient is the model's)."""
        dirs = [np.asarray(f["world_dir"]) for f in evidence.significant() if f.get("world_dir") is not None]
        consistency = float(np.linalg.norm(np.mean(dirs, axis=0))) if len(dirs) >= 2 else 0.3
        late = min(1.0, max(0.0, evidence.mean("onset_rel", 0.0)))
        return min(1.0, 0.15 + 0.25 * consistency + 0.25 * late)

    def describe(self, world, odb, target, values):
        gx, gy = values.get(pname("field_gx", target), 0.0), values.get(pname("field_gy", target), 0.0)
        return {"change_per_5cm": 0.05 * math.hypot(gx, gy), "rougher_deg": math.degrees(math.atan2(gy, gx))}

    # --- the proof: the same field, concealed as the recordings' own scene extra ----------------------------------
    def draw_truth(self, scene, odb, rng, magnitude, sign):
        g, phi = GRADIENTS[magnitude], rng.uniform(-math.pi, math.pi)
        o = scene.object
        return Truth(self.name, o, {pname("field_gx", o): g * math.cos(phi), pname("field_gy", o): g * math.sin(phi)},
                     "the surface's coefficient changing over it", {"g": g, "phi": phi})

    def conceal(self, truth, scene, odb, rollout):
        gx, gy = (truth.params[pname(k, scene.object)] for k in ("field_gx", "field_gy"))
        start = rollout.world.objects[scene.object].pose.xyz
        return rollout.with_extras(FrictionField(scene.object, gx, gy, (start[0], start[1]),
                                                 *database_pair(scene, odb, rollout.world))), rollout.telemetry

    def recovered(self, truth, found, model, world, odb):
        names = [pname(k, truth.target) for k in ("field_gx", "field_gy")]
        error = math.hypot(*(found.get(n, 0.0) - truth.params[n] for n in names))
        g = math.hypot(*(truth.params[n] for n in names))
        return Recovery(error <= 0.35 * g + 0.5, error, "1/m", f"(g_x, g_y) off by {error:.2f} of g = {g:.1f} /m "
                                                               f"(35 % + 0.5)")
