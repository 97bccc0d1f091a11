"""`pusher_offset`: the recorded robot position is offset from the true one (calibration, an encoder offset).

A robot with up to three joints (the planar pusher) is one target with one offset per joint; an arm has one
target per joint (`robot:joint`), so one encoder offset is fitted at a time.
"""
from __future__ import annotations

from dataclasses import replace

from .base import Contribution, Effect, Evidence, ParamSpec

FEW_JOINTS = 3


_KINDS: dict[tuple[str, str], dict[str, str]] = {}


def joint_kinds(world, odb) -> dict[str, str]:
    """'prismatic' or 'revolute' for each robot joint, read from the model once per robot type."""
    if world.robot is None:
        return {}
    key = (world.robot.type, str(odb.root))
    if key not in _KINDS:
        from ...sim.scene import build_scene

        robot_only = replace(world, objects={}, facts=frozenset())
        scene = build_scene(robot_only, odb)
        _KINDS[key] = {j: scene.plant.GetJointByName(j, scene.robot_instance).type_name() for j in scene.robot_joints}
    return _KINDS[key]


def _gripper(world, odb) -> set[str]:
    spec = odb.get(world.robot.type).robot
    return set(spec.gripper.joints) if spec.gripper else set()


class PusherOffset(Effect):
    name = "pusher_offset"
    summary = "the recorded robot position is offset from where the robot really was"
    mechanism = "telemetry transform: a constant offset added to joint positions"
    signature_text = ("residual from the first contact on, contact earlier or later than simulated; a "
                      "different contact point turns the object differently (across-push and yaw)")

    def targets(self, world, odb, observed):
        if world.robot is None:
            return ()
        joints = [j for j in odb.get(world.robot.type).robot.joints if j not in _gripper(world, odb)]
        if len(joints) <= FEW_JOINTS:
            return (world.robot.name,)
        return tuple(f"{world.robot.name}:{j}" for j in joints)

    def _joints(self, world, odb, target) -> list[str]:
        if ":" in target:
            return [target.split(":", 1)[1]]
        return [j for j in odb.get(world.robot.type).robot.joints if j not in _gripper(world, odb)]

    def params(self, world, odb, target):
        kinds = joint_kinds(world, odb)
        specs = []
        for j in self._joints(world, odb, target):
            if kinds.get(j) == "prismatic":
                specs.append(ParamSpec(j, -0.03, 0.03, 0.0, 0.002, "m", negligible=0.0005))
            else:
                specs.append(ParamSpec(j, -0.2, 0.2, 0.0, 0.01, "rad", negligible=0.002))
        return tuple(specs)

    def contribute(self, world, odb, target, values):
        return Contribution(joint_offsets=tuple((j, float(values[j])) for j in self._joints(world, odb, target)))

    def describe(self, world, odb, target, values):
        if ":" not in target and all(joint_kinds(world, odb).get(j) == "prismatic" for j in values):
            return {"offset_mm": 1e3 * sum(v * v for v in values.values()) ** 0.5}
        return {}

    def signature(self, evidence: Evidence, target: str) -> float:
        early = 1.0 - min(1.0, max(0.0, evidence.mean("onset_rel", 0.0)))
        return 0.2 + 0.4 * early + 0.2 * (evidence.mean("across") + evidence.mean("yaw"))
