"""Levenberg-Marquardt over a batch residual: scipy's bounded trust-region solver with a finite-difference
Jacobian evaluated as one batch (so a process pool runs its columns in parallel), keeping the best point seen.

It works in normalised coordinates (`ParameterSet.to_normal`): one unit is a parameter's typical size and the
finite-difference step, large enough to see through the small, non-smooth jitter of contact simulation.

With `secant=True` the Jacobian is differenced once, at the start, and then carried along the accepted steps by
Broyden's rank-one update (the change of the residual along the step replaces the Jacobian's prediction of it):
an iteration then costs one evaluation instead of 1 + D. The Jacobian at the best point, which the parameters'
uncertainty is read from, is differenced again at the end.
`residuals(points) -> vectors` evaluates a batch of points; its squared norm is what is minimised (the
paper's E^2 for a fit, chi^2 for a diagnosis).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np
from scipy.optimize import least_squares

FD_STEP = 1.0  # normalised units
TRUST = 8.0  # normalised units: the longest Gauss-Newton step a screen takes (the linearisation holds a few)

Residuals = Callable[[Sequence[np.ndarray]], list[np.ndarray]]
# the same for points a search keeps only if their chi^2 is below a bound: None for a point shown to exceed it
# before it was evaluated in full (`diagnosis.search.Evaluator.bounded`)
Bounded = Callable[[Sequence[np.ndarray], float], list["np.ndarray | None"]]


@dataclass(frozen=True, eq=False)
class LeastSquares:
    x: np.ndarray
    vector: np.ndarray
    jacobian: np.ndarray | None
    stopped: bool = False  # `should_stop` ended the search early (the jacobian may then be None)
    differenced: bool = True  # the jacobian is a finite difference at x (else a secant estimate, or None)

    @property
    def chi2(self) -> float:
        return float(self.vector @ self.vector)


def jacobian(residuals: Residuals, x: np.ndarray, f0: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Forward differences with a step of FD_STEP (backward at an upper bound), one batch. A column whose point
    gave a residual of another length (a failed replay) stays zero."""
    points, steps = [], []
    for j in range(len(x)):
        xj = np.array(x, dtype=float)
        h = FD_STEP if xj[j] + FD_STEP <= upper[j] else -FD_STEP
        xj[j] += h
        points.append(xj)
        steps.append(h)
    J = np.zeros((f0.size, len(x)))
    for j, (h, v) in enumerate(zip(steps, residuals(points))):
        if v.size == f0.size:
            J[:, j] = (v - f0) / h
    return J


class _Stop(Exception):
    """`should_stop` said so: leave the solver, keep the best point so far."""


class _Flat(Exception):
    """`patience` evaluations in a row lowered the best chi^2 by less than `gain`: the rest would be alike."""


def levenberg_marquardt(residuals: Residuals, x0: np.ndarray, lower: np.ndarray, upper: np.ndarray, *,
                        max_iterations: int = 6, should_stop: Callable[[], bool] | None = None,
                        secant: bool = False, patience: int | None = None, gain: float = 1e-3,
                        final_jacobian: bool = True, bounded: Bounded | None = None) -> LeastSquares:
    """Minimise |residuals(x)|^2 from x0 within [lower, upper]; returns the best point evaluated, its residual and
    the (finite-difference) Jacobian there. `should_stop` is asked before every evaluation after the first: when it
    says so, the search ends with the best point so far (`stopped`; its Jacobian only if it was evaluated).
    `secant`: Broyden updates of the Jacobian between the first and the last (see above). `patience`: the search
    also ends once that many evaluations in a row have lowered the best chi^2 by less than `gain` (relative): the
    solver then only shrinks its trust region around a point it cannot improve on. `final_jacobian` False: the
    Jacobian at the best point is not differenced again; the secant estimate there is returned
    (`differenced` False) for the caller to difference when it needs it. `bounded`: a trial step is kept only if
    it lowers chi^2 below the best so far (the trust-region solver's rule; the best so far is where it stands), so
    its evaluation may stop once it exceeds that: the solver then sees a stand-in residual above the bound, which
    it rejects as it would the true one (any rejected step shrinks the region alike), and takes the same path."""
    x0 = np.clip(np.asarray(x0, dtype=float), lower, upper)
    seen: dict[bytes, np.ndarray] = {}
    jacobians: dict[bytes, np.ndarray] = {}
    differenced: set[bytes] = set()  # points whose Jacobian is a finite difference, not a secant update
    last: list = []  # (x, f, J) where the solver last asked for a Jacobian

    def check() -> None:
        if seen and should_stop is not None and should_stop():
            raise _Stop

    flat = [math.inf, 0]  # best chi^2, evaluations in a row without a gain

    def fun(x):
        key = np.asarray(x, dtype=float).tobytes()
        if key not in seen:
            check()
            if patience is not None and flat[1] >= patience:
                raise _Flat
            point = np.asarray(x, dtype=float)
            if bounded is not None and seen:
                f = bounded([point], flat[0])[0]
                seen[key] = f if f is not None else _stand_in(flat[0], next(iter(seen.values())).size)
            else:
                seen[key] = residuals([point])[0]
            c = float(seen[key] @ seen[key])
            if c < flat[0] * (1.0 - gain) or not math.isfinite(flat[0]):
                flat[:] = [min(c, flat[0]), 0]
            else:
                flat[0], flat[1] = min(c, flat[0]), flat[1] + 1
        return seen[key]

    def jac(x):
        x = np.asarray(x, dtype=float)
        key = x.tobytes()
        if key not in jacobians:
            f = fun(x)
            if secant and last and last[1].size == f.size and np.any(x != last[0]):
                jacobians[key] = _broyden(x, f, last)
            if key not in jacobians:
                check()
                jacobians[key] = jacobian(residuals, x, f, upper)
                differenced.add(key)
        last[:] = [x, fun(x), jacobians[key]]
        return jacobians[key]

    stopped = False
    try:
        least_squares(fun, x0, jac=jac, bounds=(lower, upper), method="trf", x_scale=1.0, max_nfev=max_iterations,
                      xtol=1e-3, ftol=1e-4, gtol=1e-6)
    except (ValueError, np.linalg.LinAlgError, _Flat):
        pass  # keep the best point evaluated so far
    except _Stop:
        stopped = True
    best_key = min(seen, key=lambda k: float(seen[k] @ seen[k])) if seen else x0.tobytes()
    x_best = np.frombuffer(best_key, dtype=float).copy() if seen else x0
    f_best = fun(x_best)
    if best_key in differenced:
        return LeastSquares(x_best, f_best, jacobians[best_key], stopped)
    if not final_jacobian:
        return LeastSquares(x_best, f_best, _secant_at(x_best, f_best, last, jacobians.get(best_key)), stopped, False)
    J = None if stopped else jacobian(residuals, x_best, f_best, upper)
    return LeastSquares(x_best, f_best, J, stopped)


def _secant_at(x: np.ndarray, f: np.ndarray, last: list, J: np.ndarray | None) -> np.ndarray | None:
    """The secant estimate of the Jacobian at x: the one kept there, else the last one updated to x."""
    if J is not None or not last or last[1].size != f.size:
        return J
    return _broyden(x, f, last) if np.any(x != last[0]) else last[2]


def _broyden(x: np.ndarray, f: np.ndarray, last: list) -> np.ndarray:
    """Broyden's rank-one update of the Jacobian `last` = (x', f', J') to x: J' corrected along the step s = x - x'
    so that it predicts the change of the residual f - f' there exactly."""
    x_prev, f_prev, J_prev = last
    s = x - x_prev
    return J_prev + np.outer((f - f_prev) - J_prev @ s, s) / float(s @ s)


def _stand_in(bound: float, size: int) -> np.ndarray:
    """A residual of `size` entries whose chi^2 exceeds `bound`: the stand-in for a point cut short above it."""
    return np.full(size, math.sqrt((2.0 * bound + 1.0) / max(size, 1)))


def gauss_newton_step(residuals: Residuals, x0: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                      bounded: Bounded | None = None) -> tuple[np.ndarray, float]:
    """A cheap screen from x0: one bounded Gauss-Newton step (and a shorter one), then, if neither lowers the
    chi^2, steps of 1 and 3 units against the gradient; returns the best point and its chi^2. `bounded`: the
    steps are evaluated only as far as it takes to know they cannot be the best (`Bounded`)."""
    f0 = residuals([x0])[0]
    c0 = float(f0 @ f0)
    J = jacobian(residuals, x0, f0, upper)
    if not np.any(J):
        return x0, c0
    step, *_ = np.linalg.lstsq(J, -f0, rcond=None)
    length = float(np.linalg.norm(step))
    if length > TRUST:
        step *= TRUST / length
    best_x, best_c = x0, c0

    def evaluated(tries: list[np.ndarray]) -> list[np.ndarray | None]:  # one batch: the workers run both
        return residuals(tries) if bounded is None else bounded(tries, best_c)

    tries = [np.clip(x0 + step, lower, upper), np.clip(x0 + 0.3 * step, lower, upper)]
    for x, f in zip(tries, evaluated(tries)):
        if f is not None and float(f @ f) < best_c:
            best_x, best_c = x, float(f @ f)
    if best_c < c0:
        return best_x, best_c
    g = -(J.T @ f0)
    g = g / (np.linalg.norm(g) or 1.0)
    tries = [np.clip(x0 + size * g, lower, upper) for size in (1.0, 3.0)]
    for x, f in zip(tries, evaluated(tries)):
        if f is not None and float(f @ f) < best_c:
            best_x, best_c = x, float(f @ f)
    return best_x, best_c
