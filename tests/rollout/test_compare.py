"""The paper's pose error (eq. 1-4) on cases small enough to compute by hand."""
from __future__ import annotations

import math

import numpy as np
import pytest

from bridge.errors import BridgeError
from bridge.rollout.compare import PoseError, pose_error, pose_error_arrays, rotation_angles
from bridge.values import Pose


def axis_angle(axis, angle: float) -> np.ndarray:
    """Rodrigues' formula, independent of the code under test."""
    k = np.asarray(axis, dtype=float)
    k = k / np.linalg.norm(k)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def pose(xyz=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0), angle=0.0) -> Pose:
    return Pose.from_matrix(np.block([[axis_angle(axis, angle), np.reshape(xyz, (3, 1))]]))


def test_pure_translation_is_the_euclidean_distance():
    err = pose_error([(pose((0, 0, 0)), pose((0.3, 0.4, 0.0)))])
    assert err == PoseError(e_t=pytest.approx(0.5), e_R=pytest.approx(0.0), e=pytest.approx(0.5), count=1)


def test_pure_rotation_is_the_angle_weighted_by_sqrt_c():
    err = pose_error([(pose(), pose(axis=(0, 0, 1), angle=math.pi / 2))])
    assert err.e_t == pytest.approx(0.0)
    assert err.e_R == pytest.approx(math.pi / 2)
    assert err.e == pytest.approx(math.sqrt(0.01) * math.pi / 2)  # sqrt(c) e_R with c = 0.01


def test_translation_and_rotation_combine_by_eq_3():
    err = pose_error([(pose((1, 2, 3)), pose((1.3, 2, 3), axis=(1, 1, 0), angle=math.pi / 3))], c=0.01)
    assert err.e_t == pytest.approx(0.3)
    assert err.e_R == pytest.approx(math.pi / 3)
    assert err.e == pytest.approx(math.sqrt(0.3**2 + 0.01 * (math.pi / 3) ** 2))


def test_overall_error_is_the_rms_over_objects_and_runs():
    pairs = [
        (pose((0, 0, 0)), pose((3, 0, 0))),  # e = 3
        (pose((0, 0, 0)), pose((0, 4, 0))),  # e = 4
        (pose((1, 1, 1)), pose((1, 1, 1), axis=(0, 1, 0), angle=0.5)),  # e_t 0, e_R 0.5
    ]
    err = pose_error(pairs, c=0.01)
    assert err.count == 3
    assert err.e_t == pytest.approx(math.sqrt((9 + 16 + 0) / 3))
    assert err.e_R == pytest.approx(math.sqrt(0.25 / 3))
    assert err.e == pytest.approx(math.sqrt((9 + 16 + 0.01 * 0.25) / 3))


@pytest.mark.parametrize("degrees", [179.9, 179.999999, 180.0])
def test_rotations_near_a_half_turn_about_an_arbitrary_axis(degrees):
    angle = math.radians(degrees)
    axis = (0.3, -1.2, 0.7)
    R = axis_angle(axis, angle)
    err = pose_error_arrays(np.zeros((1, 3)), np.eye(3)[None], np.zeros((1, 3)), R[None], c=1.0)
    assert err.e_R == pytest.approx(angle, abs=1e-9)
    # through Pose (quaternion storage) as well
    assert pose_error([(pose(axis=axis, angle=angle), pose())]).e_R == pytest.approx(angle, abs=1e-7)


def test_tiny_rotations_keep_their_precision():
    angle = 1e-7  # arccos(trace) would return 0 or ~2e-8 here
    R = axis_angle((1, 2, 3), angle)
    assert rotation_angles(R[None])[0] == pytest.approx(angle, rel=1e-6)


def test_error_is_symmetric_in_observed_and_simulated():
    rng = np.random.default_rng(7)
    a = [pose(rng.normal(size=3), rng.normal(size=3), rng.uniform(0, math.pi)) for _ in range(5)]
    b = [pose(rng.normal(size=3), rng.normal(size=3), rng.uniform(0, math.pi)) for _ in range(5)]
    assert pose_error(zip(a, b)) == pose_error(zip(b, a))


def test_c_weights_the_rotational_part_only():
    pairs = [(pose((0, 0, 0)), pose((0.2, 0, 0), axis=(0, 0, 1), angle=1.0))]
    assert pose_error(pairs, c=0.0).e == pytest.approx(0.2)
    assert pose_error(pairs, c=1.0).e == pytest.approx(math.sqrt(0.04 + 1.0))
    assert pose_error(pairs, c=0.25).e == pytest.approx(math.sqrt(0.04 + 0.25))
    assert pose_error(pairs, c=0.0).e_R == pose_error(pairs, c=1.0).e_R


def test_aggregates_keep_eq_3_and_arrays_match_pairs():
    rng = np.random.default_rng(3)
    obs = [pose(rng.normal(size=3), rng.normal(size=3), rng.uniform(0, math.pi)) for _ in range(20)]
    sim = [pose(rng.normal(size=3), rng.normal(size=3), rng.uniform(0, math.pi)) for _ in range(20)]
    err = pose_error(zip(obs, sim), c=0.05)
    assert err.e**2 == pytest.approx(err.e_t**2 + 0.05 * err.e_R**2)
    arrays = pose_error_arrays(
        np.array([p.xyz for p in obs]), np.array([p.rotation() for p in obs]),
        np.array([p.xyz for p in sim]), np.array([p.rotation() for p in sim]), c=0.05)
    assert arrays.e == pytest.approx(err.e) and arrays.count == 20


def test_merge_equals_the_error_over_all_samples():
    pairs = [(pose((0, 0, 0)), pose((k, 0, 0), axis=(1, 0, 0), angle=0.1 * k)) for k in range(5)]
    whole = pose_error(pairs)
    merged = PoseError.merge([pose_error(pairs[:2]), pose_error(pairs[2:])])
    assert merged.count == whole.count
    for field in ("e_t", "e_R", "e"):
        assert getattr(merged, field) == pytest.approx(getattr(whole, field))


def test_bad_input_raises_fit_errors():
    with pytest.raises(BridgeError, match="no pose pairs"):
        pose_error([])
    with pytest.raises(BridgeError, match="weight c"):
        pose_error([(pose(), pose())], c=-1)
    with pytest.raises(BridgeError, match=r"t_sim has 2 samples but t_obs has 1"):
        pose_error_arrays(np.zeros((1, 3)), np.eye(3)[None], np.zeros((2, 3)), np.stack([np.eye(3)] * 2))
    with pytest.raises(BridgeError, match=r"R_sim sample 0 is not a rotation"):
        pose_error_arrays(np.zeros((1, 3)), np.eye(3)[None], np.zeros((1, 3)), 2 * np.eye(3)[None])
    with pytest.raises(BridgeError, match=r"t_obs must have shape \(N, 3\)"):
        pose_error_arrays(np.zeros((1, 2)), np.eye(3)[None], np.zeros((1, 3)), np.eye(3)[None])
    with pytest.raises(BridgeError, match="pose pair 0"):
        pose_error([(pose(),)])
