"""The diagnosis' search: runs cached per model, fits in normalised coordinates with the shared optimisers (through
the real Drake simulation), uncertainty from the curvature, and the criteria that compare fitted models."""
from __future__ import annotations

import math

import numpy as np
import pytest

from bridge.diagnosis.effects import get_effect, pname
from bridge.diagnosis.runs import Run, Runner, prepare
from bridge.diagnosis.search import Evaluator, FitResult, bic, correlation_time, fit, pose_error_of, screen
from bridge.params import KINDS, Parameter, ParameterSet
from bridge.prove.generate import generate_case
from bridge.prove.scenes import Case
from bridge.rollout import load_trials, make_executor


def _run(residual: np.ndarray) -> Run:
    return Run("t", {"block": residual}, residual.ravel())


def test_correlation_time_is_one_for_white_noise_and_long_for_a_smooth_misfit():
    rng = np.random.default_rng(0)
    white = _run(rng.normal(size=(200, 6)))
    t = np.linspace(0, 1, 200)[:, None]
    smooth = _run(np.sin(2 * np.pi * t) + 0.01 * rng.normal(size=(200, 6)))
    assert correlation_time([white]) == pytest.approx(1.0, abs=0.3)
    assert correlation_time([smooth]) > 10


def test_bic_pays_for_parameters_and_rewards_fit():
    assert bic(100.0, 1000, 2, 1.0) > bic(100.0, 1000, 1, 1.0)  # a parameter costs ln(n)
    assert bic(90.0, 1000, 2, 1.0) < bic(100.0, 1000, 1, 1.0)  # ... less than ten units of chi^2 buy
    assert bic(100.0, 1000, 1, 10.0) < bic(100.0, 1000, 1, 1.0)  # correlated samples count less


def test_uncertainty_from_the_curvature_of_a_linear_model():
    """For r = J x - b with unit noise, cov = (J^T J)^-1 (times the reduced chi^2 when it exceeds 1), in
    parameter units (normalised units times each step)."""
    space = ParameterSet((Parameter(KINDS["force_x"], "a", bounds=(-1, 1), start=0.0, step=0.5),
                          Parameter(KINDS["force_y"], "b", bounds=(-1, 1), start=0.0, step=2.0)))
    J = np.array([[1.0, 0.0], [0.0, 2.0], [1.0, 1.0]] * 10)
    result = FitResult(space, np.zeros(2), np.full(30, 0.5), J, (), 0)
    expected = np.sqrt(np.diag(np.linalg.inv(J.T @ J))) * np.array([0.5, 2.0])
    assert list(result.std().values()) == pytest.approx(expected)


def test_a_bound_that_stops_the_fit_is_named_and_one_that_does_not_is_not():
    """r = x - target (one unit of noise per sample): the optimum sits at the target, or on the bound nearest it
    when the target is outside; only then does the Gauss-Newton step point beyond the bound."""
    space = ParameterSet((Parameter(KINDS["force_x"], "a", bounds=(-1, 1), start=0.0, step=0.5),
                          Parameter(KINDS["force_y"], "b", bounds=(-1, 1), start=0.0, step=0.5)))
    J = np.tile(np.eye(2), (10, 1))
    lower, upper = space.normal_bounds()

    def at(x, target):
        return FitResult(space, np.asarray(x, float), J @ (np.asarray(x, float) - target), J, (), 0).at_bound()

    assert at([upper[0], 0.3], np.array([5.0, 0.3])) == {"force_x[a]": 1.0}  # wants 2.5: stopped at 1
    assert at([0.1, lower[1]], np.array([0.1, -9.0])) == {"force_y[b]": -1.0}
    assert at([upper[0], 0.0], np.array([upper[0], 0.0])) == {}  # the optimum is on the bound, not beyond it
    assert at([0.0, 0.0], np.array([5.0, 0.0])) == {}  # far from the bound: not converged, not stopped
    assert FitResult(space, np.zeros(2), np.zeros(20), None, (), 0).at_bound() == {}


def test_a_bound_pressed_for_less_than_a_parameter_is_worth_does_not_stop_the_fit():
    """100 samples, one unit of noise each: a value just past the bound would lower chi^2 by 0.01, less than the
    ln(100) BIC charges a parameter (noise points past bounds that the truth sits on); 3 units past, by 9."""
    space = ParameterSet((Parameter(KINDS["force_x"], "a", bounds=(-1, 1), start=0.0, step=0.5),))
    J = np.full((100, 1), 0.1)
    upper = space.normal_bounds()[1]

    def at(target):
        result = FitResult(space, upper.copy(), J @ (upper - target), J, (), 0)
        return result.at_bound(), result.bound_gain(["force_x[a]"])

    assert at(upper + 0.1) == ({}, pytest.approx(0.01))
    assert at(upper + 3.0) == ({"force_x[a]": 1.0}, pytest.approx(9.0))


def test_where_a_changed_mass_sits_does_not_condemn_the_mass_on_its_bound():
    """`mass_spread` = 0 (a weight at the very centre) is a state the world takes; the data asking for less
    rotational inertia than that leave the mass itself standing. The mass on its bound still counts."""
    space = ParameterSet((Parameter(KINDS["mass"], "a", bounds=(0.2, 5.0), start=1.0, step=0.3),
                          Parameter(KINDS["mass_spread"], "a", bounds=(0.0, 1.5), start=1.0, step=0.5)))
    lower, upper = space.normal_bounds()
    J = np.tile(np.eye(2), (10, 1))

    def at(x, target):
        return FitResult(space, np.asarray(x, float), J @ (np.asarray(x, float) - target), J, (), 0).at_bound()

    assert at([1.0, lower[1]], np.array([1.0, lower[1] - 3.0])) == {}
    assert at([upper[0], lower[1]], np.array([upper[0] + 3.0, lower[1] - 3.0])) == {"mass[a]": 5.0}


def test_the_contacts_damping_on_its_bound_does_not_condemn_the_model():
    """No damping is a state a contact takes, and the contact's stiffness and damping are fitted among the
    ordinary parameters to take up how the world's contact differs (`Kind.contact_model`): pressing below zero
    damping says the contact cannot take up more, not that the effect is wrong. A friction pair pressing past its
    bound still counts."""
    space = ParameterSet((Parameter(KINDS["sliding_friction"], "a", bounds=(0.02, 1.5), start=0.25, step=0.075),
                          Parameter(KINDS["dissipation"], "a", bounds=(0.0, 10.0), start=1.0, step=0.3)))
    lower, upper = space.normal_bounds()
    J = np.tile(np.eye(2), (10, 1))

    def at(x, target):
        return FitResult(space, np.asarray(x, float), J @ (np.asarray(x, float) - target), J, (), 0).at_bound()

    assert at([0.0, lower[1]], np.array([0.0, lower[1] - 3.0])) == {}
    assert at([upper[0], lower[1]], np.array([upper[0] + 3.0, lower[1] - 3.0])) == {"sliding_friction[a]": 1.5}


@pytest.fixture(scope="module")
def friction_case(odb, tmp_path_factory):
    """Two generated pushes on a surface with twice the database's friction (real Drake), prepared."""
    paths, truth = generate_case(Case("planar", "friction", "medium", 3), odb,
                                 tmp_path_factory.mktemp("search") / "case", 2, force_noise=None)
    trials = load_trials(paths, odb)
    executor = make_executor("serial", odb)
    return Runner([prepare(t, odb, 25.0) for t in trials], odb, executor), truth


@pytest.mark.slow
@pytest.mark.parametrize("optimizer", ["lm", "cmaes"])
def test_a_fit_finds_the_surface_friction_and_runs_are_cached(friction_case, odb, optimizer):
    runner, truth = friction_case
    world = runner.prepared[0].world
    space = ParameterSet((Parameter.of("friction", "surface", world, odb),))
    ev = Evaluator(runner, [0, 1])
    before = runner.simulations
    null = ev.chi2(space.model())
    assert runner.simulations == before + 2
    ev.chi2(space.model())
    assert runner.simulations == before + 2  # the same model is not simulated twice
    result = fit(ev, space, np.zeros(1), max_iterations=8, optimizer=optimizer)
    found = result.values()["friction[surface]"]
    true = truth.params[pname("friction", "surface")]
    assert null > 2 * result.n and result.chi2 < 1.3 * result.n  # from twice the noise floor down to it
    assert found == pytest.approx(true, rel=0.3), (found, true)
    assert math.isfinite(result.std()["friction[surface]"]) and result.evaluations > 0
    assert pose_error_of(result.runs).e < pose_error_of(ev.runs(space.model())).e


@pytest.mark.slow
def test_a_screen_step_lowers_the_residual_of_a_smooth_effect(friction_case, odb):
    """One Gauss-Newton step from the null friction of the surface already removes most of the misfit."""
    runner, _ = friction_case
    world = runner.prepared[0].world
    space = ParameterSet(get_effect("friction").parameters(world, odb, "surface"))
    ev = Evaluator(runner, [0, 1])
    null = ev.chi2(space.model())
    x, chi2 = screen(ev, space, np.zeros(space.dim))
    n = ev.vector(space.model()).size
    assert chi2 - n < 0.5 * (null - n) and x[0] > 0  # half the excess gone; the friction went up, as concealed


@pytest.mark.slow
def test_a_model_naming_no_object_is_an_error_not_a_score(friction_case):
    """Bad input reaches the user with its message; only a failed simulation is scored (and counted)."""
    from bridge.errors import ParameterError
    from bridge.params import Setting

    runner, _ = friction_case
    before = runner.simulations
    with pytest.raises(ParameterError, match="obstacle_x\\[tabel\\]: 'tabel' names nothing in world"):
        runner.run((Setting("obstacle_x", "tabel", 0.1),), [0])
    assert runner.simulations == before and not runner.failures
    (crushed,) = runner.run((Setting("force_z", "block", -1e5),), [0])
    assert crushed.failed and "diverged" in crushed.failed
    assert runner.failures == [(crushed.trial, crushed.failed)] and np.all(np.isfinite(crushed.normalised))


@pytest.mark.slow
def test_a_friction_range_that_excludes_the_truth_shows_as_a_fit_stopped_at_its_bound(friction_case, odb):
    """The surface is twice as rough as the database says; a range capped below the truth leaves the fit on the cap,
    and says so; the full range does not."""
    from dataclasses import replace

    runner, truth = friction_case
    world = runner.prepared[0].world
    full = Parameter.of("friction", "surface", world, odb)
    true = truth.params[pname("friction", "surface")]
    cap = full.start_value + 0.3 * (true - full.start_value)
    capped = ParameterSet((replace(full, bounds=(full.bounds[0], cap)),))
    ev = Evaluator(runner, [0, 1])
    stopped = fit(ev, capped, np.zeros(1), max_iterations=6)
    assert stopped.at_bound() == {"friction[surface]": pytest.approx(cap)}
    free = fit(ev, ParameterSet((full,)), np.zeros(1), max_iterations=8)
    assert free.at_bound() == {}


def _fresh(runner: Runner, odb) -> Runner:
    """The same recordings on a runner of its own (its own rollout cache: every replay counted)."""
    return Runner(runner.prepared, odb, make_executor("serial", odb))


@pytest.mark.slow
def test_replays_of_a_model_that_cannot_be_kept_are_cut_short(friction_case, odb):
    """Of two starts, the second (a surface ten times too rough) exceeds the first's chi^2 on its first recording:
    its second replay is never simulated and it comes back as None; a bound below anything cuts a model after
    one replay. A model run in full is exactly what `run` gives."""
    runner = _fresh(friction_case[0], odb)
    world = runner.prepared[0].world
    p = Parameter.of("friction", "surface", world, odb)
    good = ParameterSet((p,)).model([2 * p.start_value])
    rough = ParameterSet((p,)).model([10 * p.start_value])
    first, cut = runner.run_bounded([good, rough], [0, 1], [math.inf, math.inf], race=True, first=[[0, 1], [0, 1]])
    assert cut is None and runner.simulations == 3
    assert [r.chi2 for r in first] == [r.chi2 for r in runner.run(good, [0, 1])]
    assert runner.run_bounded([rough], [0, 1], [0.0]) == [None] and runner.simulations == 2 + 3 + 1


@pytest.mark.slow
def test_a_fit_and_its_cross_validation_take_the_same_path_with_replays_cut(friction_case, odb, monkeypatch):
    """The friction fit and the leave-one-out predictions of its recordings, once with the replays of rejected
    steps cut (`Evaluator.runs_below`, `runs_within`) and once with every replay run in full: the same points,
    the same predictions, bit for bit, and no more simulations."""
    from bridge.diagnosis.crossval import predict_left_out

    world = friction_case[0].prepared[0].world
    space = ParameterSet(get_effect("friction").parameters(world, odb, "surface"))

    def search(runner: Runner):
        ev = Evaluator(runner, [0, 1])
        result = fit(ev, space, np.zeros(space.dim), max_iterations=8)
        _, runs, params = predict_left_out(runner, ev, result)
        return result, [r.chi2 for r in runs], params, runner.simulations

    cut = search(_fresh(friction_case[0], odb))
    monkeypatch.setattr(Evaluator, "runs_below", lambda self, models, bound=math.inf: self.runs_many(models))
    monkeypatch.setattr(Evaluator, "runs_within", lambda self, models, bounds, counted: self.runs_many(models))
    full = search(_fresh(friction_case[0], odb))
    assert np.array_equal(cut[0].x, full[0].x) and cut[0].chi2 == full[0].chi2
    assert cut[0].evaluations == full[0].evaluations
    assert cut[1:3] == full[1:3]
    assert cut[3] <= full[3]
