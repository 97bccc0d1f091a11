"""The optimisers on cheap analytic functions (a fake rollout): convergence, determinism, checkpoints."""
from __future__ import annotations

import json
from dataclasses import asdict

import numpy as np
import pytest

from bridge.errors import FitError
from bridge.optim import OPTIMIZERS, Optimizer, make_optimizer, restore_optimizer

CENTRE = np.array([0.3, 0.7, 0.55, 0.2])
NAMES = sorted(OPTIMIZERS)


def sphere(x: np.ndarray) -> float:
    return float(np.sum((x - CENTRE[: len(x)]) ** 2))


def rosenbrock(x: np.ndarray) -> float:
    """Rosenbrock on [-2, 2]^D mapped onto the box; minimum 0 at x = 0.75."""
    z = 4.0 * np.asarray(x) - 2.0
    return float(np.sum(100.0 * (z[1:] - z[:-1] ** 2) ** 2 + (1.0 - z[:-1]) ** 2))


def run(opt: Optimizer, f, generations: int | None = None) -> Optimizer:
    while not opt.done and (generations is None or opt.generation < generations):
        candidates = opt.ask()
        opt.tell(candidates, [f(x) for x in candidates])
    return opt


@pytest.mark.parametrize("name", NAMES)
def test_reaches_the_minimum_of_a_shifted_sphere(name):
    opt = run(make_optimizer(name, [0.5] * 4, 0.2, seed=1, target_error=1e-8, tol=0, patience=1000,
                             max_generations=1000), sphere)
    assert opt.best_error <= 1e-8
    assert opt.stop_reason.startswith("target error")
    np.testing.assert_allclose(opt.best_x, CENTRE, atol=1e-3)


@pytest.mark.parametrize("name, dim, target", [("es", 2, 1e-4), ("cmaes", 2, 1e-8), ("cmaes", 4, 1e-8)])
def test_reaches_the_minimum_of_rosenbrock(name, dim, target):
    opt = run(make_optimizer(name, [0.5] * dim, 0.2, seed=3, target_error=target, tol=0, patience=10**6,
                             max_generations=2000), rosenbrock)
    assert opt.best_error <= target
    np.testing.assert_allclose(opt.best_x, 0.75, atol=0.02)


def test_es_makes_progress_on_rosenbrock_4d():
    """The isotropic ES crawls along Rosenbrock's valley: slow, but it does not stall in 4-D either."""
    opt = run(make_optimizer("es", [0.5] * 4, 0.2, seed=3, target_error=0.1, tol=0, patience=10**6,
                             max_generations=1000), rosenbrock)
    assert opt.best_error <= 0.1


def test_cmaes_needs_fewer_evaluations_than_the_es_on_the_sphere():
    evaluations = {}
    for name in NAMES:
        opt = run(make_optimizer(name, [0.5] * 4, 0.2, seed=0, target_error=1e-8, tol=0, patience=1000), sphere)
        assert opt.best_error <= 1e-8
        evaluations[name] = opt.evaluations
    assert evaluations["cmaes"] < evaluations["es"], evaluations


@pytest.mark.parametrize("name", NAMES)
def test_same_seed_gives_identical_runs_and_another_seed_does_not(name):
    a, b, c = (run(make_optimizer(name, [0.5] * 3, 0.2, seed=s, max_generations=15), sphere) for s in (7, 7, 8))
    assert [asdict(r) for r in a.history] == [asdict(r) for r in b.history]
    assert np.array_equal(a.best_x, b.best_x)
    assert not np.array_equal(a.best_x, c.best_x)


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("pending", [False, True], ids=["between-generations", "after-ask"])
def test_resuming_from_a_checkpoint_equals_an_uninterrupted_run(name, pending):
    options = dict(seed=11, tol=0, patience=1000, max_generations=25)
    whole = run(make_optimizer(name, [0.4, 0.6, 0.5], 0.2, **options), rosenbrock)

    first = run(make_optimizer(name, [0.4, 0.6, 0.5], 0.2, **options), rosenbrock, generations=8)
    asked = first.ask() if pending else None
    state = json.loads(json.dumps(first.state()))  # the checkpoint survives a trip through a file
    resumed = restore_optimizer(state)
    if pending:
        again = resumed.ask()
        assert all(np.array_equal(x, y) for x, y in zip(asked, again))
    run(resumed, rosenbrock)

    assert resumed.generation == whole.generation == 25
    assert resumed.evaluations == whole.evaluations
    assert [asdict(r) for r in resumed.history] == [asdict(r) for r in whole.history]
    assert np.array_equal(resumed.best_x, whole.best_x) and resumed.best_error == whole.best_error


@pytest.mark.parametrize("name", NAMES)
def test_candidates_stay_in_the_box_when_the_optimum_is_outside(name):
    target = np.array([-0.3, 1.4, 0.5])
    opt = make_optimizer(name, [0.0, 1.0, 0.5], 0.5, seed=2, max_generations=30)
    while not opt.done:
        candidates = opt.ask()
        assert all(np.all((0.0 <= x) & (x <= 1.0)) for x in candidates)
        opt.tell(candidates, [float(np.sum((x - target) ** 2)) for x in candidates])
    np.testing.assert_allclose(opt.best_x, [0.0, 1.0, 0.5], atol=0.02)


@pytest.mark.parametrize("name", NAMES)
def test_stops_when_the_best_error_stalls(name):
    # improvements exist but stay below tol (a constant function would trip cma's own flat-fitness stop)
    opt = run(make_optimizer(name, [0.5, 0.5], 0.1, seed=0, tol=1.0, patience=4), lambda x: 1.0 + sphere(x))
    assert opt.generation == 5  # the first generation sets the best, four more without improvement > tol
    assert "no improvement" in opt.stop_reason


@pytest.mark.parametrize("name", NAMES)
def test_stops_at_the_evaluation_budget(name):
    opt = run(make_optimizer(name, [0.5, 0.5], 0.2, seed=0, max_evaluations=50, tol=0, patience=1000), sphere)
    assert 50 <= opt.evaluations < 50 + len(opt.ask())
    assert "evaluations" in opt.stop_reason


def test_es_defaults_follow_the_paper_and_history_feeds_fig_4():
    opt = make_optimizer("es", [0.5] * 4, 0.2, seed=5, max_generations=10)
    assert (opt.lam, opt.mu, opt.rho, opt.tau) == (40, 10, 2, 0.5)
    first = opt.ask()
    assert np.array_equal(first[0], [0.5] * 4)  # generation 0 starts from the prior estimate x0
    run(opt, sphere)
    history = opt.history
    assert [r.generation for r in history] == list(range(10))
    assert [r.evaluations for r in history] == [40 * (g + 1) for g in range(10)]
    for r in history:
        assert len(r.best_x) == len(r.mean_x) == len(r.p20_x) == len(r.p80_x) == 4
        assert all(lo <= hi for lo, hi in zip(r.p20_x, r.p80_x))
        assert r.best_error <= r.generation_best_error and r.best_error <= r.selected_mean_error
    # "+" selection: neither the best nor the parents' mean error ever rises
    assert all(a.best_error >= b.best_error for a, b in zip(history, history[1:]))
    assert all(a.selected_mean_error >= b.selected_mean_error for a, b in zip(history, history[1:]))


@pytest.mark.parametrize("name", NAMES)
def test_failed_evaluations_rank_last(name):
    opt = make_optimizer(name, [0.5, 0.5], 0.2, seed=0)
    candidates = opt.ask()
    errors = [float("nan")] * len(candidates)
    errors[1] = 0.25
    opt.tell(candidates, errors)
    assert opt.best_error == 0.25 and np.array_equal(opt.best_x, candidates[1])


def test_misuse_is_reported_as_fit_errors():
    with pytest.raises(FitError, match=r"unknown optimizer 'ga'; valid: cmaes, es, lm"):
        make_optimizer("ga", [0.5], 0.1, seed=0)
    with pytest.raises(FitError, match=r"unknown option\(s\) lamda"):
        make_optimizer("es", [0.5], 0.1, seed=0, lamda=5)
    with pytest.raises(FitError, match=r"x0 must lie in the normalised box"):
        make_optimizer("cmaes", [1.5], 0.1, seed=0)
    with pytest.raises(FitError, match=r"sigma0"):
        make_optimizer("es", [0.5], 0.0, seed=0)
    with pytest.raises(FitError, match=r"rho <= mu <= lam"):
        make_optimizer("es", [0.5], 0.1, seed=0, lam=5, mu=10)
    for name in NAMES:
        opt = make_optimizer(name, [0.5, 0.5], 0.1, seed=0)
        with pytest.raises(FitError, match="without a pending ask"):
            opt.tell([np.array([0.5, 0.5])], [1.0])
        candidates = opt.ask()
        with pytest.raises(FitError, match="differ from the"):
            opt.tell([c + 0.01 for c in candidates], [1.0] * len(candidates))
        with pytest.raises(FitError, match="errors for"):
            opt.tell(candidates, [1.0])
    with pytest.raises(FitError, match="unknown optimizer"):
        restore_optimizer({"name": "nope"})
