"""`pusher_offset`: the recorded robot position is offset from the true one (calibration, an encoder offset).

A robot with up to three joints (the planar pusher) is one target with one offset per joint; an arm has one
target per joint (`robot:joint`), so one encoder offset is fitted at a time.
"""
from __future__ import annotations

import math
from dataclasses import replace

from ...values import Pose
from .base import Effect, Evidence, Recovery, Truth, pname

FEW_JOINTS = 3
SIZES = (0.002, 0.004, 0.008)  # m: the proof's base offsets (small, medium, large)


def _moving_joints(world, odb) -> list[str]:
    spec = odb.get(world.robot.type).robot
    gripper = set(spec.gripper.joints) if spec.gripper else set()
    return [j for j in spec.joints if j not in gripper]


class PusherOffset(Effect):
    name = "pusher_offset"
    summary = "the recorded robot position is offset from where the robot really was"
    mechanism = "telemetry transform: a constant offset added to joint positions"
    signature_text = ("residual from the first contact on, contact earlier or later than simulated; a "
                      "different contact point turns the object differently (across-push and yaw)")
    kinds = ("joint_offset",)

    def targets(self, world, odb, observed):
        if world.robot is None:
            return ()
        joints = _moving_joints(world, odb)
        if len(joints) <= FEW_JOINTS:
            return (world.robot.name,)
        return tuple(f"{world.robot.name}:{j}" for j in joints)

    def members(self, world, odb, target):
        joints = [target.split(":", 1)[1]] if ":" in target else _moving_joints(world, odb)
        return tuple(("joint_offset", j) for j in joints)

    def describe(self, world, odb, target, values):
        types = odb.get(world.robot.type).robot.joint_type
        if ":" not in target and all(types.get(j) == "prismatic" for _, j in self.members(world, odb, target)):
            return {"offset_mm": 1e3 * math.sqrt(sum(v * v for v in values.values()))}
        return {}

    def signature(self, evidence: Evidence, target: str) -> float:
        """Early onset, across-push and yaw residual; raised towards 1 by the share of recordings whose rod
        started inside the object, and to 1 when the contact gaps imply an offset (the loader's evidence: what a
        calibration offset leaves before any simulation)."""
        early = 1.0 - min(1.0, max(0.0, evidence.mean("onset_rel", 0.0)))
        base = 0.2 + 0.4 * early + 0.2 * (evidence.mean("across") + evidence.mean("yaw"))
        share = 1.0 if evidence.offset_evident else min(1.0, max(0.0, evidence.started_inside))
        return base + (1.0 - base) * share

    def seeds(self, evidence: Evidence, target: str) -> list[dict[str, float]]:
        """The null offset and, when the loader's evidence implies one (start penetrations, contact gaps), that
        offset (relative to the raw recording, as every fitted offset: `params.model.raw_relative`)."""
        null = self.null_values(evidence.world, evidence.odb, target)
        if not evidence.loader_offset:
            return [null]
        names = {j: pname("joint_offset", j) for _, j in self.members(evidence.world, evidence.odb, target)}
        raw = {names[j]: v for j, v in evidence.loader_offset.items() if j in names}
        return [null, {**null, **raw}] if raw else [null]

    # --- the proof: the robot's base mounted off by (dx, dy); the model offsets the joint readings --------------
    def draw_truth(self, scene, odb, rng, magnitude, sign):
        size, angle = SIZES[magnitude], rng.uniform(-math.pi, math.pi)
        return Truth(self.name, scene.robot, {pname("joint_offset", "pusher_x"): size * math.cos(angle),
                                              pname("joint_offset", "pusher_y"): size * math.sin(angle)},
                     "the robot's base mounted off")

    def conceal(self, truth, scene, odb, rollout):
        """The robot's base welded off by (dx, dy). In a scene of varied mechanisms the operator steered the real
        rod along the designed path (clear of the object at the start), so the joints, which the recorder reads,
        ran off by -(dx, dy): the recorded rod may start inside the object, as a miscalibrated one does."""
        world = rollout.world
        base = world.robot.base_pose
        dx, dy = truth.params[pname("joint_offset", "pusher_x")], truth.params[pname("joint_offset", "pusher_y")]
        moved = Pose((base.xyz[0] + dx, base.xyz[1] + dy, base.xyz[2]), base.quat)
        true = rollout.with_world(replace(world, robot=replace(world.robot, base_pose=moved)))
        if getattr(scene, "varied", False):
            true = true.with_telemetry(rollout.telemetry.with_offsets({"pusher_x": -dx, "pusher_y": -dy}))
        return true, true.telemetry

    def target_matches(self, concealed, found, world, odb):
        """The robot, or one of its joints (`robot:joint`)."""
        return found == concealed or found.startswith(concealed + ":")

    def recovered(self, truth, found, model, world, odb):
        d = math.sqrt(sum((found.get(k, 0.0) - v) ** 2 for k, v in truth.params.items()))
        size = math.sqrt(sum(v ** 2 for v in truth.params.values()))
        return Recovery(d <= 0.3 * size + 0.001, d, "m", f"offset {d * 1e3:.1f} mm off a {size * 1e3:.1f} mm offset "
                                                         f"(30 % + 1 mm)")
