"""SIEs decided by an object's own pose."""
import math

from bridge.inference import SIE, angle_between


class Upright(SIE):
    """The paper's Algorithm 1: the object's z axis is within `max_tilt_deg` of the world's."""

    def __init__(self, max_tilt_deg: float = 20.0):
        self.max_tilt = math.radians(max_tilt_deg)

    def evaluate(self, obj, ctx):
        tilt = angle_between(ctx.pose(obj).z_axis(), (0.0, 0.0, 1.0))
        return [self.fact(obj)] if tilt < self.max_tilt else []
