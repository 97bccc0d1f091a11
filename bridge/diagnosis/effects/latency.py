"""`latency`: the telemetry's clock is shifted against the observations' (transport delay, a clock offset).

dt > 0: the robot really moved dt seconds later than its telemetry says.
"""
from __future__ import annotations

from .base import Contribution, Effect, Evidence, ParamSpec


class Latency(Effect):
    name = "latency"
    summary = "telemetry and observations are shifted in time"
    mechanism = "telemetry transform: every sample shifted by dt"
    signature_text = ("along-push residual proportional to the object's speed (zero at rest, the sign of the "
                      "shift), contact starts early or late")

    def targets(self, world, odb, observed):
        return (world.robot.name,) if world.robot is not None else ()

    def params(self, world, odb, target):
        return (ParamSpec("dt", -0.3, 0.3, 0.0, 0.03, "s", "positive: the robot moved later"),)

    def contribute(self, world, odb, target, values):
        return Contribution(time_shift=values["dt"])

    def signature(self, evidence: Evidence, target: str) -> float:
        return 0.2 + 0.7 * max(0.0, evidence.mean("speed_corr"))
