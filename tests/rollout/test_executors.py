"""The backends a batch runs on give the same result: in-process, a process pool, a dask cluster; a worker's
error reaches the caller with its message; a failed simulation comes back as a failed outcome."""
from __future__ import annotations

import dataclasses
import importlib.util

import pytest

from bridge.errors import BridgeError, ParameterError
from bridge.fit.fit import fit_parameters
from bridge.fit.synthetic import recovery_spec
from bridge.params import Setting, apply_model
from bridge.rollout import Job, Rollout, make_executor
from bridge.rollout.executors import SerialExecutor
from bridge.sim.scene import SceneValues

FRICTIONS = ("friction[big_box]", "friction[table]")
HAS_DASK = importlib.util.find_spec("distributed") is not None


def _same(a, b) -> bool:
    """Equal but for round-off: a replay's error summed in another process may differ in its last digits (a
    process pool's history once differed from the serial one by 4e-14 of an error, its parameters not at all)."""
    def flat(x):
        if dataclasses.is_dataclass(x):
            return flat(dataclasses.astuple(x))
        if isinstance(x, (list, tuple)):
            return [v for item in x for v in flat(item)]
        return [x]
    return flat(a) == pytest.approx(flat(b), rel=1e-9, abs=1e-12)


def _fit(trials, odb, executor):
    return fit_parameters(trials, recovery_spec(FRICTIONS), odb=odb, executor=executor, optimizer="cmaes", seed=11,
                          generations=2, popsize=4, hold_out=0)


@pytest.fixture(scope="module")
def serial_result(trials, odb):
    with make_executor("serial", odb) as executor:
        return _fit(trials, odb, executor)


@pytest.mark.slow
def test_process_pool_gives_the_serial_result(trials, odb, pool, serial_result):
    result = _fit(trials, odb, pool)
    assert (result.executor, result.workers) == ("process", 2)
    assert result.values == serial_result.values
    assert _same(result.history, serial_result.history) and _same(result.after, serial_result.after)


@pytest.mark.slow
@pytest.mark.skipif(not HAS_DASK, reason="dask.distributed is not installed (pip install 'bridge[distributed]')")
def test_dask_cluster_gives_the_process_pool_result(trials, odb, pool, serial_result):
    with make_executor("dask", odb, workers=2) as executor:
        result = _fit(trials, odb, executor)
    assert (result.executor, result.workers) == ("dask", 2)
    assert result.values == _fit(trials, odb, pool).values == serial_result.values
    assert _same(result.history, serial_result.history)


def test_worker_errors_reach_the_caller_with_their_message(slide, pool):
    """Bad input found in a worker (scene values for a robot link that has no collision geometry) is raised in
    the caller, not scored as a failed simulation."""
    trial = slide[0]
    bad = Rollout(trial.world, trial.telemetry, SceneValues().with_object("pusher/pusher_tip", friction=0.5))
    with pytest.raises(BridgeError, match="unknown object 'pusher/pusher_tip'.*robot links .*pusher/pusher_rod"):
        pool.run([Job(bad)])


def test_a_failed_simulation_is_an_outcome_with_its_message(slide, odb, pool):
    trial = slide[0]
    crushed = apply_model((Setting("force_z", "small_box", -1e5),), Rollout(trial.world, trial.telemetry), odb)
    (outcome,) = pool.run([Job(crushed)])
    assert outcome.failed and outcome.result is None and "went through 'table'" in outcome.failure


def test_a_target_that_names_nothing_is_an_error_before_anything_runs(slide, odb):
    trial = slide[0]
    with pytest.raises(ParameterError, match="'tabel' names nothing"):
        apply_model((Setting("obstacle_x", "tabel", 0.5),), Rollout(trial.world, trial.telemetry), odb)


def test_executor_choices_are_checked(odb):
    with pytest.raises(BridgeError, match="unknown executor 'threads'; valid: process, dask, serial"):
        make_executor("threads", odb)
    with pytest.raises(BridgeError, match="needs the dask executor"):
        make_executor("process", odb, scheduler="tcp://127.0.0.1:8786")
    with pytest.raises(BridgeError, match="workers must be a whole number >= 1"):
        make_executor("process", odb, workers=0)


def test_serial_executor_hands_exceptions_to_the_future():
    future = SerialExecutor().submit(lambda: 1 / 0)
    with pytest.raises(ZeroDivisionError):
        future.result()
    assert SerialExecutor().submit(sum, [1, 2]).result() == 3


def test_iterate_submits_a_few_jobs_ahead_and_leaves_the_rest_when_stopped(monkeypatch):
    from bridge.odb import load_object_database
    from bridge.rollout import executors

    calls = []
    monkeypatch.setattr(executors, "run_task", lambda job, ref: calls.append(job) or job * 10)
    with make_executor("serial", load_object_database()) as executor:
        outcomes = executor.iterate([1, 2, 3, 4])
        assert next(outcomes) == 10 and calls == [1]  # serial: one at a time, as consumed
        assert next(outcomes) == 20 and calls == [1, 2]
        outcomes.close()  # a time limit: the jobs not started never run
        assert calls == [1, 2]
        assert list(executor.iterate([5, 6])) == [50, 60]


@pytest.mark.slow
def test_iterating_a_pool_and_stopping_early_leaves_it_usable(slide, odb, pool):
    jobs = [Job(Rollout(slide[0].world, slide[0].telemetry)) for _ in range(6)]
    outcomes = pool.iterate(jobs)
    first = next(outcomes)
    outcomes.close()
    again = pool.run(jobs[:2])
    assert not first.failed and [o.result.final_poses.keys() for o in again] == [first.result.final_poses.keys()] * 2
