"""SIEs about support: what rests on what, what is clear, what lies in a container."""
from bridge.odb.geometry import contains_xy, z_range
from bridge.inference import SIE


def rests_on(obj, support, ctx, tolerance=0.012):
    """`obj`'s lowest point is at `support`'s top, its centre is over `support`, and (if known) they touch."""
    if obj == support:
        return False
    bottom, _ = z_range(ctx.geometry(obj), ctx.pose(obj))
    _, top = z_range(ctx.geometry(support), ctx.pose(support))
    if abs(bottom - top) > tolerance:
        return False
    if not contains_xy(ctx.geometry(support), ctx.pose(support), ctx.pose(obj).position):
        return False
    if ctx.contacts is not None and not ctx.in_contact(obj, support):
        return False
    return True


class On(SIE):
    """(on x y): x rests on y's top surface."""

    def __init__(self, tolerance: float = 0.012):
        self.tolerance = tolerance

    def evaluate(self, obj, ctx):
        params = self.declaration.params if self.declaration else ("movable", "object")
        return [self.fact(obj, other) for other in ctx.objects(params[1])
                if rests_on(obj, other, ctx, self.tolerance)]


class Clear(SIE):
    """(clear x): no movable object rests on x."""

    def evaluate(self, obj, ctx):
        if any(rests_on(other, obj, ctx) for other in ctx.objects("movable")):
            return []
        return [self.fact(obj)]


class Inside(SIE):
    """(in x c): x's centre is over container c and x's bottom lies between c's floor and its rim."""

    def __init__(self, tolerance: float = 0.012):
        self.tolerance = tolerance

    def evaluate(self, obj, ctx):
        facts = []
        bottom, _ = z_range(ctx.geometry(obj), ctx.pose(obj))
        for container in ctx.objects("container"):
            if container == obj:
                continue
            low, high = z_range(ctx.geometry(container), ctx.pose(container))
            if low - self.tolerance <= bottom <= high + self.tolerance and contains_xy(
                ctx.geometry(container), ctx.pose(container), ctx.pose(obj).position
            ):
                facts.append(self.fact(obj, container))
        return facts
