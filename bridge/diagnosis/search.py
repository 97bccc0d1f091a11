"""Fitting models on the training recordings: cached runs, a fit in normalised coordinates with any of the shared
optimisers (`bridge.optim`; Levenberg-Marquardt by default, its Jacobian one batch on the executor), and the
criteria that compare fitted models (the paper's error of a run, the residual's correlation time, BIC).

Parameters are searched in normalised units x = (value - null) / step (`ParameterSet.to_normal`): the null value
(the world model's) is 0 and one unit is the parameter's typical size, also the finite-difference step.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from ..optim import minimise
from ..optim.lm import gauss_newton_step, jacobian, levenberg_marquardt
from ..params import Model, ParameterSet
from ..rollout.compare import DEFAULT_C, PoseError, error_of_residuals
from .runs import Run, Runner, vector_of


class Evaluator:
    """Runs models on the training trials, remembering every result."""

    def __init__(self, runner: Runner, indices: Sequence[int]):
        self.runner, self.indices = runner, list(indices)
        self.cache: dict[Model, tuple[Run, ...]] = {}

    def runs_many(self, models: Sequence[Model]) -> list[tuple[Run, ...]]:
        todo = [m for m in dict.fromkeys(models) if m not in self.cache]
        if todo:
            for m, runs in zip(todo, self.runner.run_many(todo, self.indices)):
                self.cache[m] = tuple(runs)
        return [self.cache[m] for m in models]

    def runs(self, model: Model) -> tuple[Run, ...]:
        return self.runs_many([model])[0]

    def vector(self, model: Model) -> np.ndarray:
        return vector_of(self.runs(model))

    def chi2(self, model: Model) -> float:
        v = self.vector(model)
        return float(v @ v)

    def residuals(self, space: ParameterSet):
        """The batch residual of `space` in normalised coordinates, for the optimisers."""
        def batch(xs: Sequence[np.ndarray]) -> list[np.ndarray]:
            return [vector_of(r) for r in self.runs_many([space.model(space.from_normal(x)) for x in xs])]
        return batch


@dataclass(frozen=True, eq=False)
class FitResult:
    space: ParameterSet
    x: np.ndarray  # normalised coordinates
    vector: np.ndarray
    jacobian: np.ndarray | None
    runs: tuple[Run, ...]
    evaluations: int  # models evaluated (each on every training trial)
    stopped: bool = False  # cut short by `should_stop` (the best point so far)

    @property
    def chi2(self) -> float:
        return float(self.vector @ self.vector)

    @property
    def n(self) -> int:
        return int(self.vector.size)

    def values(self) -> dict[str, float]:
        return self.space.as_dict(self.space.from_normal(self.x))

    def model(self) -> Model:
        return self.space.model(self.space.from_normal(self.x))

    def std(self, inflate: float = 1.0) -> dict[str, float]:
        """1-sigma parameter uncertainty from the curvature: cov = (J^T J)^-1 * max(1, reduced chi^2) * inflate."""
        if self.jacobian is None or self.space.dim == 0:
            return {n: math.nan for n in self.space.names}
        J = self.jacobian
        dof = max(1, self.n - self.space.dim)
        s2 = max(1.0, self.chi2 / dof) * inflate
        try:
            cov = np.linalg.pinv(J.T @ J) * s2
            sd = np.sqrt(np.maximum(np.diag(cov), 0.0)) * self.space.steps
        except np.linalg.LinAlgError:
            sd = np.full(self.space.dim, math.nan)
        return {n: float(v) for n, v in zip(self.space.names, sd)}


def fit(ev: Evaluator, space: ParameterSet, x0: np.ndarray, *, max_iterations: int = 6,
        optimizer: str = "lm", should_stop: Callable[[], bool] | None = None) -> FitResult:
    """Fit `space` from x0 (normalised) with `optimizer` (`lm`: Levenberg-Marquardt, scipy's bounded trust-region
    solver; `cmaes`/`es`: `max_iterations` generations); keeps the best point seen. `should_stop` (asked between
    evaluations) ends the fit early with the best point so far."""
    before = len(ev.cache)
    if space.dim == 0:
        runs = ev.runs(space.model())
        return FitResult(space, np.zeros(0), vector_of(runs), None, runs, len(ev.cache) - before)
    lower, upper = space.normal_bounds()
    residuals = ev.residuals(space)
    if optimizer == "lm":
        result = levenberg_marquardt(residuals, x0, lower, upper, max_iterations=max_iterations,
                                     should_stop=should_stop)
        x, f, J, stopped = result.x, result.vector, result.jacobian, result.stopped
    else:
        found = minimise(optimizer, lambda values: [vector_of(r) for r in ev.runs_many([space.model(v) for v in values])],
                         space, space.from_normal(x0), iterations=max_iterations, should_stop=should_stop)
        x, f, stopped = space.to_normal(found.values), found.vector, found.stopped
        J = None if stopped else jacobian(residuals, x, f, upper)
    return FitResult(space, x, f, J, ev.runs(space.model(space.from_normal(x))), len(ev.cache) - before, stopped)


def screen(ev: Evaluator, space: ParameterSet, x0: np.ndarray) -> tuple[np.ndarray, float]:
    """One bounded Gauss-Newton step from x0 (a cheap screen, `bridge.optim.lm.gauss_newton_step`)."""
    lower, upper = space.normal_bounds()
    return gauss_newton_step(ev.residuals(space), np.asarray(x0, dtype=float), lower, upper)


# --- errors and evidence --------------------------------------------------------------------------------------
def pose_error_of(runs: Sequence[Run], c: float = DEFAULT_C) -> PoseError | None:
    """The paper's error (eq. 1-4) over every observed sample of `runs`, from their residuals."""
    residuals = [res for r in runs for res in r.residuals.values()]
    if not residuals or not all(np.all(np.isfinite(res)) for res in residuals):
        return None
    return error_of_residuals(residuals, c)


def correlation_time(runs: Sequence[Run]) -> float:
    """Integrated autocorrelation time (samples) of the normalised residuals, averaged over series: 1 for white
    noise, larger when the residual is a smooth misfit; it discounts the number of independent samples."""
    taus = []
    for r in runs:
        for res in r.residuals.values():
            if not np.all(np.isfinite(res)) or len(res) < 8:
                continue
            for k in range(res.shape[1]):
                x = res[:, k] - res[:, k].mean()
                var = float(x @ x)
                if var <= 0:
                    continue
                tau = 1.0
                for lag in range(1, len(x) // 4):
                    rho = float(x[:-lag] @ x[lag:]) / var
                    if rho < 0.05:
                        break
                    tau += 2.0 * rho
                taus.append(tau)
    return float(np.clip(np.median(taus), 1.0, 50.0)) if taus else 1.0


def bic(chi2: float, n: int, k: int, tau: float) -> float:
    """Schwarz's criterion with the noise floor as sigma, on tau-discounted samples: chi2/tau + k ln(n/tau)."""
    n_eff = max(2.0, n / tau)
    return chi2 / tau + k * math.log(n_eff)
