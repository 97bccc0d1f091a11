"""The backends a generation runs on give the same fit: in-process, a process pool, a dask cluster."""
from __future__ import annotations

import importlib.util

import pytest

from bridge.errors import FitError, SceneError
from bridge.fit.executors import SerialExecutor, make_executor
from bridge.fit.fit import fit_parameters
from bridge.fit.params import parse_params
from bridge.fit.synthetic import recovery_spec

FRICTIONS = ("friction[big_box]", "friction[table]")
HAS_DASK = importlib.util.find_spec("distributed") is not None


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
    assert result.history == serial_result.history and result.after == serial_result.after


@pytest.mark.slow
@pytest.mark.skipif(not HAS_DASK, reason="dask.distributed is not installed (pip install 'bridge[distributed]')")
def test_dask_cluster_gives_the_process_pool_result(trials, odb, pool, serial_result):
    with make_executor("dask", odb, workers=2) as executor:
        result = _fit(trials, odb, executor)
    assert (result.executor, result.workers) == ("dask", 2)
    assert result.values == _fit(trials, odb, pool).values == serial_result.values
    assert result.history == serial_result.history


def test_worker_errors_reach_the_caller_with_their_message(slide, odb, pool):
    spec = parse_params({"params": [{"kind": "friction", "target": "pusher/pusher_tip", "bounds": [0.1, 1]}]})
    with pytest.raises(SceneError, match="unknown object 'pusher/pusher_tip'.*robot links .*pusher/pusher_rod"):
        pool.evaluate(slide, spec, [[0.5]])


def test_executor_choices_are_checked(odb):
    with pytest.raises(FitError, match="unknown executor 'threads'; valid: process, dask, serial"):
        make_executor("threads", odb)
    with pytest.raises(FitError, match="needs the dask executor"):
        make_executor("process", odb, scheduler="tcp://127.0.0.1:8786")
    with pytest.raises(FitError, match="workers must be a whole number >= 1"):
        make_executor("process", odb, workers=0)


def test_serial_executor_hands_exceptions_to_the_future():
    future = SerialExecutor().submit(lambda: 1 / 0)
    with pytest.raises(ZeroDivisionError):
        future.result()
    assert SerialExecutor().submit(sum, [1, 2]).result() == 3
