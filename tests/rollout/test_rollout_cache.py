"""The rollout cache in front of every executor: a repeated job is not simulated again, its outcome is the fresh
one, and the counts say how many were simulated and how many came from the cache (real Drake replays)."""
import numpy as np
import pytest

import bridge.rollout.executors as executors
from bridge.rollout import Job, Rollout, make_executor
from bridge.rollout.rollout import RolloutCache, job_key, run_job
from bridge.sim.scene import SceneValues
from bridge.sim.simulate import SimOptions


@pytest.fixture
def counted(monkeypatch):
    """Counts the simulations actually run (the serial executor runs them in this process)."""
    calls = []

    def run(job, odb):
        calls.append(job.rollout.name)
        return run_job(job, odb)

    monkeypatch.setattr(executors, "run_job", run)
    return calls


def _job(trial, name="a", friction=None, **options):
    values = SceneValues() if friction is None else SceneValues().with_object("small_box", friction=friction)
    return Job(Rollout(trial.world, trial.telemetry, values, name=name), SimOptions(settle=0.2, **options))


def test_a_repeated_job_is_simulated_once(slide, odb, counted):
    trial = slide[0]
    with make_executor("serial", odb) as ex:
        first, again = ex.run([_job(trial, "a"), _job(trial, "b")])  # equal jobs by other names, one batch
        assert counted == ["a"] and ex.cache.counts() == {"simulated": 1, "cached": 1}
        assert not first.cached and again.cached and (again.name, again.wall_time) == ("b", 0.0)
        (later,) = ex.run([_job(trial, "c")])  # a later batch
        assert counted == ["a"] and later.cached and ex.cache.counts() == {"simulated": 1, "cached": 2}
        ex.run([_job(trial, "d", friction=0.3), _job(trial, "e", contacts=True)])  # other values, other options
        assert counted == ["a", "d", "e"] and ex.cache.counts() == {"simulated": 3, "cached": 2}
        assert list(ex.iterate([_job(trial, "f"), _job(trial, "g", friction=0.3)])) and counted == ["a", "d", "e"]
        assert ex.cache.counts() == {"simulated": 3, "cached": 4}


def test_a_cached_outcome_equals_a_fresh_one(slide, odb):
    trial = slide[0]
    with make_executor("serial", odb) as ex:
        ex.run([_job(trial)])
        (cached,) = ex.run([_job(trial)])
    with make_executor("serial", odb) as ex:
        (fresh,) = ex.run([_job(trial)])
    assert cached.cached and not fresh.cached
    assert np.array_equal(cached.result.times, fresh.result.times)
    for name, track in fresh.result.tracks.items():
        assert np.array_equal(cached.result.tracks[name], track)
    assert cached.result.final_poses == fresh.result.final_poses
    with pytest.raises(ValueError):  # shared by every job that asks: read-only
        cached.result.tracks["small_box"][0, 0] = 1.0


def test_the_process_pool_simulates_each_distinct_job_once(slide, odb, pool):
    trial = slide[0]
    before = pool.cache.counts()
    outcomes = pool.run([_job(trial, "x", friction=0.41), _job(trial, "y", friction=0.42),
                         _job(trial, "z", friction=0.41)])
    after = pool.cache.counts()
    assert (after["simulated"] - before["simulated"], after["cached"] - before["cached"]) == (2, 1)
    assert [o.name for o in outcomes] == ["x", "y", "z"]
    assert np.array_equal(outcomes[0].result.tracks["small_box"], outcomes[2].result.tracks["small_box"])
    assert not np.array_equal(outcomes[0].result.tracks["small_box"], outcomes[1].result.tracks["small_box"])


def test_the_cache_is_bounded_least_recently_used_first_out(slide, odb, counted):
    trial = slide[0]
    with make_executor("serial", odb) as ex:
        ex.cache = RolloutCache(max_entries=2)
        ex.run([_job(trial, "a", friction=0.3), _job(trial, "b", friction=0.4), _job(trial, "c", friction=0.5)])
        assert len(ex.cache) == 2
        ex.run([_job(trial, "a2", friction=0.3)])  # dropped first: simulated again
        ex.run([_job(trial, "c2", friction=0.5)])  # still held
    assert counted == ["a", "b", "c", "a2"]
    assert RolloutCache(max_bytes=10).get(None) is None


def test_the_key_is_what_is_simulated(slide):
    trial = slide[0]
    assert job_key(_job(trial, "a")) == job_key(_job(trial, "b"))  # a name is a label
    assert job_key(_job(trial)) != job_key(_job(trial, friction=0.3))
    assert job_key(_job(trial)) != job_key(_job(trial, robot_force=True))

    class Unpicklable:
        def __reduce__(self):
            raise TypeError("no")

    assert job_key(Job(Rollout(trial.world, trial.telemetry, hooks=(Unpicklable(),)))) is None
