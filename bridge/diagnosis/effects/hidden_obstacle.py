"""`hidden_obstacle`: a fixed object that is not in the world model (a clamp, a cable, a forgotten part).

Modelled as a welded upright post of radius `OBSTACLE_RADIUS` at (x, y) on the surface
(`bridge.params.kinds.Obstacle`): a scene extra, so each position is a new scene (building one takes a few tens
of milliseconds).
"""
from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq, least_squares

from ...odb.geometry import half_extents
from ...params.kinds import OBSTACLE_RADIUS
from ...params.surfaces import surfaces_under
from ...recording.mitpush import signed_distance
from ...sim.extras import WeldedShape
from .base import Effect, Evidence, Recovery, Truth, pname

SIZES = (0.02, 0.03, 0.045)  # m: the proof's boxes (small, medium, large)
LATERAL = 0.015  # m: seeds beside the jam's spot, across the push (a post's radius)
TOUCH = 0.004  # m: how far off every jammed pose the one post may lie (the poses' noise and the outline's
#               modelling error, a few millimetres; beyond, the jams met different sides or different posts)


class HiddenObstacle(Effect):
    name = "hidden_obstacle"
    summary = "a fixed object that is not in the world model blocks the way"
    mechanism = "scene extra: a welded post of radius 15 mm at (x, y)"
    signature_text = ("abrupt onset in the middle of a push at the same place in several recordings; the real "
                      "object stalls or is deflected while the simulated one moves on")
    smooth = False
    local = True
    kinds = ("obstacle_x", "obstacle_y")

    def targets(self, world, odb, observed):
        return surfaces_under(world, odb, observed)

    def signature(self, evidence: Evidence, target: str) -> float:
        if any(f.get("jam_xy_obs") is not None for f in evidence.features):
            return 0.9  # the robot's force jammed in some recording: something held the object back
        late = [f for f in evidence.significant() if f.get("onset_rel") is not None and f["onset_rel"] > 0.1]
        if not late:
            return 0.1
        stall = float(np.mean([1.0 - min(1.0, f.get("stall", 1.0)) for f in late]))
        return min(1.0, 0.3 + 0.3 * len(late) / max(1, len(evidence.significant())) + 0.4 * stall)

    def seeds(self, evidence: Evidence, target: str) -> list[dict[str, float]]:
        """Posts touching the real objects' leading sides where the robot's force jammed (the surest sign: a rod
        held back by the object it pushes; with two jams or more, the one point that touches every jammed pose
        first), else where their residual began mid-push: the median spot and the first few.

        Touching, not beyond the farthest point: a post placed where the simulated object never reaches changes
        no residual, so a screen or a fit cannot move it (the mismatched proof's post 14 mm beyond a square
        turned 14 degrees stayed `none`). Each spot lies straight ahead of the object's origin along its push,
        one post radius off the outline at the observed pose (`_ahead`, `_touching_all`)."""
        outline = _outline(evidence)
        jams = [f for f in evidence.features if f.get("jam_xy_obs") is not None]
        spots = [_across(outline, f) if f.get("jam_force_dir") is not None and outline is not None else
                 _ahead(outline, f["jam_xy_obs"], f.get("jam_yaw_obs"), f["direction"], f["jam_reach"]) for f in jams]
        met = _touching_all(outline, jams, np.median(spots, axis=0)) if len(jams) >= 2 else None
        if met is not None:
            spots.insert(0, met)
        for f in evidence.significant() if not spots else ():
            if f.get("onset_rel") is None or f["onset_rel"] <= 0.05 or f.get("onset_xy_obs") is None:
                continue
            spots.append(_ahead(outline, f["onset_xy_obs"], f.get("onset_yaw_obs"), f["direction"],
                                f.get("reach", 0.05)))
        if not spots:
            return []
        spots = np.array(spots)
        middle = met if met is not None else np.median(spots, axis=0)
        candidates = [middle] + list(spots[:3])
        if jams:  # the post may touch the leading side anywhere along it: beside the first spot too
            d = np.mean([f["direction"] for f in jams], axis=0)
            e = np.array([-d[1], d[0]]) / (np.linalg.norm(d) or 1.0)
            candidates[1:1] = [middle + LATERAL * e, middle - LATERAL * e]
        seeds, seen = [], []
        for s in candidates:
            if all(np.linalg.norm(s - q) > 0.01 for q in seen):
                seen.append(s)
                seeds.append({pname("obstacle_x", target): float(s[0]), pname("obstacle_y", target): float(s[1])})
        return seeds[:5 if jams else 3]

    # --- the proof: a welded box of random size and yaw; the model places a post ------------------------------
    def draw_truth(self, scene, odb, rng, magnitude, sign):
        size = SIZES[magnitude]
        reach = half_extents(odb.get(scene.object_type).geometry)[0]
        x = scene.centre[0] + reach + 0.055 + size / 2 + rng.uniform(-0.01, 0.01)
        y = scene.centre[1] + rng.uniform(-0.025, 0.025)
        s = scene.surface
        shape, aspect = "box", 1.0
        if getattr(scene, "varied", False):  # the mismatched proof: boxes of other proportions, round posts
            shape = ("box", "cylinder")[int(rng.integers(2))]
            aspect = rng.uniform(0.5, 2.0) if shape == "box" else 1.0
        return Truth(self.name, s, {pname("obstacle_x", s): x, pname("obstacle_y", s): y}, f"a welded {shape}",
                     {"size": size, "yaw": rng.uniform(-0.8, 0.8), "shape": shape, "aspect": aspect})

    def conceal(self, truth, scene, odb, rollout):
        top = scene.surface_xyz[2] + half_extents(odb.get(scene.surface_type).geometry)[2]
        s, size = scene.surface, truth.extra["size"]
        xyz = (truth.params[pname("obstacle_x", s)], truth.params[pname("obstacle_y", s)], top + 0.03)
        if truth.extra.get("shape") == "cylinder":
            body = WeldedShape("obstacle", "cylinder", (size / 2, 0.06), xyz, friction=0.5)
        else:
            body = WeldedShape("obstacle", "box", (size, size * truth.extra.get("aspect", 1.0), 0.06), xyz,
                               (0.0, 0.0, truth.extra["yaw"]), friction=0.5)
        return rollout.with_extras(body), rollout.telemetry

    def recovered(self, truth, found, model, world, odb):
        x, y = pname("obstacle_x", truth.target), pname("obstacle_y", truth.target)
        d = math.hypot(found[x] - truth.params[x], found[y] - truth.params[y])
        return Recovery(d <= 0.025, d, "m", f"post {d * 1e3:.0f} mm from the box centre (25 mm)")


def _outline(evidence: Evidence) -> np.ndarray | None:
    """The focus object's outline (object frame), None when it is no prism or unknown."""
    from ...rollout.trials import shape_outline

    name = next((f.get("object") for f in evidence.features if f.get("object")), None)
    if name is None or name not in evidence.world.objects:
        return None
    return shape_outline(evidence.world.objects[name].type, evidence.odb)


def _gap(outline: np.ndarray, xy, yaw: float, point: np.ndarray) -> float:
    """The distance of a post centred at `point` from the outline at pose (xy, yaw), less the post's radius."""
    c, s = math.cos(yaw), math.sin(yaw)
    v = np.asarray(point, dtype=float) - np.asarray(xy, dtype=float)
    local = np.array([[c * v[0] + s * v[1], -s * v[0] + c * v[1]]])
    return float(signed_distance(local, outline)[0]) - OBSTACLE_RADIUS


def _ahead(outline: np.ndarray | None, xy, yaw: float | None, direction, reach: float, origin=None) -> np.ndarray:
    """The post straight ahead of `origin` (default: the object's origin) along `direction` that just touches the
    outline at pose (xy, yaw); without an outline (or a pose), `reach` (the farthest reach along the push) plus a
    radius."""
    xy, d = np.asarray(xy, dtype=float), np.asarray(direction, dtype=float)
    start = xy if origin is None else np.asarray(origin, dtype=float)
    far = reach + OBSTACLE_RADIUS
    if outline is None or yaw is None:
        return start + d * far

    def gap(t: float) -> float:
        return _gap(outline, xy, yaw, start + t * d)
    if gap(0.0) >= 0.0 or gap(far + 0.01) <= 0.0:  # the start too far outside the outline: no ray to follow
        return start + d * far
    return start + d * brentq(gap, 0.0, far + 0.01, xtol=1e-4)


def _across(outline: np.ndarray, jam: dict) -> np.ndarray:
    """The post on the line of the rod's force that just touches the jammed object's outline beyond it (`locate.
    _jam_line`: a squeezed object balances the rod's force against the obstacle's along one line)."""
    span = 2.0 * float(np.max(np.linalg.norm(outline, axis=1))) + OBSTACLE_RADIUS + 0.01
    return _ahead(outline, jam["jam_xy_obs"], jam["jam_yaw_obs"], jam["jam_force_dir"], span,
                  origin=jam["jam_rod_xy"])


def _touching_all(outline: np.ndarray | None, jams, start: np.ndarray) -> np.ndarray | None:
    """The post that touches every jammed pose (least squares on the gaps), None without an outline, when no
    point comes within TOUCH of all of them or it lies behind one of the pushes."""
    if outline is None or any(f.get("jam_yaw_obs") is None for f in jams):
        return None
    found = least_squares(lambda p: [_gap(outline, f["jam_xy_obs"], f["jam_yaw_obs"], p) for f in jams],
                          np.asarray(start, dtype=float), x_scale=0.01)
    p = found.x
    if np.max(np.abs(found.fun)) > TOUCH:
        return None
    if any(float(np.dot(p - np.asarray(f["jam_xy_obs"]), f["direction"])) <= 0.0 for f in jams):
        return None
    return p
