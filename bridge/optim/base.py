"""What every optimiser shares: the ask/tell protocol, stop rules, and the per-generation history.

Optimisers work in the normalised box [0, 1]^D; the fit driver maps that box onto the parameter bounds.
An optimiser's `state()` is plain data (lists, floats, strings; JSON- and pickle-able), and the class's
`from_state` continues from it exactly as if the run had never stopped.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Any, Mapping, Protocol, Sequence, runtime_checkable

import numpy as np

from ..errors import FitError


@runtime_checkable
class Optimizer(Protocol):
    """Ask for a generation of candidates in [0, 1]^D, evaluate them, tell their errors; repeat until `done`."""

    name: str

    def ask(self) -> list[np.ndarray]: ...

    def tell(self, candidates: Sequence[np.ndarray], errors: Sequence[float]) -> None: ...

    def state(self) -> dict: ...

    @property
    def generation(self) -> int: ...

    @property
    def evaluations(self) -> int: ...

    @property
    def best_x(self) -> np.ndarray | None: ...

    @property
    def best_error(self) -> float: ...

    @property
    def done(self) -> bool: ...

    @property
    def stop_reason(self) -> str | None: ...

    @property
    def history(self) -> tuple["GenerationRecord", ...]: ...


@dataclass(frozen=True)
class GenerationRecord:
    """One generation, as the paper's Fig. 4 plots it.

    "Selected" are the individuals kept as parents for the next generation (ES: the mu best of parents and
    offspring; CMA-ES: the mu best of the generation, those its recombination weights use).
    Parameters are in the normalised box [0, 1]^D.
    """

    generation: int  # 0-based index of this generation
    evaluations: int  # evaluations so far, this generation included
    best_error: float  # best error so far (over all generations)
    best_x: tuple[float, ...]  # parameters of that best individual
    generation_best_error: float  # best error among this generation's candidates
    selected_mean_error: float
    selected_p80_error: float  # with best_error: the band "best to 80th percentile" of Fig. 4 (c), (f)
    mean_x: tuple[float, ...]  # mean of each parameter over the selected
    p20_x: tuple[float, ...]  # 20th percentile of each parameter over the selected
    p80_x: tuple[float, ...]  # 80th percentile
    sigma: float  # step size: mean self-adapted sigma of the selected (ES) or the global sigma (CMA-ES)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> "GenerationRecord":
        names = {f.name for f in fields(cls)}
        return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in data.items() if k in names})


@dataclass(frozen=True)
class StopRule:
    """When to stop: the best error has improved by no more than `tol` for `patience` generations, or a budget
    (`max_generations`, `max_evaluations`) is spent, or the best error reached `target_error`."""

    tol: float = 1e-9
    patience: int = 10
    max_generations: int = 100
    max_evaluations: int | None = None
    target_error: float | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.tol) and self.tol >= 0):
            raise FitError(f"tol must be a finite number >= 0, got {self.tol!r}")
        for name in ("patience", "max_generations"):
            value = getattr(self, name)
            if not isinstance(value, (int, np.integer)) or value < 1:
                raise FitError(f"{name} must be an integer >= 1, got {value!r}")
        if self.max_evaluations is not None and (
                not isinstance(self.max_evaluations, (int, np.integer)) or self.max_evaluations < 1):
            raise FitError(f"max_evaluations must be an integer >= 1 or None, got {self.max_evaluations!r}")
        if self.target_error is not None and not math.isfinite(self.target_error):
            raise FitError(f"target_error must be a finite number or None, got {self.target_error!r}")


STOP_OPTIONS = tuple(f.name for f in fields(StopRule))


class Progress:
    """Bookkeeping shared by the optimisers: counts, best so far, stagnation, history. Mutable by design."""

    def __init__(self, rule: StopRule):
        self.rule = rule
        self.generation = 0  # generations told so far
        self.evaluations = 0
        self.best_x: np.ndarray | None = None
        self.best_error = math.inf
        self.stale = 0  # generations in a row without an improvement > tol
        self.history: list[GenerationRecord] = []

    def record(self, candidates: np.ndarray, errors: np.ndarray, selected_x: np.ndarray,
               selected_errors: np.ndarray, sigma: float) -> None:
        """Account for one told generation (errors already made rankable: NaN -> inf)."""
        best = int(np.argmin(errors))
        if errors[best] < self.best_error - self.rule.tol or self.best_x is None:
            self.stale = 0
        else:
            self.stale += 1
        if errors[best] < self.best_error or self.best_x is None:
            self.best_error = float(errors[best])
            self.best_x = candidates[best].copy()
        self.evaluations += len(candidates)
        p20, p80 = np.percentile(selected_x, [20, 80], axis=0)
        self.history.append(GenerationRecord(
            generation=self.generation,
            evaluations=self.evaluations,
            best_error=self.best_error,
            best_x=_floats(self.best_x),
            generation_best_error=float(errors[best]),
            selected_mean_error=float(np.mean(selected_errors)),
            selected_p80_error=_percentile_80(selected_errors),
            mean_x=_floats(np.mean(selected_x, axis=0)),
            p20_x=_floats(p20),
            p80_x=_floats(p80),
            sigma=float(sigma),
        ))
        self.generation += 1

    def stop_reason(self) -> str | None:
        rule = self.rule
        if rule.target_error is not None and self.best_error <= rule.target_error:
            return f"target error {rule.target_error:g} reached"
        if self.generation >= 1 and self.stale >= rule.patience:
            return f"no improvement > {rule.tol:g} for {rule.patience} generations"
        if self.generation >= rule.max_generations:
            return f"{rule.max_generations} generations done"
        if rule.max_evaluations is not None and self.evaluations >= rule.max_evaluations:
            return f"{rule.max_evaluations} evaluations done"
        return None

    # --- checkpoints --------------------------------------------------------------------------------
    def state(self) -> dict:
        return {
            "generation": self.generation,
            "evaluations": self.evaluations,
            "best_x": None if self.best_x is None else _floats(self.best_x),
            "best_error": self.best_error,
            "stale": self.stale,
            "history": [asdict(record) for record in self.history],
        }

    @classmethod
    def from_state(cls, rule: StopRule, data: Mapping[str, Any]) -> "Progress":
        progress = cls(rule)
        progress.generation = int(data["generation"])
        progress.evaluations = int(data["evaluations"])
        progress.best_x = None if data["best_x"] is None else np.array(data["best_x"], dtype=float)
        progress.best_error = float(data["best_error"])
        progress.stale = int(data["stale"])
        progress.history = [GenerationRecord.from_dict(record) for record in data["history"]]
        return progress


class Tracked:
    """What every optimiser reports from its `Progress` (`self._progress`); `stop_reason` may add its own."""

    _progress: Progress

    @property
    def generation(self) -> int:
        """Generations told so far."""
        return self._progress.generation

    @property
    def evaluations(self) -> int:
        return self._progress.evaluations

    @property
    def best_x(self) -> np.ndarray | None:
        return None if self._progress.best_x is None else self._progress.best_x.copy()

    @property
    def best_error(self) -> float:
        return self._progress.best_error

    @property
    def stop_reason(self) -> str | None:
        return self._progress.stop_reason()

    @property
    def done(self) -> bool:
        return self.stop_reason is not None

    @property
    def history(self) -> tuple[GenerationRecord, ...]:
        return tuple(self._progress.history)


# --- helpers for the optimisers -------------------------------------------------------------------------
def split_options(options: Mapping[str, Any], own: Sequence[str], optimizer: str) -> tuple[dict, StopRule]:
    """Separate an optimiser's own options from the stop rule's; unknown names are an error."""
    unknown = sorted(set(options) - set(own) - set(STOP_OPTIONS))
    if unknown:
        raise FitError(f"unknown option(s) {', '.join(unknown)} for optimizer {optimizer!r}; "
                       f"valid: {', '.join(sorted((*own, *STOP_OPTIONS)))}")
    return ({k: v for k, v in options.items() if k in own},
            StopRule(**{k: v for k, v in options.items() if k in STOP_OPTIONS}))


def check_start(x0: Sequence[float], sigma0: float) -> tuple[np.ndarray, float]:
    """x0 must lie in the normalised box; sigma0 is a step size in box units."""
    x = np.array(x0, dtype=float)
    if x.ndim != 1 or x.size == 0:
        raise FitError(f"x0 must be a non-empty vector in [0, 1]^D, got shape {x.shape}")
    if not np.all(np.isfinite(x)) or np.any(x < 0) or np.any(x > 1):
        raise FitError(f"x0 must lie in the normalised box [0, 1]^D, got {x.tolist()}")
    try:
        sigma = float(sigma0)
    except (TypeError, ValueError):
        raise FitError(f"sigma0 must be a number > 0, got {sigma0!r}") from None
    if not (math.isfinite(sigma) and sigma > 0):
        raise FitError(f"sigma0 must be a finite number > 0 (box units), got {sigma0!r}")
    return x, sigma


def check_told(pending: list[np.ndarray] | None, candidates: Sequence[np.ndarray],
               errors: Sequence[float], optimizer: str) -> np.ndarray:
    """The told candidates must be the asked ones, in order; returns errors with NaN ranked last (inf)."""
    if pending is None:
        raise FitError(f"{optimizer}: tell() without a pending ask(); call ask() first")
    if len(candidates) != len(pending) or any(
            not np.array_equal(np.asarray(c, dtype=float), p) for c, p in zip(candidates, pending)):
        raise FitError(f"{optimizer}: tell() got candidates that differ from the {len(pending)} asked for; "
                       "pass back exactly the list ask() returned")
    e = np.array(errors, dtype=float).reshape(-1)
    if e.size != len(pending):
        raise FitError(f"{optimizer}: {e.size} errors for {len(pending)} candidates")
    return np.where(np.isnan(e), np.inf, e)


def reflect(x: np.ndarray) -> np.ndarray:
    """Fold values back into [0, 1] by mirroring at the bounds (keeps the step distribution symmetric)."""
    y = np.mod(x, 2.0)
    return np.where(y > 1.0, 2.0 - y, y)


def _percentile_80(errors: np.ndarray) -> float:
    with np.errstate(invalid="ignore"):  # failed evaluations are inf; inf - inf inside the interpolation
        value = float(np.percentile(errors, 80))
    return math.inf if math.isnan(value) else value


def _floats(values: np.ndarray) -> tuple[float, ...]:
    return tuple(float(v) for v in np.asarray(values).reshape(-1))
