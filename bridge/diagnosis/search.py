"""Fitting effect parameters on trials: a normalised parameter space and a Levenberg-Marquardt fit whose
finite-difference Jacobian is evaluated as one batch (so a process pool runs it in parallel).

Parameters are searched in normalised units x = (value - null) / scale: the null value (no effect) is 0 and one
unit is the parameter's typical size, which is also the finite-difference step (large enough to see through
the small, non-smooth jitter of contact simulation).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np
from scipy.optimize import least_squares

from ..fit.error import DEFAULT_C, PoseError
from .effects import Applied, ParamSpec
from .simulation import Engine, Model, Run, vector_of

FD_STEP = 1.0  # normalised units


@dataclass(frozen=True)
class Part:
    """One effect being fitted: which, on what, its parameter specs."""

    effect: str
    target: str
    specs: tuple[ParamSpec, ...]


class Space:
    """The parameters of `parts` on top of a fixed `base` model."""

    def __init__(self, parts: Sequence[Part], base: Model = ()):
        self.parts = tuple(parts)
        self.base = tuple(base)
        self.specs = [s for p in self.parts for s in p.specs]
        self.null = np.array([s.null for s in self.specs])
        self.scale = np.array([s.scale for s in self.specs])
        self.lower = (np.array([s.lower for s in self.specs]) - self.null) / self.scale
        self.upper = (np.array([s.upper for s in self.specs]) - self.null) / self.scale

    @property
    def dim(self) -> int:
        return len(self.specs)

    def to_x(self, values: Sequence[Mapping[str, float]]) -> np.ndarray:
        flat = [values[i].get(s.name, s.null) for i, p in enumerate(self.parts) for s in p.specs]
        return np.clip((np.array(flat, dtype=float) - self.null) / self.scale, self.lower, self.upper)

    def values(self, x: np.ndarray) -> list[dict[str, float]]:
        v = self.null + np.asarray(x, dtype=float) * self.scale
        out, k = [], 0
        for p in self.parts:
            out.append({s.name: float(v[k + j]) for j, s in enumerate(p.specs)})
            k += len(p.specs)
        return out

    def applied(self, x: np.ndarray) -> tuple[Applied, ...]:
        return tuple(Applied.of(p.effect, p.target, vals) for p, vals in zip(self.parts, self.values(x)))

    def model(self, x: np.ndarray) -> Model:
        return self.base + self.applied(x)


@dataclass(frozen=True, eq=False)
class FitResult:
    space: Space
    x: np.ndarray
    vector: np.ndarray
    jacobian: np.ndarray | None
    runs: tuple[Run, ...]
    evaluations: int  # models evaluated (each on every training trial)

    @property
    def chi2(self) -> float:
        return float(self.vector @ self.vector)

    @property
    def n(self) -> int:
        return int(self.vector.size)

    def values(self) -> list[dict[str, float]]:
        return self.space.values(self.x)

    def model(self) -> Model:
        return self.space.model(self.x)

    def std(self, inflate: float = 1.0) -> list[dict[str, float]]:
        """1-sigma parameter uncertainty from the curvature: cov = (J^T J)^-1 * max(1, reduced chi^2) * inflate."""
        if self.jacobian is None or self.space.dim == 0:
            return [{s.name: math.nan for s in p.specs} for p in self.space.parts]
        J = self.jacobian
        dof = max(1, self.n - self.space.dim)
        s2 = max(1.0, self.chi2 / dof) * inflate
        try:
            cov = np.linalg.pinv(J.T @ J) * s2
            sd = np.sqrt(np.maximum(np.diag(cov), 0.0)) * self.space.scale
        except np.linalg.LinAlgError:
            sd = np.full(self.space.dim, math.nan)
        out, k = [], 0
        for p in self.space.parts:
            out.append({s.name: float(sd[k + j]) for j, s in enumerate(p.specs)})
            k += len(p.specs)
        return out


class Evaluator:
    """Runs models on the training trials, remembering every result."""

    def __init__(self, engine: Engine, indices: Sequence[int]):
        self.engine, self.indices = engine, list(indices)
        self.cache: dict[Model, tuple[Run, ...]] = {}

    def runs_many(self, models: Sequence[Model]) -> list[tuple[Run, ...]]:
        todo = [m for m in dict.fromkeys(models) if m not in self.cache]
        if todo:
            for m, runs in zip(todo, self.engine.run_many(todo, self.indices)):
                self.cache[m] = tuple(runs)
        return [self.cache[m] for m in models]

    def runs(self, model: Model) -> tuple[Run, ...]:
        return self.runs_many([model])[0]

    def vector(self, model: Model) -> np.ndarray:
        return vector_of(self.runs(model))

    def chi2(self, model: Model) -> float:
        v = self.vector(model)
        return float(v @ v)


def jacobian(ev: Evaluator, space: Space, x: np.ndarray, f0: np.ndarray) -> np.ndarray:
    """Forward differences with a step of FD_STEP normalised units (backward at an upper bound), one batch."""
    points = []
    for j in range(space.dim):
        xj = np.array(x, dtype=float)
        h = FD_STEP if xj[j] + FD_STEP <= space.upper[j] else -FD_STEP
        xj[j] += h
        points.append((xj, h))
    vectors = [vector_of(r) for r in ev.runs_many([space.model(p) for p, _ in points])]
    J = np.zeros((f0.size, space.dim))
    for j, ((_, h), v) in enumerate(zip(points, vectors)):
        if v.size == f0.size:
            J[:, j] = (v - f0) / h
    return J


def fit(ev: Evaluator, space: Space, x0: np.ndarray, *, max_iterations: int = 6) -> FitResult:
    """Levenberg-Marquardt (scipy's trust-region reflective, bounded) from x0; keeps the best point seen."""
    before = len(ev.cache)
    if space.dim == 0:
        runs = ev.runs(space.model(np.zeros(0)))
        return FitResult(space, np.zeros(0), vector_of(runs), None, runs, len(ev.cache) - before)
    x0 = np.clip(np.asarray(x0, dtype=float), space.lower, space.upper)
    seen: dict[bytes, np.ndarray] = {}
    last_J: dict[bytes, np.ndarray] = {}

    def fun(x):
        key = np.asarray(x, dtype=float).tobytes()
        if key not in seen:
            seen[key] = ev.vector(space.model(x))
        return seen[key]

    def jac(x):
        key = np.asarray(x, dtype=float).tobytes()
        if key not in last_J:
            last_J[key] = jacobian(ev, space, np.asarray(x, dtype=float), fun(x))
        return last_J[key]

    try:
        least_squares(fun, x0, jac=jac, bounds=(space.lower, space.upper), method="trf", x_scale=1.0,
                      max_nfev=max_iterations, xtol=1e-3, ftol=1e-4, gtol=1e-6)
    except (ValueError, np.linalg.LinAlgError):
        pass  # keep the best point evaluated so far
    best_key = min(seen, key=lambda k: float(seen[k] @ seen[k])) if seen else x0.tobytes()
    x_best = np.frombuffer(best_key, dtype=float).copy() if seen else x0
    f_best = fun(x_best)
    J = last_J.get(best_key)
    if J is None:
        J = jacobian(ev, space, x_best, f_best)
    return FitResult(space, x_best, f_best, J, ev.runs(space.model(x_best)), len(ev.cache) - before)


def gauss_newton_step(ev: Evaluator, space: Space, x0: np.ndarray) -> tuple[np.ndarray, float]:
    """A cheap screen from x0: one bounded Gauss-Newton step (and a shorter one), then, if neither lowers the
    chi^2, steps of 1 and 3 units against the gradient; returns the best point and its chi^2."""
    f0 = ev.vector(space.model(x0))
    c0 = float(f0 @ f0)
    J = jacobian(ev, space, x0, f0)
    if not np.any(J):
        return x0, c0
    step, *_ = np.linalg.lstsq(J, -f0, rcond=None)
    length = float(np.linalg.norm(step))
    if length > 8.0:  # trust region: the linearisation holds a few scales at most
        step *= 8.0 / length
    tries = [np.clip(x0 + step, space.lower, space.upper), np.clip(x0 + 0.3 * step, space.lower, space.upper)]
    best_x, best_c = x0, c0
    for x in tries:
        c = ev.chi2(space.model(x))
        if c < best_c:
            best_x, best_c = x, c
    if best_c < c0:
        return best_x, best_c
    g = -(J.T @ f0)
    g = g / (np.linalg.norm(g) or 1.0)
    for size in (1.0, 3.0):
        x = np.clip(x0 + size * g, space.lower, space.upper)
        c = ev.chi2(space.model(x))
        if c < best_c:
            best_x, best_c = x, c
    return best_x, best_c


# --- errors and evidence --------------------------------------------------------------------------------------
def pose_error_of(runs: Sequence[Run], c: float = DEFAULT_C) -> PoseError | None:
    """The paper's error (eq. 1-4) over every observed sample of `runs`, from their residuals."""
    e_t2, e_R2 = [], []
    for r in runs:
        for res in r.residuals.values():
            if not np.all(np.isfinite(res)):
                return None
            e_t2.append(np.sum(res[:, :3] ** 2, axis=1))
            e_R2.append(np.sum(res[:, 3:] ** 2, axis=1))
    if not e_t2:
        return None
    t2, R2 = np.concatenate(e_t2), np.concatenate(e_R2)
    return PoseError(float(np.sqrt(t2.mean())), float(np.sqrt(R2.mean())), float(np.sqrt((t2 + c * R2).mean())),
                     int(t2.size))


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
