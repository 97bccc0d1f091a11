"""`none`: the world model explains the observations to within their noise."""
from __future__ import annotations

from .base import Effect, Evidence, Recovery


class NoEffect(Effect):
    name = "none"
    summary = "nothing is missing: the residual is at the noise level"
    mechanism = "nothing changes"
    signature_text = "residual within the noise floor in every recording"

    def targets(self, world, odb, observed):
        return ("world",)

    def signature(self, evidence: Evidence, target: str) -> float:
        return 0.0 if evidence.significant() else 1.0

    def draw_truth(self, scene, odb, rng, magnitude, sign):
        from .base import Truth

        return Truth("none", "world", {}, "nothing concealed")

    def conceal(self, truth, scene, odb, rollout):
        return rollout, rollout.telemetry

    def recovered(self, truth, found, model, world, odb):
        return Recovery(True, None, "", "clean")
