"""Drake's friction-combination rule: two touching surfaces' coefficients make one coefficient for the pair.

A fitted "friction of the surface" is one factor of the pair's coefficient, not the coefficient itself; these two
functions go from the factors to the pair and back (used by action bodies, the diagnosis and the proof).
"""
from __future__ import annotations


def combined_friction(a: float, b: float) -> float:
    """Drake's rule for two surfaces' coefficients."""
    return 2.0 * a * b / (a + b) if a + b > 0 else 0.0


def surface_friction_for(pair: float, object_mu: float) -> float:
    """The surface coefficient that combines with `object_mu` to `pair` (capped: a pair cannot exceed 2 mu)."""
    pair = min(pair, 1.95 * object_mu)
    return pair * object_mu / (2.0 * object_mu - pair)


RAISE = 0.75  # an object's own coefficient is raised to this share of the largest pair asked of it (see below)


def pair_coefficients(own: float, pairs: list[float]) -> tuple[float, list[float]]:
    """Coefficients that give an object the pair values `pairs` with its partners under Drake's rule: the object's
    own (`own`), or, where a pair asks for more than the rule allows (a pair stays below twice either
    coefficient), RAISE times the largest pair; and each partner's. Why: the pairs an object is in are
    independent physical quantities (a steel rod on a steel block, the block on ABS), while per-body coefficients
    tie them together: with the object's coefficient low for a slippery pusher, no surface coefficient gives a
    grippy support. Continuous in the pairs, so a search can difference through it."""
    b = max(own, RAISE * max(pairs, default=0.0))
    return b, [p * b / (2.0 * b - p) for p in pairs]
