"""`object_scale`: the object is larger or smaller than its model (an outline or mesh drawn at another size, a
mesh exported in the wrong unit by a few per cent, another instance of the part). An error of the object model,
not of the physics: the rod meets the real outline earlier (a larger object) or later than the modelled one, at
another lever arm, and the object rests on a footprint of another size.

Modelled by the kind `object_scale` (`params.kinds.ObjectScaleKind`, `sim.extras.ObjectScale`): the whole
geometry scaled about the centre of its bottom, the mass kept, the inertia scaled with it; a new scene per value.
What it leaves: from the first contact on, every push is ahead of the simulated one (a larger object) or behind
it, whichever side is pushed, with turns scaled alike; a rod that starts inside the modelled outline in every
recording (a larger object the rod was placed clear of) or a gap the rod crosses later than simulated.
"""
from __future__ import annotations

import numpy as np

from .base import Effect, Evidence, Recovery, Truth, movable_observed, pname

SCALES = ((0.97, 1.03), (0.95, 1.05), (0.92, 1.08))  # the proof's sizes relative to the model (small to large)
SEED_STEP = 0.03  # the seeds' departure from the model's size either way: the scale acts through the contact
RECOVERED = (0.3, 0.01)  # share of the concealed departure from 1, plus 1 %


def outline_radius(world, odb, target: str) -> float | None:
    """How far `target`'s outline lies from its centre along its normals, averaged over its length (m; 2 area /
    perimeter, exact for any closed outline: the divergence theorem), None for an object without one. A size k
    moves the outline where the rod meets it by (k - 1) times the distance there, which this stands for
    (`ContactFit.inflation`): within 10 % on the dataset's rect1, ellip1 and hex, 25 % on its longer rectangles
    and ellipses and its triangles, 50 % on the non-convex butter (10th-90th percentile over the outline's
    length)."""
    from ...sim.prisms import outline_of, signed_area

    if target not in world.objects:
        return None
    outline = outline_of(odb.get(world.objects[target].type).geometry)
    if outline is None:
        return None
    perimeter = float(np.sum(np.hypot(*(np.roll(outline, -1, axis=0) - outline).T)))
    return 2.0 * abs(signed_area(outline)) / perimeter


class ObjectScaleEffect(Effect):
    name = "object_scale"
    summary = "the object is larger or smaller than its model"
    mechanism = "scene extra: the object's geometry scaled about the centre of its bottom, its mass kept"
    signature_text = ("from the first contact on, every push runs ahead of the simulated one (a larger object) or "
                      "behind it, whichever side is pushed; rods that start inside the modelled outline")
    kinds = ("object_scale",)

    def targets(self, world, odb, observed):
        return movable_observed(world, odb, observed)

    def signature(self, evidence: Evidence, target: str) -> float:
        """An early onset, raised by the share of recordings whose rod started inside the modelled outline, and
        high when the rod pushed outside (inside) the outline on every side (`Evidence.inflation`; a stiffer or
        softer contact does that too, by less)."""
        if evidence.inflation is not None:
            return 0.8
        early = 1.0 - min(1.0, max(0.0, evidence.mean("onset_rel", 0.0)))
        base = 0.1 + 0.25 * early
        return base + (0.5 - base) * min(1.0, max(0.0, evidence.started_inside))

    def seeds(self, evidence: Evidence, target: str) -> list[dict[str, float]]:
        """The model's size and SEED_STEP either way (where the rod meets the outline moves the whole push at once,
        so the residual is not a smooth function of the size at the null when a push hardly touches); and, when
        the contact gaps show the rod outside (inside) the outline on every side, the size that puts it there:
        1 + inflation / `outline_radius`."""
        null = self.null_values(evidence.world, evidence.odb, target)
        key = pname("object_scale", target)
        seeds = [null, {**null, key: 1.0 - SEED_STEP}, {**null, key: 1.0 + SEED_STEP}]
        radius = None if evidence.inflation is None else outline_radius(evidence.world, evidence.odb, target)
        if radius is None:
            return seeds
        read = float(np.clip(1.0 + evidence.inflation / radius, 0.86, 1.14))
        return [{**null, key: read}] + seeds

    def describe(self, world, odb, target, values):
        return {"size_percent": 100.0 * (values.get(pname("object_scale", target), 1.0) - 1.0)}

    # --- the proof: the real object another size than its model ----------------------------------------------
    def draw_truth(self, scene, odb, rng, magnitude, sign):
        scale = SCALES[magnitude][0 if sign < 0 else 1]
        return Truth(self.name, scene.object, {pname("object_scale", scene.object): scale},
                     "the real object is another size than its model (pushes designed around the real one)")

    def conceal(self, truth, scene, odb, rollout):
        """The world's object is the scaled one (the same mechanism as the model: a size has no other); the pushes
        are designed around it (`generate_case` reads the truth's scale)."""
        from ...sim.extras import ObjectScale

        scale = truth.params[pname("object_scale", truth.target)]
        return rollout.with_extras(ObjectScale(truth.target, scale)), rollout.telemetry

    def recovered(self, truth, found, model, world, odb):
        key = pname("object_scale", truth.target)
        want, got = truth.params[key], found.get(key, 1.0)
        share, floor = RECOVERED
        d = abs(got - want)
        return Recovery(d <= share * abs(want - 1.0) + floor, d, "",
                        f"size {100 * (got - 1):+.1f} % vs {100 * (want - 1):+.1f} % (30 % + 1 %)")
