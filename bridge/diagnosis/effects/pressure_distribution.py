"""`pressure_distribution`: the object's weight does not rest evenly on its whole bottom (a slightly convex or
concave face, a burr, a warped sheet), so its torsional friction differs from a uniform footprint's and the
centre of pressure may sit off the centre of mass.

Modelled as real contact geometry (`bridge.sim.support`): the object rests on its own footprint scaled by
`support_scale` about its centroid, uniform pressure over it; the exact outline still meets the pusher. A
smaller footprint turns every push more (the limit surface's moment axis shrinks with it), a larger one less,
whichever side is pushed; that is what tells it apart from an off-centre mass, whose turn changes sign with the
side pushed. The centre of pressure's offset (`support_x`, `support_y`, kinds a parameter file may fit) is not
part of the effect: in a quasi-static push it moves the centre of friction exactly as an off-centre mass does
(on a compliant support the pressure gathers under the centre of mass), so poses cannot tell the two apart and
`com_offset` names it.
"""
from __future__ import annotations

import math

import numpy as np

from ...sim.prisms import centroid
from ...sim.support import SupportPressure, bottom_polygon, gyration_radius
from .base import Effect, Evidence, Recovery, Truth, movable_observed, pname

SCALES = ((0.8, 1.1), (0.65, 1.2), (0.5, 1.3))  # the proof's footprint scales (small, medium, large): in, out
RECOVERED = (0.5, 2.0)  # the recovered departure from scale 1 over the concealed one
DISC_VERTICES = 16


class PressureDistribution(Effect):
    name = "pressure_distribution"
    summary = "an object's weight rests on part of its bottom (or towards its rim), not evenly on all of it"
    mechanism = "scene extra: the object rests on its own footprint scaled and moved (uniform pressure over it)"
    signature_text = ("the object turns more (or less) than simulated in every recording alike, from the first "
                      "contact on, whichever side is pushed")
    kinds = ("support_scale",)

    def targets(self, world, odb, observed):
        return movable_observed(world, odb, observed)

    def _ratios(self, evidence: Evidence) -> np.ndarray:
        return np.array([f["turn_ratio"] for f in evidence.features
                         if f.get("turn_ratio") is not None and f["turn_ratio"] > 0])

    def signature(self, evidence: Evidence, target: str) -> float:
        """High when the recordings turned by a common factor other than 1 (the same side of 1 in each): an
        off-centre mass makes some turn more and some less."""
        r = np.log(self._ratios(evidence))
        if len(r) == 0:
            return 0.1
        typical = float(np.median(r))
        same = float(np.mean(np.sign(r) == np.sign(typical)))
        size = min(1.0, abs(typical) / math.log(1.5))
        return 0.1 + 0.6 * size * max(0.0, 2.0 * same - 1.0)

    def seeds(self, evidence: Evidence, target: str) -> list[dict[str, float]]:
        """No change, and the footprint whose turn matches the typical ratio: a quasi-static push turns the object
        about inversely to the square of the footprint's radius of gyration, so scale ~ ratio^-1/2."""
        null = self.null_values(evidence.world, evidence.odb, target)
        ratios = self._ratios(evidence)
        if len(ratios) == 0:
            return [null]
        scale = float(np.clip(np.median(ratios) ** -0.5, 0.3, 1.6))
        return [null] + ([{**null, pname("support_scale", target): scale}] if abs(scale - 1.0) > 0.05 else [])

    def describe(self, world, odb, target, values):
        poly, _, _ = bottom_polygon(odb.get(world.objects[target].type), DISC_VERTICES)
        return {"gyration_radius_mm": 1e3 * values.get(pname("support_scale", target), 1.0) * gyration_radius(poly)}

    # --- the proof: a footprint of another shape (a disc of the scaled footprint's radius of gyration) ----------
    def draw_truth(self, scene, odb, rng, magnitude, sign):
        scale = SCALES[magnitude][0 if sign < 0 else 1]
        return Truth(self.name, scene.object, {pname("support_scale", scene.object): scale},
                     "the object rests on a disc of the scaled footprint's radius of gyration", {"scale": scale})

    def conceal(self, truth, scene, odb, rollout):
        poly, _, _ = bottom_polygon(odb.get(scene.object_type), DISC_VERTICES)
        c = centroid(poly)
        radius = math.sqrt(2.0) * truth.extra["scale"] * gyration_radius(poly)  # a disc's is radius / sqrt(2)
        a = np.linspace(0.0, 2 * math.pi, DISC_VERTICES, endpoint=False)
        disc = tuple((float(c[0] + radius * math.cos(t)), float(c[1] + radius * math.sin(t))) for t in a)
        return rollout.with_extras(SupportPressure(scene.object, polygon=disc)), rollout.telemetry

    def recovered(self, truth, found, model, world, odb):
        """The footprint found departs from the object's own on the concealed side, by half to twice as much:
        the concealed disc and the model's scaled footprint agree on the radius of gyration, not beyond it."""
        name = pname("support_scale", truth.target)
        got, want = found.get(name, 1.0), truth.params[name]
        ratio = (got - 1.0) / (want - 1.0)
        return Recovery(RECOVERED[0] <= ratio <= RECOVERED[1], abs(got - want), "",
                        f"scale {got:.2f} vs {want:.2f} (its departure from 1 within x{RECOVERED[0]:g}-{RECOVERED[1]:g})")
