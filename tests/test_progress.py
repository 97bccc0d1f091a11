"""Progress with the time left (bridge/progress.py) and the time limit the long searches check
(bridge/timelimit.py), without Drake: a fake clock drives them."""
from __future__ import annotations

import io
import math

import numpy as np
import pytest

from bridge.errors import BridgeError
from bridge.optim import minimise
from bridge.optim.lm import levenberg_marquardt
from bridge.progress import Progress, duration_text
from bridge.timelimit import TimeLimit, check_time_limit


class Clock:
    def __init__(self):
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def test_off_a_terminal_plain_lines_every_tenth_with_the_time_left_and_no_carriage_return():
    clock, out = Clock(), io.StringIO()
    bar = Progress("generation", total=30, stream=out, clock=clock)
    for g in range(1, 31):
        clock.t += 10.0  # 10 s a generation
        bar(g, status=f"best e {1.0 / g:.4f}")
    bar.close()
    text = out.getvalue()
    lines = text.splitlines()
    assert "\r" not in text
    assert 10 <= len(lines) <= 12  # the first, then each tenth (3 generations); the last says done
    assert lines[0].startswith("generation 1/30 (3%), best e 1.0000: 10 s elapsed, about 4 min 50 s left")
    assert "generation 16/30 (53%), best e 0.0625: 2 min 40 s elapsed, about 2 min 20 s left" in text
    assert lines[-1].startswith("generation 30/30 (100%)") and lines[-1].endswith("5 min 00 s elapsed, done")


def test_the_estimate_counts_the_pace_since_the_first_report_not_the_setting_up():
    clock, out = Clock(), io.StringIO()
    bar = Progress("sample", total=10, stream=out, clock=clock)
    clock.t += 60.0  # a slow start (the nominal replay)
    bar(1)
    clock.t += 2.0
    bar(2)  # 2 s a sample since the first: 8 left -> 16 s
    assert bar.remaining() == pytest.approx(16.0)
    assert "about 16 s left" in bar.line()


def test_a_time_limit_caps_the_estimate_and_says_so():
    clock, out = Clock(), io.StringIO()
    bar = Progress("case", total=100, stream=out, clock=clock, time_limit=30.0)
    clock.t += 10.0
    bar(1)
    assert bar.remaining() == pytest.approx(20.0)
    assert "about 20 s left (time limit)" in out.getvalue()
    clock.t += 25.0
    assert bar.eta_text() == "time limit reached: finishing"


def test_a_short_task_stays_silent_off_a_terminal_and_an_unknown_total_counts_only():
    clock, out = Clock(), io.StringIO()
    bar = Progress("replaying r", total=4.0, unit=" s simulated", number=".1f", stream=out, clock=clock, delay=5.0)
    for k in range(1, 5):
        clock.t += 1.0
        bar(float(k))
    assert out.getvalue() == ""
    steps = Progress("diagnosis step", stream=out, clock=clock)
    clock.t += 3.0
    steps(1)
    assert out.getvalue().startswith("diagnosis step 1: 3.0 s elapsed, time left not known yet")


def test_on_a_terminal_a_bar_with_the_time_left_and_log_lines_above_it():
    clock, out = Clock(), io.StringIO()
    bar = Progress("generation", total=4, stream=out, clock=clock, tty=True)
    for g in range(1, 5):
        clock.t += 5.0
        bar(g)
        if g == 2:
            bar.write("a log line")
    bar.close()
    text = out.getvalue()
    assert "\r" in text and "100%" in text and "a log line\n" in text
    assert "2/4 (50%), 10 s elapsed, about 10 s left" in text


def test_duration_text():
    assert duration_text(3.14) == "3.1 s" and duration_text(42) == "42 s"
    assert duration_text(185) == "3 min 05 s" and duration_text(3725) == "1 h 02 min"
    assert duration_text(math.inf) == "?"


# --- the time limit ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("bad", [0, -1.0, math.nan, math.inf, "10", True])
def test_a_time_limit_is_a_finite_number_of_seconds_above_zero(bad):
    with pytest.raises(BridgeError, match="time limit must be a finite number of seconds > 0"):
        check_time_limit(bad)


def test_a_time_limit_remembers_when_it_was_first_found_passed():
    clock = Clock()
    limit = TimeLimit(5.0, clock=clock)
    clock.t += 4.0
    assert not limit.expired() and limit.to_json(False) == {"stopped": None, "time_limit_s": 5.0}
    clock.t += 2.0
    assert limit.expired()
    clock.t += 10.0
    assert limit.expired() and limit.to_json(True) == {"stopped": "time limit", "time_limit_s": 5.0,
                                                        "stopped_after_s": 6.0}
    assert not TimeLimit(None).expired()


def _quadratic(xs):
    return [np.array([x[0] - 3.0, 2.0 * (x[1] + 1.0)]) for x in xs]


def test_levenberg_marquardt_stops_when_told_with_the_best_point_so_far():
    calls = []

    def residuals(xs):
        calls.append(len(xs))
        return _quadratic(xs)

    lower, upper = np.full(2, -10.0), np.full(2, 10.0)
    full = levenberg_marquardt(_quadratic, np.zeros(2), lower, upper, max_iterations=20)
    assert not full.stopped and full.jacobian is not None and np.allclose(full.x, [3.0, -1.0], atol=1e-3)
    cut = levenberg_marquardt(residuals, np.zeros(2), lower, upper, max_iterations=20, should_stop=lambda: True)
    assert cut.stopped and calls == [1] and np.allclose(cut.x, 0.0) and cut.jacobian is None


def test_an_evolution_strategy_stops_between_generations_when_told():
    from bridge.params import Parameter, ParameterSet
    from bridge.params.kinds import kind_named

    kind = kind_named("friction")
    space = ParameterSet(tuple(Parameter(kind, f"o{k}", bounds=(0.1, 1.0), start=0.5, step=0.1) for k in range(2)),
                         "test")
    generations = []

    def residuals(values):
        generations.append(len(values))
        return [np.array([v[0] - 0.3, v[1] - 0.7]) for v in values]

    found = minimise("cmaes", residuals, space, np.array([0.5, 0.5]), iterations=10,
                     should_stop=lambda: len(generations) >= 2)
    assert found.stopped and len(generations) == 2
