"""Physical ranges: the values a real object on a table can have. A value outside one is a mistake (a wrong unit,
a typo, a lost sign) and is refused where it is read (the object database, parameter and scene files) instead of
being simulated into a wrong world state.

These are not an optimiser's bounds: a fit or a diagnosis searches a narrow box around the world model's value
(`bridge.params.kinds`, `Kind.bounds`), and everything inside that box lies inside these ranges. A range here says
only what is possible at all, so it is wide, and it is the same for every object; docs/fit.md lists them and why.
"""
from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class PhysicalRange:
    """[low, high] in `unit` (low excluded when `open_low`); `why` says where the limits come from."""

    low: float
    high: float
    unit: str = ""
    why: str = ""
    open_low: bool = False

    def __contains__(self, value: float) -> bool:
        return math.isfinite(value) and (self.low < value if self.open_low else self.low <= value) and value <= self.high

    def text(self) -> str:
        unit = f" {self.unit}" if self.unit else ""
        return f"{'(' if self.open_low else '['}{self.low:g}, {self.high:g}]{unit}"

    def problem(self, value: float, what: str) -> str | None:
        """Why `value` of `what` is not physical, or None."""
        if value in self:
            return None
        unit = f" {self.unit}" if self.unit else ""
        return f"{what} {value:g}{unit} is outside the physical range {self.text()} ({self.why})"


FRICTION = PhysicalRange(0.0, 5.0, "", "real material pairs have Coulomb coefficients up to about 2, rubber on "
                         "rough surfaces; more is a typo or a percentage")
DISSIPATION = PhysicalRange(0.0, 50.0, "s/m", "everyday materials have a few s/m; at 50 s/m a contact closing at "
                            "2 cm/s already stops dead")
HYDROELASTIC_MODULUS = PhysicalRange(1.0e3, 1.0e12, "Pa", "from soft foam, about 1e4 Pa, to steel, 2e11 Pa")
MASS = PhysicalRange(0.0, 1000.0, "kg", "in kg: more than nothing, less than a robot moves on a table",
                     open_low=True)
DENSITY = PhysicalRange(0.0, 25000.0, "kg/m^3", "in kg/m^3: osmium, the densest element, has 22590", open_low=True)

RANGES: dict[str, PhysicalRange] = {
    "friction": FRICTION, "dynamic_friction": FRICTION, "dissipation": DISSIPATION,
    "hydroelastic_modulus": HYDROELASTIC_MODULUS, "mass": MASS, "density": DENSITY,
}

JOINT_TOLERANCE = 0.01  # of a joint's range: how far past its limits a recorded position may read (sensor noise)


def joint_problem(value: float, limits: tuple[float, float], joint: str, model: str) -> str | None:
    """Why a joint position is impossible for the robot model (outside its limits, with `JOINT_TOLERANCE`), or
    None. Positions are in rad (m for prismatic joints)."""
    lo, hi = limits
    if not math.isfinite(value):
        return f"joint {joint!r}: position {value!r} is not a finite number"
    slack = JOINT_TOLERANCE * (hi - lo) if math.isfinite(hi - lo) else 0.0
    if lo - slack <= value <= hi + slack:
        return None
    return (f"joint {joint!r}: position {value:g} is outside its limits [{lo:g}, {hi:g}] in {model} (rad, m for a "
            f"prismatic joint)")


__all__ = ["DENSITY", "DISSIPATION", "FRICTION", "HYDROELASTIC_MODULUS", "JOINT_TOLERANCE", "MASS", "PhysicalRange",
           "RANGES", "joint_problem"]
