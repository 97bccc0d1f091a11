"""`friction_patch`: a region of the support surface has a different friction coefficient (a worn, wet,
taped or different-material area).

Modelled as a scene extra: a micrometre-thin sheet (`bridge.sim.extras.SurfacePatch`, raised 1 um) over an
axis-aligned square (centre cx, cy, half size `half`) with its own coefficient `mu`; an object over it rests on
the sheet, so the pair's coefficient there is 2 mu mu_object / (mu + mu_object), and an object straddling its
edge feels the two coefficients side by side (the torque a uniform blend would miss). A new scene per value
(~40 ms).
"""
from __future__ import annotations

import numpy as np

from ...odb.geometry import half_extents
from ...sim.extras import SurfacePatch
from ...sim.friction import combined_friction, surface_friction_for
from .base import Contribution, Effect, Evidence, ParamSpec, movable_objects, support_of, supported_by, surface_top

RAISED = 1.0e-6  # m: the sheet carries what stands on it (objects sink ~0.6 um), its edge is no step


class FrictionPatch(Effect):
    name = "friction_patch"
    summary = "part of the support surface has a different friction coefficient"
    mechanism = "scene extra: a 1 um sheet with its own coefficient over a square of the surface"
    signature_text = ("onset in the middle of a push, when the object reaches the same place in several "
                      "recordings; the object keeps moving (no stall), it turns or slides on differently")
    smooth = False

    def targets(self, world, odb, observed):
        surfaces = [support_of(world, odb, n) for n in observed if n in movable_objects(world, odb)]
        return tuple(dict.fromkeys(s for s in surfaces if s))

    def _pair(self, world, odb, target) -> float:
        objects = supported_by(world, odb, target)
        mu_s = odb.get(world.objects[target].type).physics.friction
        mu_o = odb.get(world.objects[objects[0]].type).physics.friction if objects else mu_s
        return combined_friction(mu_o, mu_s)

    def _object_mu(self, evidence: Evidence, target: str) -> float:
        objects = supported_by(evidence.world, evidence.odb, target)
        w = evidence.world
        return evidence.odb.get(w.objects[objects[0]].type).physics.friction if objects else 0.5

    def params(self, world, odb, target):
        surface = world.objects[target]
        hx, hy, _ = half_extents(odb.get(surface.type).geometry)
        cx, cy = surface.pose.xyz[:2]
        mu = odb.get(surface.type).physics.friction
        return (ParamSpec("cx", cx - hx, cx + hx, cx, 0.01, "m", "region centre, world x"),
                ParamSpec("cy", cy - hy, cy + hy, cy, 0.01, "m", "region centre, world y"),
                ParamSpec("half", 0.005, max(hx, hy), 0.05, 0.01, "m", "half size of the square region"),
                ParamSpec("mu", 0.003, 3.0, mu, 0.3 * mu, "", "the region's own coefficient (like the surface's)"))

    def contribute(self, world, odb, target, values):
        h = values["half"]
        sheet = SurfacePatch("friction_patch", (values["cx"] - h, values["cx"] + h, values["cy"] - h, values["cy"] + h),
                             surface_top(world, odb, target), values["mu"], raised=RAISED)
        return Contribution(extras=(sheet,))

    def describe(self, world, odb, target, values):
        objects = supported_by(world, odb, target)
        mu_o = odb.get(world.objects[objects[0]].type).physics.friction if objects else values["mu"]
        return {"pair_mu_inside": combined_friction(mu_o, values["mu"])}

    def signature(self, evidence: Evidence, target: str) -> float:
        late = [f for f in evidence.significant() if f.get("onset_rel") is not None and f["onset_rel"] > 0.15]
        if not late:
            return 0.1
        stall = evidence.mean("stall", 0.0)
        return min(1.0, 0.3 + 0.5 * len(late) / max(1, len(evidence.significant())) + 0.2 * (1.0 - stall))

    def seeds(self, evidence: Evidence, target: str) -> list[dict[str, float]]:
        """Squares that begin where the objects' leading edges were at the onsets (the median entry point and the
        first single one), small and large, with a lower and a higher coefficient."""
        specs = {p.name: p for p in self.params(evidence.world, evidence.odb, target)}
        pair = self._pair(evidence.world, evidence.odb, target)
        late = [f for f in evidence.significant()
                if f.get("onset_rel") is not None and f["onset_rel"] > 0.1 and f.get("onset_xy_sim") is not None]
        if not late:
            return []
        entries = [(np.asarray(f["onset_xy_sim"]) + np.asarray(f["direction"]) * f.get("reach", 0.05),
                    np.asarray(f["direction"])) for f in late]
        points = [(np.median([e for e, _ in entries], axis=0), np.mean([d for _, d in entries], axis=0))]
        points += entries[:1]
        out = []
        for point, d in points:
            d = d / (np.linalg.norm(d) or 1.0)
            for half in (0.06, 0.15):
                c = point + d * half
                for factor in (0.55, 1.45):
                    mu_o = self._object_mu(evidence, target)
                    mu = float(np.clip(surface_friction_for(factor * pair, mu_o), specs["mu"].lower, specs["mu"].upper))
                    out.append({"cx": float(c[0]), "cy": float(c[1]), "half": half, "mu": mu})
        return out
