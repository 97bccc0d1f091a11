"""`hidden_obstacle`: a fixed object that is not in the world model (a clamp, a cable, a forgotten part).

Modelled as a welded upright post of radius `RADIUS` at (x, y) on the surface: a scene extra, so each position
is a new scene (building one takes a few tens of milliseconds).
"""
from __future__ import annotations

import numpy as np

from .base import Contribution, Effect, Evidence, ParamSpec, movable_objects, support_of, surface_top
from ...odb.geometry import half_extents, z_range
from ...sim.extras import WeldedShape

RADIUS = 0.015  # m


class HiddenObstacle(Effect):
    name = "hidden_obstacle"
    summary = "a fixed object that is not in the world model blocks the way"
    mechanism = "scene extra: a welded post of radius 15 mm at (x, y)"
    signature_text = ("abrupt onset in the middle of a push at the same place in several recordings; the real "
                      "object stalls or is deflected while the simulated one moves on")
    smooth = False

    def targets(self, world, odb, observed):
        surfaces = [support_of(world, odb, n) for n in observed if n in movable_objects(world, odb)]
        return tuple(dict.fromkeys(s for s in surfaces if s))

    def params(self, world, odb, target):
        surface = world.objects[target]
        hx, hy, _ = half_extents(odb.get(surface.type).geometry)
        cx, cy = surface.pose.xyz[:2]
        return (ParamSpec("x", cx - hx, cx + hx, cx + hx, 0.005, "m", "post centre, world x"),
                ParamSpec("y", cy - hy, cy + hy, cy + hy, 0.005, "m", "post centre, world y"))

    def contribute(self, world, odb, target, values):
        top = surface_top(world, odb, target)
        tallest = max([z_range(odb.get(o.type).geometry, o.pose)[1] for n, o in world.objects.items()
                       if not odb.get(o.type).fixed] + [top + 0.05])
        height = tallest - top + 0.05
        post = WeldedShape("hidden_obstacle", "cylinder", (RADIUS, height), (values["x"], values["y"], top + height / 2),
                           friction=0.5)
        return Contribution(extras=(post,))

    def signature(self, evidence: Evidence, target: str) -> float:
        late = [f for f in evidence.significant() if f.get("onset_rel") is not None and f["onset_rel"] > 0.1]
        if not late:
            return 0.1
        stall = float(np.mean([1.0 - min(1.0, f.get("stall", 1.0)) for f in late]))
        return min(1.0, 0.3 + 0.3 * len(late) / max(1, len(evidence.significant())) + 0.4 * stall)

    def seeds(self, evidence: Evidence, target: str) -> list[dict[str, float]]:
        spots = []
        for f in evidence.significant():
            if f.get("onset_rel") is None or f["onset_rel"] <= 0.05 or f.get("onset_xy_obs") is None:
                continue
            d = np.asarray(f["direction"])
            spots.append(np.asarray(f["onset_xy_obs"]) + d * (f.get("reach", 0.05) + RADIUS))
        if not spots:
            return []
        spots = np.array(spots)
        out = [np.median(spots, axis=0)] + [s for s in spots[:3]]
        seeds, seen = [], []
        for s in out:
            if all(np.linalg.norm(s - q) > 0.01 for q in seen):
                seen.append(s)
                seeds.append({"x": float(s[0]), "y": float(s[1])})
        return seeds[:3]
