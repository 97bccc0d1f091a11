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
