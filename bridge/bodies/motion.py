"""Motions for action bodies: a builder that turns joint-space and Cartesian moves into joint telemetry, solving
inverse kinematics with the arm's IK plant (`bridge.sim.kinematics`) and checking clearance along the way."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import ActionError
from ..recording.telemetry import Telemetry
from ..sim.kinematics import Arm, Clearance

RATE = 50.0  # Hz of generated telemetry
IK_STEP = 0.005  # m between IK solutions along a Cartesian line
IK_ANGLE_STEP = math.radians(3.0)  # rad between IK solutions along a rotation
MAX_JOINT_STEP = 0.2  # rad one IK step may change a joint by (more means the arm flipped)
ACCEL_TIME = 0.25  # s to reach cruise speed on a Cartesian line
DECIMALS = 6  # telemetry is written to a micro-radian


def frame_rotation(approach: Sequence[float], finger_axis: Sequence[float]) -> np.ndarray:
    """The tool frame's rotation: z along `approach`, y along `finger_axis` (made orthogonal to z)."""
    z = np.asarray(approach, dtype=float)
    z = z / np.linalg.norm(z)
    y = np.asarray(finger_axis, dtype=float)
    y = y - (y @ z) * z
    if np.linalg.norm(y) < 1e-6:
        raise ValueError(f"finger axis {list(finger_axis)} is parallel to the approach {list(approach)}")
    y = y / np.linalg.norm(y)
    return np.column_stack([np.cross(y, z), y, z])


# --- trajectories --------------------------------------------------------------------------------
@dataclass(frozen=True)
class Segment:
    """A stretch of the motion: its name (for messages), its times, and the objects it may touch."""

    label: str
    start: float
    end: float
    may_touch: frozenset[str] = frozenset()
    stage: int = 0  # which predicted arrangement of the objects the segment is checked against


class MotionBuilder:
    """Accumulates joint knots (time, positions in telemetry order) from moves; `telemetry()` samples them."""

    def __init__(self, arm: Arm, q0: np.ndarray, finger_joints: Sequence[int], what: str):
        self.arm = arm
        self.fingers = tuple(finger_joints)
        self.what = what  # "push_over(arm, big_box, table)", for messages
        self.times: list[float] = [0.0]
        self.knots: list[np.ndarray] = [np.asarray(q0, dtype=float).copy()]
        self.segments: list[Segment] = []
        self.stage = 0

    def next_stage(self) -> None:
        """Later segments are checked against the next arrangement of objects (after a push, a release)."""
        self.stage += 1

    @property
    def q(self) -> np.ndarray:
        return self.knots[-1].copy()

    @property
    def t(self) -> float:
        return self.times[-1]

    def finger_value(self) -> float:
        return float(self.knots[-1][self.fingers[0]]) if self.fingers else 0.0

    def _add(self, times: Iterable[float], qs: Iterable[np.ndarray], label: str, may_touch: Iterable[str]) -> None:
        start = self.t
        for t, q in zip(times, qs):
            self.times.append(float(t))
            self.knots.append(np.asarray(q, dtype=float))
        self.segments.append(Segment(label, start, self.t, frozenset(may_touch), self.stage))

    # --- moves ------------------------------------------------------------------------------------
    def wait(self, duration: float, label: str = "wait", may_touch: Iterable[str] = ()) -> None:
        self._add([self.t + duration], [self.q], label, may_touch)

    def set_fingers(self, value: float, duration: float, label: str = "gripper", may_touch: Iterable[str] = ()) -> None:
        """Move the fingers to `value` over `duration` seconds, the arm still."""
        q = self.q
        if abs(self.finger_value() - value) < 1e-9:
            return
        n = max(1, int(math.ceil(duration * RATE)))
        start = q.copy()
        goal = q.copy()
        goal[list(self.fingers)] = value
        s = _smooth(np.arange(1, n + 1) / n)
        self._add(self.t + duration * np.arange(1, n + 1) / n, [start + si * (goal - start) for si in s], label, may_touch)

    def joint_move(self, goal: np.ndarray, label: str, *, speed: float = 0.9, min_duration: float = 1.0,
                   may_touch: Iterable[str] = ()) -> None:
        """A smooth joint-space move (all joints start and stop together) at most `speed` rad/s on average."""
        start = self.q
        goal = np.asarray(goal, dtype=float)
        span = float(np.max(np.abs(goal - start)))
        if span < 1e-6:
            return
        duration = max(min_duration, 1.5 * span / speed)
        n = max(2, int(math.ceil(duration * RATE)))
        s = _smooth(np.arange(1, n + 1) / n)
        self._add(self.t + duration * np.arange(1, n + 1) / n, [start + si * (goal - start) for si in s], label, may_touch)

    def move_to(self, p: Sequence[float], R: np.ndarray, frame: str, label: str, *, nominal: np.ndarray,
                min_distance: float | None = 0.01, speed: float = 0.9, may_touch: Iterable[str] = ()) -> None:
        """Solve IK for the pose (fingers as they are), then a joint-space move there."""
        q = self.solve(p, R, frame, seed=self.q, nominal=nominal, min_distance=min_distance, label=label)
        self.joint_move(q, label, speed=speed, may_touch=may_touch)

    def line(self, p: Sequence[float], R: np.ndarray | None, frame: str, label: str, *, speed: float = 0.05,
             angular_speed: float = 0.6, min_distance: float | None = 0.005, may_touch: Iterable[str] = (),
             fingers: float | None = None) -> None:
        """Move `frame` along a straight line to `p` while turning to `R` (None: keep the rotation), with a
        trapezoidal speed profile; IK every few millimetres, each seeded with the last."""
        p0, R0 = self.arm.pose(self.q, frame)
        p1 = np.asarray(p, dtype=float)
        R1 = R0 if R is None else np.asarray(R, dtype=float)
        distance = float(np.linalg.norm(p1 - p0))
        angle = float(np.linalg.norm(Rotation.from_matrix(R0.T @ R1).as_rotvec()))
        n = max(1, int(math.ceil(max(distance / IK_STEP, angle / IK_ANGLE_STEP))))
        f0 = self.finger_value()
        f1 = f0 if fingers is None else fingers
        q = self.q
        qs = []
        for k in range(1, n + 1):
            s = k / n
            R_k = _slerp(R0, R1, s)
            p_k = p0 + s * (p1 - p0)
            f_k = f0 + s * (f1 - f0)
            q_k = self.solve(p_k, R_k, frame, seed=q, nominal=q, min_distance=min_distance, label=label,
                             fingers=f_k)
            if np.max(np.abs(q_k - q)) > MAX_JOINT_STEP:
                raise ActionError(f"{self.what}: {label}: the arm cannot follow the line to "
                                  f"{_point(p1)} (it would flip its joints near {_point(p_k)})")
            qs.append(q_k)
            q = q_k
        cruise = max(distance / speed, angle / angular_speed, 1e-3)
        fractions = np.arange(1, n + 1) / n
        times = self.t + _trapezoid_times(fractions, cruise, ACCEL_TIME)
        self._add(times, qs, label, may_touch)

    def solve(self, p, R, frame: str, *, seed, nominal, label: str, min_distance: float | None = 0.01,
              fingers: float | None = None) -> np.ndarray:
        fingers = self.finger_value() if fingers is None else fingers
        weights = np.ones(len(self.arm.joints))
        weights[6] = 0.1  # the last wrist joint is free to turn
        for tol in (0.01, 0.03):
            q = self.arm.solve(p, R, frame, seed=seed, nominal=nominal, fingers=fingers,
                               finger_joints=self.fingers, min_distance=min_distance, tolerance=tol, weights=weights)
            if q is not None:
                return q
        raise ActionError(f"{self.what}: {label}: no arm configuration puts the {frame} at {_point(p)} "
                          f"pointing {_point(np.asarray(R)[:, 2])} (out of reach, or the arm would hit a fixture)")

    # --- output -----------------------------------------------------------------------------------
    def telemetry(self, source: str = "<generated>") -> Telemetry:
        times = np.asarray(self.times)
        knots = np.vstack(self.knots)
        grid = np.arange(0.0, times[-1], 1.0 / RATE)
        grid = np.append(grid, times[-1]) if times[-1] - grid[-1] > 1e-6 else grid
        positions = np.column_stack([np.interp(grid, times, knots[:, j]) for j in range(knots.shape[1])])
        positions = np.round(positions, DECIMALS)
        return Telemetry(np.round(grid, 6), self.arm.joints, positions, source=source)

    def check_clearance(self, stages: Sequence[Clearance], margin: float = 0.005) -> None:
        """Every sample keeps `margin` from every object its segment may not touch, the objects where its stage's
        arrangement has them (the last arrangement serves the later stages)."""
        times = np.asarray(self.times)
        knots = np.vstack(self.knots)
        for seg in self.segments:
            clearance = stages[min(seg.stage, len(stages) - 1)]
            grid = np.arange(seg.start, seg.end, 0.05)
            grid = np.append(grid, seg.end)
            for t in grid:
                q = np.array([np.interp(t, times, knots[:, j]) for j in range(knots.shape[1])])
                for obj, (d, link) in clearance.distances(q).items():
                    if obj in seg.may_touch or d >= margin:
                        continue
                    raise ActionError(f"{self.what}: {seg.label}: the arm's {link} would come within {d * 1000:.0f} mm "
                                      f"of {obj!r} at t = {t:.1f} s (keep it {margin * 1000:.0f} mm away)")


def _smooth(s: np.ndarray) -> np.ndarray:
    """Quintic smoothstep: zero velocity and acceleration at both ends."""
    s = np.clip(s, 0.0, 1.0)
    return s * s * s * (10 - 15 * s + 6 * s * s)


def _trapezoid_times(fractions: np.ndarray, cruise: float, ramp: float) -> np.ndarray:
    """Times at which a trapezoidal profile (cruise time `cruise` at full speed, `ramp` s to accelerate and to
    brake) reaches each path fraction."""
    ramp = min(ramp, cruise)
    total = cruise + ramp
    t = np.linspace(0.0, total, 2000)
    v = np.minimum(1.0, np.minimum(t / ramp, (total - t) / ramp)) if ramp > 0 else np.ones_like(t)
    s = np.concatenate([[0.0], np.cumsum((v[1:] + v[:-1]) / 2 * np.diff(t))])
    s /= s[-1]
    return np.interp(fractions, s, t)


def _slerp(R0: np.ndarray, R1: np.ndarray, s: float) -> np.ndarray:
    """The rotation a fraction `s` of the way from R0 to R1 about their common axis."""
    return R0 @ Rotation.from_rotvec(s * Rotation.from_matrix(R0.T @ R1).as_rotvec()).as_matrix()


def _point(p) -> str:
    return "(" + ", ".join(f"{v:.3f}" for v in np.asarray(p, dtype=float)) + ")"


__all__ = ["MotionBuilder", "RATE", "Segment", "frame_rotation"]
