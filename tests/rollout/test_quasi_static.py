"""Quasi-static replay (`Rollout.time_scale`): a slow push played faster follows the path of the replay at its
own speed, on the recording's clock, through the real Drake simulation; a latency keeps its meaning."""
from dataclasses import replace

import numpy as np
import pytest

from bridge.params import trial_rollout
from bridge.prove.generate import generate_case
from bridge.prove.scenes import Case
from bridge.rollout import load_trials, run_rollout
from bridge.rollout.rollout import Rollout
from bridge.sim.simulate import SimOptions

OPTIONS = SimOptions(sample_rate=50.0, robot_force=True, contacts=True)


@pytest.fixture(scope="module")
def slow_push(odb, tmp_path_factory):
    """A generated MIT-format push of the steel block (no dataset needed), its telemetry slowed to about 12 mm/s."""
    paths, _ = generate_case(Case("mit_steel_block", "none", "medium", 3, "matched"), odb,
                             tmp_path_factory.mktemp("push"), 1)
    rollout = trial_rollout(load_trials(paths, odb)[0], (), odb)
    tel = rollout.telemetry
    speed = np.percentile(np.linalg.norm(np.diff(tel.positions, axis=0), axis=1) / np.diff(tel.times), 90)
    return rollout.with_telemetry(replace(tel, times=tel.times * max(1.0, speed / 0.012)))  # the rod at ~12 mm/s


def _track_difference(a, b, name):
    n = min(len(a.times), len(b.times))
    assert np.allclose(a.times[:n], b.times[:n], atol=1e-9)
    return 1e3 * np.max(np.linalg.norm(a.tracks[name][:n, :2] - b.tracks[name][:n, :2], axis=1))


@pytest.mark.slow
def test_a_slow_push_played_faster_follows_its_own_path_on_the_recordings_clock(slow_push, odb):
    own = run_rollout(slow_push, odb, OPTIONS)
    fast = run_rollout(replace(slow_push, time_scale=2.0), odb, OPTIONS)
    name = next(iter(own.tracks))
    moved = 1e3 * np.linalg.norm(own.tracks[name][-1, :2] - own.tracks[name][0, :2])
    assert moved > 20.0  # a real push, not a block at rest
    assert len(fast.times) == len(own.times) and fast.sim_time == pytest.approx(own.sim_time)
    assert _track_difference(own, fast, name) < 0.3  # mm, along the whole track (the servo's lag and the coast)
    force = lambda r: np.linalg.norm(r.robot_force[:, :2], axis=1)  # noqa: E731 - quasi-static: the same force
    assert np.median(force(fast)[force(own) > 0.1]) == pytest.approx(np.median(force(own)[force(own) > 0.1]), rel=0.05)
    # contacts and awake spans on the recording's clock too
    assert max(c.time for c in fast.contact_log) == pytest.approx(max(c.time for c in own.contact_log), abs=0.05)
    assert own.awake and fast.awake[-1][1] == pytest.approx(own.awake[-1][1], abs=0.05)


@pytest.mark.slow
def test_a_latency_is_a_delay_on_the_recordings_clock_whatever_the_replays_speed(slow_push, odb):
    """The latency is applied to the telemetry first; played twice as fast, the delay still is 0.2 s of the
    recording, not 0.1 or 0.4."""
    late = slow_push.with_telemetry(slow_push.telemetry.shifted(0.2))
    own = run_rollout(late, odb, OPTIONS)
    fast = run_rollout(replace(late, time_scale=2.0), odb, OPTIONS)
    name = next(iter(own.tracks))
    assert _track_difference(own, fast, name) < 0.3
    start = lambda r: r.times[np.argmax(np.linalg.norm(r.tracks[name][:, :2] - r.tracks[name][0, :2], axis=1) > 1e-3)]  # noqa: E731
    assert start(fast) == pytest.approx(start(own), abs=0.05)
    assert start(own) > start(run_rollout(slow_push, odb, OPTIONS)) + 0.15


def test_a_rollout_cannot_run_slower_than_its_recording(slow_push):
    with pytest.raises(ValueError, match="time_scale"):
        replace(slow_push, time_scale=0.5)
    with pytest.raises(ValueError, match="time_scale"):
        Rollout(slow_push.world, slow_push.telemetry, time_scale=float("nan"))
