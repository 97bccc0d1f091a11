"""Cross-validation: how a fitted model predicts recordings it was not fitted on, every recording held out once.

Why: a model's fit to the recordings it was fitted on says little once the world differs from the model in ways
no effect names (contact stiffness, time step, servo, sensors): every extra parameter then soaks up some of that
leftover, and criteria on the noise floor (BIC, shares of the excess above the sensor noise) take the leftover
for missing physics. What generalises is prediction: an effect that is really there predicts recordings it has
not seen better than the ordinary parameters do; one that soaks up leftovers does not.

How: the recordings held out of the fit (`--hold-out`) are predicted by the model fitted on the others, as
before. Each fitted recording k is predicted by the model refitted without it, approximated by one bounded,
damped Gauss-Newton step from the optimum with k's rows of the Jacobian and the residual left out (the
Jacobian differenced at the optimum):

    minimise |r_-k + J_-k d|^2 + PRIOR |x + d|^2   over d,  x + d within the bounds, |d_i| <= TRUST

(x in normalised units, 0 = the world model's value), then replayed on recording k in Drake: the prediction
is a real simulation, only the refit is linearised. PRIOR pulls a parameter that the other recordings do not
constrain back towards the world model (an obstacle only recording k met goes back out of the way), so no
recording predicts itself through the parameters it alone determined. TRUST bounds the step to where a linear
model of a contact simulation can be believed.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy.optimize import lsq_linear

from .runs import Run, Runner
from .search import Evaluator, FitResult, differenced

PRIOR = 1.0  # chi^2 per squared normalised unit towards the world model's value (a unit is a parameter's step)
TRUST = 3.0  # normalised units: the largest change of a parameter a leave-one-out step may make


@dataclass(frozen=True)
class Prediction:
    """A model's predictions of recordings it was not fitted on: (chi^2, samples) per recording, by name (poses
    and the robot's force together, each normalised by its noise)."""

    each: dict[str, tuple[float, int]]

    def excess(self) -> float:
        """chi^2 above the sensor noise, summed over the recordings (each at least its noise level)."""
        return float(sum(max(c - n, 0.0) for c, n in self.each.values()))

    @property
    def chi2(self) -> float:
        return float(sum(c for c, _ in self.each.values()))

    @property
    def n(self) -> int:
        return int(sum(n for _, n in self.each.values()))

    def compare(self, floor: "Prediction") -> tuple[float, float, float]:
        """(share of the floor's excess this model removes, its gains, its losses), all in units of the floor's
        excess over the recordings both predicted, each recording's chi^2 floored at its noise level first (a
        recording at the noise floor under both models is a tie)."""
        common = [name for name in self.each if name in floor.each]
        excess = sum(max(floor.each[name][0] - floor.each[name][1], 0.0) for name in common)
        if excess <= 0:
            return 0.0, 0.0, 0.0
        gains = losses = 0.0
        for name in common:
            (c, n), (b, _) = self.each[name], floor.each[name]
            d = max(b, n) - max(c, n)
            gains, losses = gains + max(d, 0.0), losses + max(-d, 0.0)
        return (gains - losses) / excess, gains / excess, losses / excess


def leave_one_out_points(result: FitResult) -> list[np.ndarray]:
    """x without each training recording (the module's step), from `result`'s Jacobian at its optimum, one point
    per recording in the order of `result.runs`."""
    J, r, x = result.jacobian, result.vector, result.x
    lower, upper = result.space.normal_bounds()
    lo = np.maximum(lower - x, -TRUST)
    hi = np.minimum(upper - x, TRUST)
    hi = np.maximum(hi, lo)  # a point outside the bounds (never, but a step must be feasible)
    sizes = [run.normalised.size for run in result.runs]
    edges = np.concatenate([[0], np.cumsum(sizes)])
    dim = x.size
    points = []
    for k in range(len(sizes)):
        keep = np.ones(r.size, dtype=bool)
        keep[edges[k]:edges[k + 1]] = False
        A = np.vstack([J[keep], np.sqrt(PRIOR) * np.eye(dim)])
        b = np.concatenate([-r[keep], -np.sqrt(PRIOR) * x])
        step = lsq_linear(A, b, bounds=(lo, hi), method="bvls").x if dim else np.zeros(0)
        points.append(x + step)
    return points


def predict_left_out(runner: Runner, ev: Evaluator, result: FitResult) -> tuple[FitResult, list[Run]]:
    """Each training recording of `ev` replayed with the model refitted without it (`leave_one_out_points`);
    returns `result` with its Jacobian differenced at the optimum (reused for the uncertainty) and the runs.
    A model without parameters predicts with itself (its runs)."""
    if result.space.dim == 0:
        return result, list(result.runs)
    result = differenced(ev, result)
    points = leave_one_out_points(result)
    pairs = [(result.space.model(result.space.from_normal(x)), index) for x, index in zip(points, ev.indices)]
    return result, runner.run_pairs(pairs)


def prediction(runs: Sequence[Run]) -> Prediction:
    """The cross-validated predictions, one run per recording (each from a fit that did not see it)."""
    return Prediction({r.trial: (r.chi2, int(r.normalised.size)) for r in runs})
