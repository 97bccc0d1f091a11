"""Localisation on generated recordings (real Drake): the onset follows the contact that causes it, the push
direction is the object's, the noise floor is the generator's, and a clean recording stays quiet."""
import numpy as np
import pytest

from bridge.diagnosis.locate import locate
from bridge.diagnosis.runs import Runner, prepare
from bridge.prove.generate import generate_case
from bridge.prove.scenes import NOISE_POSITION, NOISE_ROTATION, Case
from bridge.rollout import load_trials, make_executor
from bridge.sim.shapes import mass_properties


def _engine(case, odb, tmp_path, n=2):
    paths, truth = generate_case(case, odb, tmp_path / case.name, n)
    trials = load_trials(paths, odb)
    return Runner([prepare(t, odb, 25.0) for t in trials], odb, make_executor("serial", odb)), truth


@pytest.mark.slow
def test_com_offset_onset_follows_the_pusher_contact(odb, tmp_path):
    engine, _ = _engine(Case("planar", "com_offset", "large", 1), odb, tmp_path)
    loc = locate(engine)
    assert len(loc.objects) == 2
    for o in loc.objects:
        assert o.significant
        assert o.push_s is not None and o.onset_s >= o.push_s[0] - 0.1
        assert o.contact is not None and "pusher/pusher_rod" in o.contact and "block" in o.contact
        obs_dir = o.obs_xy[-1] - o.obs_xy[0]
        assert np.dot(o.direction, obs_dir / np.linalg.norm(obs_dir)) > 0.9
        # the noise floor comes from the data and matches the generator's noise
        assert o.sigma["along"] == pytest.approx(NOISE_POSITION, rel=0.35)
        assert o.sigma["yaw"] == pytest.approx(NOISE_ROTATION, rel=0.4)
    assert [r for r, _ in loc.recordings_ranked()][0] == loc.ranking()[0].recording
    assert "onset_s" in loc.to_json()[0]


@pytest.mark.slow
def test_clean_recordings_stay_at_the_noise_floor(odb, tmp_path):
    engine, _ = _engine(Case("planar", "none", "medium", 1), odb, tmp_path)
    loc = locate(engine)
    for o in loc.objects:
        assert not o.significant and o.rms < 2.0
        assert o.quiet_level is None or o.quiet_level < 2.0


@pytest.mark.slow
def test_a_heavier_block_shows_in_the_force_ratio_not_the_path(odb, tmp_path):
    engine, truth = _engine(Case("planar", "mass", "large", 1), odb, tmp_path)
    loc = locate(engine)
    m0 = mass_properties(odb, "steel_block").mass
    assert loc.force_scale() == pytest.approx(truth.params["mass[block]"] / m0, rel=0.15)
    assert all(f.significant for f in loc.forces)
    assert max(o.error["e_t"] for o in loc.objects) < 0.004  # the path is off by millimetres at most


@pytest.mark.slow
def test_a_clock_shift_shows_as_a_start_of_motion_shift(odb, tmp_path):
    engine, truth = _engine(Case("planar", "latency", "large", 1), odb, tmp_path)
    loc = locate(engine)
    shifts = [o.features["moves_obs_s"] - o.features["moves_sim_s"] for o in loc.objects]
    assert np.median(shifts) == pytest.approx(truth.params["latency[pusher]"], abs=0.025)


def _pushed_into_a_post(speed_after: float, surge: float):
    """A 6 s push at 10 mm/s, the force series at 25 Hz: the object moves freely for 3 s, then runs into a post:
    it moves on at `speed_after` (m/s) while the recorded force holds at `surge` times the 1 N push."""
    from types import SimpleNamespace

    from bridge.diagnosis.locate import _jam

    t = np.arange(0.0, 6.0, 0.04)
    x = np.where(t < 3.0, 0.01 * t, 0.03 + speed_after * (t - 3.0))
    xyz = np.stack([x, np.zeros_like(t), np.zeros_like(t)], axis=1)
    prepared = SimpleNamespace(series=[SimpleNamespace(times=t, xyz=xyz)], force=SimpleNamespace(times=t))
    simulated = np.ones_like(t)
    observed = np.where(t < 3.0, 1.0, surge)
    return _jam(prepared, observed, simulated, floor=0.05)


def test_an_object_squeezed_past_a_post_jams_though_it_still_moves():
    """MuJoCo worlds with a post beside the path: the object slid past it at half its speed while the rod's force
    rose to 100-1000 N on a 1 N push; read as moving, it never jammed, and no post was tried (`none`)."""
    assert _pushed_into_a_post(0.005, 100.0) == pytest.approx(3.0, abs=0.05)
    assert _pushed_into_a_post(0.0, 3.0) == pytest.approx(3.0, abs=0.05)  # stalled: a jam as before


def test_a_force_a_coefficient_error_explains_is_no_jam_while_the_object_moves():
    """Three times the simulated force while the object moves on is a friction coefficient off by three (the
    surface's coefficient moved x/1.3-1.8 in every generated world), not an obstacle."""
    assert _pushed_into_a_post(0.005, 3.0) is None
    assert _pushed_into_a_post(0.01, 8.0) is None

