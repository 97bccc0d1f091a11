"""Progress of the long commands on stderr, with an estimate of the time left.

On a terminal: a bar (tqdm) that redraws in place. Off a terminal (a log, a pipe, CI): plain lines, one each
time another tenth of the work is done or `PLAIN_SECONDS` have passed since the last one, each with the time
elapsed and the time left; never a carriage return. The library reports progress through plain callbacks
(`done`, `total`); the commands make one `Progress` per phase and hand it (or a small adapter) down.

    with Progress("generation", total=30, time_limit=args.time_limit) as bar:
        fit_parameters(..., progress=lambda p: bar(p.generation, p.max_generations, status=f"best e {p.best_e:.5f}"))

The estimate is linear: the pace of the units done since the first report (so setting up is not counted as
work), capped by what is left of a time limit.
"""
from __future__ import annotations

import math
import shutil
import sys
import time
from typing import Callable, TextIO

PLAIN_FRACTION = 0.1  # off a terminal: a line each time another tenth is done ...
PLAIN_SECONDS = 30.0  # ... or this long after the last line, whichever comes first


def duration_text(seconds: float) -> str:
    """12 s, 3 min 05 s, 1 h 02 min."""
    if not math.isfinite(seconds):
        return "?"
    s = max(0, int(round(seconds)))
    if s < 60:
        return f"{max(seconds, 0):.1f} s" if seconds < 10 else f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {(s % 3600) // 60:02d} min"


class Progress:
    """One phase of a long command: `progress(done, total, status=...)` after each unit of work.

    `label` names the unit ("generation", "sample", "case", "replaying 1_push_over"); `unit` follows the
    counts ("" or " s simulated"); `number` formats them ("d", ".1f"). `delay`: off a terminal, no line before
    this many seconds (a short replay stays silent). `time_limit` (s, counted from now) caps the estimate.
    `tty` overrides what the stream says about itself (tests)."""

    def __init__(self, label: str, *, total: float | None = None, unit: str = "", number: str = "d",
                 stream: TextIO | None = None, tty: bool | None = None, delay: float = 0.0,
                 time_limit: float | None = None, every: float = PLAIN_SECONDS,
                 clock: Callable[[], float] = time.monotonic):
        self.label, self.unit, self.number = label, unit, number
        self.stream = stream if stream is not None else sys.stderr
        isatty = getattr(self.stream, "isatty", None)
        self.tty = bool(isatty and isatty()) if tty is None else tty
        self.delay, self.time_limit, self.every, self.clock = delay, time_limit, every, clock
        self.started = clock()
        self.total, self.done, self.status = total, 0.0, ""
        self._first: tuple[float, float] | None = None  # (time, done) of the first report: the pace counts from it
        self._last_line, self._last_fraction = self.started, 0.0
        self._printed = False
        self._bar = None

    # --- reporting ---------------------------------------------------------------------------------------
    def __call__(self, done: float, total: float | None = None, status: str | None = None) -> None:
        now = self.clock()
        if total is not None:
            self.total = total
        if self.total is not None and done > self.total:  # a budget overrun (Levenberg-Marquardt's Jacobians)
            self.total = done
        if status is not None:
            self.status = status
        if self._first is None:
            self._first = (now, float(done))
        self.done = float(done)
        if self.tty:
            self._draw()
        else:
            self._plain(now)

    def write(self, message: str) -> None:
        """A line of its own (a log message), without breaking the bar."""
        if self._bar is not None:
            from tqdm import tqdm

            tqdm.write(message, file=self.stream)
        else:
            print(message, file=self.stream, flush=True)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self) -> "Progress":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # --- the estimate ------------------------------------------------------------------------------------
    @property
    def elapsed(self) -> float:
        return self.clock() - self.started

    def remaining(self) -> float | None:
        """Seconds left at the pace so far (None while it cannot tell), at most what the time limit leaves."""
        limit_left = math.inf if self.time_limit is None else max(0.0, self.time_limit - self.elapsed)
        estimate = math.inf
        if self.total is not None and self._first is not None and self.done > 0:
            now = self.clock()
            t0, d0 = self._first
            if self.done > d0 and now > t0:  # the pace since the first report
                pace = (now - t0) / (self.done - d0)
            else:  # one report so far: the pace from the start
                pace = (now - self.started) / self.done
            estimate = max(0.0, self.total - self.done) * pace
        left = min(estimate, limit_left)
        return None if math.isinf(left) else left

    def counts(self) -> str:
        done = format(self.done if self.number != "d" else int(round(self.done)), self.number)
        if self.total is None:
            return f"{done}{self.unit}"
        total = format(self.total if self.number != "d" else int(round(self.total)), self.number)
        percent = 100.0 * self.done / self.total if self.total else 100.0
        return f"{done}/{total}{self.unit} ({percent:.0f}%)"

    def eta_text(self) -> str:
        if self.total is not None and self.done >= self.total:
            return "done"
        left = self.remaining()
        if left is None:
            return "time left not known yet"
        capped = self.time_limit is not None and left >= max(0.0, self.time_limit - self.elapsed) - 1e-9
        if capped and left < 0.05:
            return "time limit reached: finishing"
        return f"about {duration_text(left)} left" + (" (time limit)" if capped else "")

    def line(self) -> str:
        """The plain line: what is done, the status, the time elapsed and left."""
        status = f", {self.status}" if self.status else ""
        return f"{self.label} {self.counts()}{status}: {duration_text(self.elapsed)} elapsed, {self.eta_text()}"

    # --- output ------------------------------------------------------------------------------------------
    def _plain(self, now: float) -> None:
        if now - self.started < self.delay:
            return
        fraction = self.done / self.total if self.total else 0.0
        finished = self.total is not None and self.done >= self.total
        due = (fraction - self._last_fraction >= PLAIN_FRACTION - 1e-9 or now - self._last_line >= self.every
               or not self._printed or finished)
        if not due or (finished and fraction <= self._last_fraction and self._printed):
            return
        self._last_line, self._last_fraction, self._printed = now, fraction, True
        print(self.line(), file=self.stream, flush=True)

    def _draw(self) -> None:
        from tqdm import tqdm

        if self._bar is None:  # the text right of the bar goes in tqdm's `unit` (its postfix adds a comma)
            size = shutil.get_terminal_size()  # a terminal that reports no size (0 x 0) gets 80 x 24
            self._bar = tqdm(total=self.total, desc=self.label, file=self.stream, leave=True,
                             ncols=size.columns, nrows=size.lines, mininterval=0.2, unit="",
                             bar_format="{desc}: {percentage:3.0f}%|{bar}| {unit}")
        if self.total is not None and self._bar.total != self.total:
            self._bar.total = self.total
        self._bar.n = self.done
        status = f", {self.status}" if self.status else ""
        self._bar.unit = f"{self.counts()}{status}, {duration_text(self.elapsed)} elapsed, {self.eta_text()}"
        self._bar.refresh()


__all__ = ["PLAIN_FRACTION", "PLAIN_SECONDS", "Progress", "duration_text"]
