"""Cross-validation's arithmetic: the leave-one-out refit on a problem where one Gauss-Newton step is exact, and
how predictions are compared with the floor (the Drake side is proven by the proofs)."""
from types import SimpleNamespace

import numpy as np

from bridge.diagnosis.crossval import CHECK_STEP, PRIOR, Prediction, _checked, leave_one_out_points


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
        assert np.allclose(points[k].x, exact, atol=1e-9), (k, points[k], exact)
    full = _linear_fit(A, y).x
    assert np.linalg.norm(points[2].x - full) > 2 * np.linalg.norm(points[0].x - full)  # leaving the odd one out matters


def test_a_parameter_only_the_left_out_recording_constrains_goes_back_to_the_world_models_value():
    # parameter 1 appears only in recording 0 (an obstacle only one push met): without it nothing holds the value
    A = [np.column_stack([np.ones(20), np.ones(20)]), np.column_stack([np.ones(20), np.zeros(20)]),
         np.column_stack([np.ones(20), np.zeros(20)])]
    y = [np.full(20, 3.0), np.full(20, 1.0), np.full(20, 1.0)]
    fit = _linear_fit(A, y)
    assert abs(fit.x[1] - 2.0) < 1e-9
    points = leave_one_out_points(fit)
    assert abs(points[0].x[1]) < 0.05 and abs(points[0].x[0] - 1.0) < 0.05


def test_a_leave_one_out_step_stays_within_the_bounds():
    A = [np.ones((10, 1)), np.ones((10, 1))]
    y = [np.full(10, 0.0), np.full(10, 4.0)]
    points = leave_one_out_points(_linear_fit(A, y, bounds=(-1.0, 3.0)))
    assert all(-1.0 - 1e-12 <= p.x[0] <= 3.0 + 1e-12 for p in points)


def _fake_evaluator(chi2_of_point):
    """An Evaluator-like view whose recordings' chi^2 at a point are chi2_of_point(x) (a list, one per recording);
    the model of a point is the point itself; every replay run in full (cutting them changes no answer:
    test_search.py)."""
    def runs_many(models):
        return [[SimpleNamespace(chi2=c, trial=j) for j, c in enumerate(chi2_of_point(np.array(m)))] for m in models]
    return SimpleNamespace(runs_many=runs_many, runs_within=lambda models, bounds, counted: runs_many(models))


def test_a_long_leave_one_out_step_the_other_recordings_refuse_keeps_the_optimum():
    # the linear model promises the others a fall along a long step, but the true objective rises there (a contact
    # simulation leaves its linear range): the refit without the recording stays at the optimum
    x = np.array([0.0])
    at_x = [SimpleNamespace(chi2=10.0, trial=j) for j in range(3)]
    space = SimpleNamespace(model=lambda v: tuple(v), from_normal=lambda v: v)
    result = SimpleNamespace(x=x, space=space, runs=at_x)
    left = [SimpleNamespace(x=np.array([2.5]), promised=5.0)] + \
        [SimpleNamespace(x=np.array([0.1]), promised=0.1)] * 2
    asked = []

    def rising_chi2(p):
        asked.append(float(p[0]))
        return [10.0 + 40 * p[0] ** 2] * 3
    done = _checked(_fake_evaluator(rising_chi2), result, left)
    assert all(done[k][0] is at_x[k] for k in range(3))  # every step refused: each recording keeps the optimum
    assert all(done[k][1] is x for k in range(3))  # and its parameters: the refit's spread shows none
    assert sorted(asked) == [0.1, 0.1, 0.625, 1.25, 2.5] and 2.5 > CHECK_STEP  # the long one halved twice first
    falling = _fake_evaluator(lambda p: [10.0 - 4 * p[0]] * 3)  # the others do gain along it: the step is kept
    done = _checked(falling, result, left)
    assert done[0][0] is not at_x[0] and done[0][0].trial == 0 and done[0][1][0] == 2.5
    assert all(done[k][0] is not at_x[k] for k in (1, 2))  # the short steps too, once checked


def test_a_short_leave_one_out_step_the_others_refuse_is_not_a_prediction():
    """On real pushes a Jacobian differenced on a non-smooth contact simulation steps the friction pairs 0.9-1.5
    units away from an optimum the other pushes are content with (real refits stay there), and the pushes left
    out are then predicted worse than the ordinary model deserves, which favours every effect over it. A short
    step is checked once, and the optimum kept when the others refuse it."""
    x = np.array([0.0, 0.0])
    at_x = [SimpleNamespace(chi2=100.0, trial=j) for j in range(4)]
    space = SimpleNamespace(model=lambda v: tuple(v), from_normal=lambda v: v)
    result = SimpleNamespace(x=x, space=space, runs=at_x)
    left = [SimpleNamespace(x=np.array([0.9, -0.5]), promised=30.0) for _ in range(4)]
    # a noisy landscape: moving either way raises every recording's chi^2 by a little (the others are content)
    flat = _fake_evaluator(lambda p: [100.0 + 5.0 * float(np.abs(p).sum())] * 4)
    done = _checked(flat, result, left)
    assert all(done[k][0] is at_x[k] for k in range(4))


def test_the_spread_is_the_range_of_each_parameter_over_the_refits_and_leaving_a_recording_out_drops_it():
    n = 100
    cv = Prediction({"a": (200.0, n), "b": (300.0, n), "c": (150.0, n)},
                    {"a": {"x": 0.02, "y": 1.0}, "b": {"x": 0.03, "y": 1.0}, "c": {"x": -0.01, "y": 1.2}})
    assert cv.spread() == {"x": (-0.01, 0.03), "y": (1.0, 1.2)}
    rest = cv.without("c")
    assert set(rest.each) == {"a", "b"} and rest.spread() == {"x": (0.02, 0.03), "y": (1.0, 1.0)}
    assert Prediction({"a": (200.0, n)}).spread() == {}  # a model without parameters has no spread


def test_compare_is_the_geometric_mean_of_the_recordings_ratios_above_the_noise_floor():
    n = 100
    floor = Prediction({"a": (900.0, n), "b": (500.0, n), "c": (80.0, n)})
    model = Prediction({"a": (100.0, n), "b": (600.0, n), "c": (90.0, n)})
    # c, at 80 and 90, is at the noise floor (100) under both: a tie, left out; a: 9 -> 1, b: 5 -> 6 noise floors
    assert abs(model.compare(floor) - (1.0 - ((100.0 / 900.0) * (600.0 / 500.0)) ** 0.5)) < 1e-12
    assert floor.excess() == 1200.0 and floor.compare(floor) == 0.0


def _pressing_fit(names: list[str], x: list[float]):
    """A FitResult whose residual asks every parameter to grow past its upper bound 1 (x in normalised units)."""
    from bridge.diagnosis.search import FitResult

    free = [SimpleNamespace(name=n, bounds=(0.05, 1.5), kind=SimpleNamespace(name=n.split("[")[0], inert_without=None,
                                                                                     contact_model=False))
            for n in names]
    space = SimpleNamespace(dim=len(names), free=free,
                            normal_bounds=lambda: (np.zeros(len(names)), np.ones(len(names))))
    J = np.eye(len(names))
    return FitResult(space, np.array(x), np.array(x) - 2.0, J, (), 0)


def test_a_pair_coefficient_on_its_bound_counts_on_its_own():
    # the ordinary parameters are the object's pairs (with its support, with the robot), free of each other: one
    # pressing past its bound says the family is wrong even while the other is free
    one = _pressing_fit(["sliding_friction[block]", "robot_friction[block]"], [1.0, 0.4])
    assert one.at_bound() == {"sliding_friction[block]": 1.5}
    effect = _pressing_fit(["sliding_friction[block]", "com_x[block]"], [0.4, 1.0])  # an effect's own parameter
    assert effect.at_bound() == {"com_x[block]": 1.5}
