"""Where the rod touched the object's outline while it pushed: the recorded frame on the object, read from the
recordings before any simulation.

While a rod pushes an object, its centre lies one rod radius outside the outline. Expressed in the body frame the
model's outline is drawn in, the recorded rod is Rot(-yaw_B) (tip - xy_R) + r, with the recorded pose (xy_R,
yaw_R), the body's yaw yaw_B = yaw_R - d and the recorded frame X_BR = (r, d) (`params.kinds.ObjectFrame`). So
the frame is what brings every pushing sample of every recording onto the outline at one common distance s (the
rod's radius plus any error of the outline's size): a robust least-squares fit of (r_x, r_y, d, s) over the
samples where the object moves, as the loader's contact gaps do for a rod offset (`loader.ContactFit`). It needs
a planar pusher (the rod's centre is its joints' x and y) and a prism outline; it sees what the simulation does
not decide, so it holds whatever the physics model gets wrong, and seeds the `object_frame` fit.

A rod calibration offset D (world frame) moves the rod in the body frame by Rot(-yaw_B) D: recordings in which
the object has one yaw cannot tell it from a frame offset, so the estimate is a seed and a signature, never a
verdict; the fits and cross-validation decide.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Sequence

import numpy as np
from scipy.optimize import least_squares

from ..recording.adjustments import StartClearance
from ..recording.mitpush import moving_samples, signed_distance, touching
from .effects.object_frame import SEED_TURN
from .loader import NOISE_SIGMAS

PLANAR_JOINTS = ("pusher_x", "pusher_y")
SCALE = 0.001  # m: the robust loss's scale (soft L1): a sample a millimetre off the outline counts fully
MIN_SAMPLES = 30  # pushing samples over all recordings, fewer and nothing is estimated
YAW_BOUND = 0.35  # rad: the fit's range of d, the `frame_yaw` search's (`params.kinds.FrameYaw.bounds`)


@dataclass(frozen=True)
class FrameFit:
    """The frame (r_x, r_y in m, d in rad) and the common gap s (m) that put the pushing samples on the outline,
    their 1-sigma (from the robust fit's curvature and its leftover scatter), the gap's RMS before (null frame)
    and after, over `count` samples of `recordings` recordings."""

    x: float
    y: float
    yaw: float
    gap: float
    std: tuple[float, float, float]
    rms_before: float
    rms_after: float
    count: int
    recordings: int
    at_bound: bool = False  # a bound of the fit stopped it: the samples do not pin the frame (one face pushed)
    object: str = ""
    # the pushing samples (rod relative to the recorded object (n, 2), recorded yaw (n,)) and the outline, to
    # measure how far any frame puts the rod off the outline (`rms_at`)
    samples: tuple[np.ndarray, np.ndarray, np.ndarray] | None = field(default=None, repr=False)

    def rms_at(self, x: float, y: float, yaw: float) -> float:
        """The gap's RMS (m; each sample's gap to the median gap, clipped at 1 cm as `rms_before`) with the recorded
        frame at (x, y, yaw): how far off the outline that frame puts the rod while it pushed."""
        if self.samples is None:
            return math.nan
        rel, heading, outline = self.samples
        gaps = _gaps(rel, heading, outline, np.array([x, y, yaw, 0.0]))
        return float(np.sqrt(np.mean(np.minimum(np.abs(gaps - np.median(gaps)), 0.01) ** 2)))

    def sigmas(self) -> float:
        """How far the frame lies from the null, in standard deviations (each component's, the largest)."""
        return max(abs(v) / s if s > 0 else 0.0 for v, s in zip((self.x, self.y, self.yaw), self.std))

    @property
    def evident(self) -> bool:
        """Beyond NOISE_SIGMAS from the null and beyond a negligible frame (1 mm or 1 deg), with the gap's RMS
        falling by a third: a frame the samples agree on, not one the fit picked from noise."""
        size = math.hypot(self.x, self.y) > 0.001 or abs(self.yaw) > math.radians(1.0)
        return (self.sigmas() > NOISE_SIGMAS and size and self.rms_after < 2 / 3 * self.rms_before
                and not self.at_bound)

    def values(self) -> dict[str, float]:
        """By parameter name (the `object_frame` kinds on `object`)."""
        o = self.object
        return {f"frame_x[{o}]": self.x, f"frame_y[{o}]": self.y, f"frame_yaw[{o}]": self.yaw}

    def sentence(self) -> str:
        return (f"while it pushed, the rod sat on {self.object}'s outline only with the recorded frame moved: the "
                f"recording tracks a frame at ({1e3 * self.x:+.1f}, {1e3 * self.y:+.1f}) mm, turned "
                f"{math.degrees(self.yaw):+.1f} deg, in the object's model ({self.sigmas():.0f} sigma, from "
                f"{self.recordings} recordings; the gap's RMS falls from {1e3 * self.rms_before:.2f} to "
                f"{1e3 * self.rms_after:.2f} mm): evidence of an object-model error (object_frame), or of a rod "
                f"offset where the object kept one yaw")

    def to_json(self) -> dict:
        return {"frame_m": [float(f"{self.x:.4g}"), float(f"{self.y:.4g}")], "frame_yaw_rad": float(f"{self.yaw:.4g}"),
                "gap_m": float(f"{self.gap:.4g}"), "std": [float(f"{v:.3g}") for v in self.std],
                "sigmas": float(f"{self.sigmas():.3g}"), "evident": self.evident,
                "gap_rms_m": [float(f"{self.rms_before:.3g}"), float(f"{self.rms_after:.3g}")],
                "samples": self.count, "recordings": self.recordings, "at_bound": self.at_bound,
                "object": self.object}


def rod_xy(trial, obj: str, times: np.ndarray) -> np.ndarray | None:
    """The recorded rod's centre (n, 2) at `times`, from the raw telemetry (the loader's start-clearance shift
    for `obj` taken back); None without a planar pusher."""
    world, telemetry = trial.world, trial.telemetry
    if world.robot is None or telemetry is None or not set(PLANAR_JOINTS) <= set(telemetry.joint_names):
        return None
    columns = [telemetry.joint_names.index(j) for j in PLANAR_JOINTS]
    tip = telemetry.sample(np.asarray(times, dtype=float))[:, columns] + np.asarray(world.robot.base_pose.xyz[:2])
    for a in trial.adjustments:
        if isinstance(a, StartClearance) and a.object == obj:
            tip = tip - np.asarray(a.shift)  # the raw recording's rod
    return tip


def object_outline(trials: Sequence, odb, obj: str) -> np.ndarray | None:
    """`obj`'s prism outline (body frame) in the world of `trials`; None where it has none."""
    from ..rollout.trials import shape_outline

    if not trials or obj not in trials[0].world.objects:
        return None
    return shape_outline(trials[0].world.objects[obj].type, odb)


@dataclass(frozen=True)
class Push:
    """One push on an even time grid: the object's track (world x-y, unwrapped yaw), the rod's centre and the force
    on the object (world x-y, the negated force the robot's sensor reads), as the force readings take them."""

    times: np.ndarray
    xy: np.ndarray
    yaw: np.ndarray
    rod: np.ndarray
    force: np.ndarray


def recorded_push(trial, obj: str, rate: float) -> Push | None:
    """`obj`'s push in a recording at `rate` (the rod from the telemetry at the grid's times, the track and the
    force interpolated); None without a force track, a planar pusher or a track of `obj`."""
    track = next((t for t in trial.observations.tracks if t.object == obj), None)
    if trial.force is None or track is None or len(track.times) < 8:
        return None
    times = np.asarray(track.times, dtype=float)
    grid = np.arange(times[0], times[-1], 1.0 / rate)
    rod = rod_xy(trial, obj, grid)
    if rod is None:
        return None
    force = -np.column_stack([np.interp(grid, trial.force.times, trial.force.force[:, k]) for k in (0, 1)])
    xy = np.column_stack([np.interp(grid, times, [p.xyz[k] for p in track.poses]) for k in (0, 1)])
    return Push(grid, xy, np.interp(grid, times, np.unwrap([p.yaw() for p in track.poses])), rod, force)


def replayed_push(trial, result, obj: str, rate: float) -> Push | None:
    """`obj`'s push in a replay of `trial` (a `sim.simulate.ReplayResult` run with `robot_force` and `joint_track`)
    at `rate`: the simulated rod, object and force; None where the replay lacks them."""
    from scipy.spatial.transform import Rotation

    if result is None or result.robot_force is None or result.joint_track is None or obj not in result.tracks:
        return None
    if not set(PLANAR_JOINTS) <= set(result.joint_names) or trial.world.robot is None or len(result.times) < 8:
        return None
    times = np.asarray(result.times, dtype=float)
    grid = np.arange(times[0], times[-1], 1.0 / rate)
    at = lambda a: np.column_stack([np.interp(grid, times, a[:, k]) for k in range(a.shape[1])])  # noqa: E731
    columns = [result.joint_names.index(j) for j in PLANAR_JOINTS]
    track = result.tracks[obj]
    yaw = np.unwrap(Rotation.from_quat(track[:, [4, 5, 6, 3]]).as_euler("zyx")[:, 0])  # tracks hold w, x, y, z
    return Push(grid, at(track[:, :2]), np.interp(grid, times, yaw),
                at(result.joint_track[:, columns]) + np.asarray(trial.world.robot.base_pose.xyz[:2]),
                at(-np.asarray(result.robot_force)[:, :2]))


def pushing_samples(trial, obj: str) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """(rod xy (n, 2), recorded object xy (n, 2), recorded yaw (n,)) at the observed samples where `obj` moves,
    the rod as `rod_xy` gives it; None without a planar pusher, an observed track of `obj` or enough samples."""
    track = next((t for t in trial.observations.tracks if t.object == obj), None)
    if track is None or len(track.times) < 5:
        return None
    times = np.asarray(track.times, dtype=float)
    tip = rod_xy(trial, obj, times)
    if tip is None:
        return None
    xy = np.array([p.xyz[:2] for p in track.poses])
    yaw = np.unwrap([p.yaw() for p in track.poses])
    moving = moving_samples(times, xy, yaw)  # the loader's rule for the samples that pin the rod on the outline
    if trial.force is not None and len(moving):  # and the rod touching, where the force says so (`touching`)
        f = trial.force
        magnitude = np.hypot(*(np.interp(times[moving], f.times, f.force[:, k]) for k in (0, 1)))
        touch = moving[touching(magnitude)]
        moving = touch if len(touch) >= 5 else moving
    if len(moving) < 5:
        return None
    return tip[moving], xy[moving], yaw[moving]


def fit_frame(samples: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray]], outline: np.ndarray) -> FrameFit | None:
    """The frame and gap that put every pushing sample on the outline (module docstring), or None with fewer than
    MIN_SAMPLES samples."""
    samples = [s for s in samples if s is not None]
    if not samples:
        return None
    tip, xy, yaw = (np.concatenate([s[k] for s in samples]) for k in range(3))
    if len(tip) < MIN_SAMPLES:
        return None
    rel = tip - xy
    outline = np.asarray(outline, dtype=float)

    def gaps(p: np.ndarray) -> np.ndarray:
        return _gaps(rel, yaw, outline, p)

    s0 = float(np.median(gaps(np.zeros(4))))
    before = gaps(np.array([0.0, 0.0, 0.0, s0]))
    half = 0.5 * float(np.max(np.abs(outline)))
    best = None
    for d0 in (0.0, -SEED_TURN, SEED_TURN):  # the effect's seeds: the turn acts through where the rod meets the outline
        fit = least_squares(gaps, np.array([0.0, 0.0, d0, s0]), loss="soft_l1", f_scale=SCALE,
                            bounds=([-half, -half, -YAW_BOUND, -0.05], [half, half, YAW_BOUND, 0.05]))
        if best is None or fit.cost < best.cost:
            best = fit
    after = best.fun
    J = best.jac
    scatter = 1.4826 * float(np.median(np.abs(after - np.median(after))))
    var = max(scatter ** 2, 1e-12)
    cov = var * np.linalg.pinv(J.T @ J)
    std = tuple(float(math.sqrt(max(cov[k, k], 0.0))) for k in range(3))
    bounded = bool(max(abs(best.x[0]), abs(best.x[1])) > 0.99 * half or abs(best.x[2]) > 0.99 * YAW_BOUND)
    return FrameFit(float(best.x[0]), float(best.x[1]), float(best.x[2]), float(best.x[3]), std,
                    float(np.sqrt(np.mean(np.minimum(np.abs(before), 0.01) ** 2))),
                    float(np.sqrt(np.mean(np.minimum(np.abs(after), 0.01) ** 2))), len(tip), len(samples), bounded,
                    samples=(rel, yaw, outline))


def _gaps(rel: np.ndarray, yaw: np.ndarray, outline: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Each sample's rod-to-outline distance less the common gap p[3], with the recorded frame at (p[0], p[1]) turned
    p[2] in the body (module docstring)."""
    heading = yaw - p[2]
    c, s = np.cos(heading), np.sin(heading)
    local = np.column_stack([c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1]]) + p[:2]
    return signed_distance(local, outline) - p[3]


def frame_evidence(prepared, odb, obj: str) -> FrameFit | None:
    """The frame the pushing samples of `obj` in every prepared trial imply (`fit_frame`), None when it cannot be
    read (no planar pusher, no prism outline, too few samples)."""
    from ..rollout.trials import shape_outline

    if obj not in prepared[0].world.objects:
        return None
    outline = shape_outline(prepared[0].world.objects[obj].type, odb)
    if outline is None:
        return None
    fit = fit_frame([pushing_samples(p.trial, obj) for p in prepared], outline)
    return None if fit is None else replace(fit, object=obj)
