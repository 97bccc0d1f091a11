"""`friction_patch`: a region of the support surface has a different friction coefficient (a worn, wet,
taped or different-material area).

Modelled as a scene extra (`bridge.params.kinds.Patch`): a micrometre-thin sheet over a rectangle (centre cx, cy,
`half` its length along its `yaw` direction, `breadth` half its breadth across) with its own coefficient `mu`;
an object over it rests on the sheet, so the pair's coefficient there is 2 mu mu_object / (mu + mu_object), and
an object straddling its edge feels the two coefficients side by side (the torque a uniform blend would miss).
A new scene per value (11-15 ms to build); its replay costs 1.4-1.6 times one without the sheet (its second
support contact; real rect1, ellip1 and hex pushes, session 60).
"""
from __future__ import annotations

import numpy as np

from ...odb.geometry import half_extents, support
from ...params.surfaces import supported_by, surfaces_under
from ...sim.extras import SurfacePatch
from ...sim.friction import combined_friction, surface_friction_for
from ...values import Pose
from .base import Effect, Evidence, Recovery, Truth, model_friction, pname

HIGHER = (1.2, 1.32, 1.44)  # the proof's pair coefficient inside, times this (small, medium, large) ...
LOWER = (0.78, 0.66, 0.56)  # ... or this
# the seeds' rectangles (half along the way, half breadth across), m: as far as pushes of a few centimetres reach
# (a half-plane to them), a strip they cross, a square they enter
SHAPES = ((0.15, 0.15), (0.025, 0.12), (0.06, 0.06))
TURN = 0.5  # rad: the mismatched proof's sheets are turned up to this about the start area
SWEPT = (0.25, 0.6)  # shares of the objects' median travel at which the swept seeds' edges meet their leading sides


def _object_mu(world, odb, surface: str) -> float:
    objects = supported_by(world, odb, surface)
    return odb.get(world.objects[objects[0]].type).physics.friction if objects else 0.5


class FrictionPatch(Effect):
    name = "friction_patch"
    summary = "part of the support surface has a different friction coefficient"
    mechanism = "scene extra: a 1 um sheet with its own coefficient over a turned rectangle of the surface"
    signature_text = ("onset in the middle of a push, when the object reaches the same place in several "
                      "recordings; the object keeps moving (no stall), it turns or slides on differently")
    smooth = False
    local = True
    kinds = ("patch_cx", "patch_cy", "patch_half", "patch_breadth", "patch_yaw", "patch_mu")

    def targets(self, world, odb, observed):
        return surfaces_under(world, odb, observed)

    def _pair(self, world, odb, target) -> float:
        objects = supported_by(world, odb, target)
        mu_s = odb.get(world.objects[target].type).physics.friction
        mu_o = odb.get(world.objects[objects[0]].type).physics.friction if objects else mu_s
        return combined_friction(mu_o, mu_s)

    def describe(self, world, odb, target, values):
        objects = supported_by(world, odb, target)
        mu = values[pname("patch_mu", target)]
        mu_o = odb.get(world.objects[objects[0]].type).physics.friction if objects else mu
        return {"pair_mu_inside": combined_friction(mu_o, mu)}

    def signature(self, evidence: Evidence, target: str) -> float:
        late = [f for f in evidence.significant() if f.get("onset_rel") is not None and f["onset_rel"] > 0.15]
        if not late:
            return 0.1
        stall = evidence.mean("stall", 0.0)
        return min(1.0, 0.3 + 0.5 * len(late) / max(1, len(evidence.significant())) + 0.2 * (1.0 - stall))

    def seeds(self, evidence: Evidence, target: str) -> list[dict[str, float]]:
        """Rectangles turned to face the way the objects went, beginning where their leading edges were at the
        onsets (the median entry point and the first single one): a half-plane (as far as the pushes go), a strip
        across the way and a square, each with a lower and a higher coefficient. Real regions of other friction
        (a mat's edge, tape, a wet spot) lie at any angle: an axis-aligned square meets an oblique edge too early
        on one side and too late on the other. Where no residual began mid-push, the same rectangles begin across
        the way the objects went, part of their travel ahead (`_swept_entries`)."""
        mu_bounds = next(p.bounds for p in self.parameters(evidence.world, evidence.odb, target)
                         if p.kind.name == "patch_mu")
        pair = self._pair(evidence.world, evidence.odb, target)
        mu_o = _object_mu(evidence.world, evidence.odb, target)
        late = [f for f in evidence.significant()
                if f.get("onset_rel") is not None and f["onset_rel"] > 0.1 and f.get("onset_xy_sim") is not None]
        if late:
            entries = [(np.asarray(f["onset_xy_sim"]) + np.asarray(f["direction"]) * f.get("reach", 0.05),
                        np.asarray(f["direction"])) for f in late]
            points = [(np.median([e for e, _ in entries], axis=0), np.mean([d for _, d in entries], axis=0))]
            points += entries[:1]
        else:
            points = _swept_entries(evidence)
        if not points:
            return []
        out = []
        for point, d in points:
            d = d / (np.linalg.norm(d) or 1.0)
            yaw = float(np.arctan2(d[1], d[0]))
            for half, breadth in SHAPES:
                c = point + d * half
                for factor in (0.55, 1.45):
                    mu = float(np.clip(surface_friction_for(factor * pair, mu_o), *mu_bounds))
                    out.append({pname("patch_cx", target): float(c[0]), pname("patch_cy", target): float(c[1]),
                                pname("patch_half", target): half, pname("patch_breadth", target): breadth,
                                pname("patch_yaw", target): yaw, pname("patch_mu", target): mu})
        return out

    # --- the proof: a sheet of another material flush on the surface over a rectangle (objects on it press on
    #     sheet and surface, so the pair coefficient there is the mean of the two pairs') ------------------------
    def draw_truth(self, scene, odb, rng, magnitude, sign):
        mu_obj = odb.get(scene.object_type).physics.friction
        mu_surf = odb.get(scene.surface_type).physics.friction
        pair0 = combined_friction(mu_obj, mu_surf)
        pair = pair0 * (HIGHER[magnitude] if sign > 0 else LOWER[magnitude])
        pair_sheet = 2 * pair - pair0
        mu_tile = pair_sheet * mu_obj / (2 * mu_obj - pair_sheet)
        # a rectangle ahead of the start area on one side: about half of the pushes run into it
        x0 = scene.centre[0] + rng.uniform(0.03, 0.06)
        x1 = x0 + rng.uniform(0.25, 0.35)
        edge = scene.centre[1] + rng.uniform(-0.02, 0.02)
        y0, y1 = (edge, edge + 0.4) if rng.random() < 0.5 else (edge - 0.4, edge)
        shape, turn = "half", 0.0
        if getattr(scene, "varied", False):  # the mismatched proof: a half-plane, a strip across the way, a square
            shape = ("half", "strip", "square")[int(rng.integers(3))]
            if shape == "strip":
                x1 = x0 + rng.uniform(0.03, 0.06)
                y0, y1 = scene.centre[1] - 0.4, scene.centre[1] + 0.4
            elif shape == "square":
                half = rng.uniform(0.03, 0.06)
                cx, cy = scene.centre[0] + rng.uniform(0.06, 0.1), scene.centre[1] + rng.uniform(-0.03, 0.03)
                x0, x1, y0, y1 = cx - half, cx + half, cy - half, cy + half
            # turned about the start area, as real regions lie at any angle to the pushes (drawn from a child
            # generator: every other draw of the world stays as it was)
            turn = float(rng.spawn(1)[0].uniform(-TURN, TURN))
            mid = np.array([(x0 + x1) / 2, (y0 + y1) / 2])
            c, s = np.cos(turn), np.sin(turn)
            dx, dy = np.asarray(scene.centre[:2]) + np.array([[c, -s], [s, c]]) @ (mid - scene.centre[:2]) - mid
            x0, x1, y0, y1 = x0 + dx, x1 + dx, y0 + dy, y1 + dy
        return Truth(self.name, scene.surface, {"pair_mu_inside": pair, "x0": x0},
                     f"a thin sheet of another material on the surface ({shape}, turned {np.degrees(turn):.0f} deg)",
                     {"region": [x0, x1, y0, y1], "tile_mu": mu_tile, "shape": shape, "turn": turn})

    def conceal(self, truth, scene, odb, rollout):
        top = scene.surface_xyz[2] + half_extents(odb.get(scene.surface_type).geometry)[2]
        sheet = SurfacePatch("sheet", tuple(truth.extra["region"]), top, truth.extra["tile_mu"],
                             yaw=truth.extra.get("turn", 0.0))
        return rollout.with_extras(sheet), rollout.telemetry

    def recovered(self, truth, found, model, world, odb):
        obj = next(n for n, o in world.objects.items() if not odb.get(o.type).fixed)
        pair = combined_friction(model_friction(model, world, odb, obj), found[pname("patch_mu", truth.target)])
        true = truth.params["pair_mu_inside"]
        err = abs(pair - true)
        return Recovery(err <= 0.3 * true, err, "", f"pair mu inside {pair:.3f} vs {true:.3f} (30 %)")


def _swept_entries(evidence: Evidence) -> list[tuple[np.ndarray, np.ndarray]]:
    """Entries of a patch no onset placed: the median of the objects' leading points at the start of their
    recorded paths, moved SWEPT shares of their median travel along their mean way, with that way. A world that
    differs from the model from the first contact on (its contact, its servo, frictions far from the database's)
    carries a residual above the noise from that contact, so no onset marks where an object met the patch (every
    independent MuJoCo patch world, session 59: the patch had no seed and was never screened); a patch that
    changed a path lies where the objects went, and the screen and the fit move its edge from there."""
    leads, ways, travels = [], [], []
    for f in evidence.significant():
        poses, name = f.get("poses_obs"), f.get("object")
        if poses is None or name not in evidence.world.objects:
            continue
        poses = np.asarray(poses)
        way = poses[-1, :2] - poses[0, :2]
        travel = float(np.linalg.norm(way))
        if travel < 1e-3:  # the object barely moved: it met no edge on the way
            continue
        d = way / travel
        geometry = evidence.odb.get(evidence.world.objects[name].type).geometry
        start = Pose.from_rpy((poses[0, 0], poses[0, 1], 0.0), (0.0, 0.0, poses[0, 2]))
        reach = support(geometry, start, np.array([d[0], d[1], 0.0])) - float(poses[0, :2] @ d)
        leads.append(poses[0, :2] + reach * d)
        ways.append(d)
        travels.append(travel)
    if not leads:
        return []
    d = np.mean(ways, axis=0)
    d = d / (np.linalg.norm(d) or 1.0)
    lead, travel = np.median(leads, axis=0), float(np.median(travels))
    return [(lead + share * travel * d, d) for share in SWEPT]
