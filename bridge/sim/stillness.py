"""Still spans: do not step a replay while nothing moves and nothing is commanded to move.

Sleeping objects (`sleep.py`) skip what the robot cannot reach. A robot that stands still beside an object, or
touching it, keeps every body near it awake, yet nothing can change there either: the robot's desired state is
constant, every body is at rest and the forces balance. That is how a recorded push begins and ends (the rod
waits against the shape before the push and after it, 30-45 % of each MIT push's replay) and how a teleoperator's
pauses look (a grasp held while the operator thinks). A replay jumps over such a span: from a sample at which
everything has been at rest for `CHECKS` samples to the last sample before the robot's desired trajectory moves
again, holding every pose, contact and force as it was, and resumes stepping from there (`Simulator.Initialize`
at the new time, as after a kinematic stretch of the sleeping replay). The replay's last interval is always
stepped (the final contacts are the full simulation's).

The numbers:
- at rest: every point of every moving body (free objects and robot links, |v| + |w| r with r the body's
  reach, as `Sleepers.speeds` reads it) slower than `REST_SPEED` at `CHECKS` samples in a row, and not speeding
  up from one to the next unless slower than a quarter of it. A millimetre a second is far below anything a push or a fall does and
  above the creep of Drake's regularised static friction: after a real ellip3 push the rod pressing the shape
  held it at 0.10-0.15 mm/s and 1-1.5 mrad/s, creeping 0.04 mm and 0.03 deg over the 0.3 s left of the replay
  (a real object held by static friction does not creep; held still, it stays where it stopped). An object
  that starts to fall or slide speeds up between two checks 20 ms apart, so it is not still.
- commanded still: the robot's desired positions (its telemetry, through any latency) stay within
  `HOLD_TOLERANCE` of where the span began (50 um or 50 urad): encoder jitter at rest and a servo settling after
  a move are not motion (the MIT rod jitters 2-3 um at rest and settles 20-30 um over the 0.3 s after a push;
  with 10 um its wait after a push broke into spans of 60 ms, each stepped afresh); no object moves further than
  the rod does, so a held span is off the full simulation by at most that; before its first and after its last
  sample a telemetry is held.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

REST_SPEED = 1e-3  # m/s at any point of a moving body
CHECKS = 2  # samples in a row at rest before a span is skipped (t = 0 never counts: the contacts settle first)
HOLD_TOLERANCE = 5e-5  # m or rad: desired positions within this of the span's start are commanded still


def hold_spans(times: np.ndarray, positions: np.ndarray, tolerance: float = HOLD_TOLERANCE
               ) -> list[tuple[float, float]]:
    """The spans (start, end) of the telemetry's clock over which every column of `positions` (samples x joints)
    stays within `tolerance` of its value at the span's start, each at least two samples long; the first starts
    at -inf when it holds from the first sample, the last ends at +inf when it holds to the last (the robot is
    still before and after its telemetry)."""
    times = np.asarray(times, dtype=float)
    q = np.asarray(positions, dtype=float).reshape(len(times), -1)
    spans = []
    i, n = 0, len(times)
    while i < n:
        j = i
        while j + 1 < n and np.all(np.abs(q[j + 1] - q[i]) <= tolerance):
            j += 1
        if j > i or n == 1:
            spans.append((-math.inf if i == 0 else float(times[i]), math.inf if j == n - 1 else float(times[j])))
        i = j + 1 if j > i else i + 1
    if not spans or spans[-1][1] != math.inf:  # after the last sample the telemetry holds it
        spans.append((float(times[-1]), math.inf))
    if spans[0][0] != -math.inf:  # before the first sample too
        spans.insert(0, (-math.inf, float(times[0])))
    return spans


@dataclass
class Stillness:
    """Watches one running replay for still spans. `update(t, speeds)` at every stepped sample; it returns the
    time up to which the replay may hold everything as it is (None: keep stepping)."""

    spans: list[tuple[float, float]]
    still_since: list[float]  # the samples at rest in a row, latest last
    last_speed: float = math.inf

    @classmethod
    def of(cls, times: np.ndarray | None, positions: np.ndarray | None) -> "Stillness":
        """From the robot's desired trajectory (sample times, positions samples x joints); without one, the robot
        (if any) holds still throughout."""
        if times is None or positions is None or len(times) == 0:
            return cls([(-math.inf, math.inf)], [])
        return cls(hold_spans(times, positions), [])

    def update(self, t: float, fastest: float) -> float | None:
        """`fastest`: the fastest point of any moving body at sample time `t` (m/s). Returns the end of the span
        the robot is commanded still over, if everything has been at rest for CHECKS samples within it and the
        span goes on past `t`; else None."""
        at_rest = t > 0.0 and fastest <= REST_SPEED and (fastest <= REST_SPEED / 4 or fastest <= self.last_speed)
        self.last_speed = fastest
        if not at_rest:
            self.still_since.clear()
            return None
        self.still_since.append(t)
        del self.still_since[:-CHECKS]
        if len(self.still_since) < CHECKS:
            return None
        first = self.still_since[0]
        for start, end in self.spans:
            if start <= first and t < end:
                return end
        return None

    def resumed(self) -> None:
        """Stepping again: rest is counted afresh."""
        self.still_since.clear()
        self.last_speed = math.inf
