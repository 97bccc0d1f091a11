"""Action bodies (paper, Section III-A): the motion that grounds each action template, as joint telemetry.

Every body has one signature, ``body(world, odb, args, *, rng=None) -> Telemetry``: all the robot's joints at
50 Hz, starting where the world's robot stands, passing through its home posture, and (except for `pick`, which
ends holding the object up) ending at home. Near objects the tool moves at most 6 cm/s. The bodies aim at what
the templates' effects say (see pddl/templates/*.yaml and the SIEs in odb/sies/):

- push_over(r, o, s): push o high on a side (80 % of its height, and 15 % above the tipping height
  w / (2 mu) + mu_pad w, which allows for the pads' friction) until it tips; it ends lying on s, clear of
  everything else.
- push(r, o, s): push o low (half the tipping height) ~9 cm along s, away from every other object.
- push_against(r, o, t, s): slide o low until it meets t, press 4 mm further, retreat.
- pick(r, o, s): grasp o from above, 3 cm below its top, close, lift 12 cm and hold it there.
- place(r, o, s): from a world where r holds o (`world_after_replay` of a pick), carry o over a free spot of s,
  lower it until it nearly rests, open, retreat.
- stand_up(r, o, s): o lies on s; grasp it near the end that must go up, lift, turn it upright about the grasp
  axis, set it down, release, retreat. (The gripper opens 8 cm: a box wider than 6 cm across cannot be stood up.)

Bodies live in pushing.py and grasping.py; wander.py makes the operator's free motion between actions (not an
action: no template names it); jobs.py holds what they share, motion.py the trajectories (the IK
plant and the clearance check are Drake: bridge.sim.kinematics),
layout.py the geometry of free space. Failures (unknown object, nothing reachable, no free spot, IK failure) raise `ActionError` naming the action,
the object and the target point. Motions are checked against the world's objects (`Clearance`) before they are
returned: the arm keeps 5 mm from everything it is not meant to touch.
"""
from __future__ import annotations

from dataclasses import replace
from typing import Mapping

from ..world import WorldState
from .grasping import pick, place, stand_up
from .jobs import Body, Job, start_job
from .pushing import push, push_against, push_at, push_over
from .wander import wander

__all__ = ["BODIES", "Body", "Job", "push_at", "start_job", "wander", "world_after_replay"]


def world_after_replay(before: WorldState, result, facts) -> WorldState:
    """The world a replay (`bridge.sim.simulate.ReplayResult` with its joint track) ends in: the simulated
    objects' final poses, the robot's joints where the simulated robot stood at the end (fingers squeezing a
    held object stay where the object stopped them), and `facts` (e.g. the inferred ones). Starting a replay
    from it puts a held object between the fingers again."""
    world = before.with_poses(result.final_poses).with_facts(facts)
    if before.robot is None or result.joint_track is None:
        return world
    joints = dict(before.robot.joints)
    joints.update({n: float(v) for n, v in zip(result.joint_names, result.joint_track[-1])})
    return replace(world, robot=replace(before.robot, joints=tuple(joints.items())))


BODIES: Mapping[str, Body] = {
    "push_over": push_over,
    "push": push,
    "push_against": push_against,
    "pick": pick,
    "place": place,
    "stand_up": stand_up,
}
