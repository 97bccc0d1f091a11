"""`bridge diagnose` end to end: trials -> held-out split -> identify -> scene file, diagnosis.json, report, plots."""
from __future__ import annotations

import io
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from ..errors import DiagnosisError
from ..odb import ObjectDatabase
from ..files import Content, write_atomic
from ..params import Model, Parameter, ParameterSet, kind_named, param_file_text
from ..rollout.executors import Executor, make_executor
from ..rollout.trials import Trial
from ..timelimit import TimeLimit
from .forks import measure_forks
from .identify import Identification, Options, identify, measured_model
from .locate import Localisation, locate
from .report import (MAX_RESIDUAL_PLOTS, diagnosis_json, parameters_text, plot_paths, plot_residuals, plot_scores,
                     report_markdown, write_outputs)
from .runs import Runner, choose_time_scales, choose_time_step, default_workers, prepare

RESIDUAL_RATE = 25.0  # Hz at which observed and simulated poses are compared
SCENE_FILE = "scene.yaml"


@dataclass(frozen=True, eq=False)
class DiagnosisRun:
    identification: Identification
    data: dict[str, Any]
    files: dict[str, Path]
    after: Localisation | None


def held_out_indices(n: int, held_out: int | None) -> list[int]:
    """Default: a quarter of the recordings (at least one) when there are 4 or more, spread evenly."""
    if held_out is None:
        held_out = max(1, round(n / 4)) if n >= 4 else 0
    if held_out < 0 or held_out >= n:
        raise DiagnosisError(f"cannot hold out {held_out} of {n} recording(s): at least one must be fitted")
    if held_out == 0:
        return []
    return sorted({int(round(k)) for k in np.linspace(n - 1, 0, held_out + 2)[:-1][:held_out]})


def run_diagnosis(trials: Sequence[Trial], odb: ObjectDatabase, out: str | Path | None, *,
                  held_out: int | None = None, workers: int | None = None, options: Options = Options(),
                  plots: bool = True, executor: Executor | None = None,
                  log: Callable[[str], None] | None = None,
                  progress: Callable[[int, int | None], None] | None = None,
                  time_limit: float | None = None, time_step: float | str = "auto",
                  quasi_static: bool = True) -> DiagnosisRun:
    """Diagnose `trials`; write outputs under `out` when given. Simulations run on `executor` (default: a process
    pool of `workers`, serial for one). `progress(done, total)` counts the steps of the search (`identify`);
    `time_limit` (s, from the call) stops the search there with the best so far: diagnosis.json then says
    "stopped": "time limit" and the report that the verdict is partial. `time_step` (s) of every replay; "auto":
    the coarse step (`runs.COARSE_STEP`) when its error is small against the mismatch (`choose_time_step`), else
    the recordings' own. `quasi_static`: slow recordings may be replayed faster where that changes little
    (`choose_time_scales`); False replays every recording at its own speed."""
    started = time.perf_counter()
    limit = TimeLimit(time_limit)
    if not trials:
        raise DiagnosisError("no recordings to diagnose")
    if time_step != "auto" and not (isinstance(time_step, (int, float)) and math.isfinite(time_step) and time_step > 0):
        raise DiagnosisError(f"time_step must be 'auto' or a finite number of seconds > 0, got {time_step!r}",
                             field="time_step")
    prepared = [prepare(t, odb, RESIDUAL_RATE) for t in trials]
    held = held_out_indices(len(prepared), held_out)
    train = [i for i in range(len(prepared)) if i not in held]
    n = default_workers() if workers is None else workers
    own = executor is None
    executor = executor or make_executor("serial" if n == 1 else "process", odb, workers=n)
    try:
        runner = Runner(prepared, odb, executor, time_step=None if time_step == "auto" else float(time_step))
        step = choose_time_step(runner, sorted(train + held))
        scales = choose_time_scales(runner, sorted(train + held), quasi_static)
        # where the object is known to be includes the calibration the recordings measure (a rod offset of 4 mm
        # moves a corner push off its fork, or onto one)
        forks = measure_forks(runner, sorted(train + held), model=measured_model(runner, train, held))
        if log is not None:
            log(step.sentence())
            log(scales.sentence())
            log(forks.sentence())
        ident = identify(runner, train, held, options, log=log, progress=progress, limit=limit)
        after = None
        if out is not None and plots and ident.verdict != "none":
            after = locate(runner, list(range(len(prepared))), model=ident.winner.model)
    finally:
        if own:
            executor.close()
    files: dict[str, Path] = {}
    data: dict[str, Any]
    failures = {"count": len(runner.failures), "first": [f"{t}: {m}" for t, m in runner.failures[:3]]}
    rollouts = runner.rollouts()  # the whole diagnosis, the replays of the plots included
    extra = {**limit.to_json(ident.partial), "rollouts": rollouts, "time_step": step.to_json(),
             "time_scales": scales.to_json(), "forks": forks.to_json(),
             "simulations": runner.simulations}  # the step's choice and the plots' replays included
    if out is None:
        data = diagnosis_json(ident, failures=failures)
        data.update(extra)
        return DiagnosisRun(ident, data, files, after)
    out = Path(out)
    scene_path = out / SCENE_FILE
    others: dict[Path, Content] = {scene_path: None}  # a scene file of an earlier diagnosis goes with its report
    if ident.verdict != "none":
        others[scene_path] = scene_file_text(scene_path, ident.winner.model, odb,
                                             {"verdict": ident.verdict, "target": ident.winner.target,
                                              "recordings": list(ident.train) + list(ident.held_out)},
                                             std=ident.winner.model_std)
    data = diagnosis_json(ident, scene_file=SCENE_FILE if others[scene_path] else None, failures=failures)
    data.update(extra)
    data["seconds"] = round(time.perf_counter() - started, 2)
    figures: dict[Path, Content] = {}
    if plots:
        figures = _plots(ident, after, out)
        others.update({p: None for p in out.glob("residual_*.png") if p not in figures})  # an earlier run's
        others.update(figures)
    json_path, md_path = write_outputs(out, data, report_markdown(ident, data, [str(p) for p in figures]), others)
    files.update({"json": json_path, "report": md_path})
    if others[scene_path] is not None:
        files["scene"] = scene_path
    return DiagnosisRun(ident, data, files, after)


def save_scene_file(path: Path, model: Model, odb: ObjectDatabase, diagnosis: dict[str, Any],
                    std: dict[str, float] | None = None) -> Path:
    """The diagnosed model as a parameter file of fixed values, each entry labelled with its effect and, where the
    fit measured it, its 1-sigma uncertainty (`std`: what `bridge infer --samples` draws from): `bridge
    infer`/`view`/`demo --scene` replay with it, `bridge fit --scene` fits on top of it, `--params` takes it too."""
    write_atomic(path, scene_file_text(path, model, odb, diagnosis, std))
    return Path(path)


def scene_file_text(path: Path, model: Model, odb: ObjectDatabase, diagnosis: dict[str, Any],
                    std: dict[str, float] | None = None) -> str:
    """What `save_scene_file` writes to `path` (a diagnosis publishes it with its report as one set)."""
    std = {k: v for k, v in (std or {}).items() if math.isfinite(v)}
    entries = tuple(Parameter(kind_named(s.kind), s.target, value=s.value, effect=s.effect, std=std.get(s.name))
                    for s in model)
    header = ("bridge scene file (bridge diagnose): the fitted ordinary parameters and the diagnosed effect, as\n"
              "fixed parameter values; use it with --scene (infer, view, demo, fit) or --params")
    return param_file_text(ParameterSet(entries, str(path)), header=header, record={"diagnosis": diagnosis})


def _plots(ident: Identification, after: Localisation | None, out: Path) -> dict[Path, Content]:
    """The report's figures, drawn into memory (published with the report): path -> PNG bytes."""
    def png(plot, *args) -> bytes:
        buffer = io.BytesIO()
        plot(*args, buffer)
        return buffer.getvalue()

    figures: dict[Path, Content] = {out / "effects.png": png(plot_scores, ident)}
    before = ident.localisation
    if ident.held_out_localisation is not None:
        before = Localisation(before.objects + ident.held_out_localisation.objects)
    figures[out / "paths.png"] = png(plot_paths, before, after)
    after_by = {(o.recording, o.object): o for o in (after.objects if after else ())}
    for o in before.ranking()[:MAX_RESIDUAL_PLOTS]:
        name = "".join(c if c.isalnum() or c in "-_" else "_" for c in f"residual_{o.recording}_{o.object}")
        figures[out / f"{name[:80]}.png"] = png(plot_residuals, o, after_by.get((o.recording, o.object)))
    return figures


def diagnose_paths(paths: Sequence[str | Path], odb: ObjectDatabase, out: str | Path, *, held_out: int | None = None,
                   workers: int | None = None, effects: Sequence[str] | None = None, max_duration: float | None = None,
                   quiet: bool = False, shape: str | None = None, time_limit: float | None = None,
                   time_step: float | str = "auto", log: Callable[[str], None] | None = None,
                   progress: Callable[[int, int | None], None] | None = None,
                   quasi_static: bool = True, contact: bool = True) -> DiagnosisRun:
    """Load recordings (folders, MIT .h5 files, folders of .h5 files; `shape` for .h5 files whose name does not
    tell theirs) and diagnose them. `log` defaults to stderr (nothing when `quiet`); `contact`: the object's
    contact stiffness and damping among the ordinary parameters (`identify.Options.contact`)."""
    from ..rollout.trials import load_trials

    # MIT pushes at their full motion-capture rate: the noise is estimated from every sample, the residual is
    # compared at RESIDUAL_RATE
    # checked before any recording is read
    options = Options(effects=tuple(effects) if effects else None, contact=contact)
    trials = load_trials(paths, odb, max_duration=max_duration, observation_rate=250.0, shape=shape)
    if log is None and not quiet:
        log = lambda m: print(m, file=sys.stderr, flush=True)  # noqa: E731
    return run_diagnosis(trials, odb, out, held_out=held_out, workers=workers, options=options, log=log,
                         progress=progress, time_limit=time_limit, time_step=time_step, quasi_static=quasi_static)


def summary_text(run: DiagnosisRun) -> str:
    ident, data = run.identification, run.data
    w = ident.winner
    lines = [f"verdict: {ident.verdict}" + (f" on {w.target}: " + parameters_text(w) if ident.verdict != "none" else "")
             + (" (partial: stopped at the time limit)" if ident.partial else "")]
    if ident.alike:
        lines.append("alike: " + ", ".join(a.effect for a in ident.alike)
                     + f" predict{'s' if len(ident.alike) == 1 else ''} the recordings not fitted on as well as "
                     f"{ident.verdict} (not told apart; see the notes)")
    if ident.runner_up is not None:
        lines.append(f"runner-up: {ident.runner_up.effect} on {ident.runner_up.target} (margin {ident.margin:.1f})")
    e = data["error"]
    lines.append(f"error e: {e['before']['e']:.5f} -> {e['after']['e']:.5f} on {len(ident.train)} fitted recording(s)")
    if "held_out_before" in e:
        lines.append(f"held-out e: {e['held_out_before']['e']:.5f} -> {e['held_out_after']['e']:.5f} on "
                     f"{len(ident.held_out)} recording(s)")
    lines.extend(f"note: {n}" for n in ident.notes)
    if ident.support is not None:  # against the verdict's footprint, so not among the notes taken during the search
        lines.append(f"note: {ident.support.sentence()}")
    return "\n".join(lines)
