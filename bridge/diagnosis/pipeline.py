"""`bridge diagnose` end to end: trials -> held-out split -> identify -> scene file, diagnosis.json, report, plots."""
from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from ..errors import DiagnosisError
from ..odb import ObjectDatabase
from ..sim.scene import SimConfig
from ..sim.shapes import mass_properties
from .effects import Applied
from .identify import Identification, Options, identify
from .locate import Localisation, locate
from .report import (
    MAX_RESIDUAL_PLOTS,
    diagnosis_json,
    plot_paths,
    plot_residuals,
    plot_scores,
    report_markdown,
    write_outputs,
)
from .scenefile import save_scene_file
from .simulation import Engine, default_workers, prepare

RESIDUAL_RATE = 25.0  # Hz at which observed and simulated poses are compared
SAMPLE_RATE = 50.0  # Hz at which the simulation is sampled


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


def run_diagnosis(trials: Sequence[Any], odb: ObjectDatabase, out: str | Path | None, *,
                  held_out: int | None = None, workers: int | None = None, options: Options = Options(),
                  config: SimConfig = SimConfig(), plots: bool = True,
                  log: Callable[[str], None] | None = None) -> DiagnosisRun:
    """Diagnose `trials` (`bridge.fit.trials.Trial` values); write outputs under `out` when given."""
    started = time.perf_counter()
    if not trials:
        raise DiagnosisError("no recordings to diagnose")
    prepared = [prepare(t, odb, RESIDUAL_RATE) for t in trials]
    held = held_out_indices(len(prepared), held_out)
    train = [i for i in range(len(prepared)) if i not in held]
    with Engine(prepared, odb, config=config, sample_rate=SAMPLE_RATE,
                workers=default_workers() if workers is None else workers) as engine:
        ident = identify(engine, train, held, options, log=log)
        after = None
        if out is not None and plots and ident.verdict != "none":
            after = locate(engine, list(range(len(prepared))), model=ident.winner.model)
    files: dict[str, Path] = {}
    data: dict[str, Any]
    if out is None:
        data = diagnosis_json(ident)
        return DiagnosisRun(ident, data, files, after)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    scene_path = param_path = None
    if ident.verdict != "none":
        scene_path = save_scene_file(out / "scene.yaml", ident.winner.model,
                                     {"verdict": ident.verdict, "target": ident.winner.target,
                                      "recordings": list(ident.train) + list(ident.held_out)})
        param_path = save_param_equivalent(out / "params.yaml", ident.winner.model, prepared[0].world, odb)
    data = diagnosis_json(ident, scene_file=scene_path.name if scene_path else None,
                          param_file=param_path.name if param_path else None)
    data["seconds"] = round(time.perf_counter() - started, 2)
    figures: list[str] = []
    if plots:
        figures = [str(p) for p in _plots(ident, after, out)]
    json_path, md_path = write_outputs(out, data, report_markdown(ident, data, figures))
    files.update({"json": json_path, "report": md_path})
    if scene_path:
        files["scene"] = scene_path
    if param_path:
        files["params"] = param_path
    return DiagnosisRun(ident, data, files, after)


def _plots(ident: Identification, after: Localisation | None, out: Path) -> list[Path]:
    figures = [plot_scores(ident, out / "effects.png")]
    before = ident.localisation
    if ident.held_out_localisation is not None:
        before = Localisation(before.objects + ident.held_out_localisation.objects)
    figures.append(plot_paths(before, after, out / "paths.png"))
    after_by = {(o.recording, o.object): o for o in (after.objects if after else ())}
    for o in before.ranking()[:MAX_RESIDUAL_PLOTS]:
        name = "".join(c if c.isalnum() or c in "-_" else "_" for c in f"residual_{o.recording}_{o.object}")
        figures.append(plot_residuals(o, after_by.get((o.recording, o.object)), out / f"{name[:80]}.png"))
    return figures


def save_param_equivalent(path: Path, model: Sequence[Applied], world, odb: ObjectDatabase) -> Path | None:
    """The model as a `bridge fit` parameter file (fixed values), when every effect maps onto a parameter kind
    (friction, mass spread like the object's own, com without a mass change, latency, joint offsets; a surface
    tilt as its tangential force); None otherwise."""
    from ..fit.params import parse_params, save_param_file

    entries = []
    for a in model:
        v = a.values()
        if a.effect == "friction":
            entries.append({"kind": "friction", "target": a.target, "value": v["mu"]})
        elif a.effect == "mass" and abs(v.get("spread", 1.0) - 1.0) < 0.05:  # the kind scales the inertia
            entries.append({"kind": "mass", "target": a.target, "value": v["mass"]})
        elif a.effect == "com_offset" and abs(v.get("mass", 0.0) / mass_properties(odb, 
                world.objects[a.target].type).mass - 1.0) < 0.01:  # a changed mass here keeps the inertia
            com = mass_properties(odb, world.objects[a.target].type).com
            entries += [{"kind": "com_x", "target": a.target, "value": float(com[0] + v["dx"])},
                        {"kind": "com_y", "target": a.target, "value": float(com[1] + v["dy"])}]
        elif a.effect == "latency":
            entries.append({"kind": "latency", "target": a.target, "value": v["dt"]})
        elif a.effect == "pusher_offset":
            entries += [{"kind": "joint_offset", "target": j, "value": x} for j, x in v.items()]
        elif a.effect == "surface_tilt":
            entries += [{"kind": "surface_slope_x", "target": a.target, "value": v["slope_x"]},
                        {"kind": "surface_slope_y", "target": a.target, "value": v["slope_y"]}]
        else:
            return None
    if not entries:
        return None
    spec = parse_params({"params": entries}, str(path))
    header = ("the diagnosed model as a bridge fit / infer --params file (fixed values)"
              + ("; the surface tilt enters as its tangential force only" if any(a.effect == "surface_tilt"
                                                                                  for a in model) else ""))
    save_param_file(path, spec, header=header)
    return path


def diagnose_paths(paths: Sequence[str | Path], odb: ObjectDatabase, out: str | Path, *, held_out: int | None = None,
                   workers: int | None = None, effects: Sequence[str] | None = None, max_duration: float | None = None,
                   quiet: bool = False) -> DiagnosisRun:
    """Load recordings (folders, MIT .h5 files, folders of .h5 files) and diagnose them."""
    from ..fit.trials import load_trials

    # MIT pushes at their full motion-capture rate: the noise is estimated from every sample, the residual is
    # compared at RESIDUAL_RATE
    trials = load_trials(paths, odb, max_duration=max_duration, observation_rate=250.0)
    log = None if quiet else (lambda m: print(m, file=sys.stderr, flush=True))
    options = Options(effects=tuple(effects) if effects else None)
    return run_diagnosis(trials, odb, out, held_out=held_out, workers=workers, options=options, log=log)


def summary_text(run: DiagnosisRun) -> str:
    ident, data = run.identification, run.data
    w = ident.winner
    lines = [f"verdict: {ident.verdict}" + (f" on {w.target}: " + ", ".join(
        f"{k} = {v:.4g} +- {w.std.get(k, math.nan):.2g}" for k, v in w.params.items()) if ident.verdict != "none" else "")]
    if ident.runner_up is not None:
        lines.append(f"runner-up: {ident.runner_up.effect} on {ident.runner_up.target} (margin {ident.margin:.1f})")
    e = data["error"]
    lines.append(f"error e: {e['before']['e']:.5f} -> {e['after']['e']:.5f} on {len(ident.train)} fitted recording(s)")
    if "held_out_before" in e:
        lines.append(f"held-out e: {e['held_out_before']['e']:.5f} -> {e['held_out_after']['e']:.5f} on "
                     f"{len(ident.held_out)} recording(s)")
    lines.extend(f"note: {n}" for n in ident.notes)
    return "\n".join(lines)
