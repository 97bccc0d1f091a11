"""Contacts of a running simulation, named as inference and diagnosis read them: object names, 'robot/link' for
robot links, 'world' for anything else (the floor, extras)."""
from __future__ import annotations

from typing import Sequence

import numpy as np

from ..values import Contact
from .scene import Scene

PROXIMITY = 0.004  # m: bodies this close count as touching for the final state


class ContactReader:
    """Names the bodies of Drake's contact results: object names, or 'robot/link' for robot links."""

    def __init__(self, scene: Scene):
        self.scene = scene
        inspector = scene.scene_graph.model_inspector()
        self.geometry_names = {gid: name for name, gids in scene.geometries.items() for gid in gids}
        for gid in inspector.GetAllGeometryIds():
            if gid not in self.geometry_names:
                body = scene.plant.GetBodyFromFrameId(inspector.GetFrameId(gid))
                if body is not None and body.index() in scene.body_names:
                    self.geometry_names[gid] = scene.body_names[body.index()]

    def name(self, gid) -> str:
        return self.geometry_names.get(gid, "world")

    def read(self, context, t: float, proximity: float = 0.0) -> list[Contact]:
        plant = self.scene.plant
        plant_ctx = plant.GetMyContextFromRoot(context)
        results = plant.get_contact_results_output_port().Eval(plant_ctx)
        contacts = []
        for i in range(results.num_hydroelastic_contacts()):
            info = results.hydroelastic_contact_info(i)
            surface = info.contact_surface()
            force = info.F_Ac_W().translational()
            contacts.append(Contact(self.name(surface.id_M()), self.name(surface.id_N()), tuple(-force),
                                    tuple(surface.centroid()), t))
        for i in range(results.num_point_pair_contacts()):
            info = results.point_pair_contact_info(i)
            pair = info.point_pair()
            contacts.append(Contact(self.name(pair.id_A), self.name(pair.id_B), tuple(info.contact_force()),
                                    tuple(info.contact_point()), t))
        if proximity > 0:
            seen = {frozenset((c.body_a, c.body_b)) for c in contacts}
            query = self.scene.scene_graph.get_query_output_port().Eval(self.scene.scene_graph.GetMyContextFromRoot(context))
            for pair in self._near_pairs(query, proximity):
                a, b = self.name(pair.id_A), self.name(pair.id_B)
                if a != b and frozenset((a, b)) not in seen:
                    contacts.append(Contact(a, b, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), t))
        return [c for c in contacts if c.body_a != c.body_b]

    def force_on(self, contacts: Sequence[Contact], robot: str) -> np.ndarray:
        """The net contact force (world frame, N) on the robot's links from everything that is not the robot:
        what a force-torque sensor between the robot and its tool would read."""
        total = np.zeros(3)
        for c in contacts:
            a_robot, b_robot = (b == robot or b.startswith(robot + "/") for b in (c.body_a, c.body_b))
            if b_robot and not a_robot:
                total += c.force
            elif a_robot and not b_robot:
                total -= c.force
        return total

    def _near_pairs(self, query, proximity: float) -> list:
        """Signed distances of the pairs closer than `proximity`. Drake has no distance query for some shape
        pairs (a convex mesh and the floor's half space): then pair by pair, skipping the unsupported ones."""
        try:
            return list(query.ComputeSignedDistancePairwiseClosestPoints(proximity))
        except RuntimeError:
            pass
        pairs = []
        for id_a, id_b in self.scene.scene_graph.model_inspector().GetCollisionCandidates():
            try:
                pair = query.ComputeSignedDistancePairClosestPoints(id_a, id_b)
            except RuntimeError:
                continue
            if pair.distance <= proximity:
                pairs.append(pair)
        return pairs


def contacts_at_start(scene: Scene, world, values=None) -> list[Contact]:
    """The contacts and near pairs of `world` as it stands, before anything is simulated."""
    return ContactReader(scene).read(scene.new_context(world, values), 0.0, proximity=PROXIMITY)
