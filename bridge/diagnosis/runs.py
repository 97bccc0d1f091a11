"""Models run on trials: the diagnosis' view of the rollout layer. A model (a tuple of `bridge.params.Setting`)
on a prepared trial is one rollout (`bridge.params.trial_rollout`), simulated on the executor; its replay is
turned into noise-normalised residuals here, in the calling process.

A replay that fails (`SimulationFailure`) is counted (`Runner.failures`, reported in diagnosis.json) and its
residual is `compare.FAILED` on every compared component, so a search ranks the model last; any other error
(a target that names nothing, a malformed value) is bad input and reaches the user.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, replace
from typing import Mapping, Sequence

import numpy as np

from ..errors import DiagnosisError
from ..odb import ObjectDatabase
from ..params import Model, trial_rollout
from ..rollout.compare import failed_residual, pose_residual, sample_track
from ..rollout.executors import Executor, expected_seconds
from ..rollout.rollout import Job, Outcome
from ..rollout.trials import Trial
from ..sim.simulate import SimOptions
from ..values import Contact
from .residuals import (ForceSeries, ObservedSeries, force_normalised, force_residual, force_series, motion_span,
                        normalised, observed_series, window_rate)

SAMPLE_RATE = 50.0  # Hz at which the simulation is sampled
FAILED_FORCE = 1.0e3  # N per component of a failed replay's force residual
EXCEEDS = 1e-9  # relative: a model's replays are cut only once their chi^2 is this far above a bound, so that
#                 summing it in another order cannot put the model back below it (`Runner.run_bounded`)
COARSE_STEP = 0.003  # s: the time step a diagnosis replays at when its error is small against the mismatch
STEP_SHARE = 0.01  # ... at most this share of the nominal model's chi^2 above the noise (`choose_time_step`)
QUASI_STATIC_SPEEDS = (0.04, 0.025)  # m/s: a slower recording is replayed at the first of these that changes it
#                                      little (`rollout.quasi_static`, `choose_time_scales`) ...
MAX_SCALE = 4.0  # ... at most this many times faster,
MIN_SCALE = 1.25  # ... not at all when it would save less than a fifth of the steps,
#                   and only where it changes the replay by STEP_SHARE at most (`choose_time_scales`)
SPEED_WINDOW = 0.2  # s over which a recording's speed is read (`recording_speed`)


@dataclass(frozen=True, eq=False)
class Prepared:
    """A trial with its observed series (per observed object that the world has as a free body) and, when the
    robot's force was recorded, its force series."""

    trial: Trial
    series: tuple[ObservedSeries, ...]
    end: float  # s simulated: past the last observation and the telemetry's end (to the sample before this)
    force: ForceSeries | None = None

    @property
    def name(self) -> str:
        return self.trial.name

    @property
    def world(self):
        return self.trial.world

    @property
    def objects(self) -> tuple[str, ...]:
        return tuple(s.object for s in self.series)


def prepare(trial: Trial, odb: ObjectDatabase, rate: float = 25.0) -> Prepared:
    series = []
    for track in trial.observations:
        if track.object not in trial.world.objects:
            raise DiagnosisError(f"observed object {track.object!r} is not in the world state", source=str(trial.source))
        if odb.get(trial.world.objects[track.object].type).fixed:
            continue
        series.append(observed_series(track, rate))
    if not series:
        raise DiagnosisError("no observed free object to compare with", source=str(trial.source))
    force = None
    if trial.force is not None and trial.world.robot is not None:
        span = motion_span(trial.telemetry.times, trial.telemetry.positions)
        force = force_series(trial.force, rate, span) if span is not None else None
    last_obs = max(float(s.times[-1]) for s in series)
    end = max(last_obs, float(trial.telemetry.times[-1])) + 0.02
    return Prepared(trial, tuple(series), end, force)


@dataclass(frozen=True, eq=False)
class Run:
    """One model on one trial: residual (n, 6) per observed object and (n, 3) of the robot's force when it was
    recorded, optionally the simulated tracks (in the recorded frames, as compared) and contacts."""

    trial: str
    residuals: Mapping[str, np.ndarray]
    normalised: np.ndarray  # every object's measured components / sigma, then the force's, flattened
    failed: str | None = None
    sim_times: np.ndarray | None = None
    tracks: Mapping[str, np.ndarray] | None = None
    contacts: tuple[Contact, ...] = ()
    wall: float = 0.0
    force_residual: np.ndarray | None = None
    force_chi2: float = 0.0  # the force rows' share of chi2
    force_n: int = 0

    @property
    def chi2(self) -> float:
        return float(self.normalised @ self.normalised)


def run_of(p: Prepared, outcome: Outcome, want_tracks: bool = False) -> Run:
    """The residuals of a prepared trial against a job's outcome."""
    result = outcome.result
    residuals, parts = {}, []
    for s in p.series:
        if result is None:
            r = failed_residual(len(s.times))
        else:
            xyz, R = sample_track(result.times, result.observed_track(s.object), s.times)
            r = pose_residual(s.xyz, s.R, xyz, R)
        residuals[s.object] = r
        parts.append(normalised(s, r))
    f_res, f_norm = None, np.zeros(0)
    if p.force is not None:
        f_res = (np.full_like(p.force.force, FAILED_FORCE) if result is None
                 else force_residual(p.force, result.times, result.robot_force))
        f_norm = force_normalised(p.force, f_res)
        parts.append(f_norm)
    keep = want_tracks and result is not None
    return Run(p.name, residuals, np.concatenate(parts), outcome.failure,
               result.times if keep else None,
               {n: result.observed_track(n) for n in result.tracks} if keep else None,
               result.contact_log if result is not None else (), outcome.wall_time, f_res, float(f_norm @ f_norm),
               int(f_norm.size))


class Runner:
    """Runs models on prepared trials through an executor; counts simulations and failures."""

    def __init__(self, prepared: Sequence[Prepared], odb: ObjectDatabase, executor: Executor, *,
                 sample_rate: float = SAMPLE_RATE, time_step: float | None = None):
        self.prepared = list(prepared)
        self.odb, self.executor, self.sample_rate = odb, executor, sample_rate
        self.time_step = time_step  # s, every replay's (None: each rollout's own, `SimConfig`'s 2 ms)
        self.time_scales: dict[int, float] = {}  # trial index -> quasi-static replay (`choose_time_scales`)
        self.simulations = 0  # asked for; `rollouts()` says how many were run and how many the cache answered
        self.failures: list[tuple[str, str]] = []  # (trial, message) of every failed replay
        self.wall = 0.0
        self._counts0 = executor.cache.counts()

    def rollouts(self) -> dict[str, int]:
        """Replays simulated for this runner and answered by the executor's rollout cache (a repeated job: the
        nominal model in several stages, an optimiser's start evaluated again)."""
        now = self.executor.cache.counts()
        return {k: now[k] - self._counts0[k] for k in now}

    def index(self, name: str) -> int:
        for i, p in enumerate(self.prepared):
            if p.name == name:
                return i
        raise DiagnosisError(f"no trial named {name!r}")

    def job(self, model: Model, index: int, contacts: bool = False) -> Job:
        p = self.prepared[index]
        end = math.floor(p.end * self.sample_rate + 1e-9) / self.sample_rate  # a whole number of samples
        options = SimOptions(sample_rate=self.sample_rate, end=end, contacts=contacts, robot_force=p.force is not None)
        rollout = trial_rollout(p.trial, model, self.odb)
        if self.time_step is not None:
            rollout = replace(rollout, config=replace(rollout.config, time_step=self.time_step))
        if self.time_scales.get(index, 1.0) != 1.0:
            rollout = replace(rollout, time_scale=self.time_scales[index])
        return Job(rollout, options)

    def run_many(self, models: Sequence[Model], indices: Sequence[int], *, tracks: bool = False,
                 contacts: bool = False) -> list[list[Run]]:
        """runs[m][k]: model m on trial indices[k], one batch on the executor."""
        runs = self.run_pairs([(tuple(m), i) for m in models for i in indices], tracks=tracks, contacts=contacts)
        k = len(indices)
        return [runs[m * k:(m + 1) * k] for m in range(len(models))]

    def run_pairs(self, pairs: Sequence[tuple[Model, int]], *, tracks: bool = False,
                  contacts: bool = False) -> list[Run]:
        """Each (model, trial index) of `pairs`, one batch on the executor (a model per recording is what
        cross-validation asks: each recording predicted by the model fitted without it)."""
        outcomes = self.executor.run([self.job(m, i, contacts) for m, i in pairs])
        self.simulations += len(pairs)
        runs = []
        for (_, i), outcome in zip(pairs, outcomes):
            if outcome.failed:
                self.failures.append((self.prepared[i].name, outcome.failure))
            runs.append(run_of(self.prepared[i], outcome, tracks))
        self.wall += sum(r.wall for r in runs)
        return runs

    def run_bounded(self, models: Sequence[Model], indices: Sequence[int], bounds: Sequence[float], *,
                    counted: Sequence[Sequence[int]] | None = None, race: bool = False,
                    first: Sequence[Sequence[int]] | None = None) -> list[list[Run] | None]:
        """runs[m] over `indices` as `run_many`, or None for a model whose replays were cut short once the chi^2
        of those finished, over its positions `counted[m]` (default: all), exceeded `bounds[m]`; in a `race`, also
        once it exceeded the least chi^2 of a model run in full. A search that only keeps a model below such a
        bound (a step that must lower chi^2, the best of several starts) gets exactly its answer, without the
        replays of the models it would discard. The models run one after the other, each its recordings in the
        order `first[m]` (positions; default longest first): those most likely to exceed the bound first."""
        k = len(indices)
        counted = [range(k)] * len(models) if counted is None else counted
        weights = [np.isin(np.arange(k), list(c)) for c in counted]
        jobs = [self.job(tuple(m), i) for m in models for i in indices]
        longest = sorted(range(k), key=lambda j: -expected_seconds(jobs[j]))
        sequence = [m * k + j for m in range(len(models)) for j in (first[m] if first is not None else longest)]
        partial = [0.0] * len(models)
        left = [k] * len(models)
        runs: list[Run | None] = [None] * len(jobs)
        best = [math.inf]

        def told(position: int, outcome: Outcome) -> list[int]:
            p = sequence[position]
            m, j = divmod(p, k)
            if outcome.failed:
                self.failures.append((self.prepared[indices[j]].name, outcome.failure))
            runs[p] = run_of(self.prepared[indices[j]], outcome)
            left[m] -= 1
            if weights[m][j]:
                partial[m] += runs[p].chi2
            if race and left[m] == 0:
                best[0] = min(best[0], partial[m])
            return [n for n in range(len(models))
                    if left[n] and _above(partial[n], min(bounds[n], best[0] if race else math.inf))]
        outcomes = self.executor.run_pruned([jobs[p] for p in sequence], [p // k for p in sequence], told)
        self.simulations += sum(o is not None for o in outcomes)
        self.wall += sum(r.wall for r in runs if r is not None)
        return [None if left[m] else list(runs[m * k:(m + 1) * k]) for m in range(len(models))]

    def run(self, model: Model, indices: Sequence[int], *, tracks: bool = False, contacts: bool = False) -> list[Run]:
        return self.run_many([model], indices, tracks=tracks, contacts=contacts)[0]


@dataclass(frozen=True)
class StepChoice:
    """The time step a diagnosis replays at, and why: the coarse step's nominal replays against the fine step's."""

    time_step: float  # s, chosen
    fine: float  # s, the recordings' own
    coarse: float | None = None  # s, tried (None: not tried)
    share: float | None = None  # chi^2 of the coarse-minus-fine residual over the fine replays' chi^2 above the noise
    failed: int = 0  # coarse replays that failed
    asked: bool = False  # the caller set the step (`Runner.time_step`): nothing was tried

    @property
    def coarse_chosen(self) -> bool:
        return self.coarse is not None and self.time_step == self.coarse

    def sentence(self) -> str:
        if self.asked:
            return f"replayed at {1e3 * self.time_step:g} ms, as asked"
        if self.coarse is None:
            return f"replayed at the recordings' time step ({1e3 * self.fine:g} ms)"
        if self.failed:
            why = f"{self.failed} replay(s) at {1e3 * self.coarse:g} ms failed"
        elif self.share is None:
            why = "the nominal replays sit at the noise floor, where the coarse step's own error would read as physics"
        else:
            why = (f"at {1e3 * self.coarse:g} ms the nominal replays differ from those at {1e3 * self.fine:g} ms by "
                   f"{_percent(self.share)} % of their chi^2 above the noise (at most {100 * STEP_SHARE:g} % allowed)")
        return f"replayed at {1e3 * self.time_step:g} ms: {why}"

    def to_json(self) -> dict:
        return {"time_step_s": self.time_step, "fine_s": self.fine, "coarse_s": self.coarse,
                "share": None if self.share is None else float(f"{self.share:.4g}"), "failed": self.failed,
                "asked": self.asked, "note": self.sentence()}


def _above(chi2: float, bound: float) -> bool:
    return chi2 > bound + EXCEEDS * (abs(bound) + 1.0)


def _percent(share: float) -> str:
    return f"{100 * share:.2g}" if share < 0.1 else f"{100 * share:.0f}"


def choose_time_step(runner: Runner, indices: Sequence[int], coarse: float = COARSE_STEP) -> StepChoice:
    """Replay at `coarse` when that changes the nominal replays by little against what the diagnosis explains.

    A diagnosis runs hundreds of replays, and a 3 ms step costs about 0.7 of a 2 ms one (the contact solve is per
    step; docs/diagnosis.md). The coarser step is a slightly different model: its nominal residual differs from
    the fine one by d. It is taken when chi^2(d) is at most STEP_SHARE of the fine replays' chi^2 above the noise
    (|d| at most a tenth of the mismatch's size): a twentieth of the smallest change of chi^2 the verdict counts
    (MIN_GAIN, CV_GAIN: 20-25 %), and the same d shifts every model alike. Where the recordings sit near the
    noise (a world the model matches), the step's own error would be read as physics: the fine step stays. Not
    4 ms: the steel blocks of the MIT data replay well at 4 ms until the surface is tilted by a few mrad, where
    they hop off it (a stability limit the nominal replays do not show); 3 ms tracks 2 ms along the parameter
    lines tried (tilt, mass, centre of mass). Sets `runner.time_step` to the choice; costs one replay of each
    recording (the other step's replays are those `locate` reads). A step the caller set is kept as asked."""
    fine_step = runner.job((), indices[0]).rollout.config.time_step
    if runner.time_step is not None:
        return StepChoice(runner.time_step, fine_step, asked=True)
    if fine_step >= coarse:
        return StepChoice(fine_step, fine_step)
    # as `locate` asks for them: the rollout cache answers its nominal replays at whichever step is kept
    fine = runner.run((), indices, tracks=True, contacts=True)
    runner.time_step = coarse
    rough = runner.run((), indices, tracks=True, contacts=True)
    failed = sum(r.failed is not None for r in rough)
    excess = sum(r.chi2 - r.normalised.size for r in fine)
    d = vector_of(rough) - vector_of(fine)
    share = float(d @ d) / excess if excess > 0 else None
    if failed or any(r.failed is not None for r in fine) or share is None or share > STEP_SHARE:
        runner.time_step = None
    return StepChoice(runner.time_step or fine_step, fine_step, coarse, share, failed)


@dataclass(frozen=True)
class ScaleChoice:
    """Which recordings a diagnosis replays faster than they ran (quasi-static), and why."""

    speeds: Mapping[str, float]  # recording -> m/s: how fast its objects (and a planar rod) moved while moving
    tried: Mapping[str, float]  # recording -> the scale tried
    shares: Mapping[str, float | None]  # recording -> chi^2 of the change over its nominal chi^2 above the noise
    taken: Mapping[str, float]  # recording -> the scale kept
    asked_off: bool = False

    def sentence(self) -> str:
        if self.asked_off:
            return "every recording replayed at its own speed, as asked"
        if not self.tried:
            return (f"every recording replayed at its own speed: none moved slower than "
                    f"{1e3 * QUASI_STATIC_SPEEDS[0] / MIN_SCALE:.0f} mm/s")
        kept = ", ".join(f"{n} x{k:.2g}" for n, k in self.taken.items()) or "none"
        refused = [n for n in self.tried if n not in self.taken]
        text = (f"slow recordings replayed faster (quasi-static, at most {1e3 * QUASI_STATIC_SPEEDS[0]:.0f} mm/s): "
                f"{kept}")
        if refused:
            text += (f"; at their own speed: {', '.join(refused)} (the faster replay changed it by more than "
                     f"{100 * STEP_SHARE:g} % of its chi^2 above the noise, or it sits at the noise)")
        return text

    def to_json(self) -> dict:
        return {"speeds_mps": {n: float(f"{v:.4g}") for n, v in self.speeds.items()},
                "tried": {n: round(k, 4) for n, k in self.tried.items()},
                "taken": {n: round(k, 4) for n, k in self.taken.items()},
                "shares": {n: None if v is None else float(f"{v:.4g}") for n, v in self.shares.items()},
                "note": self.sentence()}


def recording_speed(p: Prepared) -> float:
    """How fast a recording's motion went (m/s): the largest 90th percentile, over its observed objects and a
    planar robot's rod, of the speed at the samples where that one moves (a tenth of its top speed or more),
    each speed over SPEED_WINDOW (a difference of noisy poses 40 ms apart reads 0.2 mm of noise as 5 mm/s)."""
    from .outline import rod_xy

    paths = [(s.times, s.xyz[:, :2]) for s in p.series]
    rod = rod_xy(p.trial, p.series[0].object, p.series[0].times)
    if rod is not None:
        paths.append((p.series[0].times, rod))
    fastest = 0.0
    for times, xy in paths:
        if len(times) < 3:
            continue
        speed = np.linalg.norm(window_rate(times, xy, SPEED_WINDOW), axis=1)
        top = float(np.max(speed))
        if top > 0.0:
            fastest = max(fastest, float(np.percentile(speed[speed >= 0.1 * top], 90)))
    return fastest


def choose_time_scales(runner: Runner, indices: Sequence[int], enabled: bool = True) -> ScaleChoice:
    """Replay slow recordings faster (`rollout.quasi_static`) where that changes their nominal replay by little
    against what the diagnosis explains.

    A recording whose motion went slower than a speed of QUASI_STATIC_SPEEDS / MIN_SCALE is tried at that speed
    (at most MAX_SCALE times faster), the fastest first; it keeps the first scale at which the change d of its
    nominal residual has chi^2(d) at most STEP_SHARE of its nominal chi^2 above the noise: the rule the time step
    follows, per recording (`choose_time_step`). Near the noise (a world the model matches) or where every faster
    replay fails, the recording runs at its own speed. Costs one replay of each recording at each scale tried
    (the nominal replays at their own speed are those the step's choice ran). Sets `runner.time_scales`."""
    names = {i: runner.prepared[i].name for i in indices}
    speeds = {i: recording_speed(runner.prepared[i]) for i in indices}
    if not enabled:
        runner.time_scales = {}
        return ScaleChoice({names[i]: v for i, v in speeds.items()}, {}, {}, {}, asked_off=True)
    tried: dict[int, float] = {}
    shares: dict[int, float | None] = {}
    taken: dict[int, float] = {}
    base: dict[int, Run] = {}  # at its own speed
    for speed in QUASI_STATIC_SPEEDS:
        scales = {i: min(MAX_SCALE, speed / v) for i, v in speeds.items() if v > 0.0 and i not in taken}
        # a slower scale, and only where the own-speed replay left something to compare with (not at the noise)
        scales = {i: k for i, k in scales.items() if MIN_SCALE <= k < tried.get(i, math.inf)
                  and (i not in base or _excess(base[i]) > 0.0)}
        if not scales:
            continue
        order = sorted(scales)
        runner.time_scales = {}
        new = [i for i in order if i not in base]
        base.update(zip(new, runner.run((), new, tracks=True, contacts=True)))
        runner.time_scales = dict(scales)
        for i, fast in zip(order, runner.run((), order, tracks=True, contacts=True)):
            ok = fast.failed is None and _excess(base[i]) > 0.0
            d = fast.normalised - base[i].normalised if ok else None
            tried[i], shares[i] = scales[i], (float(d @ d) / _excess(base[i]) if ok else None)
            if ok and shares[i] <= STEP_SHARE:
                taken[i] = scales[i]
    runner.time_scales = taken
    return ScaleChoice({names[i]: v for i, v in speeds.items()}, {names[i]: k for i, k in tried.items()},
                       {names[i]: v for i, v in shares.items()}, {names[i]: k for i, k in taken.items()})


def _excess(run: Run) -> float:
    """chi^2 above the noise of a replay that did not fail (-1 for one that did: nothing to compare with)."""
    return run.chi2 - run.normalised.size if run.failed is None else -1.0


def default_workers() -> int:
    return max(1, min(2, os.cpu_count() or 1))


def chi2_of(runs: Sequence[Run]) -> tuple[float, int]:
    """Total chi^2 and number of normalised residual values over runs."""
    return float(sum(r.chi2 for r in runs)), int(sum(r.normalised.size for r in runs))


def vector_of(runs: Sequence[Run]) -> np.ndarray:
    return np.concatenate([r.normalised for r in runs]) if runs else np.zeros(0)


def all_finite(runs: Sequence[Run]) -> bool:
    return all(r.failed is None for r in runs) and all(math.isfinite(r.chi2) for r in runs)
