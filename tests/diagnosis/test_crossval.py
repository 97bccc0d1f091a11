"""Cross-validation's arithmetic: the leave-one-out refit on a problem where one Gauss-Newton step is exact, and
how predictions are compared with the floor (the Drake side is proven by the proofs)."""
from types import SimpleNamespace

import numpy as np

from bridge.diagnosis.crossval import PRIOR, Prediction, leave_one_out_points


def _linear_fit(A: list[np.ndarray], y: list[np.ndarray], bounds=(-10.0, 10.0)):
    """A FitResult-like view of the least-squares fit of sum_k |A_k x - y_k|^2 (residual = A x - y)."""
    AA, yy = np.vstack(A), np.concatenate(y)
    x = np.linalg.lstsq(AA, yy, rcond=None)[0]
    runs = tuple(SimpleNamespace(normalised=np.zeros(len(yk))) for yk in y)
    space = SimpleNamespace(normal_bounds=lambda: (np.full(x.size, bounds[0]), np.full(x.size, bounds[1])))
    return SimpleNamespace(jacobian=AA, vector=AA @ x - yy, x=x, space=space, runs=runs)


def test_leave_one_out_points_are_the_refits_without_each_recording():
    rng = np.random.default_rng(4)
    A = [rng.normal(size=(30, 2)) for _ in range(4)]
    truth = np.array([0.7, -0.4])
    y = [a @ truth + rng.normal(0, 0.3, 30) for a in A]
    y[2] = y[2] + 1.5  # one recording unlike the others: its own fit pulls the common one
    points = leave_one_out_points(_linear_fit(A, y))
    for k in range(4):
        others = [a for j, a in enumerate(A) if j != k]
        rhs = [b for j, b in enumerate(y) if j != k]
        # the same problem refitted without recording k, with the prior towards 0 that the step carries
        M = np.vstack(others + [np.sqrt(PRIOR) * np.eye(2)])
        exact = np.linalg.lstsq(M, np.concatenate(rhs + [np.zeros(2)]), rcond=None)[0]
        assert np.allclose(points[k], exact, atol=1e-9), (k, points[k], exact)
    full = _linear_fit(A, y).x
    assert np.linalg.norm(points[2] - full) > 2 * np.linalg.norm(points[0] - full)  # leaving the odd one out matters


def test_a_parameter_only_the_left_out_recording_constrains_goes_back_to_the_world_models_value():
    # parameter 1 appears only in recording 0 (an obstacle only one push met): without it nothing holds the value
    A = [np.column_stack([np.ones(20), np.ones(20)]), np.column_stack([np.ones(20), np.zeros(20)]),
         np.column_stack([np.ones(20), np.zeros(20)])]
    y = [np.full(20, 3.0), np.full(20, 1.0), np.full(20, 1.0)]
    fit = _linear_fit(A, y)
    assert abs(fit.x[1] - 2.0) < 1e-9
    points = leave_one_out_points(fit)
    assert abs(points[0][1]) < 0.05 and abs(points[0][0] - 1.0) < 0.05


def test_a_leave_one_out_step_stays_within_the_bounds():
    A = [np.ones((10, 1)), np.ones((10, 1))]
    y = [np.full(10, 0.0), np.full(10, 4.0)]
    points = leave_one_out_points(_linear_fit(A, y, bounds=(-1.0, 3.0)))
    assert all(-1.0 - 1e-12 <= p[0] <= 3.0 + 1e-12 for p in points)


def test_compare_counts_gains_and_losses_above_the_noise_floor():
    n = 100
    floor = Prediction({"a": (900.0, n), "b": (500.0, n), "c": (80.0, n)})
    model = Prediction({"a": (100.0, n), "b": (600.0, n), "c": (90.0, n)})
    share, gains, losses = model.compare(floor)
    # in units of the floor's excess (1200): c, at 80 and 90, is at the noise floor (100) under both, a tie
    assert abs(gains - 800.0 / 1200.0) < 1e-12 and abs(losses - 100.0 / 1200.0) < 1e-12
    assert abs(share - 700.0 / 1200.0) < 1e-12
    assert floor.excess() == 1200.0
