"""SIEs decided by contacts between objects."""
import numpy as np

from bridge.odb.geometry import support
from bridge.inference import SIE

from .support import rests_on

AXES = np.vstack([np.eye(3), -np.eye(3)])


def near(a, b, ctx, gap):
    """World-aligned bounding boxes of a and b come within `gap` of each other."""
    ra = np.array([support(ctx.geometry(a), ctx.pose(a), d) for d in AXES])
    rb = np.array([support(ctx.geometry(b), ctx.pose(b), d) for d in AXES])
    lo_a, hi_a, lo_b, hi_b = -ra[3:], ra[:3], -rb[3:], rb[:3]
    separation = np.maximum(lo_b - hi_a, lo_a - hi_b)
    return bool(np.all(separation <= gap))


class Touching(SIE):
    """(touching x y): x and y, both movable, touch side by side (neither rests on the other)."""

    def __init__(self, gap: float = 0.005):
        self.gap = gap

    def evaluate(self, obj, ctx):
        facts = []
        for other in ctx.objects("movable"):
            if other == obj or rests_on(obj, other, ctx) or rests_on(other, obj, ctx):
                continue
            if ctx.contacts is not None:
                touching = any(c.involves(other) for c in ctx.contacts if c.involves(obj))
            else:
                touching = near(obj, other, ctx, self.gap)
            if touching:
                facts.append(self.fact(obj, other))
        return facts
