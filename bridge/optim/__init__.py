"""Optimisers, interchangeable over one residual: the paper's (mu/rho + lambda)-ES and CMA-ES (ask/tell in the
unit box [0, 1]^D, checkpointable) and Levenberg-Marquardt (normalised coordinates, batched Jacobians). Fitting
and diagnosis both use them; `minimise` runs any of them on a batch residual.

    opt = make_optimizer("es", x0, sigma0=0.2, seed=1)
    while not opt.done:
        candidates = opt.ask()                       # points in [0, 1]^D
        opt.tell(candidates, [error(c) for c in candidates])
        save(opt.state())                            # resume: restore_optimizer(state)
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ..errors import FitError
from .base import GenerationRecord, Optimizer, StopRule
from .cmaes import CMAES
from .es import EvolutionStrategy
from .lm import levenberg_marquardt

OPTIMIZERS: dict[str, type] = {
    "es": EvolutionStrategy,
    "cmaes": CMAES,
}
NAMES = ("cmaes", "es", "lm")  # every optimiser `minimise` and `bridge fit --optimizer` accept

__all__ = ["CMAES", "NAMES", "OPTIMIZERS", "EvolutionStrategy", "GenerationRecord", "Minimum", "Optimizer",
           "StopRule", "make_optimizer", "minimise", "restore_optimizer"]


def make_optimizer(name: str, x0: Sequence[float], sigma0: float, seed: int | None, **options: Any) -> Optimizer:
    """A fresh ask/tell optimiser by registry name; options are the optimiser's own plus the stop rule's
    (tol, patience, max_generations, max_evaluations, target_error)."""
    return _lookup(name)(x0, sigma0, seed, **options)


def restore_optimizer(state: Mapping[str, Any]) -> Optimizer:
    """The optimiser a `state()` dict was taken from, ready to continue."""
    if not isinstance(state, Mapping) or "name" not in state:
        raise FitError("an optimizer checkpoint must be a dict with a 'name' entry")
    return _lookup(state["name"]).from_state(state)


def _lookup(name: str) -> type:
    try:
        return OPTIMIZERS[name]
    except (KeyError, TypeError):
        raise FitError(f"unknown optimizer {name!r}; valid: {', '.join(NAMES)}") from None


@dataclass(frozen=True, eq=False)
class Minimum:
    values: np.ndarray  # parameter units
    vector: np.ndarray  # the residual there
    jacobian: np.ndarray | None = None  # in normalised coordinates (Levenberg-Marquardt only)
    stopped: bool = False  # `should_stop` ended the search early


def minimise(name: str, residuals: Callable[[Sequence[np.ndarray]], list[np.ndarray]], parameters, start: np.ndarray,
             *, iterations: int = 6, seed: int = 0, sigma0: float = 0.15,
             should_stop: Callable[[], bool] | None = None) -> Minimum:
    """Minimise |residuals(values)|^2 over the free parameters of `parameters` (a `bridge.params.ParameterSet`)
    from `start` (parameter units) with `name`: `lm` (at most `iterations` evaluations of the solver), or `es` /
    `cmaes` (`iterations` generations). `residuals` takes a batch of value vectors. `should_stop` is asked
    between evaluations (after the first): when it says so, the best point so far is returned (`stopped`)."""
    if name == "lm":
        lower, upper = parameters.normal_bounds()

        def in_normal(xs):
            return residuals([parameters.from_normal(x) for x in xs])

        fit = levenberg_marquardt(in_normal, parameters.to_normal(start), lower, upper, max_iterations=iterations,
                                  should_stop=should_stop)
        return Minimum(parameters.from_normal(fit.x), fit.vector, fit.jacobian, fit.stopped)
    opt = make_optimizer(name, np.clip(parameters.to_unit(start), 0.0, 1.0), sigma0, seed,
                         max_generations=iterations, patience=iterations)
    best: tuple[float, np.ndarray, np.ndarray] | None = None
    while not opt.done:
        if best is not None and should_stop is not None and should_stop():
            return Minimum(best[1], best[2], stopped=True)
        candidates = opt.ask()
        values = [parameters.from_unit(u) for u in candidates]
        vectors = residuals(values)
        errors = [float(v @ v) for v in vectors]
        opt.tell(candidates, errors)
        k = int(np.argmin(errors))
        if best is None or errors[k] < best[0]:
            best = (errors[k], values[k], vectors[k])
    return Minimum(best[1], best[2])
