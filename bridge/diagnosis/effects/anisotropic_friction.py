"""`anisotropic_friction`: the object slides more easily in one direction of the surface than across it (a
brushed, rolled, machined or printed surface; a grain).

Modelled as a coefficient ellipse around the pair's isotropic coefficient (`bridge.sim.anisotropy`): mu (1 + a)
along the world direction theta, mu (1 - a) across it, as the parameters (a_c, a_s) = a (cos 2 theta,
sin 2 theta), added to Drake's isotropic friction as a force from each footprint point's slip velocity. Its
signature: the object drifts towards the slippery direction, so the residual across each push changes sign with
the push's direction relative to the grain, as sin 2 (phi - theta) (a tilt makes it change as sin (phi - psi):
one turn of the push direction, not two).
"""
from __future__ import annotations

import math

import numpy as np

from ...params.surfaces import support_of, surface_top
from ...sim.anisotropy import AnisotropicFriction
from ...sim.friction import combined_friction
from .base import Effect, Evidence, Recovery, Truth, movable_observed, pname

ANISOTROPY = (0.15, 0.3, 0.45)  # the proof's a (small, medium, large)
SEED = 0.2  # the seed's a, in the direction the across-push residuals point to


def database_pair(scene, odb, world) -> tuple[float, float]:
    """(the object's pair coefficient with its surface in the object database, the surface's top z): what a proof
    case's force system adds to."""
    mu = combined_friction(odb.get(scene.object_type).physics.friction, odb.get(scene.surface_type).physics.friction)
    return mu, surface_top(world, odb, support_of(world, odb, scene.object))


def _harmonic_fit(angles: np.ndarray, values: np.ndarray, k: int) -> tuple[np.ndarray, float]:
    """Least squares of values ~ c cos(k phi) + s sin(k phi): (c, s) and the share of the sum of squares explained."""
    A = np.column_stack([np.cos(k * angles), np.sin(k * angles)])
    coef = np.linalg.lstsq(A, values, rcond=None)[0]
    total = float(np.sum(values ** 2)) or 1.0
    return coef, 1.0 - float(np.sum((values - A @ coef) ** 2)) / total


class AnisotropicFrictionEffect(Effect):
    name = "anisotropic_friction"
    summary = "the surface's friction depends on the direction of sliding (a grain)"
    mechanism = "scene extra: a force from each footprint point's slip velocity, the coefficient ellipse less Drake's isotropic coefficient"
    signature_text = ("the object drifts across each push towards the slippery direction: the across-push residual "
                      "changes sign twice per turn of the push direction")
    kinds = ("aniso_c", "aniso_s")

    def targets(self, world, odb, observed):
        return tuple(n for n in movable_observed(world, odb, observed) if support_of(world, odb, n) is not None)

    def _across(self, evidence: Evidence) -> tuple[np.ndarray, np.ndarray]:
        rows = [(math.atan2(f["direction"][1], f["direction"][0]), f["final_across"]) for f in evidence.features
                if f.get("final_across") is not None and f.get("direction") is not None]
        return (np.array([a for a, _ in rows]), np.array([v for _, v in rows])) if rows else (np.zeros(0), np.zeros(0))

    def signature(self, evidence: Evidence, target: str) -> float:
        """How much of the across-push residuals two turns of the push direction explain, and how much more than
        one turn does (needs three recordings or more, pushed in different directions)."""
        angles, across = self._across(evidence)
        if len(angles) < 3 or np.ptp(angles) < math.radians(10):
            return 0.15
        _, two = _harmonic_fit(angles, across, 2)
        _, one = _harmonic_fit(angles, across, 1)
        return 0.15 + 0.35 * max(0.0, two) + 0.35 * max(0.0, two - one)

    def seeds(self, evidence: Evidence, target: str) -> list[dict[str, float]]:
        """No anisotropy, and a = SEED along the grain the across-push residuals suggest: more friction along
        theta turns a push at phi towards the slippery direction, so the real object ends left of the simulated
        one (the residual, observed - simulated, across the push, left positive) by about k sin 2 (phi - theta),
        k > 0: the residuals' cos 2phi and sin 2phi coefficients (C, S) are (-k sin 2theta, k cos 2theta)."""
        null = self.null_values(evidence.world, evidence.odb, target)
        angles, across = self._across(evidence)
        if len(angles) < 2:
            return [null]
        (c, s), _ = _harmonic_fit(angles, across, 2)
        norm = math.hypot(c, s)
        if norm == 0:
            return [null]
        return [null, {**null, pname("aniso_c", target): SEED * s / norm, pname("aniso_s", target): -SEED * c / norm}]

    def describe(self, world, odb, target, values):
        c, s = values.get(pname("aniso_c", target), 0.0), values.get(pname("aniso_s", target), 0.0)
        return {"anisotropy": math.hypot(c, s), "grain_deg": math.degrees(0.5 * math.atan2(s, c))}

    # --- the proof: the same force on a finer quadrature with a softer regularisation ---------------------------
    def draw_truth(self, scene, odb, rng, magnitude, sign):
        a, theta = ANISOTROPY[magnitude], rng.uniform(-math.pi / 2, math.pi / 2)
        c, s = a * math.cos(2 * theta), a * math.sin(2 * theta)
        return Truth(self.name, scene.object, {pname("aniso_c", scene.object): c, pname("aniso_s", scene.object): s},
                     "a coefficient ellipse on the surface", {"a": a, "theta": theta})

    def conceal(self, truth, scene, odb, rollout):
        c, s = (truth.params[pname(k, scene.object)] for k in ("aniso_c", "aniso_s"))
        return rollout.with_extras(AnisotropicFriction(scene.object, c, s, *database_pair(scene, odb, rollout.world))), \
            rollout.telemetry

    def recovered(self, truth, found, model, world, odb):
        names = [pname(k, truth.target) for k in ("aniso_c", "aniso_s")]
        error = math.hypot(*(found.get(n, 0.0) - truth.params[n] for n in names))
        a = math.hypot(*(truth.params[n] for n in names))
        return Recovery(error <= 0.35 * a + 0.03, error, "",
                        f"(a_c, a_s) off by {error:.3f} of a = {a:.2f} (35 % + 0.03)")
