"""The diagnosis' time step (`runs.choose_time_step`): the coarse step only where its own error is small against
the mismatch being diagnosed, every replay of the diagnosis at the step chosen. Real Drake replays of generated
planar pushes."""
from __future__ import annotations

import pytest

from bridge.diagnosis import runs
from bridge.diagnosis.runs import (COARSE_STEP, MAX_SCALE, QUASI_STATIC_SPEEDS, STEP_SHARE, Runner,
                                    choose_time_scales, choose_time_step, prepare)
from bridge.prove.generate import generate_case
from bridge.prove.scenes import Case
from bridge.rollout import load_trials, make_executor


def _runner(odb, folder, effect: str, magnitude: str) -> Runner:
    paths, _ = generate_case(Case("planar", effect, magnitude, 3), odb, folder, 2, force_noise=None)
    return Runner([prepare(t, odb, 25.0) for t in load_trials(paths, odb)], odb, make_executor("serial", odb))


def test_a_coarse_step_whose_error_is_small_against_the_mismatch_is_taken_for_every_replay(odb, tmp_path):
    """An off-centre weight moves the block's path far more than the coarser step does: it is taken, and every
    replay after the choice runs at it."""
    runner = _runner(odb, tmp_path / "com", "com_offset", "small")
    choice = choose_time_step(runner, [0, 1])
    assert choice.coarse_chosen and choice.time_step == COARSE_STEP
    assert choice.share is not None and choice.share <= STEP_SHARE
    assert runner.time_step == COARSE_STEP
    assert runner.job((), 0).rollout.config.time_step == COARSE_STEP
    assert f"replayed at {1e3 * COARSE_STEP:g} ms" in choice.sentence()


def test_the_fine_step_stays_where_the_coarse_one_would_be_read_as_physics(odb, tmp_path):
    """A world the model matches (residual at the noise floor), and a block whose coarse replay differs from its
    2 ms one by a large share of what the doubled friction it is diagnosed for leaves: both keep the recordings'
    2 ms."""
    for effect, magnitude in (("none", "medium"), ("friction", "medium")):
        runner = _runner(odb, tmp_path / effect, effect, magnitude)
        choice = choose_time_step(runner, [0, 1])
        assert not choice.coarse_chosen, (effect, choice)
        assert runner.time_step is None and runner.job((), 0).rollout.config.time_step == pytest.approx(0.002)
        assert choice.share is None if effect == "none" else choice.share > STEP_SHARE


def test_a_step_the_caller_sets_is_kept_without_a_replay(odb, tmp_path):
    runner = _runner(odb, tmp_path / "com", "com_offset", "small")
    runner.time_step = 0.0025
    choice = choose_time_step(runner, [0, 1])
    assert choice.asked and choice.time_step == 0.0025 and runner.simulations == 0
    assert runner.job((), 1).rollout.config.time_step == 0.0025 and "as asked" in choice.sentence()


# --- quasi-static replays (`runs.choose_time_scales`) -------------------------------------------------------------
def _slow_runner(odb, folder, effect: str, magnitude: str, speeds=(0.008, 0.012)) -> Runner:
    paths, _ = generate_case(Case("planar", effect, magnitude, 3), odb, folder, 2, force_noise=None, speeds=speeds)
    return Runner([prepare(t, odb, 25.0) for t in load_trials(paths, odb)], odb, make_executor("serial", odb))


def test_slow_pushes_that_miss_by_far_more_than_a_faster_replay_changes_are_replayed_faster(odb, tmp_path):
    """Pushes at 8-12 mm/s of a block with an off-centre weight: played at 25 mm/s, each nominal replay changes by
    far less than the weight moves it, so every replay of the diagnosis after the choice runs faster."""
    runner = _slow_runner(odb, tmp_path / "com", "com_offset", "medium")
    choice = choose_time_scales(runner, [0, 1])
    names = [p.name for p in runner.prepared]
    assert all(0.006 < choice.speeds[n] < 0.016 for n in names), choice.speeds
    assert set(choice.taken) == set(names), choice
    assert all(choice.shares[n] <= STEP_SHARE for n in names)
    scales = {n: [pytest.approx(min(MAX_SCALE, s / choice.speeds[n])) for s in QUASI_STATIC_SPEEDS] for n in names}
    assert all(choice.taken[n] in scales[n] for n in names), (choice, scales)
    assert runner.job((), 0).rollout.time_scale == choice.taken[names[0]]
    assert "replayed faster" in choice.sentence()


def test_a_scale_that_changes_a_replay_too_much_falls_back_to_the_next_speed(odb, tmp_path, monkeypatch):
    """Played 20-24 times faster (250 mm/s) the block coasts about a centimetre after each push, more than a
    small off-centre weight moves it, so that scale is refused; the next speed (25 mm/s) changes little and is
    kept. (Under a medium weight the 250 mm/s replay of one push stays within the share and is taken.)"""
    monkeypatch.setattr(runs, "QUASI_STATIC_SPEEDS", (0.25, 0.025))
    monkeypatch.setattr(runs, "MAX_SCALE", 40.0)
    runner = _slow_runner(odb, tmp_path / "com", "com_offset", "small")
    choice = choose_time_scales(runner, [0, 1])
    names = [p.name for p in runner.prepared]
    assert set(choice.taken) == set(names), choice
    assert all(choice.taken[n] == pytest.approx(0.025 / choice.speeds[n]) for n in names)
    assert all(choice.tried[n] == choice.taken[n] and choice.shares[n] <= STEP_SHARE for n in names)
    assert runner.simulations == 3 * len(names)  # own speed once, then each scale tried


def test_a_world_the_model_matches_and_fast_pushes_are_replayed_at_their_own_speed(odb, tmp_path):
    """At the noise floor the faster replay's own change would be read as physics; pushes at 60-200 mm/s are
    not tried at all; and the caller may turn it off."""
    clean = _slow_runner(odb, tmp_path / "none", "none", "medium")
    choice = choose_time_scales(clean, [0, 1])
    assert choice.tried and not choice.taken and clean.job((), 0).rollout.time_scale == 1.0
    fast = _runner(odb, tmp_path / "fast", "com_offset", "medium")
    assert not choose_time_scales(fast, [0, 1]).tried and fast.simulations == 0
    slow = _slow_runner(odb, tmp_path / "com", "com_offset", "medium")
    off = choose_time_scales(slow, [0, 1], enabled=False)
    assert not off.taken and slow.simulations == 0 and "own speed, as asked" in off.sentence()
