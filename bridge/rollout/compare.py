"""How a replay is compared with a recording's observations: one pose interpolation, one residual, the paper's
error (Section V, eq. 1-4), and the residual vector a least-squares optimiser minimises.

The residual of an observed pose is observed minus simulated position (m) and the rotation vector of
R_obs R_sim^T (rad, world frame: its z is the yaw difference, x and y the tilt). Simulated poses are interpolated
between the replay's samples (linear in position, normalised lerp of the quaternions in orientation).

The paper's error, per object i and run k (a recording, or one of K repeated simulations of it) and
observation time:

    e_t = ||t - t_hat||                                   (1)  translational, metres
    e_R = ||log(R R_hat^T)||_F / sqrt(2)                 (2)  geodesic, radians (the rotation angle, 0..pi)
    e   = sqrt(e_t^2 + c e_R^2)                           (3)  combined, c = 0.01 by default
    E   = sqrt(mean over all samples of e^2)             (4)  root mean square over objects, runs and times

Every field of `PoseError` is a root mean square over the same samples (as in the paper's Table I), so the
aggregates keep eq. (3): ``E**2 == e_t**2 + c * e_R**2`` holds for the reported values too.
The angle comes from an atan2 formula that stays accurate near 0 and near pi, where arccos of the trace and
quaternion dot products lose precision.

A failed replay (`Outcome.failed`) has no poses; its residual is `FAILED` (1 m, 1 rad) in every compared
component: far outside any real mismatch and finite, so optimisers rank it last. Callers count and report
failures; the value only keeps the arithmetic going.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Collection, Iterable, Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import BridgeError
from ..recording.observations import ObservedPoses, ObservedTrack
from ..sim.simulate import ReplayResult
from ..values import Pose

DEFAULT_C = 0.01
FAILED = 1.0  # m and rad per residual component of a failed replay
_ROTATION_TOLERANCE = 1e-6


# --- interpolation and residuals -----------------------------------------------------------------------------
def sample_track(sim_times: np.ndarray, track: np.ndarray, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Simulated positions (n, 3) and rotation matrices (n, 3, 3) at `times` (clipped to the replay's span),
    interpolated from a (T, 7) track of x, y, z, qw, qx, qy, qz."""
    t = np.clip(times, sim_times[0], sim_times[-1])
    xyz = np.column_stack([np.interp(t, sim_times, track[:, k]) for k in range(3)])
    quats = track[:, 3:7].copy()
    for k in range(1, len(quats)):  # one hemisphere, so the linear blend below is the short way
        if quats[k] @ quats[k - 1] < 0:
            quats[k] = -quats[k]
    q = np.column_stack([np.interp(t, sim_times, quats[:, k]) for k in range(4)])
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return xyz, Rotation.from_quat(q[:, [1, 2, 3, 0]]).as_matrix()


def pose_residual(obs_xyz: np.ndarray, obs_R: np.ndarray, sim_xyz: np.ndarray, sim_R: np.ndarray) -> np.ndarray:
    """(n, 6): observed minus simulated position, and the rotation vector of R_obs R_sim^T (world frame)."""
    dr = Rotation.from_matrix(obs_R @ np.swapaxes(sim_R, 1, 2)).as_rotvec()
    return np.column_stack([obs_xyz - sim_xyz, dr])


def failed_residual(n: int) -> np.ndarray:
    return np.full((n, 6), FAILED)


def error_of_residuals(residuals: Iterable[np.ndarray], c: float = DEFAULT_C) -> "PoseError":
    """The paper's error over every row of the (n, 6) residuals (a rotation vector's norm is the angle)."""
    rows = [np.asarray(r, dtype=float) for r in residuals if len(r)]
    if not rows:
        raise BridgeError("no samples to compare: the error needs at least one observed pose")
    r = np.concatenate(rows)
    t2, R2 = np.sum(r[:, :3] ** 2, axis=1), np.sum(r[:, 3:] ** 2, axis=1)
    c = _check_weight(c)
    return PoseError(float(np.sqrt(t2.mean())), float(np.sqrt(R2.mean())), float(np.sqrt((t2 + c * R2).mean())),
                     int(len(r)))


def least_squares_vector(residuals: Sequence[np.ndarray], c: float = DEFAULT_C) -> np.ndarray:
    """The residuals as one vector whose squared norm is the paper's E^2: positions and sqrt(c) x rotations,
    divided by sqrt(samples)."""
    r = np.concatenate([np.asarray(x, dtype=float) for x in residuals]) if residuals else np.zeros((0, 6))
    if not len(r):
        return np.zeros(0)
    return np.column_stack([r[:, :3], math.sqrt(c) * r[:, 3:]]).ravel() / math.sqrt(len(r))


# --- a trial's observations against a replay ---------------------------------------------------------------
def compared_times(track: ObservedTrack) -> np.ndarray:
    """The observations a replay is scored on: every one after t = 0 (the pose at t = 0 is the given start)."""
    return np.asarray(track.times)[np.asarray(track.times) > 0]


def observed_residuals(observations: ObservedPoses, objects: Collection[str], telemetry_end: float,
                       result: ReplayResult | None) -> list[np.ndarray]:
    """Per observed object among `objects` (the free ones: fixtures cannot move in a simulation), the (n, 6)
    residuals at `compared_times`. Dense observations are compared at their times; a sparse one (before /
    after) taken at or after the telemetry's end with the objects at rest (the replay's last sample).
    `result` None (a failed replay): `FAILED` rows."""
    out = []
    for track in observations:
        if track.object not in objects:
            continue
        times = compared_times(track)
        if not len(times):
            continue
        if result is None:
            out.append(failed_residual(len(times)))
            continue
        index = np.searchsorted(track.times, times)
        poses = [track.poses[i] for i in index]
        query = np.clip(times, 0.0, result.times[-1])
        if not observations.is_dense:
            query = np.where(times >= telemetry_end, result.times[-1], query)
        sim_xyz, sim_R = sample_track(result.times, result.observed_track(track.object), query)
        out.append(pose_residual(np.array([p.xyz for p in poses]), np.array([p.rotation() for p in poses]),
                                 sim_xyz, sim_R))
    return out


# --- the paper's error ------------------------------------------------------------------------------------------

DEFAULT_C = 0.01
_ROTATION_TOLERANCE = 1e-6


@dataclass(frozen=True)
class PoseError:
    """Root-mean-square errors over `count` samples (object x run x observation time).

    e_t: RMS of the Euclidean position errors (m); e_R: RMS of the rotation angles (rad);
    e: RMS of the combined per-sample errors, the value an optimiser minimises.
    """

    e_t: float
    e_R: float
    e: float
    count: int

    @classmethod
    def merge(cls, parts: Iterable["PoseError"]) -> "PoseError":
        """The error over the union of the samples behind `parts` (a count-weighted RMS)."""
        parts = tuple(parts)
        total = sum(p.count for p in parts)
        if total == 0:
            raise BridgeError("cannot merge pose errors: no samples")

        def rms(values: list[tuple[float, int]]) -> float:
            return math.sqrt(sum(v * v * n for v, n in values) / total)

        return cls(
            e_t=rms([(p.e_t, p.count) for p in parts]),
            e_R=rms([(p.e_R, p.count) for p in parts]),
            e=rms([(p.e, p.count) for p in parts]),
            count=total,
        )


def pose_error(pairs: Iterable[tuple[Pose, Pose]], c: float = DEFAULT_C) -> PoseError:
    """The error over (observed, simulated) pose pairs, one pair per object, run and observation time."""
    observed: list[Pose] = []
    simulated: list[Pose] = []
    for index, pair in enumerate(pairs):
        try:
            obs, sim = pair
        except (TypeError, ValueError):
            raise BridgeError(f"pose pair {index}: expected (observed Pose, simulated Pose), got {pair!r}") from None
        if not isinstance(obs, Pose) or not isinstance(sim, Pose):
            raise BridgeError(f"pose pair {index}: expected two Pose values, got {type(obs).__name__} and "
                           f"{type(sim).__name__}")
        observed.append(obs)
        simulated.append(sim)
    if not observed:
        raise BridgeError("no pose pairs to compare: the error needs at least one observed pose")
    return pose_error_arrays(
        np.array([p.xyz for p in observed]),
        np.array([p.rotation() for p in observed]),
        np.array([p.xyz for p in simulated]),
        np.array([p.rotation() for p in simulated]),
        c,
    )


def pose_error_arrays(
    t_obs: np.ndarray, R_obs: np.ndarray, t_sim: np.ndarray, R_sim: np.ndarray, c: float = DEFAULT_C
) -> PoseError:
    """Vectorised `pose_error`: positions (N, 3) and rotation matrices (N, 3, 3), row i of each is one sample.

    Returns e_t = sqrt(mean e_t,i^2), e_R = sqrt(mean e_R,i^2), e = sqrt(mean (e_t,i^2 + c e_R,i^2)), count = N.
    """
    c = _check_weight(c)
    t_obs, t_sim = (_positions(a, name) for a, name in ((t_obs, "t_obs"), (t_sim, "t_sim")))
    R_obs, R_sim = (_rotations(a, name) for a, name in ((R_obs, "R_obs"), (R_sim, "R_sim")))
    n = t_obs.shape[0]
    for name, array in (("t_sim", t_sim), ("R_obs", R_obs), ("R_sim", R_sim)):
        if array.shape[0] != n:
            raise BridgeError(f"{name} has {array.shape[0]} samples but t_obs has {n}; pass one row per sample")
    if n == 0:
        raise BridgeError("no samples to compare: the error needs at least one observed pose")
    e_t_sq = np.sum((t_obs - t_sim) ** 2, axis=1)
    e_R_sq = rotation_angles(R_obs @ np.swapaxes(R_sim, 1, 2)) ** 2
    return PoseError(
        e_t=float(np.sqrt(np.mean(e_t_sq))),
        e_R=float(np.sqrt(np.mean(e_R_sq))),
        e=float(np.sqrt(np.mean(e_t_sq + c * e_R_sq))),
        count=int(n),
    )


def rotation_angles(R: np.ndarray) -> np.ndarray:
    """Angles (rad, 0..pi) of a stack of rotation matrices (..., 3, 3); `bridge.values.rotation_angle` per matrix.

    atan2(|axis part| / 2, (trace - 1) / 2) keeps full precision at both ends, unlike arccos of the trace.
    """
    R = np.asarray(R, dtype=float)
    axis = np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], axis=-1)
    return np.arctan2(0.5 * np.linalg.norm(axis, axis=-1), 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1.0))


# --- validation ---------------------------------------------------------------------------------------------
def _check_weight(c: float) -> float:
    try:
        value = float(c)
    except (TypeError, ValueError):
        raise BridgeError(f"weight c must be a number >= 0, got {c!r}") from None
    if not math.isfinite(value) or value < 0:
        raise BridgeError(f"weight c must be a finite number >= 0, got {c!r}")
    return value


def _positions(array: np.ndarray, name: str) -> np.ndarray:
    a = np.asarray(array, dtype=float)
    if a.ndim != 2 or a.shape[1] != 3:
        raise BridgeError(f"{name} must have shape (N, 3) (one position per row), got {a.shape}")
    if not np.all(np.isfinite(a)):
        row = int(np.nonzero(~np.all(np.isfinite(a), axis=1))[0][0])
        raise BridgeError(f"{name} row {row} is not finite: {a[row].tolist()}")
    return a


def _rotations(array: np.ndarray, name: str) -> np.ndarray:
    a = np.asarray(array, dtype=float)
    if a.ndim != 3 or a.shape[1:] != (3, 3):
        raise BridgeError(f"{name} must have shape (N, 3, 3) (one rotation matrix per sample), got {a.shape}")
    finite = np.all(np.isfinite(a), axis=(1, 2))
    if not np.all(finite):
        raise BridgeError(f"{name} sample {int(np.nonzero(~finite)[0][0])} is not finite")
    if len(a):
        off = np.abs(a @ np.swapaxes(a, 1, 2) - np.eye(3)).max(axis=(1, 2))
        bad = np.nonzero((off > _ROTATION_TOLERANCE) | (np.linalg.det(a) <= 0))[0]
        if len(bad):
            raise BridgeError(f"{name} sample {int(bad[0])} is not a rotation matrix (R R^T != I or det(R) <= 0)")
    return a
