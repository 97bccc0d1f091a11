"""Forks (`diagnosis.forks`): a push whose outcome turns on a millimetre of where the rod meets the object is
scored with that fork as part of its tolerance; a push the model predicts smoothly is scored as before. Real
Drake replays of MIT-format pushes of the dataset-free steel block (90 x 90 mm, the rod 4.76 mm in radius)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from bridge.diagnosis.forks import PLACEMENT, measure_forks
from bridge.diagnosis.runs import Runner, prepare
from bridge.recording.mitpush import save_push
from bridge.rollout import load_trials, make_executor

HALF, ROD = 0.045, 0.00476  # m: the block's half side, the rod's radius
T0 = 1.7e9  # unix s


def _push(path, start, direction, rng) -> str:
    """A rod moving from `start` along `direction` at 50 mm/s for 1.4 s; the block tracked at rest at the origin
    with motion-capture noise (what it really did does not matter: a fork is the model's own)."""
    t = np.arange(0.0, 1.6, 0.004)
    moved = 0.05 * np.clip(t - 0.1, 0.0, 1.4)
    tip = np.asarray(start)[None, :] + moved[:, None] * np.asarray(direction)[None, :]
    tip_pose = np.column_stack([T0 + t, tip, np.zeros_like(t)])
    obj = np.column_stack([T0 + t, rng.normal(0, 2e-4, (len(t), 2)), rng.normal(0, 2e-3, len(t))])
    save_push(path, tip_pose, obj, shape="steel_block")
    return str(path)


@pytest.mark.slow
def test_a_push_at_a_corner_forks_and_a_push_at_a_face_does_not(odb, tmp_path):
    rng = np.random.default_rng(4)
    d = np.array([1.0, 1.0]) / math.sqrt(2.0)
    corner = np.array([-HALF, -HALF]) - (ROD + 0.012) * d + 0.0004 * np.array([-d[1], d[0]])  # 0.4 mm off the diagonal
    paths = [_push(tmp_path / "face.h5", (-HALF - ROD - 0.006, 0.01), (1.0, 0.0), rng),
             _push(tmp_path / "corner.h5", corner, d, rng)]
    runner = Runner([prepare(t, odb, 25.0) for t in load_trials(paths, odb)], odb, make_executor("serial", odb))
    before = [r.chi2 for r in runner.run((), [0, 1])]
    forks = measure_forks(runner, [0, 1])
    assert runner.rollouts()["simulated"] == 2 + 2 * 4  # the nominal replays (then cached), four shifted ones each
    assert forks.placement == PLACEMENT and not forks.failed
    assert forks.size["face"] == 0.0, forks  # a smooth push: its even part is second order, below the shift
    assert forks.size["corner"] > 5.0, forks  # one shift sends the block round the other side of the corner
    assert forks.forked() == ["corner"] and "corner" in forks.sentence()
    after = [r.chi2 for r in runner.run((), [0, 1])]  # the same replays (cached), scored with the fork
    assert after[0] == pytest.approx(before[0], rel=0.5)
    assert after[1] < 0.2 * before[1]
    series = runner.prepared[1].series[0]
    assert series.fork.shape == (len(series.times), 6)
    assert not runner.prepared[0].series[0].fork.any()  # a smooth push's second-order part is no fork
    assert series.fork[0].sum() == 0.0 and series.fork[-1].sum() > 0.0  # forked after the contact, not before


@pytest.mark.slow
def test_forks_are_measured_where_a_measured_calibration_puts_the_rod(odb, tmp_path):
    """The corner push forks where the rod is recorded; with a rod offset the recordings measure (8 mm across the
    diagonal, `identify.measured_model`) the rod meets a face 8 mm beside the corner, smoothly: scored there, the
    push keeps the noise as its tolerance, and the forks say where they were measured."""
    from bridge.params import Setting

    rng = np.random.default_rng(4)
    d = np.array([1.0, 1.0]) / math.sqrt(2.0)
    corner = np.array([-HALF, -HALF]) - (ROD + 0.012) * d + 0.0004 * np.array([-d[1], d[0]])
    path = _push(tmp_path / "corner.h5", corner, d, rng)
    across = 0.008 * np.array([-d[1], d[0]])
    model = tuple(Setting("joint_offset", j, float(v)) for j, v in zip(("pusher_x", "pusher_y"), across))
    nominal = measure_forks(Runner([prepare(t, odb, 25.0) for t in load_trials([path], odb)], odb,
                                   make_executor("serial", odb)), [0])
    runner = Runner([prepare(t, odb, 25.0) for t in load_trials([path], odb)], odb, make_executor("serial", odb))
    calibrated = measure_forks(runner, [0], model=model)
    assert nominal.forked() == ["corner"]
    assert calibrated.forked() == [], calibrated
    assert not runner.prepared[0].series[0].fork.any()
    assert calibrated.to_json()["measured_at"] == pytest.approx({"joint_offset[pusher_x]": across[0],
                                                                 "joint_offset[pusher_y]": across[1]})
    assert "joint_offset[pusher_x]" in calibrated.sentence()
