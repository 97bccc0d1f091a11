"""What changed between two world states (or a world state and a PDDL problem): facts, moves, objects.

`WorldDiff.to_json()` keys::

    added            ["(on big_box tray)", ...]       facts that hold after but not before, sorted
    removed          ["(upright big_box)", ...]       facts that held before but not after, sorted
    moved            [{"object": "big_box", "translation_m": 0.152, "rotation_deg": 87.3}, ...]
    objects_added    ["cup"]                          names only in the later state
    objects_removed  []                               names only in the earlier state
    uncertain        [{"fact": "(upright big_box)", "p": 0.62, "interval": [0.42, 0.79]}, ...]
                                                      facts of the later state that held in only some of its
                                                      parameter samples (bridge infer --samples), likeliest first
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from .probability import wilson_interval
from .values import Fact
from .world import WorldState

if TYPE_CHECKING:
    from .planning.problem import ProblemFacts


@dataclass(frozen=True)
class ObjectMove:
    object: str
    translation_m: float
    rotation_deg: float


@dataclass(frozen=True)
class WorldDiff:
    added: frozenset[Fact] = frozenset()
    removed: frozenset[Fact] = frozenset()
    moved: tuple[ObjectMove, ...] = ()
    objects_added: tuple[str, ...] = ()
    objects_removed: tuple[str, ...] = ()
    uncertain: tuple[tuple[Fact, float], ...] = ()  # (fact, probability) of the later state
    samples: int = 0

    @property
    def empty(self) -> bool:
        return not (self.added or self.removed or self.moved or self.objects_added or self.objects_removed
                    or self.uncertain)

    def text(self) -> str:
        """One line per change: ``+ (on big_box tray)``, ``- (upright big_box)``, ``~ big_box moved 0.152 m, turned
        87.3 deg``, ``? (upright big_box) p = 0.62 [0.42, 0.79]`` (a fact that held in some samples only)."""
        lines = [f"- object {name}" for name in self.objects_removed]
        lines += [f"+ object {name}" for name in self.objects_added]
        lines += [f"- {fact}" for fact in sorted(self.removed)]
        lines += [f"+ {fact}" for fact in sorted(self.added)]
        lines += [f"~ {m.object} moved {m.translation_m:.3f} m, turned {m.rotation_deg:.1f} deg" for m in self.moved]
        lines += [f"? {fact} p = {p:.2f} [{lo:.2f}, {hi:.2f}] of {self.samples} samples"
                  for fact, p, (lo, hi) in self._intervals()]
        return "\n".join(lines) if lines else "no change"

    def _intervals(self):
        return [(f, p, wilson_interval(p, self.samples)) for f, p in self.uncertain]

    def to_json(self) -> dict[str, Any]:
        return {
            "added": [str(f) for f in sorted(self.added)],
            "removed": [str(f) for f in sorted(self.removed)],
            "moved": [{"object": m.object, "translation_m": round(m.translation_m, 6), "rotation_deg": round(m.rotation_deg, 3)}
                      for m in self.moved],
            "objects_added": list(self.objects_added),
            "objects_removed": list(self.objects_removed),
            "uncertain": [{"fact": str(f), "p": round(p, 4), "interval": [round(lo, 4), round(hi, 4)]}
                          for f, p, (lo, hi) in self._intervals()],
        }


def diff_worlds(before: WorldState, after: WorldState, *, translation_threshold: float = 0.01,
                rotation_threshold_deg: float = 5.0) -> WorldDiff:
    """Facts added and removed, and objects that moved more than a threshold (metres, degrees) or came and went."""
    moved = []
    for name, obj in before.objects.items():
        other = after.objects.get(name)
        if other is None:
            continue
        translation = obj.pose.translation_to(other.pose)
        rotation = math.degrees(obj.pose.rotation_to(other.pose))
        if translation > translation_threshold or rotation > rotation_threshold_deg:
            moved.append(ObjectMove(name, translation, rotation))
    return WorldDiff(
        added=after.facts - before.facts,
        removed=before.facts - after.facts,
        moved=tuple(moved),
        objects_added=tuple(n for n in after.all_names() if n not in set(before.all_names())),
        objects_removed=tuple(n for n in before.all_names() if n not in set(after.all_names())),
        uncertain=tuple(sorted(after.probabilities.items(), key=lambda fp: (-fp[1], fp[0]))),
        samples=after.samples,
    )


def diff_world_problem(world: WorldState, problem: "ProblemFacts") -> WorldDiff:
    """From a world state to what a PDDL problem says: facts and object names (a problem has no poses).

    A problem written without ``; bridge-name`` comments names "Cup 1" as ``cup_1``; such names are mapped back
    through the world's own name map.
    """
    names = world.all_names()
    known = set(names)

    def original(name: str) -> str:
        if name in known:
            return name
        mapped = world.names.original(name.lower())
        return mapped if mapped in known else name

    facts = frozenset(Fact(f.predicate, tuple(original(a) for a in f.args)) for f in problem.facts)
    objects = {original(n) for n in problem.objects}
    return WorldDiff(
        added=facts - world.facts,
        removed=world.facts - facts,
        objects_added=tuple(sorted(n for n in objects if n not in known)),
        objects_removed=tuple(n for n in names if n not in objects),
    )
