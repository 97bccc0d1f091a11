"""What the direction of the robot's force says, before any simulation: the friction between the rod and the object.

While the rod slides along the object's outline, the force it puts on the object lies on the edge of the friction
cone: its component along the outline is mu_c times its component into it, and points the way the rod slides over
the object. While the contact sticks, the force lies anywhere inside the cone. So over the samples where the rod is
on the outline, presses into it and slides along it (relative to the object, faster than SLIP_SHARE of the push's
speed, the force's tangential part in the slip's direction), |f_t| / f_n is mu_c: the pair coefficient of rod and
object as Drake combines it (`robot_friction` x the model's pair), whatever the surface, the mass, the pressure
distribution or the robot's servo (a pose fit of the rod's friction instead wanders from fold to fold on real
pushes, soaking up what the model lacks elsewhere).

The normal is the model outline's at the nearest point, so an outline or a frame turned by delta against the
real object tilts every force angle by delta: theta = atan2(f_t, f_n) = sigma atan(mu_c) + delta for a slip of
sign sigma. Pushes that slide both ways tell the two apart (least squares over each recording's median angle per
slip direction), and delta is then itself evidence of a turned frame; pushes that slide one way only give
atan(mu_c) + delta, said so (`turn` is None). On the real MIT pushes (the shapes' quarter-turn frames): ellip1
0.225, ellip3 0.21, hex 0.22 with delta 0.5-1.3 deg; one steel rod on steel shapes, one coefficient, where the
model has 0.25 (docs/real_push.md). Neglected besides: the rod's and the sensor's inertia (tenths of a newton at
the pushes' accelerations) and a force-sensor bias. A sample counts only with the force well above the sensor's
noise (`mitpush.touching`) and the rod within GAP_TOLERANCE of its median distance to the outline while pushing;
under a rod that sticks, the tracks' noise makes "slips" of either sign: a slip counts only beyond NOISE_SIGMAS
times its noise (estimated from the track's scatter about its smoothed path) and where it keeps its direction for
MIN_RUN, and a recording's slips one way only where the force leans that way in most of them (LEANS).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np
from scipy.signal import savgol_coeffs, savgol_filter

from ..recording.mitpush import closest_on_outline, touching
from .loader import NOISE_SIGMAS
from .outline import object_outline, recorded_push, replayed_push

RATE = 100.0  # Hz: the tracks, the rod and the force are resampled here before differencing (`work.RATE`)
SMOOTHING = 0.07  # s: the Savitzky-Golay window of the rod's velocity over the object (`work.SMOOTHING`)
SLIP_SHARE = 0.2  # the rod slides over the object faster than this share of the push's (90th percentile) speed
GAP_TOLERANCE = 0.0015  # m: the rod's distance to the outline within this of its median while pushing (on it)
MIN_SAMPLES = 10  # sliding samples a recording needs to count (0.1 s at RATE)
MIN_RUN = 0.15  # s: a slip counts where it keeps its direction this long (the tracks' noise under a sticking rod
#                 flips it within the velocity's smoothing window)
MIN_RECORDINGS = 2  # recordings that slid, fewer and nothing is measured
LEANS = 0.8  # share of a (recording, slip direction)'s samples whose force leans the slip's way: below it the
#             "slip" is the tracks' noise under a sticking rod (MuJoCo's worlds, pose noise 0.2 mm: 0.5), not sliding
#             (the real MIT pushes that slide: 0.9-1.0)
DISAGREES = 0.2  # a model's rod factor this share off the force's (and NOISE_SIGMAS sigma) contradicts it


@dataclass(frozen=True)
class ContactFriction:
    """The rod-object pair's coefficient, and the turn of the model's outline against the force (rad, None when the
    pushes slid one way only), that the force's direction reads while the contact slides (module docstring); their
    1-sigma from the scatter of the (recording, slip direction) medians, the independent measurements."""

    object: str
    coefficient: float
    coefficient_sd: float
    turn: float | None
    turn_sd: float | None
    groups: int
    recordings: int
    samples: int

    def sentence(self) -> str:
        turn = ("the outline's normals agree with the force's (pushes slid both ways; turned "
                f"{math.degrees(self.turn):+.1f} +- {math.degrees(self.turn_sd):.1f} deg)" if self.turn is not None else
                "the pushes slid one way only: an outline turned against the real object reads as friction here")
        return (f"while the rod slid along {self.object} ({self.samples} samples of {self.recordings} recordings) "
                f"the force on it leaned {self.coefficient:.3f} +- {self.coefficient_sd:.3f} of its push into the "
                f"outline along it: the rod-object friction coefficient, read from the force's direction; {turn}")

    def to_json(self) -> dict[str, Any]:
        return {"object": self.object, "coefficient": _g(self.coefficient), "coefficient_sd": _g(self.coefficient_sd),
                "turn_rad": None if self.turn is None else _g(self.turn),
                "turn_sd_rad": None if self.turn_sd is None else _g(self.turn_sd),
                "groups": self.groups, "recordings": self.recordings, "samples": self.samples,
                "sentence": self.sentence()}


def _g(value: float) -> float:
    return float(f"{value:.4g}")


def sliding_angles(times: np.ndarray, xy: np.ndarray, yaw: np.ndarray, rod: np.ndarray, force: np.ndarray,
                   outline: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The force's angle to the outline's inward normal (rad, positive along the outline's tangent) and the slip's
    sign at the samples of one push where the rod slides along the outline (module docstring): the object's track
    (world x-y, yaw), the rod's centre and the force on the object (world x-y), all at the evenly spaced `times`."""
    none = np.zeros(0), np.zeros(0)
    if len(times) < 8 or times[-1] - times[0] < 2 * SMOOTHING:
        return none
    dt = float(times[1] - times[0])
    c, s = np.cos(yaw), np.sin(yaw)
    to_body = lambda v: np.column_stack([c * v[:, 0] + s * v[:, 1], -s * v[:, 0] + c * v[:, 1]])  # noqa: E731
    local = to_body(rod - xy)
    f = to_body(force)
    distance, _, normal = closest_on_outline(local, np.asarray(outline, dtype=float))
    tangent = np.column_stack([-normal[:, 1], normal[:, 0]])
    length = max(5, int(round(SMOOTHING / dt)) | 1)
    slip = np.sum(savgol_filter(local, length, 2, deriv=1, delta=dt, axis=0) * tangent, axis=1)
    speed = np.hypot(*savgol_filter(rod, length, 2, deriv=1, delta=dt, axis=0).T)
    # the slip's noise: the rod's position on the object scatters by sigma about its smoothed path (white noise
    # leaves sigma^2 (1 - c0) there, c0 the smoother's own weight), and the derivative filter passes |d| sigma of it
    left = local - savgol_filter(local, length, 2, axis=0)
    c0 = savgol_coeffs(length, 2)[length // 2]
    sigma = 1.4826 * float(np.median(np.abs(left - np.median(left, axis=0)))) / math.sqrt(1.0 - c0)
    slip_noise = sigma * float(np.linalg.norm(savgol_coeffs(length, 2, deriv=1, delta=dt)))
    f_n, f_t = -np.sum(f * normal, axis=1), np.sum(f * tangent, axis=1)
    pressing = touching(np.hypot(*f.T)) & (f_n > 0)
    if pressing.sum() < MIN_SAMPLES:
        return none
    on = np.abs(distance - np.median(distance[pressing])) < GAP_TOLERANCE
    sliding = pressing & on & (np.abs(slip) > max(SLIP_SHARE * np.percentile(speed, 90), NOISE_SIGMAS * slip_noise))
    direction = np.where(sliding, np.sign(slip), 0.0)
    sliding &= _runs(direction) >= MIN_RUN * RATE * dt  # one way for MIN_RUN seconds at least: not the tracks' noise
    return np.arctan2(f_t[sliding], f_n[sliding]), np.sign(slip[sliding])


def _runs(values: np.ndarray) -> np.ndarray:
    """Each sample's run length: how many neighbours in a row hold its value."""
    edges = np.flatnonzero(np.diff(values) != 0) + 1
    starts, ends = np.r_[0, edges], np.r_[edges, len(values)]
    return np.repeat(ends - starts, ends - starts)


def push_groups(times: np.ndarray, xy: np.ndarray, yaw: np.ndarray, rod: np.ndarray, force: np.ndarray,
                outline: np.ndarray) -> list[tuple[float, float, int]]:
    """(slip sign, median force angle, samples) per slip direction of one push (arrays as `sliding_angles` takes
    them, at any times: resampled to RATE here) in which the rod slid that way (MIN_SAMPLES, LEANS)."""
    times = np.asarray(times, dtype=float)
    if len(times) < 8:
        return []
    grid = np.arange(times[0], times[-1], 1.0 / RATE)
    at = lambda a: np.column_stack([np.interp(grid, times, a[:, k]) for k in range(a.shape[1])])  # noqa: E731
    angle, sign = sliding_angles(grid, at(np.asarray(xy)), np.interp(grid, times, np.unwrap(yaw)), at(np.asarray(rod)),
                                 at(np.asarray(force)), outline)
    return [(s, float(np.median(angle[sign == s])), int(np.sum(sign == s))) for s in (1.0, -1.0)
            if np.sum(sign == s) >= MIN_SAMPLES and np.mean(np.sign(angle[sign == s]) == s) >= LEANS]


def contact_friction(trials: Sequence, odb, obj: str) -> ContactFriction | None:
    """The `ContactFriction` of the rod and `obj` over `trials` (`rollout.trials.Trial`) as recorded; None without
    a planar pusher, a force track, a prism outline or MIN_RECORDINGS recordings in which the rod slid along it."""
    outline = object_outline(trials, odb, obj)
    if outline is None:
        return None
    pushes = [push_groups(p.times, p.xy, p.yaw, p.rod, p.force, outline)
              for p in (recorded_push(trial, obj, RATE) for trial in trials) if p is not None]
    return _solve(obj, pushes)


def simulated_contact_friction(trials: Sequence, results: Sequence, odb, obj: str) -> ContactFriction | None:
    """The same reading on replays of `trials` (`sim.simulate.ReplayResult`s run with `robot_force` and
    `joint_track`; None entries are skipped): the simulated rod, object and force. Read under the model's own
    coefficient, it gives the ratio the model's contact turns a pair coefficient into (a rod pressed into a
    compliant side meets it over an arc, and the arc's normals partly cancel where the friction adds: Drake's
    replays read 9-36 % above their pair, more at small coefficients), so the recordings' reading against the
    replays' is the factor on the model's pair (`robot_friction`) they ask for (`calibrated_factor`), whatever the
    reading's own biases."""
    outline = object_outline(trials, odb, obj)
    if outline is None:
        return None
    pushes = [push_groups(p.times, p.xy, p.yaw, p.rod, p.force, outline)
              for p in (replayed_push(t, r, obj, RATE) for t, r in zip(trials, results)) if p is not None]
    return _solve(obj, pushes)


def _solve(obj: str, pushes: list[list[tuple[float, float, int]]]) -> ContactFriction | None:
    """theta = sigma phi + delta over the pushes' groups (least squares) when both slip directions are there; phi
    alone (the median of sigma theta) when one is; None with fewer than MIN_RECORDINGS pushes that slid."""
    recordings = sum(bool(p) for p in pushes)
    if recordings < MIN_RECORDINGS:
        return None
    groups = [g for p in pushes for g in p]
    sign = np.array([g[0] for g in groups])
    theta = np.array([g[1] for g in groups])
    samples = int(sum(g[2] for g in groups))
    both = bool(np.any(sign > 0) and np.any(sign < 0))
    if both and len(groups) >= 3:
        A = np.column_stack([sign, np.ones(len(groups))])
        x, *_ = np.linalg.lstsq(A, theta, rcond=None)
        left = theta - A @ x
        var = float(left @ left) / max(1, len(groups) - 2)
        cov = var * np.linalg.inv(A.T @ A)
        phi, phi_sd = float(x[0]), math.sqrt(cov[0, 0])
        turn, turn_sd = float(x[1]), math.sqrt(cov[1, 1])
    else:
        along = sign * theta
        phi = float(np.median(along))
        phi_sd = 1.4826 * float(np.median(np.abs(along - phi))) / math.sqrt(len(along))
        turn = turn_sd = None
    mu = math.tan(phi)
    return ContactFriction(obj, mu, phi_sd * (1 + mu * mu), turn, turn_sd, len(groups), recordings, samples)


def calibrated_factor(recorded: ContactFriction, replayed: Sequence[tuple[float, ContactFriction]]) -> float:
    """The factor on the model's rod pair (`robot_friction`) whose replays would read what the recordings read:
    from replays at one factor f, f x recorded / replayed (the reading taken as proportional to the pair); from
    two or more, the line through the last two (the reading is affine in the pair: the arc of a rod pressed into
    a compliant side adds to it, most at small coefficients)."""
    if not replayed:
        raise ValueError("calibrated_factor needs at least one replayed reading")
    (f0, r0), (f1, r1) = (replayed[-2] if len(replayed) > 1 else (0.0, None)), replayed[-1]
    if r0 is None or abs(r1.coefficient - r0.coefficient) < 1e-9:
        return f1 * recorded.coefficient / r1.coefficient
    return f1 + (recorded.coefficient - r1.coefficient) * (f1 - f0) / (r1.coefficient - r0.coefficient)


@dataclass(frozen=True)
class RodReading:
    """The reading on the recordings and on replays of them at a known rod factor (`replayed_factor`, on the
    model's pair: `robot_friction`), what that says of the rod pair (the factor whose replays would read what the
    recordings read, and its 1-sigma: both readings' sigmas, relative, in quadrature) and the factor a fit gave."""

    recorded: ContactFriction
    replayed: ContactFriction
    replayed_factor: float
    factor: float
    factor_sd: float
    fitted: float

    @property
    def contradicts(self) -> bool:
        """The fitted rod factor is more than NOISE_SIGMAS sigma and DISAGREES of it off the reading's."""
        return abs(self.fitted - self.factor) > max(NOISE_SIGMAS * self.factor_sd, DISAGREES * self.factor)

    def sentence(self) -> str:
        verdict = (": the friction fit's rod pair contradicts the force, it bends to what the model lacks elsewhere"
                   if self.contradicts else ": the friction fit's rod pair agrees with the force")
        return (f"{self.recorded.sentence()}; the friction model's replays at {self.replayed_factor:g} x the model's "
                f"rod pair lean {self.replayed.coefficient:.3f}, so the force asks for {self.factor:.2f} +- "
                f"{self.factor_sd:.2f} x it where the fit has {self.fitted:.2f}{verdict}")

    def to_json(self) -> dict[str, Any]:
        return {"recorded": self.recorded.to_json(), "replayed": self.replayed.to_json(),
                "replayed_factor": _g(self.replayed_factor), "factor": _g(self.factor),
                "factor_sd": _g(self.factor_sd), "fitted": _g(self.fitted), "contradicts": self.contradicts,
                "sentence": self.sentence()}


def rod_reading(trials: Sequence, results: Sequence, odb, obj: str, replayed_factor: float,
                fitted: float) -> RodReading | None:
    """The `RodReading` of `obj` over `trials` and their replays (`simulated_contact_friction`) at the rod factor
    `replayed_factor`, against a `fitted` one; None where either side cannot be read."""
    recorded = contact_friction(trials, odb, obj)
    replayed = simulated_contact_friction(trials, results, odb, obj) if recorded is not None else None
    if replayed is None:
        return None
    factor = calibrated_factor(recorded, [(replayed_factor, replayed)])
    sd = abs(factor) * math.hypot(recorded.coefficient_sd / recorded.coefficient,
                                  replayed.coefficient_sd / replayed.coefficient)
    return RodReading(recorded, replayed, replayed_factor, factor, sd, fitted)
