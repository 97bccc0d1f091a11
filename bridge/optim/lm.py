"""Levenberg-Marquardt over a batch residual: scipy's bounded trust-region solver with a finite-difference
Jacobian evaluated as one batch (so a process pool runs its columns in parallel), keeping the best point seen.

It works in normalised coordinates (`ParameterSet.to_normal`): one unit is a parameter's typical size and the
finite-difference step, large enough to see through the small, non-smooth jitter of contact simulation.
`residuals(points) -> vectors` evaluates a batch of points; its squared norm is what is minimised (the
paper's E^2 for a fit, chi^2 for a diagnosis).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np
from scipy.optimize import least_squares

FD_STEP = 1.0  # normalised units
TRUST = 8.0  # normalised units: the longest Gauss-Newton step a screen takes (the linearisation holds a few)

Residuals = Callable[[Sequence[np.ndarray]], list[np.ndarray]]


@dataclass(frozen=True, eq=False)
class LeastSquares:
    x: np.ndarray
    vector: np.ndarray
    jacobian: np.ndarray | None
    stopped: bool = False  # `should_stop` ended the search early (the jacobian may then be None)

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


def levenberg_marquardt(residuals: Residuals, x0: np.ndarray, lower: np.ndarray, upper: np.ndarray, *,
                        max_iterations: int = 6, should_stop: Callable[[], bool] | None = None) -> LeastSquares:
    """Minimise |residuals(x)|^2 from x0 within [lower, upper]; returns the best point evaluated, its residual and
    the Jacobian there. `should_stop` is asked before every evaluation after the first: when it says so, the
    search ends with the best point so far (`stopped`; its Jacobian only if it was evaluated)."""
    x0 = np.clip(np.asarray(x0, dtype=float), lower, upper)
    seen: dict[bytes, np.ndarray] = {}
    jacobians: dict[bytes, np.ndarray] = {}

    def check() -> None:
        if seen and should_stop is not None and should_stop():
            raise _Stop

    def fun(x):
        key = np.asarray(x, dtype=float).tobytes()
        if key not in seen:
            check()
            seen[key] = residuals([np.asarray(x, dtype=float)])[0]
        return seen[key]

    def jac(x):
        key = np.asarray(x, dtype=float).tobytes()
        if key not in jacobians:
            f = fun(x)
            check()
            jacobians[key] = jacobian(residuals, np.asarray(x, dtype=float), f, upper)
        return jacobians[key]

    stopped = False
    try:
        least_squares(fun, x0, jac=jac, bounds=(lower, upper), method="trf", x_scale=1.0, max_nfev=max_iterations,
                      xtol=1e-3, ftol=1e-4, gtol=1e-6)
    except (ValueError, np.linalg.LinAlgError):
        pass  # keep the best point evaluated so far
    except _Stop:
        stopped = True
    best_key = min(seen, key=lambda k: float(seen[k] @ seen[k])) if seen else x0.tobytes()
    x_best = np.frombuffer(best_key, dtype=float).copy() if seen else x0
    f_best = fun(x_best)
    J = jacobians.get(best_key)
    if J is None and not stopped:
        J = jacobian(residuals, x_best, f_best, upper)
    return LeastSquares(x_best, f_best, J, stopped)


def gauss_newton_step(residuals: Residuals, x0: np.ndarray, lower: np.ndarray, upper: np.ndarray
                      ) -> tuple[np.ndarray, float]:
    """A cheap screen from x0: one bounded Gauss-Newton step (and a shorter one), then, if neither lowers the
    chi^2, steps of 1 and 3 units against the gradient; returns the best point and its chi^2."""
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
    for x in (np.clip(x0 + step, lower, upper), np.clip(x0 + 0.3 * step, lower, upper)):
        f = residuals([x])[0]
        if float(f @ f) < best_c:
            best_x, best_c = x, float(f @ f)
    if best_c < c0:
        return best_x, best_c
    g = -(J.T @ f0)
    g = g / (np.linalg.norm(g) or 1.0)
    for size in (1.0, 3.0):
        x = np.clip(x0 + size * g, lower, upper)
        f = residuals([x])[0]
        if float(f @ f) < best_c:
            best_x, best_c = x, float(f @ f)
    return best_x, best_c
