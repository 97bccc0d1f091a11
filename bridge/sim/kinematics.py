"""Arm kinematics in Drake for action bodies: an IK-only plant per robot (the arm and the fixtures), inverse
kinematics, and a clearance check against a world's objects.

The IK plant holds no movable object, so it is built once per robot placement and fixture layout and cached; the
clearance checker holds the world's objects as fixed geometry and is cached per object layout.
"""
from __future__ import annotations

from functools import lru_cache
from typing import Sequence

import numpy as np
from pydrake.geometry import ProximityProperties
from pydrake.math import RotationMatrix
from pydrake.multibody.inverse_kinematics import InverseKinematics
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.solvers import Solve
from pydrake.systems.framework import DiagramBuilder

from ..errors import ActionError
from ..odb import ObjectDatabase
from ..values import Pose
from ..world import WorldState
from .scene import add_models, to_drake
from .shapes import drake_shape


# --- the IK plant ---------------------------------------------------------------------------------
class Arm:
    """A robot arm alone with the fixtures (no movable object): forward and inverse kinematics."""

    def __init__(self, model: str, base_link: str, base: Pose, joints: tuple[str, ...],
                 fixtures: tuple[tuple[str, object, Pose], ...]):
        builder = DiagramBuilder()
        plant, _ = AddMultibodyPlant(MultibodyPlantConfig(time_step=0.0), builder)
        (instance,) = add_models(Parser(plant, "ik_arm"), model)
        plant.WeldFrames(plant.world_frame(), plant.GetFrameByName(base_link, instance), to_drake(base))
        for name, shape, pose in fixtures:
            plant.RegisterCollisionGeometry(plant.world_body(), to_drake(pose), shape, f"{name}/ik",
                                            _proximity())
        plant.Finalize()
        self.diagram = builder.Build()
        self.plant = plant
        self.instance = instance
        self.joints = joints
        self.model, self.base_link, self.base = model, base_link, base
        self.context = self.diagram.CreateDefaultContext()
        self.plant_context = plant.GetMyMutableContextFromRoot(self.context)
        starts = [plant.GetJointByName(j, instance).position_start() for j in joints]
        if sorted(starts) != list(range(plant.num_positions())):
            raise ActionError(f"robot model {model}: the joints {list(joints)} are not all its positions")
        self.index = np.asarray(starts)  # plant position of each joint in telemetry order
        self.lower = plant.GetPositionLowerLimits()[self.index]
        self.upper = plant.GetPositionUpperLimits()[self.index]

    def has_frame(self, name: str) -> bool:
        return self.plant.HasFrameNamed(name, self.instance)

    def frame(self, name: str):
        return self.plant.GetFrameByName(name, self.instance)

    def to_plant(self, q: np.ndarray) -> np.ndarray:
        out = np.zeros(self.plant.num_positions())
        out[self.index] = q
        return out

    def from_plant(self, q_plant: np.ndarray) -> np.ndarray:
        return np.asarray(q_plant)[self.index]

    def pose(self, q: np.ndarray, frame: str) -> tuple[np.ndarray, np.ndarray]:
        """Position and rotation matrix of `frame` at joint positions `q` (telemetry order)."""
        self.plant.SetPositions(self.plant_context, self.to_plant(q))
        X = self.frame(frame).CalcPoseInWorld(self.plant_context)
        return X.translation().copy(), X.rotation().matrix().copy()

    def solve(self, p: Sequence[float], R: np.ndarray, frame: str, *, seed: np.ndarray, nominal: np.ndarray,
              fingers: float, finger_joints: Sequence[int], min_distance: float | None = None,
              tolerance: float = 0.01, weights: np.ndarray | None = None) -> np.ndarray | None:
        """Joint positions putting `frame` at `p` with rotation `R` (within `tolerance` rad), fingers at
        `fingers`, close to `nominal`; None when the solver fails."""
        ik = InverseKinematics(self.plant, self.plant_context)
        W = self.plant.world_frame()
        target = np.asarray(p, dtype=float)
        ik.AddPositionConstraint(self.frame(frame), np.zeros(3), W, target - 1e-4, target + 1e-4)
        ik.AddOrientationConstraint(W, RotationMatrix(R), self.frame(frame), RotationMatrix(), tolerance)
        if min_distance is not None:
            ik.AddMinimumDistanceLowerBoundConstraint(min_distance, 0.05)
        q = ik.q()
        prog = ik.prog()
        for i in finger_joints:
            prog.AddBoundingBoxConstraint(fingers, fingers, q[self.index[i]])
        w = np.ones(len(self.joints)) if weights is None else weights
        for i in finger_joints:
            w[i] = 0.0
        W_plant = np.zeros(self.plant.num_positions())
        W_plant[self.index] = w
        prog.AddQuadraticErrorCost(np.diag(W_plant), self.to_plant(nominal), q)
        prog.SetInitialGuess(q, self.to_plant(seed))
        result = Solve(prog)
        if not result.is_success():
            return None
        return self.from_plant(result.GetSolution(q))


def _proximity() -> ProximityProperties:
    return ProximityProperties()


def arm_for(world: WorldState, odb: ObjectDatabase) -> Arm:
    """The cached IK plant of the world's robot at its base pose, with the world's fixtures."""
    if world.robot is None:
        raise ActionError(f"world {world.name!r} has no robot to move")
    spec = odb.get(world.robot.type).robot
    fixtures = tuple(sorted((n, o.type, o.pose) for n, o in world.objects.items() if odb.get(o.type).fixed))
    return _arm(str(spec.model), spec.base_link, world.robot.base_pose, spec.joints, fixtures, odb)


@lru_cache(maxsize=8)
def _arm(model: str, base_link: str, base: Pose, joints: tuple[str, ...], fixtures, odb: ObjectDatabase) -> Arm:
    return Arm(model, base_link, base, joints, tuple((n, drake_shape(odb.get(t)), p) for n, t, p in fixtures))


# --- clearance -----------------------------------------------------------------------------------
class Clearance:
    """The arm among a world's objects (all fixed where the world has them): distances from the arm to each."""

    def __init__(self, arm: Arm, objects: tuple[tuple[str, object, Pose], ...], reach: float = 0.1):
        builder = DiagramBuilder()
        plant, scene_graph = AddMultibodyPlant(MultibodyPlantConfig(time_step=0.0), builder)
        (instance,) = add_models(Parser(plant, "clearance_arm"), arm.model)
        plant.WeldFrames(plant.world_frame(), plant.GetFrameByName(arm.base_link, instance), to_drake(arm.base))
        self.names = {}
        for name, shape, pose in objects:
            gid = plant.RegisterCollisionGeometry(plant.world_body(), to_drake(pose), shape, f"{name}/clearance",
                                                  _proximity())
            self.names[gid] = name
        plant.Finalize()
        self.diagram = builder.Build()
        self.plant, self.scene_graph = plant, scene_graph
        self.context = self.diagram.CreateDefaultContext()
        self.plant_context = plant.GetMyMutableContextFromRoot(self.context)
        self.sg_context = scene_graph.GetMyContextFromRoot(self.context)
        self.arm = arm
        self.reach = reach
        self.link_of = {}
        inspector = scene_graph.model_inspector()
        for gid in inspector.GetAllGeometryIds():
            body = plant.GetBodyFromFrameId(inspector.GetFrameId(gid))
            if body is not None and body.model_instance() == instance:
                self.link_of[gid] = body.name()

    def distances(self, q: np.ndarray) -> dict[str, tuple[float, str]]:
        """Per object (within `reach`): the smallest distance to the arm and the link that comes closest."""
        self.plant.SetPositions(self.plant_context, self.arm.to_plant(q))
        query = self.scene_graph.get_query_output_port().Eval(self.sg_context)
        found: dict[str, tuple[float, str]] = {}
        for pair in query.ComputeSignedDistancePairwiseClosestPoints(self.reach):
            ids = (pair.id_A, pair.id_B)
            obj = next((self.names[i] for i in ids if i in self.names), None)
            link = next((self.link_of[i] for i in ids if i in self.link_of), None)
            if obj is None or link is None:
                continue
            if obj not in found or pair.distance < found[obj][0]:
                found[obj] = (float(pair.distance), link)
        return found


def clearance_for(world: WorldState, odb: ObjectDatabase) -> Clearance:
    arm = arm_for(world, odb)
    objects = tuple(sorted((n, o.type, o.pose) for n, o in world.objects.items()))
    return _clearance(arm, objects, odb)


@lru_cache(maxsize=8)
def _clearance(arm: Arm, objects, odb: ObjectDatabase) -> Clearance:
    return Clearance(arm, tuple((n, drake_shape(odb.get(t)), p) for n, t, p in objects))
