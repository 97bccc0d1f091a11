"""Real pushing physics (issue 12): Drake's replay of the MIT planar pushes beside the analytical baseline, the
ellipsoidal limit surface (`bridge.rollout.limit_surface`), each nominal and with friction fitted on other pushes.

Data: MIT planar pushing (Yu, Bauza, Fazeli, Rodriguez, "More than a Million Ways to Be Pushed", IROS 2016), the
shared subset's train/ folder. For each shape, k-fold over its pushes (k = min(5, n), push i in fold i mod k): every
push is held out once and scored by what was fitted on the others. Columns:

  drake        nominal Drake replay (`run_rollout`, the object database's friction)
  ls           limit surface, nominal friction (Drake's combined coefficients of the same pairs)
  ls_fit       limit surface, mu_p fitted on the training folds (scipy least squares on the paper's E); mu_s
               does not change quasi-static poses, so it is fitted on the recorded pusher force instead
               (reported, where the force can be trusted)
  ls_fit_c     limit surface, mu_p and a factor on the uniform pressure's c fitted on the training folds (is the
               pressure distribution what the baseline misses?)
  drake_fit    Drake, the surface's and the rod's friction fitted on the training folds (`fit_parameters`,
               Levenberg-Marquardt, a small budget; only with --drake-fit: expensive)
  drake_ps     Drake with the pressure_distribution effect: the support footprint's scale (`support_scale`,
               bridge/sim/support.py) chosen on the training folds from a grid (--support-grid; every push is
               replayed once per grid value, then each fold picks the value of least training E)
  drake_an     Drake with the anisotropic_friction effect (bridge/sim/anisotropy.py): anisotropy a along one of
               --aniso-directions grains, chosen on the training folds from a grid (--aniso-grid), as drake_ps
  drake_rate   Drake with the support's friction falling with the slip speed (the Stribeck curve, rate_drop and
               rate_speed, bridge/sim/anisotropy.py), chosen on the training folds from a grid (--rate-grid), as
               drake_ps
  drake_gap    Drake with the rod offset D that the training folds' contact gaps imply (the loader's evidence,
               `bridge.diagnosis.loader.ContactFit`: no simulation, no fit), applied to the held-out push's
               telemetry; D = 0 when the training pushes do not make it evident
  drake_cone   Drake with the rod's friction the force's direction reads on the training folds while the rod slid
               (`bridge.diagnosis.cone`: the recordings' reading over the nominal replays', a factor on the model's
               rod pair; no pose fit); nominal where the force is not trusted (rect1) or the rod never slid
  drake_read   Drake with both readings of the training folds, the rod offset of drake_gap and the rod friction
               of drake_cone: everything the recordings measure before any simulation, no pose fit
  drake_diag   Drake with the model `bridge diagnose` chooses on the training folds (friction and the verdict's
               effect; the whole diagnosis per fold, every training push cross-validated inside it: only with
               --diagnose, expensive). Each fold's verdict, parameters, their spread over the diagnosis's own
               refits and its stability are kept, with the effects the fold's recordings did not tell apart
               from the verdict (`alike`, their parameters): the verdict per shape is stable when most folds
               give it, and an effect is supported in a fold where it is the verdict or alike with it

Scores per held-out push: final-pose error (mm, deg: the last observation) and the paper's trajectory error
e_t (mm), e_R (deg) over the observed track (`bridge.rollout.compare`, eq. 1-4). Median and p90 per shape and
over all pushes; one table; JSON in benchmarks/results/real_push.json.

    BRIDGE_MIT_PUSH=../shared/datasets/mit-push python benchmarks/real_push_benchmark.py          # a few minutes
    python benchmarks/real_push_benchmark.py --quick --shapes ellip1 rect1
    python benchmarks/real_push_benchmark.py --drake-fit ellip1    # all shapes, Drake also fitted on ellip1's folds
    python benchmarks/real_push_benchmark.py --support-grid 0.5 0.6 0.7 0.8 0.9 1.1 1.2   # drake_ps
    python benchmarks/real_push_benchmark.py --aniso-grid 0.15 0.3                        # drake_an
    python benchmarks/real_push_benchmark.py --rate-grid 1,0.02 1,0.05 1,0.1 2,0.05 --merge  # drake_rate
    python benchmarks/real_push_benchmark.py --diagnose --merge    # drake_diag, the other columns kept from the JSON
"""
from __future__ import annotations

import argparse
import json
import math
import platform
import sys
import time
from collections import Counter
from dataclasses import replace
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from bridge.fit.evaluate import residuals_of, sim_options  # noqa: E402
from bridge.diagnosis.cone import rod_reading  # noqa: E402
from bridge.diagnosis.loader import read_adjustments  # noqa: E402
from bridge.diagnosis.runs import prepare  # noqa: E402
from bridge.fit.fit import fit_parameters  # noqa: E402
from bridge.odb import load_object_database  # noqa: E402
from bridge.params import kind_named, parse_params, trial_rollout  # noqa: E402
from bridge.recording.mitpush import find_mit_push_root, push_spec  # noqa: E402
from bridge.rollout import load_trials, make_executor  # noqa: E402
from bridge.params.model import Setting  # noqa: E402
from bridge.rollout.compare import error_of_residuals, least_squares_vector  # noqa: E402
from bridge.rollout.limit_surface import (fit_pusher_friction, push_residuals, push_trial, pushed_object,  # noqa: E402
                                          surface_friction_from_force)
from bridge.rollout.rollout import Job  # noqa: E402
from bridge.sim.friction import combined_friction  # noqa: E402

COLUMNS = ("drake", "ls", "ls_fit", "ls_fit_c", "drake_fit", "drake_ps", "drake_an", "drake_rate", "drake_gap",
           "drake_cone", "drake_read", "drake_diag")
METRICS = ("final_mm", "final_deg", "e_t_mm", "e_R_deg")
MAX_FOLDS = 5
ROD = "pusher/pusher_rod"
ROD_FRICTION = 0.25  # drake:mu_static of the rod in models/pusher2d/pusher2d.sdf (no object database entry)
SURFACE = "surface"
DRAKE_FIT_PARAMS = {"params": [  # as benchmarks/fit_benchmark.py's MIT part
    {"kind": "friction", "target": SURFACE, "bounds": [0.05, 1.5], "start": 0.25},
    {"kind": "friction", "target": ROD, "bounds": [0.02, 1.5], "start": 0.25},
]}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--shapes", nargs="*", default=None, help="shapes to run (default: every shape in train/)")
    parser.add_argument("--trials", type=int, default=None, help="at most N pushes per shape")
    parser.add_argument("--quick", action="store_true", help="3 pushes per shape, 2 LM iterations for --drake-fit")
    parser.add_argument("--drake-fit", nargs="*", default=None, metavar="SHAPE",
                        help="also fit Drake's friction per fold (slow): on the shapes named, or on all without names")
    parser.add_argument("--drake-fit-iterations", type=int, default=4, help="LM iterations per fold (default 4)")
    parser.add_argument("--support-grid", nargs="*", type=float, default=None, metavar="SCALE",
                        help="the drake_ps column: support footprint scales to try (1 is always tried)")
    parser.add_argument("--aniso-grid", nargs="*", type=float, default=None, metavar="A",
                        help="the drake_an column: anisotropies a to try, each along --aniso-directions grains")
    parser.add_argument("--aniso-directions", type=int, default=4, help="grain directions over 180 deg (default 4)")
    parser.add_argument("--rate-grid", nargs="*", default=None, metavar="DROP,SPEED",
                        help="the drake_rate column: friction falling with the slip speed, rate_drop,rate_speed (m/s) "
                        "pairs to try (the flat curve is always tried)")
    parser.add_argument("--diagnose", nargs="*", default=None, metavar="SHAPE",
                        help="the drake_diag column: `bridge diagnose` on each fold's training pushes (slow: minutes "
                             "a fold), on the shapes named, or on all without names")
    parser.add_argument("--workers", type=int, default=2, help="processes of each fold's diagnosis (default 2)")
    parser.add_argument("--merge", action="store_true",
                        help="keep the columns this run does not compute (and the shapes it does not run) from --json")
    parser.add_argument("--json", default=str(REPO / "benchmarks" / "results" / "real_push.json"))
    args = parser.parse_args(argv)
    if args.trials is not None and args.trials < 1:
        parser.error("--trials must be >= 1")
    root = find_mit_push_root()
    if root is None or not (root / "train").is_dir():
        print("MIT planar pushing dataset not found: set BRIDGE_MIT_PUSH (the folder holding train/ and obj/)")
        return
    per_shape = 3 if args.quick and args.trials is None else args.trials
    if args.merge and per_shape is not None:
        parser.error("--merge needs every push (no --quick, no --trials): the folds of fewer pushes are other folds")
    iterations = 2 if args.quick else args.drake_fit_iterations
    files = select_files(root / "train", args.shapes, per_shape)
    for option, named in (("--drake-fit", args.drake_fit), ("--diagnose", args.diagnose)):
        unknown = sorted(set(named or ()) - set(files))
        if unknown:  # else that shape would silently go without the column
            parser.error(f"{option}: {', '.join(unknown)} not among the shapes run ({', '.join(files)})")
    odb = load_object_database()
    started = time.perf_counter()
    rows, fits = [], {}
    with make_executor("serial", odb) as executor:
        for shape, paths in files.items():
            shape_started = time.perf_counter()
            trials = load_trials(paths, odb)
            drake_fit = args.drake_fit is not None and (not args.drake_fit or shape in args.drake_fit)
            diagnose = args.diagnose is not None and (not args.diagnose or shape in args.diagnose)
            # as `bridge diagnose` loads them: the motion capture at its full rate (read once, a subset per fold)
            diagnosed = load_trials(paths, odb, observation_rate=250.0) if diagnose else None
            shape_rows, fits[shape] = run_shape(trials, odb, executor, drake_fit, iterations, grid_models(args),
                                                diagnosed, args.workers)
            rows.extend(dict(r, shape=shape) for r in shape_rows)
            print(f"{shape}: {len(trials)} pushes, {time.perf_counter() - shape_started:.0f} s", flush=True)
    out = Path(args.json)
    meta = {"data": "MIT planar pushing, Yu et al. IROS 2016 (arXiv:1604.04038), shared subset train/",
            "mode": "quick" if args.quick else "full", "per_shape": per_shape, "drake_fit": args.drake_fit,
            "drake_fit_iterations": iterations if args.drake_fit is not None else None, "folds": f"min({MAX_FOLDS}, n)",
            "support_grid": args.support_grid, "aniso_grid": args.aniso_grid, "rate_grid": args.rate_grid,
            "diagnose": args.diagnose,
            "machine": platform.platform(), "total_s": round(time.perf_counter() - started, 1)}
    if args.merge and out.is_file():
        meta, rows, fits = merged(json.loads(out.read_text()), meta, rows, fits)
    summary = summarise(rows)
    print_table(summary, fits, "drake_fit" in summary.get("all", {}))
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({**meta, "summary": summary, "fits": fits, "trials": rows}, indent=1) + "\n")
    print(f"wrote {out} ({time.perf_counter() - started:.0f} s)")


def merged(old: dict, meta: dict, rows: list[dict], fits: dict) -> tuple[dict, list[dict], dict]:
    """This run's results over an earlier file's: a push's columns this run computed replace the earlier ones, the
    others (an earlier --drake-fit, grid or --diagnose) stay; so do the shapes this run did not touch. Settings
    this run left unset keep the earlier file's values; the earlier total time is kept beside this one's."""
    new = {(r["shape"], r["trial"]): r for r in rows}
    kept = [{**r, **new.pop((r["shape"], r["trial"]), {})} for r in old.get("trials", [])]
    meta = {**{k: v for k, v in old.items() if k not in ("summary", "fits", "trials")},
            **{k: v for k, v in meta.items() if v is not None}, "earlier_total_s": old.get("total_s")}
    out_fits = dict(old.get("fits", {}))
    for shape, fit in fits.items():
        earlier = {f["fold"]: f for f in out_fits.get(shape, {}).get("folds", [])}
        folds = [{**earlier.get(f["fold"], {}), **f} for f in fit["folds"]]
        out_fits[shape] = {**out_fits.get(shape, {}), **fit, "folds": folds}
    return meta, kept + list(new.values()), out_fits


def diagnose_fold(trials: list, train: list[int], odb, workers: int) -> tuple[tuple, dict]:
    """`bridge diagnose` on the training pushes (every one fitted, cross-validated inside the diagnosis): its model
    (friction and the verdict's effect) and what the fold reports."""
    from bridge.diagnosis.pipeline import run_diagnosis

    started = time.perf_counter()
    run = run_diagnosis([trials[i] for i in train], odb, None, held_out=0, workers=workers, plots=False)
    ident, data = run.identification, run.data
    winner = (data.get("winner") or {}) if ident.verdict != "none" else {}
    stability = (data.get("cross_validation") or {}).get("stability") or {}
    entry = {"verdict": ident.verdict, "params": winner.get("params", {}),
             "params_range": (winner.get("cv") or {}).get("params_range", {}), "model": winner.get("model", []),
             "stability": stability.get("agree"), "selections": stability.get("selections"),
             "floor": (data.get("cross_validation") or {}).get("floor"),
             "alike": [a.effect for a in ident.alike],  # the effects not told apart from the verdict, and their fits
             "alike_params": {e["effect"]: e["params"] for e in data["effects"]
                              if e["effect"] in {a.effect for a in ident.alike}},
             "cross_validated": {e["effect"]: e["cv"]["rms_sigma_each"] for e in data["effects"] if e.get("cv")},
             "simulations": data["simulations"], "wall_s": round(time.perf_counter() - started, 1)}
    return ident.model(), entry


def rod_cone(trials: list, outcomes: list, odb, obj: str) -> tuple[dict | None, float]:
    """The rod's friction the force's direction reads on the recordings and on their nominal replays, and the
    factor on the model's rod pair it asks for (1 where either cannot be read)."""
    reading = rod_reading(trials, [None if o.failed else o.result for o in outcomes], odb, obj, 1.0, 1.0)
    return (None, 1.0) if reading is None else (reading.to_json(), reading.factor)


def select_files(train: Path, shapes: list[str] | None, per_shape: int | None) -> dict[str, list[Path]]:
    by_shape: dict[str, list[Path]] = {}
    for path in sorted(train.glob("*.h5")):
        by_shape.setdefault(push_spec(path, None, None).shape, []).append(path)
    if shapes:
        unknown = sorted(set(shapes) - set(by_shape))
        if unknown:
            raise SystemExit(f"--shapes: {', '.join(unknown)} not in {train}; shapes there: {', '.join(by_shape)}")
        by_shape = {s: by_shape[s] for s in shapes}
    if per_shape is not None:  # spread over the pushes, not the first N names (one speed, one side)
        by_shape = {s: [p[i] for i in np.linspace(0, len(p) - 1, min(per_shape, len(p))).round().astype(int)]
                    for s, p in by_shape.items()}
    return by_shape


def nominal_friction(trial, odb, pushed) -> tuple[float, float]:
    """(mu_s, mu_p): Drake's combined coefficients of object-surface and object-rod at the nominal values."""
    friction = kind_named("friction")
    shape_mu = odb.get(trial.world.objects[pushed.name].type).physics.friction
    return (combined_friction(friction.null(trial.world, odb, SURFACE), shape_mu),
            combined_friction(ROD_FRICTION, shape_mu))


def scores(rows: list[np.ndarray]) -> dict[str, float]:
    error = error_of_residuals(rows)
    final = np.concatenate(rows)[-1]
    return {"final_mm": 1e3 * float(np.linalg.norm(final[:3])), "final_deg": math.degrees(np.linalg.norm(final[3:])),
            "e_t_mm": 1e3 * error.e_t, "e_R_deg": math.degrees(error.e_R), "e_mm": 1e3 * error.e}


def grid_models(args) -> dict[str, dict[str, tuple]]:
    """Per grid column, its models by label: settings on the pushed object ("{obj}" stands for its name)."""
    grids = {}
    if args.support_grid is not None:
        grids["drake_ps"] = {f"{v:g}": (("support_scale", v),) for v in sorted({1.0, *args.support_grid})}
    if args.aniso_grid is not None:
        models = {"0": ()}
        for a in args.aniso_grid:
            for deg in range(0, 180, 180 // args.aniso_directions):
                t = math.radians(deg)
                models[f"{a:g}@{deg}"] = (("aniso_c", a * math.cos(2 * t)), ("aniso_s", a * math.sin(2 * t)))
        grids["drake_an"] = models
    if args.rate_grid is not None:
        models = {"0": ()}
        for pair in args.rate_grid:
            drop, speed = (float(v) for v in pair.split(","))
            models[f"{drop:g}@{speed:g}"] = (("rate_drop", drop), ("rate_speed", speed))
        grids["drake_rate"] = models
    return grids


def replay_grid(trials, pushed, odb, executor, models: dict[str, tuple]) -> dict[str, list]:
    """Each push's residuals replayed under each model of a grid (None where the replay failed)."""
    out = {}
    for label, settings in models.items():
        jobs = [Job(trial_rollout(t, tuple(Setting(k, p.name, v) for k, v in settings), odb), sim_options(t))
                for t, p in zip(trials, pushed)]
        out[label] = [None if o.failed else residuals_of(t, o.result, odb) for t, o in zip(trials, executor.run(jobs))]
        print(f"  {label}: {len(jobs)} replays", flush=True)
    return out


def run_shape(trials, odb, executor, drake_fit: bool, iterations: int,
              grids: dict[str, dict[str, tuple]] | None = None, diagnose: list | None = None,
              workers: int = 2) -> tuple[list[dict], dict]:
    pushed = [pushed_object(t, odb) for t in trials]
    mu_s0, mu_p0 = nominal_friction(trials[0], odb, pushed[0])
    k = min(MAX_FOLDS, len(trials))
    folds = [[i for i in range(len(trials)) if i % k == f] for f in range(k)]
    rows = [{"trial": t.name, "fold": i % k} for i, t in enumerate(trials)]
    outcomes = executor.run([Job(trial_rollout(t, (), odb), replace(sim_options(t), robot_force=True, joint_track=True))
                             for t in trials])  # with the force and the rod as simulated: the cone's reading
    for row, trial, outcome, p in zip(rows, trials, outcomes, pushed):
        row["drake"] = None if outcome.failed else scores(residuals_of(trial, outcome.result, odb))
        if outcome.failed:
            row["drake_failure"] = outcome.failure
        push = push_trial(trial, p, mu_p0)
        row["ls"] = scores(push_residuals(trial, p, push)[0])
        row["mu_s_from_force"] = surface_friction_from_force(trial, p, push)
    fold_fits = []
    spec = parse_params(DRAKE_FIT_PARAMS, "real_push_benchmark Drake friction")
    replayed = {column: replay_grid(trials, pushed, odb, executor, models) for column, models in (grids or {}).items()}
    for f, held in enumerate(folds):
        train = [i for i in range(len(trials)) if i not in held]
        if not train:  # one push: nothing to fit on
            for i in held:
                rows[i]["ls_fit"] = rows[i]["ls_fit_c"] = None
            continue
        offset = read_adjustments([prepare(trials[i], odb) for i in train]).offset_estimate() or {}
        gap_jobs = [Job(replace(trial_rollout(trials[i], (), odb), telemetry=trials[i].telemetry.with_offsets(offset)),
                        sim_options(trials[i])) for i in held]
        for i, outcome in zip(held, executor.run(gap_jobs)):
            rows[i]["drake_gap"] = None if outcome.failed else scores(residuals_of(trials[i], outcome.result, odb))
        entry_cone, factor = rod_cone([trials[i] for i in train], [outcomes[i] for i in train], odb, pushed[0].name)
        rod = lambda i: (Setting("robot_friction", pushed[i].name, factor),) if factor != 1.0 else ()  # noqa: E731
        cone_jobs = [Job(trial_rollout(trials[i], rod(i), odb), sim_options(trials[i])) for i in held]
        both_jobs = [Job(replace(trial_rollout(trials[i], rod(i), odb),
                                 telemetry=trials[i].telemetry.with_offsets(offset)), sim_options(trials[i]))
                     for i in held]
        outcomes_held = executor.run(cone_jobs + both_jobs)
        for k, i in enumerate(held):
            for column, outcome in (("drake_cone", outcomes_held[k]), ("drake_read", outcomes_held[len(held) + k])):
                rows[i][column] = None if outcome.failed else scores(residuals_of(trials[i], outcome.result, odb))
        fit = fit_pusher_friction([trials[i] for i in train], [pushed[i] for i in train], mu_p0)
        forces = [rows[i]["mu_s_from_force"] for i in train if rows[i]["mu_s_from_force"] is not None]
        entry = {"fold": f, "held_out": [trials[i].name for i in held], "ls_mu_p": fit.mu_p,
                 "gap_offset_mm": {j: round(1e3 * v, 3) for j, v in offset.items()}, "cone": entry_cone,
                 "ls_mu_s_from_force": float(np.median(forces)) if forces else None,
                 "ls_train_e_mm": [1e3 * fit.before.e, 1e3 * fit.after.e], "ls_evaluations": fit.evaluations}
        for i in held:
            rows[i]["ls_fit"] = scores(push_residuals(trials[i], pushed[i], push_trial(trials[i], pushed[i], fit.mu_p))[0])
        fit_c = fit_pusher_friction([trials[i] for i in train], [pushed[i] for i in train], mu_p0, fit_pressure=True)
        entry.update(ls_c_mu_p=fit_c.mu_p, ls_c_scale=fit_c.c_scale, ls_c_train_e_mm=[1e3 * fit_c.before.e, 1e3 * fit_c.after.e])
        for i in held:
            scaled = replace(pushed[i], surface=replace(pushed[i].surface, c=pushed[i].surface.c * fit_c.c_scale))
            rows[i]["ls_fit_c"] = scores(push_residuals(trials[i], scaled, push_trial(trials[i], scaled, fit_c.mu_p))[0])
        if drake_fit:
            started = time.perf_counter()
            result = fit_parameters([trials[i] for i in train], spec, odb=odb, executor=executor, optimizer="lm",
                                    generations=iterations, hold_out=0, seed=f)
            model = spec.model([result.values[p.name] for p in spec.free])
            held_out = executor.run([Job(trial_rollout(trials[i], model, odb), sim_options(trials[i])) for i in held])
            for i, outcome in zip(held, held_out):
                rows[i]["drake_fit"] = None if outcome.failed else scores(residuals_of(trials[i], outcome.result, odb))
            entry.update(drake_values=dict(result.values), drake_train_e_mm=[1e3 * result.before.e, 1e3 * result.after.e],
                         drake_simulations=result.simulations, drake_wall_s=round(time.perf_counter() - started, 1))
            print(f"  fold {f}: Drake fit {entry['drake_values']} in {entry['drake_wall_s']:.0f} s", flush=True)
        if diagnose is not None:
            model, entry["diagnosis"] = diagnose_fold(diagnose, train, odb, workers)
            held_out = executor.run([Job(trial_rollout(trials[i], model, odb), sim_options(trials[i])) for i in held])
            for i, outcome in zip(held, held_out):
                rows[i]["drake_diag"] = None if outcome.failed else scores(residuals_of(trials[i], outcome.result, odb))
            d = entry["diagnosis"]
            steady = f" (the same in {d['stability']} of {d['selections']} selections)" if d["selections"] else ""
            print(f"  fold {f}: diagnosis {d['verdict']} {d['params']}{steady} in {d['wall_s']:.0f} s", flush=True)
        for column, by_model in replayed.items():  # the grid's model of least training E (the paper's E)
            def training_e(label: str) -> float:
                got = [by_model[label][i] for i in train]
                if any(g is None for g in got):
                    return math.inf
                return float(np.linalg.norm(least_squares_vector([r for g in got for r in g])))
            best = min(by_model, key=training_e)
            entry[column] = {"chosen": best, "train_e_mm": {k: 1e3 * training_e(k) for k in by_model}}
            for i in held:
                rows[i][column] = None if by_model[best][i] is None else scores(by_model[best][i])
        fold_fits.append(entry)
    curves = {column: {k: {m: float(np.median([scores(r)[m] for r in v if r is not None])) for m in METRICS}
                       for k, v in by_model.items()}  # every push under each model (not held out)
              for column, by_model in replayed.items()}
    return rows, {"nominal_mu_s": mu_s0, "nominal_mu_p": mu_p0, "c_m": pushed[0].surface.c,
                  "mass_kg": pushed[0].mass, "folds": fold_fits, "curves": curves}


def summarise(rows: list[dict]) -> dict:
    groups = {s: [r for r in rows if r["shape"] == s] for s in dict.fromkeys(r["shape"] for r in rows)}
    groups["all"] = rows
    out = {}
    for name, group in groups.items():
        out[name] = {"pushes": len(group)}
        for column in COLUMNS:
            got = [r[column] for r in group if r.get(column) is not None]
            if not got:
                continue
            out[name][column] = {m: {"median": float(np.median([g[m] for g in got])),
                                     "p90": float(np.percentile([g[m] for g in got], 90))} for m in METRICS}
            out[name][column]["n"] = len(got)
    return out


def supported_text(diagnosed: list[dict]) -> str:
    """The folds' verdicts, and the effects each fold supports: its verdict and the effects its recordings did not
    tell apart from it (`alike`). A verdict that wanders between effects the folds support alike is one answer
    with rivals, not several answers; an effect supported in more than half of the folds is the shape's answer."""
    verdicts = [d["verdict"] for d in diagnosed]
    top, count = Counter(verdicts).most_common(1)[0]
    text = (f"{', '.join(verdicts)}: {top} in {count} of {len(verdicts)} folds"
            + ("" if 2 * count > len(verdicts) else " (not stable)"))
    support = Counter(e for d in diagnosed for e in {d["verdict"], *d.get("alike", [])})
    if any(d.get("alike") for d in diagnosed):
        text += "; supported (the verdict or alike with it): " + ", ".join(
            f"{e} in {c}" for e, c in support.most_common())
    return text


def print_table(summary: dict, fits: dict, drake_fit: bool) -> None:
    columns = [c for c in COLUMNS if c != "drake_fit" or drake_fit]  # drake_ps: shown where it was run
    print("\nheld-out error per push: median / p90 (final pose: mm, deg; trajectory: the paper's e_t mm, e_R deg)")
    print(f"{'shape':<8}{'n':>4}  {'model':<10}" + "".join(f"{m:>16}" for m in METRICS))
    for shape, entry in summary.items():
        for column in columns:
            if column not in entry:
                continue
            cells = "".join(f"{entry[column][m]['median']:>8.2f}/{entry[column][m]['p90']:<7.2f}" for m in METRICS)
            print(f"{shape:<8}{entry[column]['n']:>4}  {column:<10}{cells}")
    print("\nfitted per fold (limit surface: pair coefficient mu_p; mu_s from the recorded force, median over the "
          "training pushes that have one)")
    for shape, fit in fits.items():
        mu_p = [f["ls_mu_p"] for f in fit["folds"]]
        mu_s = [f["ls_mu_s_from_force"] for f in fit["folds"] if f["ls_mu_s_from_force"] is not None]
        with_c = ", ".join(f"{f['ls_c_mu_p']:.2f} x{f['ls_c_scale']:.2f}" for f in fit["folds"])
        line = (f"{shape:<8} c = {fit['c_m'] * 1e3:.1f} mm, nominal mu_s {fit['nominal_mu_s']:.2f} mu_p "
                f"{fit['nominal_mu_p']:.2f}; fitted mu_p {', '.join(f'{v:.2f}' for v in mu_p) or '-'}; mu_s "
                f"{', '.join(f'{v:.2f}' for v in mu_s) or 'no trusted force'}; mu_p with c x factor {with_c or '-'}")
        for column in ("drake_ps", "drake_an", "drake_rate"):
            if any(column in f for f in fit["folds"]):
                line += f"; {column} " + ", ".join(f[column]["chosen"] for f in fit["folds"] if column in f)
        cones = [f["cone"] for f in fit["folds"] if f.get("cone")]
        if cones:
            read = ", ".join(f"{c['recorded']['coefficient']:.3f}" for c in cones)
            line += f"; rod friction read from the force {read} (replays " + ", ".join(
                f"{c['replayed']['coefficient']:.3f}" for c in cones) + ")"
        diagnosed = [f["diagnosis"] for f in fit["folds"] if "diagnosis" in f]
        if diagnosed:
            line += "; diagnosis " + supported_text(diagnosed)
        if any("drake_values" in f for f in fit["folds"]):
            line += "; Drake " + "; ".join(", ".join(f"{k.split('[')[1][:-1]} {v:.2f}" for k, v in f["drake_values"].items())
                                           for f in fit["folds"] if "drake_values" in f)
        print(line)


if __name__ == "__main__":
    main()
