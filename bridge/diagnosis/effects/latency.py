"""`latency`: the telemetry's clock is shifted against the observations' (transport delay, a clock offset).

latency > 0: the robot really moved that much later than its telemetry says.
"""
from __future__ import annotations

import numpy as np

from ...recording.telemetry import Telemetry
from .base import Effect, Evidence, Recovery, Truth, pname

SHIFTS = (0.03, 0.06, 0.12)  # s: the proof's clock offsets (small, medium, large), either sign


class Latency(Effect):
    name = "latency"
    summary = "telemetry and observations are shifted in time"
    mechanism = "telemetry transform: every sample shifted by the latency"
    signature_text = ("along-push residual proportional to the object's speed (zero at rest, the sign of the "
                      "shift), the object starts to move early or late by the same time in every recording")
    smooth = False  # a shift of more than a sample or two is far outside the linearisation: start from seeds
    kinds = ("latency",)

    def targets(self, world, odb, observed):
        return (world.robot.name,) if world.robot is not None else ()

    def signature(self, evidence: Evidence, target: str) -> float:
        """The start-of-motion shifts' consistency and the residual's correlation with speed; 1 when the contact
        gaps measure a latency (the loader's evidence, before any simulation)."""
        if evidence.latency is not None:
            return 1.0
        shifts = self._shifts(evidence)
        consistent = 0.0
        if len(shifts) >= 2 and abs(float(np.median(shifts))) > 0.01:
            consistent = float(np.mean(np.sign(shifts) == np.sign(np.median(shifts))))
        return 0.2 + 0.4 * max(0.0, evidence.mean("speed_corr")) + 0.4 * consistent

    def seeds(self, evidence: Evidence, target: str) -> list[dict[str, float]]:
        """The latency the contact gaps measure, the median start-of-motion shift (observed minus simulated), half
        and one and a half of it, and the null value."""
        (p,) = self.parameters(evidence.world, evidence.odb, target)
        shifts = self._shifts(evidence)
        out = [{p.name: 0.0}]
        if evidence.latency is not None:
            out.append({p.name: float(np.clip(evidence.latency, *p.bounds))})
        if shifts:
            dt = float(np.median(shifts))
            out += [{p.name: float(np.clip(f * dt, *p.bounds))} for f in (1.0, 0.5, 1.5) if dt]
        return out

    @staticmethod
    def _shifts(evidence: Evidence) -> list[float]:
        return [f["moves_obs_s"] - f["moves_sim_s"] for f in evidence.features
                if f.get("moves_obs_s") is not None and f.get("moves_sim_s") is not None]

    # --- the proof: the recorder stamps the telemetry early or late (resampled at its own clock) ----------------
    def draw_truth(self, scene, odb, rng, magnitude, sign):
        return Truth(self.name, scene.robot, {pname("latency", scene.robot): sign * SHIFTS[magnitude]},
                     "telemetry stamped early or late")

    def conceal(self, truth, scene, odb, rollout):
        # the recorded samples read the true motion dt later than their stamps say (true(t) = recorded(t - dt))
        tel = rollout.telemetry
        dt = truth.params[pname("latency", scene.robot)]
        return rollout, Telemetry(tel.times, tel.joint_names, tel.sample(tel.times + dt))

    def recovered(self, truth, found, model, world, odb):
        name = pname("latency", truth.target)
        err = abs(found[name] - truth.params[name])
        return Recovery(err <= 0.2 * abs(truth.params[name]) + 0.01, err, "s",
                        f"latency {found[name] * 1e3:.0f} vs {truth.params[name] * 1e3:.0f} ms (20 % + 10 ms)")
