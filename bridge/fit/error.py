"""The paper's pose error (Section V, eq. 1-4): how far simulated object poses are from observed ones.

Per object i and run k (a recording, or one of K repeated simulations of it) and observation time:

    e_t = ||t - t_hat||                                   (1)  translational, metres
    e_R = ||log(R R_hat^T)||_F / sqrt(2)                 (2)  geodesic, radians (the rotation angle, 0..pi)
    e   = sqrt(e_t^2 + c e_R^2)                           (3)  combined, c = 0.01 by default
    E   = sqrt(mean over all samples of e^2)             (4)  root mean square over objects, runs and times

Every field of `PoseError` is a root mean square over the same samples (as in the paper's Table I), so the
aggregates keep eq. (3): ``E**2 == e_t**2 + c * e_R**2`` holds for the reported values too.
The angle comes from an atan2 formula that stays accurate near 0 and near pi, where arccos of the trace and
quaternion dot products lose precision.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable

import numpy as np

from ..errors import FitError
from ..values import Pose

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
            raise FitError("cannot merge pose errors: no samples")

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
            raise FitError(f"pose pair {index}: expected (observed Pose, simulated Pose), got {pair!r}") from None
        if not isinstance(obs, Pose) or not isinstance(sim, Pose):
            raise FitError(f"pose pair {index}: expected two Pose values, got {type(obs).__name__} and "
                           f"{type(sim).__name__}")
        observed.append(obs)
        simulated.append(sim)
    if not observed:
        raise FitError("no pose pairs to compare: the error needs at least one observed pose")
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
            raise FitError(f"{name} has {array.shape[0]} samples but t_obs has {n}; pass one row per sample")
    if n == 0:
        raise FitError("no samples to compare: the error needs at least one observed pose")
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
        raise FitError(f"weight c must be a number >= 0, got {c!r}") from None
    if not math.isfinite(value) or value < 0:
        raise FitError(f"weight c must be a finite number >= 0, got {c!r}")
    return value


def _positions(array: np.ndarray, name: str) -> np.ndarray:
    a = np.asarray(array, dtype=float)
    if a.ndim != 2 or a.shape[1] != 3:
        raise FitError(f"{name} must have shape (N, 3) (one position per row), got {a.shape}")
    if not np.all(np.isfinite(a)):
        row = int(np.nonzero(~np.all(np.isfinite(a), axis=1))[0][0])
        raise FitError(f"{name} row {row} is not finite: {a[row].tolist()}")
    return a


def _rotations(array: np.ndarray, name: str) -> np.ndarray:
    a = np.asarray(array, dtype=float)
    if a.ndim != 3 or a.shape[1:] != (3, 3):
        raise FitError(f"{name} must have shape (N, 3, 3) (one rotation matrix per sample), got {a.shape}")
    finite = np.all(np.isfinite(a), axis=(1, 2))
    if not np.all(finite):
        raise FitError(f"{name} sample {int(np.nonzero(~finite)[0][0])} is not finite")
    if len(a):
        off = np.abs(a @ np.swapaxes(a, 1, 2) - np.eye(3)).max(axis=(1, 2))
        bad = np.nonzero((off > _ROTATION_TOLERANCE) | (np.linalg.det(a) <= 0))[0]
        if len(bad):
            raise FitError(f"{name} sample {int(bad[0])} is not a rotation matrix (R R^T != I or det(R) <= 0)")
    return a
