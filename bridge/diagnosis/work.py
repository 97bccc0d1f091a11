"""What the work the robot did on a pushed object says, before any simulation: its sliding friction and the slope
of the surface under it.

While the rod pushes a sliding object, the power it puts in (F . v_c: the force on the object, the negated force
the robot's sensor reads, times the velocity of the object's point under the rod) goes into sliding friction on the
support, into lifting the object where it moves uphill, and into its kinetic energy:

    F . v_c = mu m g D - m g s . v + dK/dt,

D the mean sliding speed over the footprint (uniform pressure: each footprint point's speed under the object's
recorded twist), v the centre's velocity, s = sin(theta) times the downhill direction of a surface tilted by theta,
K the kinetic energy. Integrated over short windows of the pushes, the recordings give a linear least-squares
problem in (mu, s) from what was recorded alone (the force sensor, the rod's track, the object's track), whatever
the contact physics and the robot's servo. Friction is even in the direction of motion and the slope odd, so pushes
in several directions tell them apart.

What it neglects, and why it only seeds the `surface_tilt` search (a simulation and cross-validation judge it,
never this): the pressure is taken uniform (an off-centre mass or a few pads weigh the rotation's share of D
differently), the coefficient isotropic and the same everywhere (a patch or a field the pushes head for, or
anisotropic friction along one push direction, read partly as a slope), and a force-sensor bias along the pushes
reads as a slope too. Independent MuJoCo worlds (benchmarks/independent_pushes.py) read their 1 deg tilts as
1.1-1.3 deg with the downhill direction within 20 deg, their level worlds as 0.2-0.5 deg; the mismatched
proof's tilted Drake worlds (softer contact, a weak servo) 2-5 times too steep (downhill within 17 deg), worlds
with a patch or a miscalibrated rod 1.6-1.8 deg, the real MIT pushes 4-8 deg (docs/diagnosis.md section 3d): far
from a measurement. `coefficient` is mu at the object database's mass (a heavier object reads as a larger mu: the
force measures weight x coefficient); it reads within 0.025 of the truth in every simulated world whose pushes pin
the slope. Where they do not (pushes in about one direction: a slope along them and the coefficient trade off), mu
is read on a level surface, one unknown: the joint fit there put planar worlds of 0.36-0.49 at 0.05-0.10 with a
slope of 16-29 deg, and within 0.012 of the truth on a level surface (where the slope is pinned, the two agree
within 0.003 in the proof's worlds without a post).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, Sequence

import numpy as np
from scipy.signal import savgol_filter

from ..values import GRAVITY
from .loader import NOISE_SIGMAS
from .outline import rod_xy

RATE = 100.0  # Hz: the tracks are resampled here before differencing (the noise of 250 Hz poses would dominate D)
SMOOTHING = 0.07  # s: the Savitzky-Golay window of the velocities (a push's speed changes over tenths of a second)
WINDOW = 0.2  # s: the work is balanced over windows this long (short against a push, long against the smoothing)
MOVING_SHARE = 0.1  # share of a push's 90th-percentile speed above which the object counts as sliding
MIN_SLOPE = 0.0017  # rad: below this a slope is negligible (`params.kinds.SurfaceSlopeX.negligible`)
PINNED = 0.0175  # rad (1 deg): the largest 1 sigma of a slope component that still seeds a search; the tilts that
#                  matter are 0.5-2 deg, and pushes along one direction leave the other unpinned (sigma of radians)
OUTLIER = 4.0  # windows off the fit by more than this many robust deviations are left out of the refit
AGREES = 0.025  # a fitted sliding coefficient this close to the work's agrees with it: the work reads within 0.025
#                of the truth in every simulated world without a patch (module docstring)
HELD = 2.0  # a window whose mean force exceeds this many times the object's weight is left out: real material pairs
#            slide at coefficients up to about 2 (`odb.ranges.FRICTION`), so something else holds the object
#            there (a jam against an obstacle: independent MuJoCo pushes jammed at up to 1,100 N on a 4 N hexagon read
#            coefficients of 2.5-9 with those windows in)


@dataclass(frozen=True)
class WorkFit:
    """mu and the downhill slope s (sin(theta) x the downhill unit vector, world x-y) that balance the work the
    robot did on `object` over every window of every recording that has a force track; covariances from the
    leftover scatter, clustered by recording (`balance`)."""

    object: str
    coefficient: float
    coefficient_sd: float
    slope: tuple[float, float]
    slope_cov: tuple[tuple[float, float], tuple[float, float]]
    windows: int
    recordings: int
    level: bool = False  # the coefficient read on a level surface: the pushes do not pin the slope (`work_fit`)

    def slope_sigmas(self) -> float:
        s = np.array(self.slope)
        return float(math.sqrt(max(0.0, s @ np.linalg.pinv(np.array(self.slope_cov)) @ s)))

    @property
    def slope_sd(self) -> np.ndarray:
        return np.sqrt(np.diag(np.array(self.slope_cov)))

    @property
    def tilt(self) -> float:
        """rad: the slope's angle."""
        return math.asin(min(1.0, math.hypot(*self.slope)))

    @property
    def pinned(self) -> bool:
        """Both slope components known to PINNED: pushes in several directions, a balance that holds."""
        return bool(np.all(self.slope_sd <= PINNED))

    @property
    def seed(self) -> tuple[float, float] | None:
        """The slope to start a `surface_tilt` search from: pinned and not negligible (None otherwise)."""
        return self.slope if self.pinned and self.tilt > MIN_SLOPE else None

    @property
    def evident(self) -> bool:
        return self.pinned and self.slope_sigmas() > NOISE_SIGMAS and self.tilt > MIN_SLOPE

    def disagrees(self, fitted: float) -> bool:
        """A fitted sliding coefficient the work the robot did contradicts: more than AGREES and NOISE_SIGMAS
        sigma off (the fit soaked up something the force does not show, e.g. a tilt's drift taken as easier
        sliding)."""
        return abs(fitted - self.coefficient) > max(AGREES, NOISE_SIGMAS * self.coefficient_sd)

    def sentence(self) -> str:
        """The report's line: the coefficient always (a friction fit far from it soaks up something else), the
        slope when it is evident."""
        text = (f"the work the robot did on {self.object} ({self.windows} windows of {self.recordings} recordings) "
                f"balances with a sliding coefficient of {self.coefficient:.3f} +- {self.coefficient_sd:.3f} at the "
                "object database's mass (the force measures weight x coefficient)")
        if self.level:
            text += "; read on a level surface, as the pushes do not pin a slope"
        if not self.evident:
            return text
        sd = self.slope_sd
        return (f"{text} and the surface sloping {math.degrees(self.tilt):.1f} deg downhill towards "
                f"{math.degrees(math.atan2(self.slope[1], self.slope[0])):+.0f} deg (x +- {math.degrees(sd[0]):.1f}, "
                f"y +- {math.degrees(sd[1]):.1f} deg): a seed for `surface_tilt`, not a measurement (a friction that "
                "differs over the surface or with direction, or a force-sensor bias, reads as a slope too)")

    def to_json(self) -> dict[str, Any]:
        return {"object": self.object, "coefficient": _g(self.coefficient), "coefficient_sd": _g(self.coefficient_sd),
                "slope_rad": [_g(v) for v in self.slope], "slope_sd_rad": [_g(v) for v in self.slope_sd],
                "tilt_deg": _g(math.degrees(self.tilt)),
                "downhill_deg": _g(math.degrees(math.atan2(self.slope[1], self.slope[0]))),
                "slope_sigmas": _g(self.slope_sigmas()), "pinned": self.pinned, "evident": self.evident,
                "level_surface": self.level, "windows": self.windows, "recordings": self.recordings}


def _g(value: float) -> float:
    return float(f"{value:.4g}")


def windows_of(times: np.ndarray, xy: np.ndarray, yaw: np.ndarray, rod: np.ndarray, force: np.ndarray,
               footprint: tuple[np.ndarray, np.ndarray], mass: float) -> np.ndarray:
    """Rows (work - kinetic energy change, m g x integral of D, m g x displacement x, y) over the WINDOW-long
    windows of one push while its object slides and nothing but its support holds it (the force below HELD times
    its weight); the arrays are the object's track, the rod's centre and the force on the object (world x-y), all
    at `times`; `footprint` the uniform quadrature of its bottom (points in the body frame, weights:
    `sim.anisotropy.footprint_points`)."""
    if len(times) < 8 or times[-1] - times[0] < 2 * SMOOTHING:
        return np.zeros((0, 4))
    grid = np.arange(times[0], times[-1], 1.0 / RATE)
    at = lambda a: np.column_stack([np.interp(grid, times, a[:, k]) for k in range(a.shape[1])])  # noqa: E731
    xy, rod, force = at(xy), at(rod), at(force)
    yaw = np.interp(grid, times, np.unwrap(yaw))
    length = max(5, int(round(SMOOTHING * RATE)) | 1)
    v = savgol_filter(xy, length, 2, deriv=1, delta=1.0 / RATE, axis=0)
    w = savgol_filter(yaw, length, 2, deriv=1, delta=1.0 / RATE)
    arm = rod - xy
    power = np.sum(force * (v + w[:, None] * np.column_stack([-arm[:, 1], arm[:, 0]])), axis=1)
    points, weights = footprint
    c, s = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
    px = points[:, 0] * c - points[:, 1] * s
    py = points[:, 0] * s + points[:, 1] * c
    sliding = np.hypot(v[:, :1] - w[:, None] * py, v[:, 1:] + w[:, None] * px) @ weights
    spread = points - weights @ points
    inertia = mass * float(weights @ np.sum(spread ** 2, axis=1))
    kinetic = 0.5 * mass * np.sum(v ** 2, axis=1) + 0.5 * inertia * w ** 2
    speed = np.hypot(*v.T) + math.sqrt(inertia / mass) * np.abs(w)
    moving = np.nonzero(speed > MOVING_SHARE * np.percentile(speed, 90))[0] if np.any(speed > 0) else []
    if len(moving) < 3:
        return np.zeros((0, 4))
    rows = []
    edges = np.arange(grid[moving[0]], grid[moving[-1]] + 1e-9, WINDOW)
    for a, b in zip(edges[:-1], edges[1:]):
        k = np.nonzero((grid >= a) & (grid <= b))[0]
        if len(k) < 3 or np.mean(np.hypot(*force[k].T)) > HELD * mass * GRAVITY:
            continue
        t = grid[k]
        rows.append((np.trapezoid(power[k], t) - (kinetic[k[-1]] - kinetic[k[0]]),
                     mass * GRAVITY * np.trapezoid(sliding[k], t), *(mass * GRAVITY * (xy[k[-1]] - xy[k[0]]))))
    return np.array(rows).reshape(-1, 4)


def balance(rows: np.ndarray, groups: np.ndarray, slope: bool = True) -> tuple[np.ndarray, np.ndarray] | None:
    """(mu, s_x, s_y) and their covariance from the windows' rows (`windows_of`; `groups`: each row's recording):
    least squares of work = mu (m g D) - s . (m g displacement), refitted without the windows off by more than
    OUTLIER robust deviations (a post the object slid along, a jam); (mu,) alone on a level surface without
    `slope`. The covariance is clustered by recording (the sandwich estimator): a push's windows share its errors
    (where the rod met the object, how it turned), so the recordings, not the windows, are the independent samples.
    None when the rows cannot pin the unknowns."""
    if len(rows) < 6:
        return None
    A = np.column_stack([rows[:, 1], -rows[:, 2], -rows[:, 3]]) if slope else rows[:, 1:2]
    b = rows[:, 0]
    unknowns = A.shape[1]
    keep = np.ones(len(b), dtype=bool)
    for _ in range(3):
        if keep.sum() < 6 or np.linalg.matrix_rank(A[keep]) < unknowns:
            return None
        x, *_ = np.linalg.lstsq(A[keep], b[keep], rcond=None)
        left = b - A @ x
        scale = 1.4826 * float(np.median(np.abs(left[keep]))) or 1e-12
        kept = np.abs(left) <= OUTLIER * scale
        if np.array_equal(kept, keep):
            break
        keep = kept
    bread = np.linalg.inv(A[keep].T @ A[keep])
    labels = np.unique(groups[keep])
    meat = np.zeros((unknowns, unknowns))
    for g in labels:
        k = keep & (groups == g)
        score = A[k].T @ left[k]
        meat += np.outer(score, score)
    n_groups = len(labels)
    if n_groups <= unknowns:
        return None
    return x, bread @ meat @ bread * n_groups / (n_groups - 1)


def push_windows(trials: Sequence, odb, obj: str) -> list[tuple[int, np.ndarray]] | None:
    """Each pushing trial's `windows_of` rows for `obj` (its index in `trials`, the rows); None without a planar
    pusher's object with a prism outline. Trials without a force track, a rod or a sliding window are left out.
    A window's own coefficient is row[0] / row[1] (no slope), its mean sliding speed row[1] / (m g WINDOW)."""
    from ..rollout.trials import shape_outline
    from ..sim.anisotropy import footprint_points
    from ..sim.shapes import mass_properties

    if not trials or obj not in trials[0].world.objects:
        return None
    kind = trials[0].world.objects[obj].type
    outline = shape_outline(kind, odb)
    if outline is None:
        return None
    footprint = footprint_points(outline)
    mass = float(mass_properties(odb, kind).mass)
    out = []
    for index, trial in enumerate(trials):
        track = next((t for t in trial.observations.tracks if t.object == obj), None)
        if trial.force is None or track is None or len(track.times) < 8:
            continue
        times = np.asarray(track.times, dtype=float)
        rod = rod_xy(trial, obj, times)
        if rod is None:
            continue
        force = -np.column_stack([np.interp(times, trial.force.times, trial.force.force[:, k]) for k in (0, 1)])
        xy = np.array([p.xyz[:2] for p in track.poses])
        yaw = np.array([p.yaw() for p in track.poses])
        push = windows_of(times, xy, yaw, rod, force, footprint, mass)
        if len(push):
            out.append((index, push))
    return out


def work_fit(trials: Sequence, odb, obj: str) -> WorkFit | None:
    """The `WorkFit` of `obj` over `trials` (`rollout.trials.Trial`); None without a planar pusher, a force track,
    a prism outline or windows enough (four recordings or more that pushed it: three unknowns, clustered). Where
    the slope is not pinned, the coefficient is the level surface's (module docstring)."""
    pushes = push_windows(trials, odb, obj)
    if pushes is None or len(pushes) < 4:
        return None
    rows = np.concatenate([r for _, r in pushes])
    groups = np.concatenate([np.full(len(r), g) for g, (_, r) in enumerate(pushes)])
    solved = balance(rows, groups)
    if solved is None:
        return None
    x, cov = solved
    fit = WorkFit(obj, float(x[0]), float(math.sqrt(max(cov[0, 0], 0.0))), (float(x[1]), float(x[2])),
                  ((float(cov[1, 1]), float(cov[1, 2])), (float(cov[2, 1]), float(cov[2, 2]))), len(rows), len(pushes))
    level = None if fit.pinned else balance(rows, groups, slope=False)
    if level is None:
        return fit
    return replace(fit, coefficient=float(level[0][0]), coefficient_sd=float(math.sqrt(max(level[1][0, 0], 0.0))),
                   level=True)
