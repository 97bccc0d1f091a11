"""Context hooks for `simulate_tracks`: physics that depends on where things are, written into the running context.

`FrictionRegion` models a region of a support surface with a different friction coefficient without new
geometry: while an object slides over the region, the surface's coefficient is rewritten so that the pair's
combined coefficient blends from the outside value to `pair_friction` with the fraction of the object's
footprint inside the region (a smooth function of the pose, so fits can follow it).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from pydrake.geometry import RoleAssign

from ..odb.geometry import half_extents
from .scene import ObjectParams, Scene, SceneParams, proximity

UPDATE_TOLERANCE = 0.002  # change of the surface coefficient below which the context is left alone


def combined_friction(a: float, b: float) -> float:
    """Drake's rule for two geometries' coefficients: 2 a b / (a + b)."""
    return 2.0 * a * b / (a + b) if a + b > 0 else 0.0


def surface_friction_for(pair: float, object_mu: float) -> float:
    """The surface coefficient that combines with `object_mu` to `pair` (capped: a pair cannot exceed 2 mu)."""
    pair = min(pair, 1.95 * object_mu)
    return pair * object_mu / (2.0 * object_mu - pair)


@dataclass(frozen=True)
class FrictionRegion:
    """An axis-aligned rectangle (centre, half sizes; world x, y) of `surface` where `objects` slide with the
    combined coefficient `pair_friction`."""

    surface: str
    objects: tuple[str, ...]
    centre: tuple[float, float]
    half: tuple[float, float]
    pair_friction: float
    grid: int = 7  # footprint samples per side

    def _mu(self, scene: Scene, params: SceneParams, name: str) -> float:
        p = params.objects.get(name, ObjectParams())
        return p.friction if p.friction is not None else scene.odb.get(scene.world.objects[name].type).physics.friction

    def start(self, scene: Scene, context, params: SceneParams) -> dict:
        footprints = {}
        for name in self.objects:
            geometry = scene.odb.get(scene.world.objects[name].type).geometry
            hx, hy, _ = half_extents(geometry)
            u = np.linspace(-1.0, 1.0, self.grid)
            gx, gy = np.meshgrid(u * hx, u * hy)
            footprints[name] = np.column_stack([gx.ravel(), gy.ravel()])
        surface_mu = self._mu(scene, params, self.surface)
        return {"params": params, "footprints": footprints, "surface_mu": surface_mu, "current": surface_mu,
                "outside": {n: combined_friction(self._mu(scene, params, n), surface_mu) for n in self.objects},
                "object_mu": {n: self._mu(scene, params, n) for n in self.objects}}

    def fraction(self, pose, footprint: np.ndarray) -> float:
        R = pose.rotation()
        points = footprint @ R[:2, :2].T + np.asarray(pose.xyz[:2])
        inside = (np.abs(points[:, 0] - self.centre[0]) <= self.half[0]) & (
            np.abs(points[:, 1] - self.centre[1]) <= self.half[1])
        return float(np.mean(inside))

    def update(self, scene: Scene, context, t: float, poses: dict, state: dict) -> None:
        best_name, best_fraction = None, 0.0
        for name in self.objects:
            if name in poses:
                f = self.fraction(poses[name], state["footprints"][name])
                if best_name is None or f > best_fraction:
                    best_name, best_fraction = name, f
        if best_name is None:
            return
        outside = state["outside"][best_name]
        pair = outside + (self.pair_friction - outside) * best_fraction
        mu = state["surface_mu"] if best_fraction == 0.0 else surface_friction_for(pair, state["object_mu"][best_name])
        if abs(mu - state["current"]) < UPDATE_TOLERANCE:
            return
        state["current"] = mu
        set_friction(scene, context, self.surface, mu, state["params"])


def set_friction(scene: Scene, context, name: str, mu: float, params: SceneParams) -> None:
    """Rewrite one object's (or fixture's) friction in a running context, keeping its other contact values."""
    obj_type = scene.odb.get(scene.world.objects[name].type)
    base = params.objects.get(name, ObjectParams())
    props = proximity(obj_type, scene.config, replace(base, friction=mu, dynamic_friction=mu))
    sg_ctx = scene.scene_graph.GetMyMutableContextFromRoot(context)
    for gid in scene.geometries[name]:
        scene.scene_graph.AssignRole(sg_ctx, scene.plant.get_source_id(), gid, props, RoleAssign.kReplace)
