"""Benchmark the parameter fit (issue: estimate simulation parameters, the paper's Section V), three parts in one run:

1. Optimisers. On the synthetic recovery problem (4 parameters like the paper's: two frictions, the small box's
   mass and the big box's centre of mass; `bridge.fit.synthetic`), the paper's ES (lambda = 10 D = 40, mu = 10,
   rho = 2) runs 30 generations; its best error is the target. Reported: how many simulations the ES, CMA-ES
   (cma's default population) and Levenberg-Marquardt (on the residual of the same error) need to reach that
   target, from the same wrong start and seed.
2. Workers. The wall time of one fixed fit with a process pool of 1 worker, of 2 workers, and a dask
   `LocalCluster` of 2 worker processes (`make_executor("dask", ...)`; skipped, and said so, when the `distributed`
   extra is not installed); each started and warmed up first, so the time is the fit's, and each with an empty
   rollout cache (every simulation of the fit is run). Target: 2 workers >= 1.8x faster than 1, on either backend.
3. Real data. MIT planar pushing (Yu, Bauza, Fazeli, Rodriguez, IROS 2016): fit the surface's and the pusher
   rod's friction on most trials, report the held-out error before (nominal values) and after.

    python benchmarks/fit_benchmark.py            # the full run, < 20 minutes on 2 cores
    python benchmarks/fit_benchmark.py --quick    # < 3 minutes
    python benchmarks/fit_benchmark.py --only workers   # one part; the stored figures of the others are kept

Prints a table and writes benchmarks/results/fit.json (fit_quick.json with --quick; or --json PATH) so two
revisions can be compared.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from bridge.fit.evaluate import evaluate  # noqa: E402
from bridge.fit.fit import FitResult, fit_parameters  # noqa: E402
from bridge.fit.synthetic import TRUE_VALUES, push_trials, recovery, recovery_spec  # noqa: E402
from bridge.odb import load_object_database  # noqa: E402
from bridge.params import parse_params  # noqa: E402
from bridge.errors import BridgeError  # noqa: E402
from bridge.rollout import make_executor  # noqa: E402

SPEEDUP_TARGET = 1.8
PARTS = ("optimizers", "workers", "mit")
ROD_FRICTION, BLOCK_FRICTION = 0.25, 0.25  # models/pusher2d/pusher2d.sdf and odb/types/mit_push.yaml

FULL = dict(es_generations=30, es_lam=40,  # mu = lam / 4 = 10, as in the paper
            cmaes_generations=120, lm_iterations=20, speed_generations=10, speed_popsize=8, speed_repeats=2,
            mit_trials=None, mit_duration=1.2, mit_generations=8, mit_popsize=6)
QUICK = dict(es_generations=8, es_lam=20, cmaes_generations=30, lm_iterations=10, speed_generations=4, speed_popsize=8,
             speed_repeats=1,
             mit_trials=8, mit_duration=0.6, mit_generations=3, mit_popsize=4)

MIT_PARAMS = {"params": [
    {"kind": "friction", "target": "surface", "bounds": [0.05, 1.5], "start": 0.25},
    {"kind": "friction", "target": "pusher/pusher_rod", "bounds": [0.02, 1.5], "start": ROD_FRICTION},
]}


def simulations_to_reach(result: FitResult, target: float, n_trials: int) -> int | None:
    """Simulations spent when the best error first reached `target` (whole generations), or None."""
    for record in result.history:
        if record.best_error <= target * (1 + 1e-12):
            return record.evaluations * n_trials
    return None


def part_optimizers(odb, executor, cfg: dict, seed: int) -> dict:
    trials = push_trials(odb)
    spec = recovery_spec()
    started = time.perf_counter()
    es = fit_parameters(trials, spec, odb=odb, executor=executor, optimizer="es", seed=seed,
                        generations=cfg["es_generations"], popsize=cfg["es_lam"], hold_out=0,
                        patience=cfg["es_generations"], tol=0.0)
    es_time = time.perf_counter() - started
    target = es.history[-1].best_error
    started = time.perf_counter()
    cma = fit_parameters(trials, spec, odb=odb, executor=executor, optimizer="cmaes", seed=seed,
                         generations=cfg["cmaes_generations"], hold_out=0, patience=cfg["cmaes_generations"],
                         tol=0.0, target_error=target)
    cma_time = time.perf_counter() - started
    started = time.perf_counter()
    lm = fit_parameters(trials, spec, odb=odb, executor=executor, optimizer="lm", seed=seed,
                        generations=cfg["lm_iterations"], hold_out=0)
    lm_time = time.perf_counter() - started
    rows = {}
    for name, result, seconds in (("es", es, es_time), ("cmaes", cma, cma_time), ("lm", lm, lm_time)):
        rows[name] = {
            "simulations_to_target": simulations_to_reach(result, target, len(trials)),
            "generations_run": result.generations, "popsize": result.history[0].evaluations,
            "best_e": result.history[-1].best_error,
            "values": dict(result.values), "recovery_error": recovery(dict(result.values)).errors,
            "wall_s": round(seconds, 1), "stop": result.stop_reason}
    return {"target_e": target, "true_values": TRUE_VALUES, "start": dict(es.start), "trials": len(trials),
            "es_generations": cfg["es_generations"], **rows}


def _burn(n: int) -> float:
    started = time.perf_counter()
    total = 0
    for i in range(n):
        total += i * i
    return time.perf_counter() - started


def parallel_capacity(n: int = 5_000_000) -> float:
    """How much faster two processes do two equal pure-Python jobs than one process does one of them, twice:
    about 2 on two idle cores, about 1 when another program keeps one core busy."""
    import multiprocessing

    one = min(_burn(n) for _ in range(2))
    with multiprocessing.get_context("spawn").Pool(2) as pool:
        pool.map(_burn, [1000, 1000])
        started = time.perf_counter()
        pool.map(_burn, [n, n])
        two = time.perf_counter() - started
    return 2 * one / two


class _Recording:
    """Passes a fit's batches to an executor and keeps every task's CPU time per batch."""

    def __init__(self, executor):
        self.executor, self.kind, self.workers, self.odb = executor, executor.kind, executor.workers, executor.odb
        self.batches = []

    @property
    def cache(self):
        return self.executor.cache

    def run(self, jobs):
        outcomes = self.executor.run(jobs)
        self.batches.append([o.cpu_time for o in outcomes if not o.cached])
        return outcomes


def scheduled_time(batches: list[list[float]], workers: int) -> float:
    """Makespan of each batch when its tasks go, in order, to whichever of `workers` is free first (how the pool
    hands them out), summed: the parallel part of a fit on idle cores."""
    total = 0.0
    for batch in batches:
        free = [0.0] * workers
        for cost in batch:
            k = free.index(min(free))
            free[k] += cost
        total += max(free)
    return total


BACKENDS = (("process", 1), ("process", 2), ("dask", 2))


def _warm(executor, trials, spec) -> None:
    """Import Drake and build the diagrams in every worker: distinct jobs (the cache would answer equal ones
    without a worker), then an empty cache, so the fit's own simulations are all run."""
    from bridge.rollout.rollout import RolloutCache

    units = [np.full(spec.dim, 0.3 + 0.4 * k / max(1, 4 * executor.workers)) for k in range(4 * executor.workers)]
    evaluate(executor, trials, spec, [spec.from_unit(u) for u in units])
    executor.cache = RolloutCache()


def part_workers(odb, cfg: dict, seed: int) -> dict:
    trials = push_trials(odb)
    spec = recovery_spec()
    runs, skipped = [], None
    for repeat in range(cfg["speed_repeats"]):
        for kind, workers in BACKENDS:
            if kind == "dask" and skipped:
                continue
            try:
                executor = make_executor(kind, odb, workers=workers)
            except BridgeError as exc:  # dask is an optional extra
                skipped = str(exc)
                continue
            with executor:
                _warm(executor, trials, spec)
                capacity, load = parallel_capacity(), os.getloadavg()[0]
                recorder = _Recording(executor)
                started = time.perf_counter()
                result = fit_parameters(trials, spec, odb=odb, executor=recorder, optimizer="cmaes", seed=seed,
                                        generations=cfg["speed_generations"], popsize=cfg["speed_popsize"],
                                        hold_out=0, patience=cfg["speed_generations"], tol=0.0)
                runs.append({"backend": f"{kind} {workers}", "workers": workers,
                             "wall_s": round(time.perf_counter() - started, 3),
                             "cpu_s": round(sum(map(sum, recorder.batches)), 3), "capacity": round(capacity, 2),
                             "load_average": round(load, 2), "rollouts": dict(result.rollouts),
                             "batches": recorder.batches})
    backends = list(dict.fromkeys(r["backend"] for r in runs))
    best = {b: min(r["wall_s"] for r in runs if r["backend"] == b) for b in backends}
    one = [r for r in runs if r["backend"] == "process 1"]
    batches = one[0]["batches"]
    cpu_per_sim = {b: sum(r["cpu_s"] for r in runs if r["backend"] == b) / sum(
        len(x) for r in runs if r["backend"] == b for x in r["batches"]) for b in backends}
    estimate = scheduled_time(batches, 1) / scheduled_time(batches, 2)
    driver_share = 1 - one[0]["cpu_s"] / one[0]["wall_s"]
    for r in runs:
        del r["batches"]
    speedups = {b: round(best["process 1"] / best[b], 3) for b in backends if b != "process 1"}
    return {"simulations": result.simulations, "runs": runs, "wall_s": best, "speedups": speedups,
            "wall_s_1_worker": best["process 1"], "wall_s_2_workers": best.get("process 2"),
            "speedup": speedups.get("process 2"), "dask_speedup": speedups.get("dask 2"), "dask_skipped": skipped,
            "cpu_s_per_simulation": {b: round(v, 4) for b, v in cpu_per_sim.items()},
            "estimated_idle_speedup": round(estimate, 3), "driver_share_1_worker": round(driver_share, 3),
            "target_speedup": SPEEDUP_TARGET, "cpus": os.cpu_count(),
            "machine_parallel_capacity": min(r["capacity"] for r in runs)}


def part_mit(odb, executor, cfg: dict, seed: int) -> dict | None:
    from bridge.rollout import load_trials
    from bridge.recording.mitpush import find_mit_push_root

    root = find_mit_push_root()
    if root is None:
        return None
    files = sorted((root / "train").glob("*.h5"))
    if cfg["mit_trials"] is not None:  # the same number of pushes of every shape
        shapes = sorted({f.name.split("shape=")[1].split("_")[0] for f in files})
        per_shape = max(1, cfg["mit_trials"] // len(shapes))
        files = [f for s in shapes for f in [g for g in files if f"shape={s}_" in g.name][:per_shape]]
    trials = load_trials(files, odb, max_duration=cfg["mit_duration"])
    spec = parse_params(MIT_PARAMS, "benchmark MIT parameters")
    started = time.perf_counter()
    result = fit_parameters(trials, spec, odb=odb, executor=executor, optimizer="cmaes", seed=seed,
                            generations=cfg["mit_generations"], popsize=cfg["mit_popsize"])
    combined = {name: 2 * v * BLOCK_FRICTION / (v + BLOCK_FRICTION) for name, v in result.values.items()}
    per_trial = [{"trial": b.trial, "held_out": b.trial in result.held_out, "before_mm": round(b.error.e * 1e3, 3),
                  "after_mm": round(a.error.e * 1e3, 3)}
                 for b, a in zip(result.trial_errors_before, result.trial_errors_after)]
    return {"trials": len(trials), "fitted": len(result.fit_trials), "held_out": len(result.held_out),
            "duration_s": cfg["mit_duration"], "values": dict(result.values),
            "effective_with_block": combined,
            "fit_before": _e(result.before), "fit_after": _e(result.after),
            "held_out_before": _e(result.held_out_before), "held_out_after": _e(result.held_out_after),
            "simulations": result.simulations, "failures": result.failures, "wall_s": round(time.perf_counter() - started, 1),
            "per_trial": per_trial}


def _e(error) -> dict:
    return {"e_mm": round(error.e * 1e3, 4), "e_t_mm": round(error.e_t * 1e3, 4),
            "e_R_deg": round(math.degrees(error.e_R), 3)}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller budgets, < 3 minutes")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--workers", type=int, default=2, help="workers for parts 1 and 3 (default %(default)s)")
    parser.add_argument("--only", default=None, help=f"comma-separated parts to run ({', '.join(PARTS)}; default all); "
                        "the other parts' stored figures are kept")
    parser.add_argument("--json", default=None, help="default: benchmarks/results/fit.json (fit_quick.json with --quick)")
    args = parser.parse_args(argv)
    cfg = QUICK if args.quick else FULL
    args.json = args.json or str(REPO / "benchmarks" / "results" / ("fit_quick.json" if args.quick else "fit.json"))
    odb = load_object_database()
    parts = args.only.split(",") if args.only else list(PARTS)
    unknown = sorted(set(parts) - set(PARTS))
    if unknown:
        parser.error(f"--only: unknown part(s) {', '.join(unknown)}; choose from {', '.join(PARTS)}")
    out = Path(args.json)
    # a partial run updates its parts of the stored figures and keeps the others
    report = json.loads(out.read_text()) if args.only and out.is_file() else {}
    started = time.perf_counter()
    if "optimizers" in parts or "mit" in parts:
        with make_executor("process", odb, workers=args.workers) as executor:
            if "optimizers" in parts:
                report["optimizers"] = part_optimizers(odb, executor, cfg, args.seed)
                print_optimizers(report["optimizers"])
            if "mit" in parts:
                report["mit"] = part_mit(odb, executor, cfg, args.seed)
    if "workers" in parts:
        report["workers"] = part_workers(odb, cfg, args.seed)
        print_workers(report["workers"])
    if "mit" in parts:
        print_mit(report["mit"])
    total = time.perf_counter() - started
    print(f"\ntotal {total:.0f} s ({'quick' if args.quick else 'full'} run)")
    out.parent.mkdir(parents=True, exist_ok=True)
    report.update({"mode": "quick" if args.quick else "full", "seed": args.seed, "config": cfg,
                   "machine": platform.platform(), "total_s": round(total, 1)})
    out.write_text(json.dumps(report, indent=1) + "\n")
    print(f"wrote {out}")


def print_optimizers(r: dict) -> None:
    print(f"\n1. optimisers on the synthetic 4-parameter recovery problem ({r['trials']} trials); target = the ES's "
          f"best error after {r['es_generations']} generations: e = {r['target_e'] * 1e3:.4f} mm")
    print(f"   {'optimizer':<10}{'sims to target':>16}{'generations':>13}{'best e (mm)':>13}{'wall (s)':>10}   "
          "fitted - true")
    for name in ("es", "cmaes", "lm"):
        row = r[name]
        sims = row["simulations_to_target"]
        errors = ", ".join(f"{k.split('[')[0]} {v:+.3f}" for k, v in row["recovery_error"].items())
        print(f"   {name:<10}{sims if sims is not None else 'not reached':>16}{row['generations_run']:>13}"
              f"{row['best_e'] * 1e3:>13.4f}{row['wall_s']:>10.1f}   {errors}")


def print_workers(r: dict) -> None:
    repeats = sum(1 for run in r["runs"] if run["backend"] == "process 1")
    print(f"\n2. workers ({r['simulations']} simulations per fit, {r['cpus']} CPUs), best of {repeats}:")
    for backend, wall in r["wall_s"].items():
        speedup = r["speedups"].get(backend)
        ok = "" if speedup is None else (f", {speedup:.2f}x ({'meets' if speedup >= r['target_speedup'] else 'MISSES'}"
                                         f" the {r['target_speedup']}x target)")
        print(f"   {backend:<10} {wall:7.1f} s{ok}")
    if r["dask_skipped"]:
        print(f"   dask: skipped ({r['dask_skipped']})")
    for run in r["runs"]:
        print(f"   run: {run['backend']} {run['wall_s']:.1f} s wall, {run['cpu_s']:.1f} s CPU in simulations; "
              f"machine: 2 processes {run['capacity']:.2f}x as fast as 1, load average {run['load_average']:.1f}")
    cpu = r["cpu_s_per_simulation"]
    print("   CPU per simulation: " + ", ".join(f"{v * 1e3:.0f} ms ({b})" for b, v in cpu.items())
          + " (no parallel overhead when equal); on idle cores the pool's schedule of these tasks gives "
          f"{r['estimated_idle_speedup']:.2f}x (1-worker wall time not spent simulating - driver, IPC, waiting for a busy "
          f"machine: "
          f"{100 * r['driver_share_1_worker']:.0f} %)")
    if r["machine_parallel_capacity"] < 1.8:
        print("   warning: other programs were using the CPUs during some runs, so the measured speedup understates "
              "the fit's; run again on an idle machine")


def print_mit(r: dict | None) -> None:
    if r is None:
        print("\n3. MIT planar pushing: dataset not found (set BRIDGE_MIT_PUSH), skipped")
        return
    print(f"\n3. MIT planar pushing (Yu et al., IROS 2016): {r['trials']} pushes ({r['duration_s']} s each), "
          f"{r['fitted']} fitted, {r['held_out']} held out; {r['simulations']} simulations, {r['failures']} failed, "
          f"{r['wall_s']:.0f} s")
    for name, value in r["values"].items():
        print(f"   {name} = {value:.3f} (with the block's 0.25: effective {r['effective_with_block'][name]:.3f})")
    print(f"   {'':<12}{'e (mm)':>10}{'e_t (mm)':>10}{'e_R (deg)':>11}")
    for label, key in (("fitted before", "fit_before"), ("fitted after", "fit_after"),
                       ("held-out before", "held_out_before"), ("held-out after", "held_out_after")):
        e = r[key]
        print(f"   {label:<16}{e['e_mm']:>6.3f}{e['e_t_mm']:>10.3f}{e['e_R_deg']:>11.2f}")


if __name__ == "__main__":
    main()
