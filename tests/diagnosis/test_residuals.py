"""Noise is estimated from the data; residuals are zero for identical tracks."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from bridge.diagnosis.residuals import estimate_noise, observed_series
from bridge.rollout.compare import pose_residual
from bridge.recording.observations import ObservedTrack
from bridge.values import Pose


def _track(noise_p, noise_r, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 2.0, 0.02)
    x = 0.05 * np.clip(t - 0.5, 0, 1)  # a push at 5 cm/s
    yaw = 0.2 * np.clip(t - 0.5, 0, 1)
    poses = []
    for ti, xi, yi in zip(t, x, yaw):
        R = Rotation.from_rotvec(rng.normal(0, noise_r, 3)) * Rotation.from_euler("z", yi)
        q = R.as_quat()
        poses.append(Pose(tuple(np.array([xi, 0.0, 0.0064]) + rng.normal(0, noise_p, 3)), (q[3], q[0], q[1], q[2])))
    return ObservedTrack("block", t, tuple(poses))


def test_noise_is_estimated_from_second_differences():
    track = _track(3e-4, 2e-3)
    xyz = np.array([p.xyz for p in track.poses])
    R = np.array([p.rotation() for p in track.poses])
    sigma, measured, estimated = estimate_noise(track.times, xyz, R)
    assert estimated and measured.all()
    np.testing.assert_allclose(sigma[:3], 3e-4, rtol=0.3)
    np.testing.assert_allclose(sigma[3:], 2e-3, rtol=0.35)


def test_constant_components_are_not_measured():
    track = _track(0.0, 0.0)
    s = observed_series(track, 25.0)
    assert list(s.measured) == [True, False, False, False, False, True]  # x and yaw move, the rest is constant


def test_residual_of_identical_tracks_is_zero():
    s = observed_series(_track(1e-4, 1e-3), 25.0)
    assert np.abs(pose_residual(s.xyz, s.R, s.xyz, s.R)).max() < 1e-12


def test_force_noise_is_estimated_and_identical_forces_leave_no_residual():
    from bridge.diagnosis.residuals import FORCE_MODEL_ERROR, force_residual, force_series
    from bridge.recording.forces import ObservedForce

    rng = np.random.default_rng(1)
    t = np.arange(0.0, 2.0, 0.004)  # a 250 Hz sensor
    clean = np.column_stack([2.0 * np.clip(t - 0.5, 0, 0.2) / 0.2, 0.5 * np.sin(t), np.zeros_like(t)])
    noisy = ObservedForce(t, clean + np.column_stack([rng.normal(0, 0.05, (len(t), 2)), np.zeros(len(t))]))
    series = force_series(noisy, 25.0)
    assert series.sigma[:2] == pytest.approx([0.05, 0.05], rel=0.2)  # from the data, not assumed
    assert series.measured.tolist() == [True, True, False]
    sim = force_series(ObservedForce(t, clean), 25.0)
    assert np.abs(force_residual(sim, t, clean)).max() < 1e-9
    # the tolerance grows with the force: 3 % of 2 N on top of the noise
    pushing = series.force[:, 0] > 1.9
    assert np.all(series.tolerance[pushing, 0] > np.hypot(series.sigma[0], FORCE_MODEL_ERROR * 1.9))


def test_the_force_is_compared_only_while_the_robot_moves():
    """Before its motion and after it the robot's force is a hold (a pre-load, the last push force kept by its
    servo against static friction), which depends on a servo stiffness no model knows: it is left out."""
    from bridge.diagnosis.residuals import force_series, motion_span
    from bridge.recording.forces import ObservedForce

    rng = np.random.default_rng(2)
    t = np.arange(0.0, 3.0, 0.004)  # an encoder at 250 Hz: still, a push from 0.5 s to 2 s at 5 cm/s, still
    x = 0.05 * np.clip(t - 0.5, 0.0, 1.5) + rng.normal(0.0, 2e-6, len(t))  # micrometre encoder noise
    start, end = motion_span(t, np.column_stack([x, np.full(len(t), 0.1)]))
    assert start == pytest.approx(0.5, abs=0.06) and end == pytest.approx(2.0, abs=0.06)
    assert motion_span(t, np.column_stack([np.full(len(t), 0.2)])) is None  # nothing moves
    held = ObservedForce(t, np.column_stack([np.where(t > 0.5, 3.0, 0.5), np.zeros(len(t)), np.zeros(len(t))]))
    series = force_series(held, 25.0, (start, end))
    assert series.times[0] >= start - 1e-9 and series.times[-1] <= end + 1e-9
    assert len(series.times) == pytest.approx(25 * (end - start), abs=2)
    assert len(force_series(held, 25.0).times) > len(series.times)  # without a span: every sample
