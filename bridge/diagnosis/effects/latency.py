"""`latency`: the telemetry's clock is shifted against the observations' (transport delay, a clock offset).

dt > 0: the robot really moved dt seconds later than its telemetry says.
"""
from __future__ import annotations

import numpy as np

from .base import Contribution, Effect, Evidence, ParamSpec


class Latency(Effect):
    name = "latency"
    summary = "telemetry and observations are shifted in time"
    mechanism = "telemetry transform: every sample shifted by dt"
    signature_text = ("along-push residual proportional to the object's speed (zero at rest, the sign of the "
                      "shift), the object starts to move early or late by the same time in every recording")
    smooth = False  # a shift of more than a sample or two is far outside the linearisation: start from seeds

    def targets(self, world, odb, observed):
        return (world.robot.name,) if world.robot is not None else ()

    def params(self, world, odb, target):
        return (ParamSpec("dt", -0.3, 0.3, 0.0, 0.03, "s", "positive: the robot moved later", negligible=0.005),)

    def contribute(self, world, odb, target, values):
        return Contribution(time_shift=values["dt"])

    def signature(self, evidence: Evidence, target: str) -> float:
        shifts = self._shifts(evidence)
        consistent = 0.0
        if len(shifts) >= 2 and abs(float(np.median(shifts))) > 0.01:
            consistent = float(np.mean(np.sign(shifts) == np.sign(np.median(shifts))))
        return 0.2 + 0.4 * max(0.0, evidence.mean("speed_corr")) + 0.4 * consistent

    def seeds(self, evidence: Evidence, target: str) -> list[dict[str, float]]:
        """The median start-of-motion shift (observed minus simulated), half and one and a half of it, and the
        null value."""
        spec = self.params(evidence.world, evidence.odb, target)[0]
        shifts = self._shifts(evidence)
        out = [{"dt": 0.0}]
        if shifts:
            dt = float(np.median(shifts))
            out += [{"dt": float(np.clip(f * dt, spec.lower, spec.upper))} for f in (1.0, 0.5, 1.5) if dt]
        return out

    @staticmethod
    def _shifts(evidence: Evidence) -> list[float]:
        return [f["moves_obs_s"] - f["moves_sim_s"] for f in evidence.features
                if f.get("moves_obs_s") is not None and f.get("moves_sim_s") is not None]
