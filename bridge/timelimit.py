"""A time limit for the long searches (fit, diagnosis, proof, sampled replays): they check it between units of
work (a generation, a candidate, a case, a sample) and, once it has passed, stop there with what they have.

    limit = TimeLimit(60.0)          # started now; TimeLimit(None) never expires
    while work_left and not limit.expired():
        ...
    data.update(limit.to_json(stopped))

A search always finishes one unit of work first (a fit needs a generation to report a best candidate), and
scoring and writing the result come on top, so a command ends a little after its limit, never before it.
"""
from __future__ import annotations

import math
import time
from typing import Any, Callable

from .errors import BridgeError

STOPPED = "time limit"  # what a search stopped by its limit says in its JSON ("stopped")


def check_time_limit(seconds: Any, name: str = "time limit") -> float | None:
    """None, or a finite number of seconds > 0."""
    if seconds is None:
        return None
    if isinstance(seconds, bool) or not isinstance(seconds, (int, float)) or not math.isfinite(seconds) or seconds <= 0:
        raise BridgeError(f"{name} must be a finite number of seconds > 0, got {seconds!r}")
    return float(seconds)


class TimeLimit:
    """`seconds` from now (None: no limit). `clock` is for tests."""

    def __init__(self, seconds: float | None = None, *, clock: Callable[[], float] = time.monotonic):
        self.seconds = check_time_limit(seconds)
        self.clock = clock
        self.started = clock()
        self.stopped_after: float | None = None  # elapsed when `expired` first said so: where the search stopped

    @property
    def elapsed(self) -> float:
        return self.clock() - self.started

    @property
    def remaining(self) -> float:
        return math.inf if self.seconds is None else max(0.0, self.seconds - self.elapsed)

    def expired(self) -> bool:
        """Whether the limit has passed; the first time it has, the elapsed time is kept (`stopped_after`)."""
        if self.seconds is None:
            return False
        if self.stopped_after is None:
            elapsed = self.elapsed
            if elapsed < self.seconds:
                return False
            self.stopped_after = elapsed
        return True

    def to_json(self, stopped: bool) -> dict[str, Any]:
        """The keys a result file carries: `stopped` ("time limit" or None), the limit and, when stopped, the
        seconds the search had run when it stopped."""
        out: dict[str, Any] = {"stopped": STOPPED if stopped else None, "time_limit_s": self.seconds}
        if stopped:
            out["stopped_after_s"] = round(self.stopped_after if self.stopped_after is not None else self.elapsed, 2)
        return out

    def text(self) -> str:
        return f"the time limit of {self.seconds:g} s"


__all__ = ["STOPPED", "TimeLimit", "check_time_limit"]
