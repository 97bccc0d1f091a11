"""Optimisers for fitting simulation parameters: one file each, one ask/tell interface, an explicit registry.

    opt = make_optimizer("es", x0, sigma0=0.2, seed=1)
    while not opt.done:
        candidates = opt.ask()                       # points in [0, 1]^D
        opt.tell(candidates, [error(c) for c in candidates])
        save(opt.state())                            # resume: restore_optimizer(state)
"""
from __future__ import annotations

from typing import Any, Mapping, Sequence

from ...errors import FitError
from .base import GenerationRecord, Optimizer, StopRule
from .cmaes import CMAES
from .es import EvolutionStrategy

OPTIMIZERS: dict[str, type] = {
    "es": EvolutionStrategy,
    "cmaes": CMAES,
}

__all__ = ["OPTIMIZERS", "CMAES", "EvolutionStrategy", "GenerationRecord", "Optimizer", "StopRule",
           "make_optimizer", "restore_optimizer"]


def make_optimizer(name: str, x0: Sequence[float], sigma0: float, seed: int | None, **options: Any) -> Optimizer:
    """A fresh optimiser by registry name; options are the optimiser's own plus the stop rule's
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
        raise FitError(f"unknown optimizer {name!r}; valid: {', '.join(sorted(OPTIMIZERS))}") from None
