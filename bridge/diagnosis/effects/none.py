"""`none`: the world model explains the observations to within their noise."""
from __future__ import annotations

from .base import Contribution, Effect, Evidence


class NoEffect(Effect):
    name = "none"
    summary = "nothing is missing: the residual is at the noise level"
    mechanism = "nothing changes"
    signature_text = "residual within the noise floor in every recording"

    def targets(self, world, odb, observed):
        return ("world",)

    def params(self, world, odb, target):
        return ()

    def contribute(self, world, odb, target, values):
        return Contribution()

    def signature(self, evidence: Evidence, target: str) -> float:
        return 0.0 if evidence.significant() else 1.0
