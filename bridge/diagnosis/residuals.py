"""Observed tracks as arrays with their measurement noise estimated from the data: what the diagnosis divides
residuals by (`bridge.rollout.compare` computes them).

Residual components (world frame): position dx, dy, dz (m) and rotation rx, ry, rz (rad, the rotation vector of
R_obs R_sim^T: rz is the yaw difference, rx and ry the tilt). A component the observations do not really measure
(constant to the last digit, e.g. z and tilt of a planar motion-capture track) is left out of every score.

Noise: the standard deviation of white measurement noise shows in the second differences of a densely sampled
track, where smooth motion contributes almost nothing: sigma = 1.4826 MAD(d2) / sqrt(6). It is estimated per
component from the full-rate track, so it is a property of the data, not an assumption.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import DiagnosisError
from ..recording.observations import ObservedTrack

COMPONENTS = ("dx", "dy", "dz", "rx", "ry", "rz")
MIN_SIGMA = (2e-6, 2e-6, 2e-6, 2e-5, 2e-5, 2e-5)  # numerical floor (m, rad): far below any real sensor
SPARSE_SIGMA = (1e-3, 1e-3, 1e-3, 0.01, 0.01, 0.01)  # used only when a track is too short to estimate noise


@dataclass(frozen=True, eq=False)
class ObservedSeries:
    """One object's observed poses at the residual times, with the noise estimated from its full track."""

    object: str
    times: np.ndarray  # (n,)
    xyz: np.ndarray  # (n, 3)
    R: np.ndarray  # (n, 3, 3)
    sigma: np.ndarray  # (6,) noise per component
    measured: np.ndarray  # (6,) bool: the component carries information
    estimated: bool  # False when the track was too short and SPARSE_SIGMA stands in
    fork: np.ndarray | None = None  # (n, 6): how far the model's own prediction forks at each sample
    #                                 (`diagnosis.forks`), added to the noise in quadrature

    @property
    def weights(self) -> np.ndarray:
        """1 / sigma for measured components, 0 for the others."""
        return np.where(self.measured, 1.0 / self.sigma, 0.0)

    @property
    def tolerance(self) -> np.ndarray:
        """(n, 6) per sample: the noise and the model's fork added in quadrature."""
        noise = np.broadcast_to(self.sigma, (len(self.times), 6))
        return noise if self.fork is None else np.sqrt(noise ** 2 + self.fork ** 2)


def rotvecs_relative(R: np.ndarray) -> np.ndarray:
    """World-frame rotation vectors of each R relative to the first (n, 3)."""
    return Rotation.from_matrix(R @ R[0].T).as_rotvec()


def estimate_noise(times: np.ndarray, xyz: np.ndarray, R: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
    """(sigma (6,), measured (6,), estimated) from a full-rate track."""
    series = np.column_stack([xyz, rotvecs_relative(R)]) if len(times) else np.zeros((0, 6))
    measured = np.array([len(series) > 1 and float(np.ptp(series[:, k])) > 1e-12 for k in range(6)])
    if len(times) < 8:
        return np.array(SPARSE_SIGMA), measured, False
    d2 = series[2:] - 2 * series[1:-1] + series[:-2]
    mad = np.median(np.abs(d2 - np.median(d2, axis=0)), axis=0)
    sigma = np.maximum(1.4826 * mad / math.sqrt(6.0), MIN_SIGMA)
    return sigma, measured, True


def observed_series(track: ObservedTrack, rate: float) -> ObservedSeries:
    """The track thinned to at most `rate` Hz (first and last pose kept), noise from the full track."""
    if rate <= 0:
        raise DiagnosisError(f"residual rate must be > 0 Hz, got {rate!r}")
    times = np.asarray(track.times, dtype=float)
    xyz = np.array([p.xyz for p in track.poses])
    R = np.array([p.rotation() for p in track.poses])
    sigma, measured, estimated = estimate_noise(times, xyz, R)
    keep, last = [], -math.inf
    for i, t in enumerate(times):
        if t - last >= 1.0 / rate - 1e-9 or i == len(times) - 1:
            keep.append(i)
            last = t
    keep = np.array(keep)
    return ObservedSeries(track.object, times[keep], xyz[keep], R[keep], sigma, measured, estimated)


def normalised(obs: ObservedSeries, res: np.ndarray) -> np.ndarray:
    """Residual divided by the noise (and the model's fork where it has one), measured components only,
    flattened: what scores and fits use."""
    return (res[:, obs.measured] / obs.tolerance[:, obs.measured]).ravel()


# --- the robot's force sensor -------------------------------------------------------------------------------------
FORCE_COMPONENTS = ("fx", "fy", "fz")
MIN_FORCE_SIGMA = 1e-3  # N: numerical floor
SPARSE_FORCE_SIGMA = 0.5  # N, only when a force track is too short to estimate its noise
FORCE_MODEL_ERROR = 0.03  # share of the observed force a simulated contact force is trusted to (assumed)
MOVING_SHARE = 0.02  # a joint moves when its speed (over MOVING_WINDOW) exceeds this share of its peak speed
MOVING_WINDOW = 0.1  # s over which a joint's speed is measured: encoder noise does not read as motion


@dataclass(frozen=True, eq=False)
class ForceSeries:
    """The observed force on the robot at the residual times, with its noise estimated from the full track."""

    times: np.ndarray  # (n,)
    force: np.ndarray  # (n, 3) N
    sigma: np.ndarray  # (3,) N: the sensor's noise, from the data
    measured: np.ndarray  # (3,) bool
    fork: np.ndarray | None = None  # (n, 3) N: the model's own fork at each sample (`diagnosis.forks`)

    @property
    def tolerance(self) -> np.ndarray:
        """(n, 3) N per sample: the noise, FORCE_MODEL_ERROR of the force's size and the model's fork, added in
        quadrature. A simulated contact force is not exact (stiff contacts, jams against an obstacle reach tens
        of newtons and are sensitive to everything); without this share a force residual would drown the poses."""
        size = np.linalg.norm(self.force, axis=1, keepdims=True)
        fork = 0.0 if self.fork is None else self.fork ** 2
        return np.sqrt(self.sigma[None, :] ** 2 + (FORCE_MODEL_ERROR * size) ** 2 + fork)


def force_series(observed, rate: float, span: tuple[float, float] | None = None) -> ForceSeries:
    """`observed` (a `bridge.recording.forces.ObservedForce`) on a grid of `rate` Hz, each value the mean over
    the 1/rate s window around it (`window_mean`, the same operation the simulated force gets, so impacts and
    steps compare like with like); the noise from second differences of the full-rate track (not reduced for
    the averaging: a conservative floor). With `span` (s, `motion_span`), only the grid times within it: while
    the robot stands still, before its motion and after it, the force it feels is what its servo's and the
    contact's compliance hold against static friction (a pre-load, the push's last force held after the stop),
    which depends on a servo stiffness no model here knows; while it moves, the force is what sliding
    friction and inertia ask for. (Measured: the real MIT pushes hold 0.1-5.6 N after the rod stops, Drake's
    replays 0-2.5 N, an independent MuJoCo world whose contacts creep 0.1 N; kept, that held force pulled
    a friction fit to 0.23 where the sliding force said 0.55.)"""
    times = np.asarray(observed.times, dtype=float)
    force = np.asarray(observed.force, dtype=float)
    grid = np.arange(times[0], times[-1] + 1e-9, 1.0 / rate)
    if span is not None:
        grid = grid[(grid >= span[0] - 1e-9) & (grid <= span[1] + 1e-9)]
    if len(times) >= 8:
        d2 = force[2:] - 2 * force[1:-1] + force[:-2]
        mad = np.median(np.abs(d2 - np.median(d2, axis=0)), axis=0)
        sigma = 1.4826 * mad / math.sqrt(6.0)
    else:
        sigma = np.full(3, SPARSE_FORCE_SIGMA)
    return ForceSeries(grid, window_mean(times, force, grid), np.maximum(sigma, MIN_FORCE_SIGMA),
                       np.asarray(observed.measured, dtype=bool))


def motion_span(times: np.ndarray, positions: np.ndarray) -> tuple[float, float] | None:
    """(first, last) time a joint of the telemetry moves: its displacement over MOVING_WINDOW faster than
    MOVING_SHARE of its own peak speed; None when nothing moves."""
    times = np.asarray(times, dtype=float)
    if len(times) < 2:
        return None
    speed = np.abs(window_rate(times, positions, MOVING_WINDOW))
    peak = speed.max(axis=0)
    moving = np.nonzero(np.any((speed > MOVING_SHARE * peak) & (peak > 0), axis=1))[0]
    return (float(times[moving[0]]), float(times[moving[-1]])) if len(moving) else None


def window_rate(times: np.ndarray, values: np.ndarray, window: float) -> np.ndarray:
    """(n, k): each column's change over `window` centred on each time, per second (the signal held beyond its
    ends): a rate that noise of a sample or two does not set."""
    times = np.asarray(times, dtype=float)
    half = window / 2
    columns = np.asarray(values, dtype=float).reshape(len(times), -1).T
    return np.stack([np.interp(times + half, times, q) - np.interp(times - half, times, q) for q in columns],
                    axis=1) / window


def window_mean(times: np.ndarray, values: np.ndarray, grid: np.ndarray, points: int = 9) -> np.ndarray:
    """(len(grid), k): the mean of the linearly interpolated signal over the window of one grid step around each
    grid time (`points` samples per window; the signal is held beyond its ends)."""
    step = grid[1] - grid[0] if len(grid) > 1 else 0.0
    t = grid[:, None] + np.linspace(-step / 2, step / 2, points)[None, :]
    return np.stack([np.interp(t, times, values[:, k]).mean(axis=1) for k in range(values.shape[1])], axis=1)


def force_residual(obs: ForceSeries, sim_times: np.ndarray, sim_force: np.ndarray) -> np.ndarray:
    """(n, 3) observed minus simulated force (N), both averaged over the same windows."""
    return obs.force - window_mean(sim_times, sim_force, obs.times)


def force_normalised(obs: ForceSeries, res: np.ndarray) -> np.ndarray:
    return (res[:, obs.measured] / obs.tolerance[:, obs.measured]).ravel()
