"""`surface_tilt`: the support surface is not level.

Modelled as the tangential part of gravity, a constant force m g sin(theta) downhill on every free object on
the surface (the normal force's cos(theta) change is left out: 0.1 % at 3 deg). Parameters are the slope
components (rad): downhill direction atan2(slope_y, slope_x), angle hypot(slope_x, slope_y).
"""
from __future__ import annotations

import math

import numpy as np

from .base import Contribution, Effect, Evidence, ParamSpec, movable_objects, support_of, supported_by

G = 9.81


class SurfaceTilt(Effect):
    name = "surface_tilt"
    summary = "the support surface is tilted"
    mechanism = "scene values: a constant external force m g sin(theta) downhill on each object on the surface"
    signature_text = ("drift in one world direction in every recording, whatever the push direction, from the "
                      "first contact on; observed tilt of resting objects when tilt is measured")

    def targets(self, world, odb, observed):
        surfaces = [support_of(world, odb, n) for n in observed if n in movable_objects(world, odb)]
        return tuple(dict.fromkeys(s for s in surfaces if s))

    def params(self, world, odb, target):
        return (ParamSpec("slope_x", -0.15, 0.15, 0.0, 0.01, "rad", "downhill component along world x"),
                ParamSpec("slope_y", -0.15, 0.15, 0.0, 0.01, "rad", "downhill component along world y"))

    def contribute(self, world, odb, target, values):
        s = np.array([values["slope_x"], values["slope_y"]])
        theta = float(np.linalg.norm(s))
        if theta == 0.0:
            return Contribution()
        direction = s / theta
        forces = []
        for name in supported_by(world, odb, target):
            m = odb.mass_properties(world.objects[name].type).mass
            f = m * G * math.sin(theta) * direction
            forces.append((name, (float(f[0]), float(f[1]), 0.0)))
        return Contribution(forces=tuple(forces))

    def describe(self, world, odb, target, values):
        return {"tilt_deg": math.degrees(math.hypot(values["slope_x"], values["slope_y"])),
                "downhill_deg": math.degrees(math.atan2(values["slope_y"], values["slope_x"]))}

    def signature(self, evidence: Evidence, target: str) -> float:
        dirs = [np.asarray(f["world_dir"]) for f in evidence.significant() if f.get("world_dir") is not None]
        consistency = float(np.linalg.norm(np.mean(dirs, axis=0))) if len(dirs) >= 2 else 0.3
        early = 1.0 - min(1.0, max(0.0, evidence.mean("onset_rel", 0.0)))
        tilt = min(1.0, 2.0 * evidence.mean("tilt"))
        return min(1.0, 0.15 + 0.5 * consistency * early + 0.35 * tilt)
