"""Levenberg-Marquardt with secant (Broyden) Jacobians and a stop once it gains nothing: the same optimum for
fewer evaluations, the finite-difference Jacobian at the end where the uncertainty is read."""
import numpy as np

from bridge.optim.lm import jacobian, levenberg_marquardt

LOWER, UPPER = np.full(3, -10.0), np.full(3, 10.0)


def _counted(fn):
    calls = []

    def residuals(xs):
        calls.append(len(xs))
        return [fn(np.asarray(x)) for x in xs]

    return residuals, calls


def _curved(x):
    """A mildly non-linear least-squares problem with its minimum at (1, -2, 0.5)."""
    d = x - np.array([1.0, -2.0, 0.5])
    return np.concatenate([d * (1.0 + 0.1 * d ** 2), [0.3 * d[0] * d[1], 0.2 * d[2] ** 2]])


def test_secant_jacobians_reach_the_optimum_for_fewer_evaluations():
    plain, plain_calls = _counted(_curved)
    secant, secant_calls = _counted(_curved)
    a = levenberg_marquardt(plain, np.zeros(3), LOWER, UPPER, max_iterations=30)
    b = levenberg_marquardt(secant, np.zeros(3), LOWER, UPPER, max_iterations=30, secant=True)
    assert np.allclose(a.x, [1.0, -2.0, 0.5], atol=1e-2) and np.allclose(b.x, [1.0, -2.0, 0.5], atol=1e-2)
    assert sum(secant_calls) < sum(plain_calls)
    assert b.differenced and np.allclose(b.jacobian, jacobian(plain, b.x, b.vector, UPPER))  # differenced at the end


def test_the_secant_estimate_is_returned_when_the_caller_differences_later():
    residuals, calls = _counted(_curved)
    r = levenberg_marquardt(residuals, np.zeros(3), LOWER, UPPER, max_iterations=30, secant=True, final_jacobian=False)
    assert not r.differenced and r.jacobian is not None and r.jacobian.shape == (5, 3)


def test_a_search_that_gains_nothing_stops_after_its_patience():
    flat, calls = _counted(lambda x: np.array([1.0, 2.0]) + 1e-9 * x[:2])  # no gain anywhere
    r = levenberg_marquardt(flat, np.zeros(3), LOWER, UPPER, max_iterations=30, secant=True, patience=2)
    singles = [n for n in calls if n == 1]
    assert len(singles) <= 3  # the start and two evaluations without a gain
    assert np.allclose(r.x, 0.0) and not r.stopped
