"""A fit's report folder: the fitted parameter file, fit.json, the paper's Table I and Fig. 4, and for planar
pushes the real and simulated paths before and after the fit. The keys of fit.json are documented in docs/fit.md.
"""
from __future__ import annotations

import io
import json
import math
from pathlib import Path
from typing import Any, BinaryIO, Sequence

import numpy as np

from ..errors import SimulationFailure
from ..files import write_set
from ..odb import ObjectDatabase
from ..params import param_file_text, trial_rollout
from ..rollout.compare import PoseError
from ..rollout.rollout import run_rollout
from ..rollout.trials import Trial
from .evaluate import sim_options
from .fit import FitResult

PARAMS_FILE, FIT_FILE, TABLE_FILE = "params.yaml", "fit.json", "table1.md"
FIG4_PARAMS, FIG4_ERRORS, TRAJECTORIES = "fig4_params.png", "fig4_errors.png", "trajectories.png"
MAX_TRAJECTORY_PLOTS = 4
ORANGE, DARK_BLUE, LIGHT_BLUE = "#ff7f0e", "#1f3a93", "#9ecae1"


def write_report(result: FitResult, out: str | Path, *, trials: Sequence[Trial] = (),
                 odb: ObjectDatabase | None = None) -> dict[str, Path]:
    """Write every file of the report into `out` as one set (`bridge.files.write_set`: an interrupt leaves the
    old report or the new one; a trajectory plot of an earlier fit is removed when this one has none); returns
    them by name. Trajectories need `trials` and `odb` (a few extra replays, in this process)."""
    out = Path(out)
    header = (f"fitted by bridge fit ({result.optimizer}, seed {result.seed}, {result.generations} generations) on "
              f"{len(result.fit_trials)} trial(s): e {result.before.e:.6f} -> {result.after.e:.6f} m"
              + (f"\npartial: {result.stop_reason}; the best candidate so far" if result.partial else ""))
    contents: dict[str, str | bytes | None] = {
        PARAMS_FILE: param_file_text(result.fitted_spec, header=header),
        FIT_FILE: json.dumps(fit_json(result), indent=1) + "\n",
        TABLE_FILE: table1(result) + "\n",
        FIG4_PARAMS: _png(plot_parameters, result),
        FIG4_ERRORS: _png(plot_errors, result),
        TRAJECTORIES: None}
    pushes = [t for t in trials if t.is_planar_push]
    if pushes and odb is not None:
        contents[TRAJECTORIES] = _png(plot_trajectories, result, pushes, odb)
    write_set({out / name: content for name, content in contents.items()})
    return {name: out / name for name, content in contents.items() if content is not None}


def _png(plot, *args) -> bytes:
    """A figure drawn into memory, so it is published with the rest of the report."""
    buffer = io.BytesIO()
    plot(*args, buffer)
    return buffer.getvalue()


# --- fit.json ------------------------------------------------------------------------------------------------
def _errors(e: PoseError | None) -> dict[str, float] | None:
    return None if e is None else {"e": e.e, "e_t": e.e_t, "e_R": e.e_R, "count": e.count}


def fit_json(result: FitResult) -> dict[str, Any]:
    spec = result.spec
    units = [p.kind.unit for p in spec.free]
    data: dict[str, Any] = {
        "params": dict(result.values),
        "std": {k: float(f"{v:.4g}") for k, v in result.std.items()},
        "start": dict(result.start),
        "units": dict(zip(spec.names, units)),
        "before": _errors(result.before),
        "after": _errors(result.after),
    }
    if result.held_out_before is not None:
        data["held_out_before"] = _errors(result.held_out_before)
        data["held_out_after"] = _errors(result.held_out_after)
    first, last = result.generation_errors[0], result.generation_errors[-1]
    data.update({
        "optimizer": result.optimizer, "seed": result.seed, "generations": result.generations,
        "evaluations": result.evaluations, "simulations": result.simulations, "failures": result.failures,
        "rollouts": {k: int(v) for k, v in (result.rollouts or {"simulated": result.simulations, "cached": 0}).items()},
        "stop_reason": result.stop_reason, "wall_time_s": round(result.wall_time, 3),
        "max_generations": result.max_generations, "stopped": result.stopped, "time_limit_s": result.time_limit,
        **({"stopped_after_s": round(result.stopped_after, 2)} if result.stopped_after is not None else {}),
        "executor": result.executor, "workers": result.workers,
        "fit_trials": list(result.fit_trials), "held_out_trials": list(result.held_out),
        "table1": {"initial_generation": {"params": spec.as_dict(first.best_values), **_errors(first.best)},
                   "final": {"params": spec.as_dict(last.best_values), **_errors(last.best)}},
        "trials": [{"trial": b.trial, "held_out": b.trial in result.held_out, "before": _errors(b.error),
                    "after": _errors(a.error), "failure_before": b.failure, "failure_after": a.failure}
                   for b, a in zip(result.trial_errors_before, result.trial_errors_after)],
        "history": [_history_row(result, record, errors)
                    for record, errors in zip(result.history, result.generation_errors)],
        "notes": list(result.notes),
    })
    return data


def _history_row(result: FitResult, record, errors) -> dict[str, Any]:
    spec = result.spec

    def values(unit) -> dict[str, float]:
        return spec.as_dict(spec.from_unit(unit))

    return {"generation": record.generation, "evaluations": record.evaluations, "best_e": record.best_error,
            "generation_best_e": record.generation_best_error, "selected_mean_e": record.selected_mean_error,
            "selected_p80_e": _finite(record.selected_p80_error), "sigma": _finite(record.sigma),
            "best_e_t": errors.best.e_t, "best_e_R": errors.best.e_R,
            "selected_mean_e_t": errors.selected_e_t[0], "selected_p80_e_t": errors.selected_e_t[1],
            "selected_mean_e_R": errors.selected_e_R[0], "selected_p80_e_R": errors.selected_e_R[1],
            "best": values(record.best_x), "mean": values(record.mean_x), "p20": values(record.p20_x),
            "p80": values(record.p80_x), "failures": errors.failures, "elapsed_s": round(errors.elapsed, 3)}


def _finite(value: float) -> float | None:
    return value if math.isfinite(value) else None


# --- Table I -------------------------------------------------------------------------------------------------
def table1(result: FitResult) -> str:
    """The paper's Table I: the best individual of the first generation and of the last, with its errors."""
    names = result.spec.names
    first, last = result.generation_errors[0], result.generation_errors[-1]
    head = ["", *names, "error rotational e_R (rad)", "error translational e_t (m)", "overall error e"]
    rows = [("initial generation", first), (f"generation {result.generations}", last)]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for label, g in rows:
        cells = [label, *(f"{v:.4g}" for v in g.best_values), f"{g.best.e_R:.4f}", f"{g.best.e_t:.5f}",
                 f"{g.best.e:.5f}"]
        lines.append("| " + " | ".join(cells) + " |")
    lines.append("")
    lines.append(f"Best individuals of the first and the last generation ({result.optimizer}, seed {result.seed}, "
                 f"{len(result.fit_trials)} fitted trial(s)); e = sqrt(mean(e_t^2 + c e_R^2)), c = 0.01 by default.")
    if result.partial:
        lines.append(f"Partial result: {result.stop_reason}; the last row is the best candidate so far, not a "
                     "converged fit.")
    return "\n".join(lines)


# --- Fig. 4 --------------------------------------------------------------------------------------------------
def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_parameters(result: FitResult, path: Path | BinaryIO) -> Path | BinaryIO:
    """Fig. 4 (a, b, d, e): per parameter the best individual, the parents' mean and their 20-80 % band."""
    plt = _pyplot()
    spec, history = result.spec, result.history
    n = len(spec.free)
    cols = min(n, 2)
    rows = math.ceil(n / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(5.5 * cols, 3.2 * rows), squeeze=False)
    gens = [r.generation + 1 for r in history]
    for j, p in enumerate(spec.free):
        ax = axes[j // cols][j % cols]
        conv = lambda xs: [p.from_unit(x[j]) for x in xs]  # noqa: E731
        ax.fill_between(gens, conv([r.p20_x for r in history]), conv([r.p80_x for r in history]), color=LIGHT_BLUE,
                        label="parents 20-80 %")
        ax.plot(gens, conv([r.mean_x for r in history]), color=DARK_BLUE, label="parents' mean")
        ax.plot(gens, conv([r.best_x for r in history]), color=ORANGE, label="best")
        ax.set_title(p.name)
        ax.set_xlabel("generation")
        ax.set_ylabel(p.kind.unit or "value")
        if p.spacing == "log":
            ax.set_yscale("log")
    for j in range(n, rows * cols):
        axes[j // cols][j % cols].axis("off")
    axes[0][0].legend(fontsize=8)
    fig.suptitle(f"Parameter evolution ({result.optimizer})")
    fig.tight_layout()
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)
    return path


def plot_errors(result: FitResult, path: Path | BinaryIO) -> Path | BinaryIO:
    """Fig. 4 (c, f) and the overall error: best so far, the selected individuals' mean, best-to-80th band."""
    plt = _pyplot()
    gens = [g.generation + 1 for g in result.generation_errors]
    ge = result.generation_errors
    fig, axes = plt.subplots(1, 3, figsize=(15, 3.6))
    panels = [("rotational error e_R (rad)", [g.best.e_R for g in ge], [g.selected_e_R for g in ge]),
              ("translational error e_t (m)", [g.best.e_t for g in ge], [g.selected_e_t for g in ge]),
              ("overall error e", [r.best_error for r in result.history],
               [(r.selected_mean_error, r.selected_p80_error) for r in result.history])]
    for ax, (title, best, selected) in zip(axes, panels):
        mean = [s[0] for s in selected]
        p80 = [s[1] if math.isfinite(s[1]) else np.nan for s in selected]
        ax.fill_between(gens, best, p80, color=LIGHT_BLUE, label="best to 80th percentile")
        ax.plot(gens, mean, color=DARK_BLUE, label="selected mean")
        ax.plot(gens, best, color=ORANGE, label="best overall")
        ax.set_title(title)
        ax.set_xlabel("generation")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)
    return path


# --- planar pushes -------------------------------------------------------------------------------------------
def plot_trajectories(result: FitResult, trials: Sequence[Trial], odb: ObjectDatabase,
                      path: Path | BinaryIO) -> Path | BinaryIO:
    """Observed and simulated object paths (x-y, mm) before and after the fit, for a few held-out pushes (or
    fitted ones when none is held out). Data: Yu, Bauza, Fazeli, Rodriguez, IROS 2016."""
    plt = _pyplot()
    held = [t for t in trials if t.name in result.held_out]
    chosen = (held or [t for t in trials if t.name in result.fit_trials])[:MAX_TRAJECTORY_PLOTS]
    errors_before = {e.trial: e for e in result.trial_errors_before}
    errors_after = {e.trial: e for e in result.trial_errors_after}
    fitted = [result.values[n] for n in result.spec.names]
    fig, axes = plt.subplots(1, max(1, len(chosen)), figsize=(4.2 * max(1, len(chosen)), 4.4), squeeze=False)
    for ax, trial in zip(axes[0], chosen):
        track = trial.observations.tracks[0]
        obs = np.array([p.xyz for p in track.poses]) * 1e3
        ax.plot(obs[:, 0], obs[:, 1], color="black", lw=2, label="observed")
        for label, x, style in (("before", None, dict(color="grey", ls="--")), ("after", fitted, dict(color=ORANGE))):
            try:
                rollout = trial_rollout(trial, result.spec.model(x), odb, strict=False)
                sim = run_rollout(rollout, odb, sim_options(trial)).observed_track(track.object) * 1e3
                ax.plot(sim[:, 0], sim[:, 1], label=f"simulated {label}", **style)
            except SimulationFailure:
                ax.plot([], [], label=f"simulated {label}: failed", **style)
        ax.plot(*obs[0, :2], "o", color="black", ms=4)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("y (mm)")
        b, a = errors_before.get(trial.name), errors_after.get(trial.name)
        status = "held out" if trial.name in result.held_out else "fitted"
        title = trial.name.replace("motion_surface=", "").replace("_a=0", "")
        if b is not None and a is not None:
            title += f"\n{status}: e {b.error.e * 1e3:.2f} -> {a.error.e * 1e3:.2f} mm"
        ax.set_title(title, fontsize=8)
        ax.legend(fontsize=7)
    fig.suptitle("MIT planar pushing (Yu et al., IROS 2016)\nreal vs simulated object paths", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)
    return path


__all__ = ["write_report", "fit_json", "table1", "plot_parameters", "plot_errors", "plot_trajectories"]
