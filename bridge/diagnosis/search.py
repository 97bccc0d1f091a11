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
from ..params import Model, ParameterSet, canonical_model
from ..rollout.compare import DEFAULT_C, PoseError, error_of_residuals
from .runs import Run, Runner, chi2_of, vector_of

PATIENCE = 3  # Levenberg-Marquardt evaluations in a row that gain less than GAIN end a fit
GAIN = 1e-3  # relative chi^2: a gain below this changes no comparison the diagnosis makes (MIN_GAIN is 20 %)
AT_BOUND = 0.25  # a fitted value this close to a bound (in units of the parameter's step, its typical size) is on it


class Evaluator:
    """Runs models on the training trials, remembering every result by the model's canonical form
    (`bridge.params.canonical_model`: settings that reproduce the world model left out), so a candidate at its
    null values is the friction model it extends, not a new simulation."""

    def __init__(self, runner: Runner, indices: Sequence[int]):
        self.runner, self.indices = runner, list(indices)
        self.cache: dict[Model, tuple[Run, ...]] = {}
        self.world = runner.prepared[self.indices[0]].world if self.indices else None
        self._seconds: list[float] | None = None  # each recording's replay, simulated seconds (`telling`)

    def canonical(self, model: Model) -> Model:
        return canonical_model(model, self.world, self.runner.odb) if self.world is not None else tuple(model)

    def runs_many(self, models: Sequence[Model]) -> list[tuple[Run, ...]]:
        keys = [self.canonical(m) for m in models]
        todo = [k for k in dict.fromkeys(keys) if k not in self.cache]
        if todo:
            for k, runs in zip(todo, self.runner.run_many(todo, self.indices)):
                self.cache[k] = tuple(runs)
        return [self.cache[k] for k in keys]

    def runs(self, model: Model) -> tuple[Run, ...]:
        return self.runs_many([model])[0]

    def runs_below(self, models: Sequence[Model], bound: float = math.inf) -> list[tuple[Run, ...] | None]:
        """The runs of the models that can be the least chi^2 below `bound` (the first of equals among them, as
        with every model run); None for a model whose replays were cut once they showed it cannot
        (`Runner.run_bounded`, a race). For searches that keep only such a model."""
        keys = [self.canonical(m) for m in models]
        best = min([bound] + [chi2_of(self.cache[k])[0] for k in keys if k in self.cache])
        todo = [k for k in dict.fromkeys(keys) if k not in self.cache]
        if todo:
            self._keep(todo, self.runner.run_bounded(todo, self.indices, [best] * len(todo), race=True,
                                                     first=[self.telling()] * len(todo)))
        return [self.cache.get(k) for k in keys]

    def runs_within(self, models: Sequence[Model], bounds: Sequence[float], counted: Sequence[Sequence[int]]
                    ) -> list[tuple[Run, ...] | None]:
        """The runs of each model, or None for one whose replays were cut once the chi^2 over its positions
        `counted[m]` exceeded `bounds[m]` (`Runner.run_bounded`): a test that a model passes only below it. The
        positions not counted are replayed last, once the model has passed. A model asked for twice (two tests of
        one point) is run in full."""
        keys = [self.canonical(m) for m in models]
        todo: dict[Model, int] = {}
        for m, k in enumerate(keys):
            if k not in self.cache:
                todo.setdefault(k, m)
        if todo:
            order = self.telling()
            ms = list(todo.values())
            first = [[j for j in order if j in counted[m]] + [j for j in order if j not in counted[m]] for m in ms]
            bound = [bounds[m] if keys.count(keys[m]) == 1 else math.inf for m in ms]
            self._keep(list(todo), self.runner.run_bounded(list(todo), self.indices, bound,
                                                           counted=[counted[m] for m in ms], first=first))
        return [self.cache.get(k) for k in keys]

    def _keep(self, keys: Sequence[Model], runs: Sequence[Sequence[Run] | None]) -> None:
        """Cache the models run in full (a model cut short is not: its runs are not all there)."""
        self.cache.update((k, tuple(r)) for k, r in zip(keys, runs) if r is not None)

    def telling(self) -> list[int]:
        """The training recordings (positions) in the order that tells soonest whether a model exceeds a bound:
        the best model so far's chi^2 per simulated second, largest first."""
        from ..rollout.executors import expected_seconds

        if not self.cache:
            return list(range(len(self.indices)))
        if self._seconds is None:
            self._seconds = [expected_seconds(self.runner.job((), i)) for i in self.indices]
        best = min(self.cache.values(), key=lambda runs: chi2_of(runs)[0])
        return sorted(range(len(self.indices)), key=lambda j: -best[j].chi2 / max(self._seconds[j], 1e-3))

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

    def bounded(self, space: ParameterSet):
        """`residuals` for points a search keeps only below a chi^2 (`runs_below`): None for the others."""
        def batch(xs: Sequence[np.ndarray], bound: float) -> list[np.ndarray | None]:
            runs = self.runs_below([space.model(space.from_normal(x)) for x in xs], bound)
            return [None if r is None else vector_of(r) for r in runs]
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
    differenced: bool = True  # `jacobian` is a finite difference at x; else the search's secant estimate there

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

    def at_bound(self) -> dict[str, float]:
        """The parameters a bound stopped: within AT_BOUND of it, the Gauss-Newton step from the optimum (the
        minimum of chi^2's local quadratic model, all parameters together) lies beyond it, and going there would
        pay for itself (`bound_gain`). The data then ask for a value the parameter's physical range excludes: the
        model family, not the value, is what is wrong. Two kinds of bound do not count:
        - one a step points past by noise alone (the gain test);
        - one of a parameter that only says how another acts (`Kind.inert_without`: where a changed mass sits,
          `mass_spread`), whose bound is itself a state the world takes (the weight at the very centre): in a
          world that differs from the model elsewhere (a softer pusher) such a parameter is where the misfit
          goes, and the value it qualifies (the mass) is still what the recordings say;
        - one of the contact's own stiffness or damping (`Kind.contact_model`), fitted among the ordinary
          parameters to take up how the world's contact differs from the model's (a softer pusher, another
          solver): no damping is a state a contact takes, and what presses there is a leftover the contact
          parameters cannot take up, not a wrong effect.
        The ordinary parameters are pair coefficients (`kinds.PairFriction`), each free of the other, so each
        counts on its own like any parameter. By name, the bound reached."""
        if self.jacobian is None or self.space.dim == 0:
            return {}
        lower, upper = self.space.normal_bounds()
        J = self.jacobian
        step = -np.linalg.pinv(J.T @ J) @ (J.T @ self.vector)
        beyond = self.x + step
        out = {}
        for i, p in enumerate(self.space.free):
            if p.kind.inert_without is not None or p.kind.contact_model:
                continue
            if self.x[i] >= upper[i] - AT_BOUND and beyond[i] > upper[i]:
                out[p.name] = float(p.bounds[1])
            elif self.x[i] <= lower[i] + AT_BOUND and beyond[i] < lower[i]:
                out[p.name] = float(p.bounds[0])
        price = self.parameter_price()
        return {k: v for k, v in out.items() if self.bound_gain([k]) > price}

    def bound_gain(self, names: Sequence[str]) -> float:
        """How much lower chi^2 (tau-discounted, like `bic`'s) would be if the parameters `names` could leave
        their bounds: the local quadratic model's minimum with them held against the one with every parameter
        free. A bound stops a fit only when this exceeds what BIC charges for as many parameters
        (`parameter_price`)."""
        J, r = self.jacobian, self.vector
        index = [i for i, p in enumerate(self.space.free) if p.name in set(names)]
        rest = np.delete(J, index, axis=1)

        def floor(A: np.ndarray) -> float:
            if A.shape[1] == 0:
                return float(r @ r)
            s, *_ = np.linalg.lstsq(A, -r, rcond=None)
            e = r + A @ s
            return float(e @ e)

        return (floor(rest) - floor(J)) / correlation_time(self.runs)

    def parameter_price(self) -> float:
        """What BIC charges one parameter on these samples: ln(n / tau) (`bic`)."""
        return math.log(max(2.0, self.n / correlation_time(self.runs)))

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
        optimizer: str = "lm", should_stop: Callable[[], bool] | None = None, secant: bool = True,
        final_jacobian: bool = False) -> FitResult:
    """Fit `space` from x0 (normalised) with `optimizer` (`lm`: Levenberg-Marquardt, scipy's bounded trust-region
    solver, its Jacobian differenced at the start and carried along the steps by Broyden updates unless `secant`
    is False, ending once PATIENCE evaluations in a row gained less than GAIN; `cmaes`/`es`: `max_iterations`
    generations); keeps the best point seen. The Jacobian at the best point is then the secant estimate
    (`differenced` False; `differenced(ev, result)` replaces it by a finite difference where the uncertainty
    matters), unless `final_jacobian`. `should_stop` (asked between evaluations) ends the fit early with the best
    point so far."""
    before = len(ev.cache)
    if space.dim == 0:
        runs = ev.runs(space.model())
        return FitResult(space, np.zeros(0), vector_of(runs), None, runs, len(ev.cache) - before)
    lower, upper = space.normal_bounds()
    residuals = ev.residuals(space)
    if optimizer == "lm":
        result = levenberg_marquardt(residuals, x0, lower, upper, max_iterations=max_iterations,
                                     should_stop=should_stop, secant=secant, patience=PATIENCE if secant else None,
                                     gain=GAIN, final_jacobian=final_jacobian or not secant,
                                     bounded=ev.bounded(space))
        x, f, J, stopped = result.x, result.vector, result.jacobian, result.stopped
        if not result.differenced:
            return FitResult(space, x, f, J, ev.runs(space.model(space.from_normal(x))), len(ev.cache) - before,
                             stopped, differenced=False)
    else:
        found = minimise(optimizer, lambda values: [vector_of(r) for r in ev.runs_many([space.model(v) for v in values])],
                         space, space.from_normal(x0), iterations=max_iterations, should_stop=should_stop)
        x, f, stopped = space.to_normal(found.values), found.vector, found.stopped
        J = None if stopped else jacobian(residuals, x, f, upper)
    return FitResult(space, x, f, J, ev.runs(space.model(space.from_normal(x))), len(ev.cache) - before, stopped)


def differenced(ev: Evaluator, result: FitResult) -> FitResult:
    """`result` with the finite-difference Jacobian at its point (the uncertainty of the parameters is read from
    it), computed now if the search left a secant estimate there."""
    from dataclasses import replace

    if result.differenced or result.space.dim == 0 or result.stopped:
        return result
    _, upper = result.space.normal_bounds()
    return replace(result, jacobian=jacobian(ev.residuals(result.space), result.x, result.vector, upper),
                   differenced=True)


def screen(ev: Evaluator, space: ParameterSet, x0: np.ndarray, free: Sequence[int] | None = None
           ) -> tuple[np.ndarray, float]:
    """One bounded Gauss-Newton step from x0 (a cheap screen, `bridge.optim.lm.gauss_newton_step`), in the
    coordinates `free` only (default: all; the others stay at x0's)."""
    lower, upper = space.normal_bounds()
    x0 = np.asarray(x0, dtype=float)
    if free is None:
        return gauss_newton_step(ev.residuals(space), x0, lower, upper, ev.bounded(space))
    free = list(free)
    batch, bounded = ev.residuals(space), ev.bounded(space)

    def points(ys: Sequence[np.ndarray]) -> list[np.ndarray]:
        out = []
        for y in ys:
            x = x0.copy()
            x[free] = y
            out.append(x)
        return out

    y, chi2 = gauss_newton_step(lambda ys: batch(points(ys)), x0[free], lower[free], upper[free],
                                lambda ys, bound: bounded(points(ys), bound))
    x = x0.copy()
    x[free] = y
    return x, chi2


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
