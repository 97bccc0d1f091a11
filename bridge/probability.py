"""How sure a fact is: the share of parameter samples in which it held, and the interval that share leaves.

Wilson's score interval (95 %) is used rather than the normal approximation: it stays inside [0, 1] and is honest
at 0 or 1 successes, which is where facts usually sit (a box upright in 24 of 24 samples is not certain, only
likely above 0.86). Latin-hypercube samples estimate a share with no more variance than independent ones, so
the interval is, if anything, conservative.
"""
from __future__ import annotations

import math

from .errors import BridgeError

Z95 = 1.959963984540054
DEFAULT_MIN_PROBABILITY = 0.9  # what the planner is told as true (bridge export / infer --min-probability)


def wilson_interval(p: float, n: int, z: float = Z95) -> tuple[float, float]:
    """The 95 % interval of a share `p` observed in `n` samples."""
    if n <= 0:
        return 0.0, 1.0
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return max(0.0, centre - half), min(1.0, centre + half)


def check_min_probability(value: float) -> float:
    """A threshold above one half: a fact and its negation cannot both be believed."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.5 < value <= 1.0:
        raise BridgeError(f"the minimum probability must be in (0.5, 1], got {value!r}")
    return float(value)
