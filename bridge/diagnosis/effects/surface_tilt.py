"""`surface_tilt`: the support surface is not level (or not at the height the world model says).

Modelled as a tilted surface (`bridge.params.kinds.SurfaceTilt`): the fixture and every free object standing on
it rotated about the point of its top above its centre so that it slopes downhill along (slope_x, slope_y) (rad;
angle hypot(slope_x, slope_y), downhill direction atan2(slope_y, slope_x)) and raised by `dz`. The objects keep
their x, y on the tilted top. A new scene per value (the fixture's pose is structure); building one takes a few
tens of milliseconds.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from scipy.spatial.transform import Rotation

from ...odb.geometry import half_extents
from ...params.surfaces import surfaces_under
from ...values import Pose
from .base import Effect, Evidence, Recovery, Truth, pname

ANGLES = (0.5, 1.0, 2.0)  # deg: the proof's tilts (small, medium, large)


class SurfaceTilt(Effect):
    name = "surface_tilt"
    summary = "the support surface is tilted"
    mechanism = "world poses: the fixture and what stands on it tilted (and raised by dz); a new scene per value"
    signature_text = ("drift in one world direction in every recording, whatever the push direction, from the "
                      "first contact on; observed tilt of resting objects when tilt is measured")
    kinds = ("surface_slope_x", "surface_slope_y", "surface_dz")
    reads_work = True

    def targets(self, world, odb, observed):
        return surfaces_under(world, odb, observed)

    def describe(self, world, odb, target, values):
        sx, sy = values[pname("surface_slope_x", target)], values[pname("surface_slope_y", target)]
        return {"tilt_deg": math.degrees(math.hypot(sx, sy)), "downhill_deg": math.degrees(math.atan2(sy, sx))}

    def signature(self, evidence: Evidence, target: str) -> float:
        dirs = [np.asarray(f["world_dir"]) for f in evidence.significant() if f.get("world_dir") is not None]
        consistency = float(np.linalg.norm(np.mean(dirs, axis=0))) if len(dirs) >= 2 else 0.3
        early = 1.0 - min(1.0, max(0.0, evidence.mean("onset_rel", 0.0)))
        tilt = min(1.0, 2.0 * evidence.mean("tilt"))
        return min(1.0, 0.15 + 0.5 * consistency * early + 0.35 * tilt)

    def seeds(self, evidence: Evidence, target: str) -> list[dict[str, float]]:
        """The level surface and, where the work the robot did reads a slope (`Evidence.slope`, `diagnosis.work`),
        that slope: a tilt's drift is a small share of a mismatched world's residual, so one Gauss-Newton step from
        level goes where the rest of the mismatch pulls (independent MuJoCo rect1, 1 deg: screened last from level,
        named and recovered to 0.2 deg from the work's seed)."""
        null = self.null_values(evidence.world, evidence.odb, target)
        if evidence.slope is None:
            return [null]
        x, y = pname("surface_slope_x", target), pname("surface_slope_y", target)
        lo, hi = next(p.bounds for p in self.parameters(evidence.world, evidence.odb, target) if p.name == x)
        sx, sy = (float(v) for v in np.clip(evidence.slope, lo, hi))
        return [null, {**null, x: sx, y: sy}]

    # --- the proof: the fixture really rotated, about a point of its top away from its centre ------------------
    def draw_truth(self, scene, odb, rng, magnitude, sign):
        theta = math.radians(ANGLES[magnitude])
        phi = rng.uniform(-math.pi, math.pi)
        sx, sy = theta * math.cos(phi), theta * math.sin(phi)
        # the model turns the fixture about its centre: it has to find the height change at the pivot too
        pivot = (scene.centre[0] + rng.uniform(-0.05, 0.05), scene.centre[1] + rng.uniform(-0.05, 0.05))
        dz = -((scene.surface_xyz[0] - pivot[0]) * math.tan(sx) + (scene.surface_xyz[1] - pivot[1]) * math.tan(sy))
        s = scene.surface
        return Truth(self.name, s, {pname("surface_slope_x", s): sx, pname("surface_slope_y", s): sy,
                                    pname("surface_dz", s): dz},
                     "the support fixture rotated", {"tilt_deg": math.degrees(theta), "downhill_deg": math.degrees(phi),
                                                     "pivot": list(pivot)})

    def conceal(self, truth, scene, odb, rollout):
        s = scene.surface
        sx, sy = truth.params[pname("surface_slope_x", s)], truth.params[pname("surface_slope_y", s)]
        theta = math.hypot(sx, sy)
        world = rollout.world
        if theta == 0:
            return rollout, rollout.telemetry
        R = Rotation.from_rotvec(np.array([-sy, sx, 0.0]) / theta * theta)  # the normal tilts toward downhill
        top = scene.surface_xyz[2] + half_extents(odb.get(scene.surface_type).geometry)[2]
        pivot = np.array([*truth.extra["pivot"], top])
        objects = dict(world.objects)
        for name in (scene.surface, scene.object):
            o = objects[name]
            xyz = R.apply(np.asarray(o.pose.xyz) - pivot) + pivot
            Rm = R.as_matrix() @ o.pose.rotation()
            objects[name] = replace(o, pose=Pose.from_matrix(np.vstack([np.column_stack([Rm, xyz]), [0, 0, 0, 1]])))
        return rollout.with_world(replace(world, objects=objects)), rollout.telemetry

    def recovered(self, truth, found, model, world, odb):
        x, y = pname("surface_slope_x", truth.target), pname("surface_slope_y", truth.target)
        d = math.hypot(found[x] - truth.params[x], found[y] - truth.params[y])
        size = math.hypot(truth.params[x], truth.params[y])
        return Recovery(d <= 0.3 * size + 0.005, d, "rad",
                        f"slope ({math.degrees(found[x]):.2f}, {math.degrees(found[y]):.2f}) vs "
                        f"({math.degrees(truth.params[x]):.2f}, {math.degrees(truth.params[y]):.2f}) deg "
                        f"(30 % + 0.3 deg)")
