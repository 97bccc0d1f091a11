"""Fit simulation parameters to recordings (the paper's Section V): split off held-out trials, run an optimiser
over the free parameters, checkpoint every generation, and score the result before and after.

    with make_executor("process", odb, workers=2) as ex:
        result = fit_parameters(trials, spec, odb=odb, executor=ex, optimizer="cmaes", seed=1, generations=30)

The evolution strategies work in [0, 1]^D (each free parameter's bounds mapped linearly, or logarithmically for
`scale: log`); Levenberg-Marquardt (`optimizer="lm"`) in normalised coordinates on the residual whose squared
norm is the same error, one Jacobian batch per "generation". The history is turned back into parameter units for
the report. "Before" is the start values.
"""
from __future__ import annotations

import json
import time as wallclock
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ..errors import FitError
from ..files import write_atomic
from ..odb import ObjectDatabase
from ..optim import NAMES, GenerationRecord, make_optimizer, restore_optimizer
from ..optim.base import Progress as OptimizerProgress
from ..optim.base import StopRule, Tracked
from ..optim.lm import levenberg_marquardt
from ..params import ParameterSet, check_targets, check_values
from ..rollout.compare import DEFAULT_C, PoseError
from ..rollout.executors import Executor, make_executor
from ..rollout.rollout import Rollout
from ..rollout.trials import Trial
from ..timelimit import STOPPED, TimeLimit
from .evaluate import Evaluation, TrialError, evaluate

CHECKPOINT_FILE = "checkpoint.json"
CHECKPOINT_FORMAT = 1
HOLD_OUT_SHARE = 0.25
HOLD_OUT_MIN_TRIALS = 4
ES_PARENT_SHARE = 4  # the paper: lambda = 40, mu = 10


@dataclass(frozen=True)
class GenerationErrors:
    """A generation's errors with their parts, for Table I and Fig. 4 (c), (f).

    `best` is the best individual so far; `selected_*` are over the generation's mu best candidates
    (mean and 80th percentile), `failures` the failed simulations in the generation.
    """

    generation: int
    best: PoseError
    best_values: tuple[float, ...]
    generation_best: PoseError
    selected_e_t: tuple[float, float]
    selected_e_R: tuple[float, float]
    failures: int
    elapsed: float

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> "GenerationErrors":
        return cls(d["generation"], PoseError(**d["best"]), tuple(d["best_values"]), PoseError(**d["generation_best"]),
                   tuple(d["selected_e_t"]), tuple(d["selected_e_R"]), d["failures"], d["elapsed"])


@dataclass(frozen=True)
class Progress:
    """What the progress callback gets after each generation."""

    generation: int
    max_generations: int
    best_e: float
    generation_best_e: float
    evaluations: int
    simulations: int
    failures: int
    elapsed: float


@dataclass(frozen=True)
class FitResult:
    spec: ParameterSet
    values: Mapping[str, float]  # fitted free parameters, parameter units
    start: Mapping[str, float]
    fit_trials: tuple[str, ...]
    held_out: tuple[str, ...]
    before: PoseError  # on the fitted trials, at the start values
    after: PoseError
    held_out_before: PoseError | None
    held_out_after: PoseError | None
    trial_errors_before: tuple[TrialError, ...]  # every trial, fitted then held out
    trial_errors_after: tuple[TrialError, ...]
    optimizer: str
    seed: int
    generations: int
    evaluations: int  # candidates evaluated (each on every fitted trial)
    simulations: int  # Drake replays, the before/after scoring included
    failures: int  # failed replays during the search
    stop_reason: str
    history: tuple[GenerationRecord, ...]  # the optimiser's, in [0, 1]^D
    generation_errors: tuple[GenerationErrors, ...]
    wall_time: float
    executor: str = "serial"
    workers: int = 1
    notes: tuple[str, ...] = field(default=())
    std: Mapping[str, float] = field(default_factory=dict)  # 1 sigma of each fitted value (see `_uncertainty`)
    stopped: str | None = None  # "time limit": the search was cut short, `values` is the best candidate so far
    time_limit: float | None = None  # s, when one was set
    stopped_after: float | None = None  # s of search when the time limit stopped it
    max_generations: int | None = None  # what the optimiser was allowed
    rollouts: Mapping[str, int] = field(default_factory=dict)  # of `simulations`: {simulated, cached} (rollout cache)

    @property
    def partial(self) -> bool:
        return self.stopped is not None

    @property
    def fitted_spec(self) -> ParameterSet:
        return self.spec.fixed_at(self.values, self.std)


def split_hold_out(names: Sequence[str], hold_out: int | None, seed: int) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(fitted, held out): `hold_out` trials (default: 25 %, at least 1, when there are >= 4) chosen by a shuffle
    seeded with `seed`; the fitted keep their given order."""
    n = len(names)
    if hold_out is None:
        hold_out = max(1, round(HOLD_OUT_SHARE * n)) if n >= HOLD_OUT_MIN_TRIALS else 0
    if not isinstance(hold_out, (int, np.integer)) or hold_out < 0:
        raise FitError(f"hold_out must be a whole number >= 0, got {hold_out!r}")
    if hold_out >= n:
        raise FitError(f"cannot hold out {hold_out} of {n} trial(s): at least one must remain to fit")
    order = np.random.default_rng(seed).permutation(n)
    held = set(int(i) for i in order[:hold_out])
    return (tuple(nm for i, nm in enumerate(names) if i not in held), tuple(nm for i, nm in enumerate(names) if i in held))


def check_trials(trials: Sequence[Trial]) -> None:
    """Trials must be Trial values with at least one observed pose after t = 0."""
    if not trials:
        raise FitError("no trials to fit")
    for trial in trials:
        if not isinstance(trial, Trial):
            raise FitError(f"expected Trial values, got {type(trial).__name__}")
        if not any(float(tr.times[-1]) > 0 for tr in trial.observations):
            raise FitError("no observation after t = 0: nothing to compare the simulation with",
                           source=str(trial.source))


def fit_parameters(trials: Sequence[Trial], spec: ParameterSet, *, odb: ObjectDatabase, optimizer: str = "cmaes",
                   seed: int = 0, generations: int = 30, popsize: int | None = None, sigma0: float = 0.25,
                   executor: Executor | None = None, hold_out: int | None = None,
                   checkpoint: str | Path | None = None, resume: bool = False, patience: int = 8, tol: float = 1e-6,
                   target_error: float | None = None, c: float = DEFAULT_C,
                   progress: Callable[[Progress], None] | None = None, time_limit: float | None = None) -> FitResult:
    """Fit the free parameters of `spec` to `trials` (see the module docstring).

    `checkpoint` is a folder: after every generation DIR/checkpoint.json holds the optimiser and the bookkeeping;
    `resume` continues from it (it must be the same fit: trials, parameters, optimiser, seed; not for "lm").
    Early stop: no improvement of the best error by more than `tol` (m) for `patience` generations, or the best
    error at or below `target_error`. `time_limit` (s, from the call): no new generation starts once it has
    passed (the first always runs); the result is the best candidate so far, scored as usual, with `stopped` =
    "time limit" (a checkpointed es/cmaes fit can be continued with `resume`).
    """
    started = wallclock.perf_counter()
    limit = TimeLimit(time_limit)
    check_trials(trials)
    if not spec.free:
        raise FitError("the parameter file has no free parameter (entries with bounds)", source=spec.source)
    check_targets(spec, [t.world for t in trials], odb)
    check_values(spec, [Rollout(t.world, t.telemetry, name=t.name) for t in trials], odb)
    by_name = {t.name: t for t in trials}
    if len(by_name) != len(trials):
        raise FitError("trial names must be unique (load_trials makes them so)")
    if not isinstance(generations, (int, np.integer)) or generations < 1:
        raise FitError(f"generations must be a whole number >= 1, got {generations!r}")
    if optimizer not in NAMES:
        raise FitError(f"unknown optimizer {optimizer!r}; valid: {', '.join(NAMES)}")
    if optimizer == "lm" and resume:
        raise FitError("a Levenberg-Marquardt fit keeps no checkpoint to resume from; use es or cmaes")
    fit_names, held_names = split_hold_out([t.name for t in trials], hold_out, seed)
    fit_set, held_set = [by_name[n] for n in fit_names], [by_name[n] for n in held_names]
    own_executor = executor is None
    executor = executor or make_executor("serial", odb)
    counts0 = executor.cache.counts()
    path = None if checkpoint is None else Path(checkpoint) / CHECKPOINT_FILE
    fingerprint = _fingerprint(spec, fit_names, held_names, optimizer, seed, c)
    try:
        state = _RunState.resume(path, fingerprint) if resume else None
        if state is None:
            if resume and path is not None and not path.is_file():
                raise FitError("no checkpoint to resume from", source=str(path))
            options = _optimizer_options(optimizer, popsize, generations, patience, tol, target_error)
            opt = (_LeastSquaresRun(StopRule(**options)) if optimizer == "lm" else
                   make_optimizer(optimizer, spec.to_unit(spec.start_values()), sigma0, seed, **options))
            start_rows = evaluate(executor, fit_set + held_set, spec, [spec.start_values()], c=c)[0].errors
            state = _RunState(opt, tuple(start_rows), simulations=len(start_rows))
        opt = state.optimizer
        max_generations = int(opt.state()["options"]["max_generations"])

        def generation(values: list[np.ndarray], units: list[np.ndarray]) -> list[Evaluation]:
            """Evaluate one batch on the fitted trials, tell the optimiser, record, checkpoint, report."""
            batch = evaluate(executor, fit_set, spec, values, c=c)
            rows = [list(b.errors) for b in batch]
            merged = [b.error for b in batch]
            opt.tell(units, [m.e for m in merged])
            state.record(spec, values, merged, rows, opt, wallclock.perf_counter() - started)
            if path is not None and optimizer != "lm":
                state.save(path, fingerprint)
            if progress is not None:
                last = state.generation_errors[-1]
                progress(Progress(opt.generation, max_generations, last.best.e, last.generation_best.e,
                                  opt.evaluations, state.simulations, state.failures,
                                  wallclock.perf_counter() - started))
            return batch

        stopped = None
        if optimizer == "lm":
            opt.run(spec, generation, should_stop=limit.expired)
            stopped = STOPPED if opt.stopped_by_limit else None
        while not opt.done:
            if opt.generation > 0 and limit.expired():
                stopped = STOPPED
                break
            candidates = opt.ask()
            generation([spec.from_unit(u) for u in candidates], candidates)
        best = spec.from_unit(opt.best_x)
        after_rows = evaluate(executor, fit_set + held_set, spec, [best], c=c)[0].errors
        rollouts = {k: v - counts0[k] for k, v in executor.cache.counts().items()}
    finally:
        if own_executor:
            executor.close()
    before_rows = state.start_rows
    n_fit = len(fit_set)
    return FitResult(
        spec=spec, values=spec.as_dict(best), start=spec.as_dict(spec.start_values()),
        fit_trials=fit_names, held_out=held_names,
        before=_merge(before_rows[:n_fit]), after=_merge(after_rows[:n_fit]),
        held_out_before=_merge(before_rows[n_fit:]) if held_set else None,
        held_out_after=_merge(after_rows[n_fit:]) if held_set else None,
        trial_errors_before=tuple(before_rows), trial_errors_after=tuple(after_rows),
        optimizer=optimizer, seed=seed, generations=opt.generation, evaluations=opt.evaluations,
        simulations=state.simulations + len(after_rows), failures=state.failures,
        stop_reason=(f"{limit.text()} reached after {opt.generation} of {max_generations} generations" if stopped
                     else opt.stop_reason or ""),
        history=opt.history, generation_errors=tuple(state.generation_errors),
        wall_time=wallclock.perf_counter() - started, executor=executor.kind, workers=executor.workers,
        notes=tuple(dict.fromkeys(n for t in trials for n in t.notes)), std=_uncertainty(spec, opt),
        stopped=stopped, time_limit=limit.seconds, stopped_after=limit.stopped_after, max_generations=max_generations,
        rollouts=rollouts)


def _uncertainty(spec: ParameterSet, opt) -> dict[str, float]:
    """1 sigma of each fitted value: from the curvature for Levenberg-Marquardt (cov = (J^T J)^-1 |r|^2 / (n - k),
    the classic estimate for least squares), else from the spread of the last generation's selected individuals
    ((p80 - p20) / 1.68 of a normal), mapped back from the unit box. Either is the optimiser's own estimate, not
    a posterior; `bridge infer --samples` draws from it."""
    if isinstance(opt, _LeastSquaresRun):
        return opt.std(spec)
    last = opt.history[-1]
    out = {}
    for p, lo, hi in zip(spec.free, last.p20_x, last.p80_x):
        out[p.name] = abs(p.from_unit(hi) - p.from_unit(lo)) / 1.683
    return out


def _merge(rows: Sequence[TrialError]) -> PoseError:
    return PoseError.merge(r.error for r in rows)


def _optimizer_options(name: str, popsize: int | None, generations: int, patience: int, tol: float,
                       target_error: float | None) -> dict[str, Any]:
    options: dict[str, Any] = {"max_generations": int(generations), "patience": int(patience), "tol": float(tol),
                               "target_error": target_error}
    if popsize is not None and name != "lm":
        if not isinstance(popsize, (int, np.integer)) or popsize < 2:
            raise FitError(f"popsize must be a whole number >= 2, got {popsize!r}")
        if name == "es":
            mu = max(2, popsize // ES_PARENT_SHARE)
            options.update(lam=int(popsize), mu=mu, rho=min(2, mu))
        else:
            options["popsize"] = int(popsize)
    return options


def _fingerprint(spec: ParameterSet, fit_names, held_names, optimizer: str, seed: int, c: float) -> dict[str, Any]:
    return {"params": spec.to_dict()["params"], "fit_trials": list(fit_names), "held_out": list(held_names),
            "optimizer": optimizer, "seed": seed, "c": c}


class _LeastSquaresRun(Tracked):
    """Levenberg-Marquardt in the fit driver's terms: each residual batch it asks for (a point, or a Jacobian's
    columns) is one "generation" of the history; the solver itself runs inside `run`, not through ask/tell."""

    name = "lm"

    def __init__(self, rule: StopRule):
        self.rule = rule
        self._progress = OptimizerProgress(rule)
        self._stopped: str | None = None
        self.stopped_by_limit = False

    def run(self, spec: ParameterSet, generation: Callable, should_stop: Callable[[], bool] | None = None) -> None:
        lower, upper = spec.normal_bounds()

        def residuals(xs: Sequence[np.ndarray]) -> list[np.ndarray]:
            values = [spec.from_normal(x) for x in xs]
            return [b.vector for b in generation(values, [spec.to_unit(v) for v in values])]

        self._found = levenberg_marquardt(residuals, spec.to_normal(spec.start_values()), lower, upper,
                                          max_iterations=self.rule.max_generations, should_stop=should_stop)
        self.stopped_by_limit = self._found.stopped
        self._stopped = f"Levenberg-Marquardt: {self.rule.max_generations} solver evaluations at most"

    def std(self, spec: ParameterSet) -> dict[str, float]:
        if self._found.jacobian is None:  # stopped before a Jacobian was evaluated
            return {}
        J, r = self._found.jacobian, self._found.vector
        s2 = float(r @ r) / max(1, r.size - spec.dim)
        sd = np.sqrt(np.maximum(np.diag(np.linalg.pinv(J.T @ J)), 0.0) * s2) * spec.steps
        return {n: float(v) for n, v in zip(spec.names, sd)}

    def tell(self, units: Sequence[np.ndarray], errors: Sequence[float]) -> None:
        u = np.array(units, dtype=float)
        e = np.asarray(errors, dtype=float)
        best = np.argsort(e, kind="stable")[:max(1, len(e) // ES_PARENT_SHARE)]
        self._progress.record(u, e, u[best], e[best], float("nan"))

    def state(self) -> dict:
        return {"name": self.name, "options": {"max_generations": self.rule.max_generations}}

    @property
    def stop_reason(self) -> str | None:
        return self._stopped


class _RunState:
    """The driver's bookkeeping next to the optimiser; all of it goes into the checkpoint. Mutable by design."""

    def __init__(self, optimizer, start_rows: tuple[TrialError, ...], simulations: int = 0, failures: int = 0,
                 generation_errors: list[GenerationErrors] | None = None, elapsed_before: float = 0.0):
        self.optimizer = optimizer
        self.start_rows = start_rows
        self.simulations = simulations
        self.failures = failures
        self.generation_errors = generation_errors or []
        self.best: tuple[PoseError, tuple[float, ...]] | None = (
            (self.generation_errors[-1].best, self.generation_errors[-1].best_values) if self.generation_errors else None)

    def record(self, spec: ParameterSet, values, merged: list[PoseError], rows, opt, elapsed: float) -> None:
        e = np.array([m.e for m in merged])
        order = np.argsort(e, kind="stable")
        k = int(order[0])
        if self.best is None or merged[k].e < self.best[0].e:
            self.best = (merged[k], tuple(float(v) for v in values[k]))
        mu = max(1, len(e) // ES_PARENT_SHARE)
        sel = [merged[int(i)] for i in order[:mu]]
        failed = sum(1 for row in rows for r in row if r.failed)
        self.simulations += sum(len(row) for row in rows)
        self.failures += failed

        def stats(xs: list[float]) -> tuple[float, float]:
            return float(np.mean(xs)), float(np.percentile(xs, 80))

        self.generation_errors.append(GenerationErrors(
            generation=opt.generation - 1, best=self.best[0], best_values=self.best[1], generation_best=merged[k],
            selected_e_t=stats([s.e_t for s in sel]), selected_e_R=stats([s.e_R for s in sel]), failures=failed,
            elapsed=elapsed))

    def save(self, path: Path, fingerprint: Mapping[str, Any]) -> None:
        data = {"format": CHECKPOINT_FORMAT, "fit": fingerprint, "optimizer": self.optimizer.state(),
                "start_rows": [asdict(r) for r in self.start_rows], "simulations": self.simulations,
                "failures": self.failures, "generation_errors": [asdict(g) for g in self.generation_errors]}
        write_atomic(path, json.dumps(data))

    @classmethod
    def resume(cls, path: Path | None, fingerprint: Mapping[str, Any]) -> "_RunState | None":
        if path is None:
            raise FitError("resuming needs a checkpoint folder (--out DIR)")
        if not path.is_file():
            return None
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise FitError(f"cannot read the checkpoint: {exc}", source=str(path)) from None
        if not isinstance(data, dict) or data.get("format") != CHECKPOINT_FORMAT:
            raise FitError(f"not a bridge fit checkpoint (format {CHECKPOINT_FORMAT})", source=str(path))
        saved = data.get("fit", {})
        differ = [k for k in fingerprint if json.loads(json.dumps(fingerprint[k])) != saved.get(k)]
        if differ:
            raise FitError(f"the checkpoint is of a different fit ({', '.join(differ)} differ); remove it or run "
                           "without --resume", source=str(path))
        try:
            rows = tuple(TrialError(r["trial"], PoseError(**r["error"]), r["failure"], r["wall_time"],
                                    r.get("cpu_time", 0.0)) for r in data["start_rows"])
            errors = [GenerationErrors.from_dict(g) for g in data["generation_errors"]]
            return cls(restore_optimizer(data["optimizer"]), rows, int(data["simulations"]), int(data["failures"]),
                       errors)
        except (KeyError, TypeError, ValueError) as exc:
            raise FitError(f"the checkpoint is incomplete: {exc!r}", source=str(path)) from None


def result_summary(result: FitResult) -> str:
    """One paragraph for the terminal."""
    lines = [f"{result.optimizer}: {result.generations} generations, {result.evaluations} candidates, "
             f"{result.simulations} simulations ({result.failures} failed"
             + (f", {result.rollouts['cached']} from the rollout cache" if result.rollouts.get("cached") else "")
             + f"), {result.wall_time:.1f} s on "
             f"{result.workers} {result.executor} worker(s); stopped: {result.stop_reason}"]
    if result.partial:
        lines.append("  partial result: the best candidate when the time limit stopped the search (not converged)")
    for name, value in result.values.items():
        lines.append(f"  {name} = {value:.6g} (start {result.start[name]:.6g})")
    lines.append(f"  fitted trials ({len(result.fit_trials)}): e {result.before.e:.5f} -> {result.after.e:.5f}")
    if result.held_out_before is not None:
        lines.append(f"  held-out trials ({len(result.held_out)}): e {result.held_out_before.e:.5f} -> "
                     f"{result.held_out_after.e:.5f}")
    return "\n".join(lines)


__all__ = ["CHECKPOINT_FILE", "FitResult", "GenerationErrors", "Progress", "fit_parameters", "result_summary",
           "split_hold_out"]
