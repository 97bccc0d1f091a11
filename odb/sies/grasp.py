"""SIEs about the robot's gripper: holding and hand-empty, decided from finger contacts."""
from bridge.inference import SIE


def finger_links(ctx):
    robot = ctx.world.robot
    if robot is None:
        return ()
    spec = ctx.odb.get(robot.type).robot
    if spec is None or spec.gripper is None:
        return ()
    return tuple(f"{robot.name}/{link}" for link in spec.gripper.finger_links)


def is_held(obj, ctx):
    """Every finger touches the object (known only after a simulation)."""
    fingers = finger_links(ctx)
    return bool(fingers) and ctx.contacts is not None and all(ctx.in_contact(obj, f) for f in fingers)


class Holding(SIE):
    """(holding r x): both fingers of r's gripper touch x."""

    def evaluate(self, obj, ctx):
        return [self.fact(ctx.robot, obj)] if ctx.robot and is_held(obj, ctx) else []


class HandEmpty(SIE):
    """(hand-empty r): r's gripper holds no movable object."""

    def evaluate(self, obj, ctx):
        if ctx.contacts is None:  # nothing simulated: keep what the state said
            return [f for f in ctx.world.facts if f.predicate == self.predicate and f.args == (obj,)]
        if any(is_held(other, ctx) for other in ctx.objects("movable")):
            return []
        return [self.fact(obj)]
