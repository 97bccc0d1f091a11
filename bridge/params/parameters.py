"""Parameters: which kinds on which targets a search may change (with bounds and a start) or holds fixed, and the
coordinates optimisers work in.

Two coordinate systems over the same parameters, one per family of optimisers:
- the unit box [0, 1]^D (`to_unit`/`from_unit`) for the evolution strategies: each free parameter's bounds
  mapped linearly, or logarithmically with `spacing="log"`;
- normalised coordinates x = (value - start) / step (`to_normal`/`from_normal`) for least squares: the start is
  the origin and one unit is the parameter's typical size, also the finite-difference step (large enough to see
  through the small, non-smooth jitter of contact simulation). A diagnosis starts from the world model (start =
  the kind's null value, step = the kind's step); a parameter file's entries default to a twentieth of their
  bounds.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, Mapping, Sequence

import numpy as np

from ..errors import ParameterError
from ..odb import ObjectDatabase
from ..rollout.rollout import Rollout
from ..world import WorldState
from .kinds import Kind, kind_named
from .model import Model, Setting

SPACINGS = ("linear", "log")


@dataclass(frozen=True)
class Parameter:
    """One entry: free when it has `bounds` and no `value`, fixed otherwise."""

    kind: Kind
    target: str
    bounds: tuple[float, float] | None = None
    start: float | None = None
    value: float | None = None
    spacing: str = "linear"
    step: float | None = None
    effect: str = ""
    std: float | None = None  # 1 sigma of a fixed value (a fit's or a diagnosis' estimate): what sampling draws from

    @classmethod
    def of(cls, kind: str | Kind, target: str, world: WorldState, odb: ObjectDatabase, *, effect: str = "",
           start: float | None = None) -> "Parameter":
        """A free parameter with the kind's physical bounds and step on `world`, starting at its null value (the
        world model's) unless `start` is given."""
        kind = kind_named(kind) if isinstance(kind, str) else kind
        null = kind.null(world, odb, target) if start is None else start
        lo, hi = kind.bounds(world, odb, target)
        r = kind.physical  # a search never leaves what is possible (an odb value near its range's end)
        bounds = (max(lo, r.low), min(hi, r.high))
        return cls(kind, target, bounds=bounds, start=min(max(null, bounds[0]), bounds[1]),
                   step=kind.step(world, odb, target), effect=effect)

    @property
    def name(self) -> str:
        return f"{self.kind.name}[{self.target}]"

    @property
    def free(self) -> bool:
        return self.value is None

    @property
    def start_value(self) -> float:
        """The start: `start`, else the middle of the bounds (geometric middle on a log spacing)."""
        if self.start is not None:
            return self.start
        lo, hi = self.bounds
        return math.sqrt(lo * hi) if self.spacing == "log" else 0.5 * (lo + hi)

    @property
    def step_value(self) -> float:
        if self.step is not None:
            return self.step
        lo, hi = self.bounds
        return (hi - lo) / 20.0

    def setting(self, value: float | None = None) -> Setting:
        return Setting(self.kind.name, self.target, float(self.value if value is None else value), self.effect)

    def to_unit(self, value: float) -> float:
        lo, hi = self.bounds
        if self.spacing == "log":
            return (math.log(value) - math.log(lo)) / (math.log(hi) - math.log(lo))
        return (value - lo) / (hi - lo)

    def from_unit(self, u: float) -> float:
        lo, hi = self.bounds
        u = min(1.0, max(0.0, float(u)))
        if self.spacing == "log":
            return float(math.exp(math.log(lo) + u * (math.log(hi) - math.log(lo))))
        return float(lo + u * (hi - lo))


@dataclass(frozen=True)
class ParameterSet:
    """Parameters in order (a parameter file's entries, or a diagnosis' ordinary parameters and an effect's)."""

    entries: tuple[Parameter, ...]
    source: str = "<memory>"

    @property
    def free(self) -> tuple[Parameter, ...]:
        return tuple(p for p in self.entries if p.free)

    @property
    def fixed(self) -> tuple[Parameter, ...]:
        return tuple(p for p in self.entries if not p.free)

    @property
    def names(self) -> tuple[str, ...]:
        """Names of the free parameters, the order of every parameter vector."""
        return tuple(p.name for p in self.free)

    @property
    def dim(self) -> int:
        return len(self.free)

    def start_values(self) -> np.ndarray:
        return np.array([p.start_value for p in self.free])

    def as_dict(self, values: Sequence[float]) -> dict[str, float]:
        return {n: float(v) for n, v in zip(self.names, values)}

    def model(self, values: Sequence[float] | None = None) -> Model:
        """The settings: every entry in order, free ones at `values` (parameter units; None: their starts)."""
        values = self.start_values() if values is None else np.asarray(values, dtype=float)
        if len(values) != self.dim:
            raise ParameterError(f"{len(values)} values for the {self.dim} free parameters {', '.join(self.names)}",
                              source=self.source)
        it = iter(values)
        return tuple(p.setting() if not p.free else p.setting(float(next(it))) for p in self.entries)

    def fixed_at(self, values: Sequence[float] | Mapping[str, float],
                 std: Mapping[str, float] | None = None) -> "ParameterSet":
        """The same parameters with the free ones fixed at `values` (a fitted parameter file), each with its
        uncertainty from `std` (by name) when given."""
        if isinstance(values, Mapping):
            values = [values[n] for n in self.names]
        it = iter(float(v) for v in values)
        std = std or {}
        return replace(self, entries=tuple(p if not p.free else replace(p, value=next(it), std=std.get(p.name))
                                           for p in self.entries))

    # --- the unit box (evolution strategies) ------------------------------------------------------------------
    def to_unit(self, values: Sequence[float]) -> np.ndarray:
        return np.array([p.to_unit(v) for p, v in zip(self.free, values)])

    def from_unit(self, u: Sequence[float]) -> np.ndarray:
        return np.array([p.from_unit(v) for p, v in zip(self.free, u)])

    # --- normalised coordinates (least squares) --------------------------------------------------------------
    @property
    def origin(self) -> np.ndarray:
        return self.start_values()

    @property
    def steps(self) -> np.ndarray:
        return np.array([p.step_value for p in self.free])

    def normal_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        lo = np.array([p.bounds[0] for p in self.free])
        hi = np.array([p.bounds[1] for p in self.free])
        return (lo - self.origin) / self.steps, (hi - self.origin) / self.steps

    def to_normal(self, values: Sequence[float] | Mapping[str, float]) -> np.ndarray:
        """Normalised coordinates of `values` (by name: missing ones at their start), clipped to the bounds."""
        if isinstance(values, Mapping):
            values = [values.get(p.name, p.start_value) for p in self.free]
        lower, upper = self.normal_bounds()
        return np.clip((np.asarray(values, dtype=float) - self.origin) / self.steps, lower, upper)

    def from_normal(self, x: Sequence[float]) -> np.ndarray:
        """Values of normalised coordinates, within the bounds: a point on a bound comes back a rounding error
        past it (a damping of -2e-16 s/m, which Drake refuses), never to be simulated."""
        lo = np.array([p.bounds[0] for p in self.free])
        hi = np.array([p.bounds[1] for p in self.free])
        return np.clip(self.origin + np.asarray(x, dtype=float) * self.steps, lo, hi)

    def to_dict(self) -> dict[str, Any]:
        from .files import entry_dict

        return {"params": [entry_dict(p) for p in self.entries]}


def check_targets(parameters: ParameterSet, worlds: Sequence[WorldState], odb: ObjectDatabase) -> None:
    """Every target selects something in at least one world; an error lists what could be named."""
    for index, p in enumerate(parameters.entries):
        if any(p.kind.select(p.target, w, odb) for w in worlds):
            continue
        raise ParameterError(f"unknown target {p.target!r} for {p.kind.name}; {p.kind.valid_targets(worlds, odb)}",
                          source=parameters.source, field=f"params[{index}].target")


def check_values(parameters: ParameterSet, rollouts: Sequence[Rollout], odb: ObjectDatabase) -> None:
    """Every value a file gives (a fixed value, a free entry's bounds) is possible in every recording whose world
    its target names something in (`Kind.check_on`: a latency well inside the telemetry, a centre of mass inside
    the body, ...); an error names the file, the entry and the recording. The physical ranges are checked when
    the file is read."""
    for index, p in enumerate(parameters.entries):
        given = [("value", p.value)] if not p.free else [(f"bounds[{k}]", b) for k, b in enumerate(p.bounds)]
        for rollout in rollouts:
            names = p.kind.select(p.target, rollout.world, odb)
            for key, value in given if names else ():
                problem = p.kind.check_on(float(value), names, rollout, odb)
                if problem:
                    where = f" (recording {rollout.name})" if rollout.name and len(rollouts) > 1 else ""
                    raise ParameterError(problem + where, source=parameters.source, field=f"params[{index}].{key}")


def replay_model(parameters: ParameterSet) -> Model:
    """The model a parameter file gives a replay (`bridge infer`, `view`, `demo --params`): each entry's value, or
    a free entry's start; a free entry without a start is an error (pass a fitted file, or give values)."""
    missing = [p.name for p in parameters.free if p.start is None]
    if missing:
        raise ParameterError(f"parameter {missing[0]} has bounds but no value; pass a fitted parameter file (the "
                             "params.yaml bridge fit writes) or give each entry a value", source=parameters.source)
    return parameters.model()
