"""CMA-ES through the `cma` library, behind the same ask/tell interface as the paper's ES.

`cma.CMAEvolutionStrategy` runs in the normalised box with ``bounds=[0, 1]`` (cma's boundary transformation,
so every candidate lies in the box). Randomness: cma's own ``seed`` option only seeds numpy's *global* RNG,
which a pickle of the strategy would not capture; instead cma draws its normal samples through the ``randn``
option from a private `np.random.default_rng(seed)`, which lives inside the strategy object.

Checkpoint: `state()` holds the whole `cma.CMAEvolutionStrategy` (RNG included) pickled and base64-encoded,
next to plain-data bookkeeping, so the dict stays JSON-able. `from_state` unpickles it: only restore
checkpoints you wrote yourself (unpickling runs code), and with the same `cma` version.
Stopping: our `StopRule` (tol/patience/budgets/target) and cma's own numerical criteria (tolx, tolfun, ...);
cma's iteration and evaluation budgets are switched off in favour of ours.
"""
from __future__ import annotations

import base64
import math
import pickle
from typing import Any, Mapping, Sequence

import numpy as np

from ..errors import FitError
from .base import Progress, StopRule, Tracked, check_start, check_told, split_options

_OWN_OPTIONS = ("popsize", "cma_options")
_FORMAT = 1
_WORST = 1e300  # cma wants finite values; failed evaluations (NaN/inf) rank last
_BUDGET_STOPS = {"maxiter", "maxfevals"}


class _Randn:
    """``randn(*shape)`` drawing from a private, picklable generator (cma's ``randn`` option)."""

    def __init__(self, seed: int | None):
        self.rng = np.random.default_rng(seed)

    def __call__(self, *shape: int) -> np.ndarray:
        return self.rng.standard_normal(shape)


class CMAES(Tracked):
    """CMA-ES (Hansen) on [0, 1]^D via `cma`; `popsize` defaults to cma's 4 + floor(3 ln D)."""

    name = "cmaes"

    def __init__(self, x0: Sequence[float], sigma0: float, seed: int | None, **options: Any):
        x, sigma = check_start(x0, sigma0)
        own, rule = split_options(options, _OWN_OPTIONS, self.name)
        self.x0 = x
        self.sigma0 = sigma
        self.seed = seed
        self.popsize = own.get("popsize")
        self.cma_options = dict(own.get("cma_options") or {})
        if self.popsize is not None and (not isinstance(self.popsize, (int, np.integer)) or self.popsize < 2):
            raise FitError(f"cmaes: popsize must be an integer >= 2, got {self.popsize!r}")
        reserved = {"bounds", "seed", "randn", "popsize"} & set(self.cma_options)
        if reserved:
            raise FitError(f"cmaes: cma_options may not set {', '.join(sorted(reserved))}; "
                           "bounds, seed and popsize are managed by bridge")
        self._progress = Progress(rule)
        self._pending: list[np.ndarray] | None = None
        self._es = self._make_strategy()

    def _make_strategy(self) -> Any:
        import cma  # local: the ES must not need it

        opts = {"verbose": -9, "verb_disp": 0, "verb_log": 0, "maxiter": math.inf, "maxfevals": math.inf,
                **self.cma_options, "bounds": [0.0, 1.0], "seed": math.nan, "randn": _Randn(self.seed)}
        if self.popsize is not None:
            opts["popsize"] = int(self.popsize)
        try:
            return cma.CMAEvolutionStrategy(self.x0.tolist(), self.sigma0, opts)
        except (ValueError, TypeError) as exc:
            raise FitError(f"cmaes: cma rejected the settings: {exc}") from None

    # --- ask / tell ---------------------------------------------------------------------------------
    def ask(self) -> list[np.ndarray]:
        """The next generation's candidates; asking again before `tell` returns the same ones."""
        if self._pending is None:
            self._pending = [np.array(x, dtype=float) for x in self._es.ask()]
        return [x.copy() for x in self._pending]

    def tell(self, candidates: Sequence[np.ndarray], errors: Sequence[float]) -> None:
        """Errors of the asked candidates (NaN/inf count as worst)."""
        e = check_told(self._pending, candidates, errors, self.name)
        xs = np.array(self._pending)
        self._es.tell(self._pending, np.where(np.isfinite(e), e, _WORST).tolist())
        self._pending = None
        selected = np.argsort(e, kind="stable")[: int(self._es.sp.weights.mu)]
        self._progress.record(xs, e, xs[selected], e[selected], float(self._es.sigma))

    # --- progress -----------------------------------------------------------------------------------
    @property
    def stop_reason(self) -> str | None:
        reason = self._progress.stop_reason()
        if reason is None and self._progress.generation > 0:
            stops = {k: v for k, v in self._es.stop().items() if k not in _BUDGET_STOPS}
            if stops:
                reason = "cma: " + ", ".join(f"{k}={v}" for k, v in stops.items())
        return reason

    # --- checkpoints --------------------------------------------------------------------------------
    def state(self) -> dict:
        """Settings and bookkeeping as plain data; the cma strategy itself pickled (base64 text)."""
        rule = self._progress.rule
        return {
            "name": self.name,
            "format": _FORMAT,
            "x0": self.x0.tolist(),
            "sigma0": self.sigma0,
            "seed": self.seed,
            "options": {"popsize": self.popsize, "cma_options": self.cma_options,
                        "tol": rule.tol, "patience": rule.patience, "max_generations": rule.max_generations,
                        "max_evaluations": rule.max_evaluations, "target_error": rule.target_error},
            "cma_pickle": base64.b64encode(pickle.dumps(self._es)).decode("ascii"),
            "pending": None if self._pending is None else [x.tolist() for x in self._pending],
            "progress": self._progress.state(),
        }

    @classmethod
    def from_state(cls, state: Mapping[str, Any]) -> "CMAES":
        """Continue from `state()`; unpickles the cma strategy, so only load checkpoints you trust."""
        if state.get("name") != cls.name or state.get("format") != _FORMAT:
            raise FitError(f"not a cmaes checkpoint (name {state.get('name')!r}, format {state.get('format')!r})")
        try:
            opt = cls.__new__(cls)
            opt.x0 = np.array(state["x0"], dtype=float)
            opt.sigma0 = float(state["sigma0"])
            opt.seed = state["seed"]
            options = dict(state["options"])
            opt.popsize = options.pop("popsize")
            opt.cma_options = dict(options.pop("cma_options") or {})
            opt._progress = Progress.from_state(StopRule(**options), state["progress"])
            opt._pending = None if state["pending"] is None else [np.array(x, dtype=float) for x in state["pending"]]
            opt._es = pickle.loads(base64.b64decode(state["cma_pickle"]))
        except (KeyError, TypeError, ValueError, pickle.UnpicklingError) as exc:
            raise FitError(f"cmaes checkpoint is incomplete or malformed: {exc!r}") from None
        return opt
