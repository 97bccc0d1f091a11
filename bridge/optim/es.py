"""The paper's (mu/rho + lambda) evolution strategy with sigma self-adaptation (Section V).

Each individual carries its position x in [0, 1]^D and one step size sigma. A generation of lambda offspring:
  1. pick rho distinct parents uniformly at random,
  2. recombine intermediately: x_r = mean of their x, sigma_r = mean of their sigma,
  3. mutate the step size log-normally: sigma = sigma_r * exp(tau * N(0, 1)), kept in [sigma_min, sigma_max],
  4. mutate the position: x = x_r + sigma * N(0, I), mirrored back into [0, 1] at the bounds.
Selection is "+": the mu best of parents and offspring become the next parents, so the best error never
rises. Parents are not re-evaluated; with a noisy simulation a lucky parent can survive (evaluate each
candidate on K runs, as the paper does, to damp that). Generation 0 is x0 itself plus lambda - 1 samples
around it with sigma0. Defaults follow the paper: lambda = 10 D, mu = 10, rho = 2, tau = D^-1/2.
All randomness comes from one `np.random.default_rng(seed)`, whose state is part of the checkpoint.
"""
from __future__ import annotations

import math
from typing import Any, Mapping, Sequence

import numpy as np

from ..errors import FitError
from .base import Progress, Tracked, check_start, check_told, reflect, split_options

_OWN_OPTIONS = ("lam", "mu", "rho", "tau", "sigma_min", "sigma_max")
_FORMAT = 1


class EvolutionStrategy(Tracked):
    """(mu/rho + lambda)-ES on [0, 1]^D with one self-adapted sigma per individual."""

    name = "es"

    def __init__(self, x0: Sequence[float], sigma0: float, seed: int | None, **options: Any):
        x, sigma = check_start(x0, sigma0)
        own, rule = split_options(options, _OWN_OPTIONS, self.name)
        dim = x.size
        self.dim = dim
        self.lam = int(own.get("lam", 10 * dim))
        self.mu = int(own.get("mu", 10))
        self.rho = int(own.get("rho", 2))
        self.tau = float(own.get("tau", dim ** -0.5))
        self.sigma_min = float(own.get("sigma_min", 1e-12))
        self.sigma_max = float(own.get("sigma_max", 1.0))
        self._check_sizes()
        self.x0 = x
        self.sigma0 = sigma
        self.seed = seed
        self._rng = np.random.default_rng(seed)
        self._progress = Progress(rule)
        self._parents_x = np.empty((0, dim))
        self._parents_sigma = np.empty(0)
        self._parents_error = np.empty(0)
        self._pending: list[np.ndarray] | None = None
        self._pending_sigma: np.ndarray | None = None

    def _check_sizes(self) -> None:
        if not 1 <= self.rho <= self.mu <= self.lam:
            raise FitError(f"es: need 1 <= rho <= mu <= lam, got rho={self.rho}, mu={self.mu}, lam={self.lam}")
        if not (math.isfinite(self.tau) and self.tau >= 0):
            raise FitError(f"es: tau must be a finite number >= 0, got {self.tau!r}")
        if not 0 < self.sigma_min <= self.sigma_max:
            raise FitError(f"es: need 0 < sigma_min <= sigma_max, got {self.sigma_min}, {self.sigma_max}")

    # --- ask / tell ---------------------------------------------------------------------------------
    def ask(self) -> list[np.ndarray]:
        """The next generation's candidates; asking again before `tell` returns the same ones."""
        if self._pending is None:
            xs, sigmas = self._first_generation() if self._progress.generation == 0 else self._offspring()
            self._pending = [x for x in xs]
            self._pending_sigma = sigmas
        return [x.copy() for x in self._pending]

    def tell(self, candidates: Sequence[np.ndarray], errors: Sequence[float]) -> None:
        """Errors of the asked candidates (NaN counts as worst); selects the next parents."""
        e = check_told(self._pending, candidates, errors, self.name)
        xs = np.array(self._pending)
        pool_x = np.concatenate([self._parents_x, xs])
        pool_sigma = np.concatenate([self._parents_sigma, self._pending_sigma])
        pool_error = np.concatenate([self._parents_error, e])
        keep = np.argsort(pool_error, kind="stable")[: self.mu]  # ties keep the older individual
        self._parents_x, self._parents_sigma, self._parents_error = pool_x[keep], pool_sigma[keep], pool_error[keep]
        self._pending = self._pending_sigma = None
        self._progress.record(xs, e, self._parents_x, self._parents_error, float(np.mean(self._parents_sigma)))

    def _first_generation(self) -> tuple[np.ndarray, np.ndarray]:
        steps = self._rng.standard_normal((self.lam - 1, self.dim))
        xs = np.vstack([self.x0, reflect(self.x0 + self.sigma0 * steps)])
        return xs, np.full(self.lam, self.sigma0)

    def _offspring(self) -> tuple[np.ndarray, np.ndarray]:
        xs = np.empty((self.lam, self.dim))
        sigmas = np.empty(self.lam)
        for k in range(self.lam):
            mates = self._rng.choice(self.mu, size=self.rho, replace=False)
            x_r = self._parents_x[mates].mean(axis=0)
            sigma_r = self._parents_sigma[mates].mean()
            sigma = float(np.clip(sigma_r * math.exp(self.tau * self._rng.standard_normal()),
                                  self.sigma_min, self.sigma_max))
            xs[k] = reflect(x_r + sigma * self._rng.standard_normal(self.dim))
            sigmas[k] = sigma
        return xs, sigmas

    # --- checkpoints --------------------------------------------------------------------------------
    def state(self) -> dict:
        """Everything needed to continue exactly: settings, RNG state, parents, pending generation, history."""
        rule = self._progress.rule
        return {
            "name": self.name,
            "format": _FORMAT,
            "x0": self.x0.tolist(),
            "sigma0": self.sigma0,
            "seed": self.seed,
            "options": {"lam": self.lam, "mu": self.mu, "rho": self.rho, "tau": self.tau,
                        "sigma_min": self.sigma_min, "sigma_max": self.sigma_max,
                        "tol": rule.tol, "patience": rule.patience, "max_generations": rule.max_generations,
                        "max_evaluations": rule.max_evaluations, "target_error": rule.target_error},
            "rng": self._rng.bit_generator.state,
            "parents": {"x": self._parents_x.tolist(), "sigma": self._parents_sigma.tolist(),
                        "error": self._parents_error.tolist()},
            "pending": None if self._pending is None else {
                "x": [x.tolist() for x in self._pending], "sigma": self._pending_sigma.tolist()},
            "progress": self._progress.state(),
        }

    @classmethod
    def from_state(cls, state: Mapping[str, Any]) -> "EvolutionStrategy":
        """Continue from `state()` (also after a JSON round trip)."""
        if state.get("name") != cls.name or state.get("format") != _FORMAT:
            raise FitError(f"not an es checkpoint (name {state.get('name')!r}, format {state.get('format')!r})")
        try:
            opt = cls(state["x0"], state["sigma0"], state["seed"], **state["options"])
            opt._rng.bit_generator.state = state["rng"]
            parents = state["parents"]
            opt._parents_x = np.array(parents["x"], dtype=float).reshape(-1, opt.dim)
            opt._parents_sigma = np.array(parents["sigma"], dtype=float)
            opt._parents_error = np.array(parents["error"], dtype=float)
            if state["pending"] is not None:
                opt._pending = [np.array(x, dtype=float) for x in state["pending"]["x"]]
                opt._pending_sigma = np.array(state["pending"]["sigma"], dtype=float)
            opt._progress = Progress.from_state(opt._progress.rule, state["progress"])
        except (KeyError, TypeError, ValueError) as exc:
            raise FitError(f"es checkpoint is incomplete or malformed: {exc!r}") from None
        return opt
