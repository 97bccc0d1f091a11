"""The proof: recordings with each effect concealed (by a physical mechanism, `scenarios.py`), diagnosed blind.

For each case the generator writes recording folders (world.yaml, telemetry.csv, observed.csv) and, beside them,
truth.json; the diagnosis reads only the recordings. The result is a confusion matrix (true effect x verdict),
parameter recovery against the truth (with the tolerances below) and the error before and after on held-out
recordings.

Sizes: `small` (CI: every planar effect once at a large magnitude, clean data, one tabletop case) and `full`
(benchmarks/prove_benchmark.py: every planar effect at three magnitudes with two seeds, tabletop com_offset and
hidden_obstacle at three magnitudes, and clean cases).
"""
from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from ..errors import DiagnosisError
from ..odb import ObjectDatabase
from ..sim.friction import combined_friction
from ..files import write_atomic
from .effects import EFFECTS
from .identify import Options
from .pipeline import DiagnosisRun, run_diagnosis
from .scenarios import MAGNITUDES, PLANAR_EFFECTS, TABLETOP_EFFECTS, Case, Truth, generate_case

SIZES = ("small", "full")


@dataclass(frozen=True)
class ProofSettings:
    recordings: int
    held_out: int
    options: Options


SETTINGS = {
    "small": ProofSettings(4, 1, Options(max_full_fits=4, max_iterations=4)),
    "full": ProofSettings(8, 2, Options(max_full_fits=4, max_iterations=4)),
}


def proof_cases(size: str, seed: int = 0) -> list[Case]:
    if size == "small":
        cases = [Case("planar", e, "large", seed + 1) for e in PLANAR_EFFECTS]
        cases.append(Case("planar", "none", "medium", seed + 1))
        cases.append(Case("tabletop", "com_offset", "large", seed + 1))
        return cases
    if size == "full":  # seed by seed, so that a run cut short still covers every effect and magnitude
        cases = []
        for s in (1, 2):
            cases += [Case("planar", e, m, seed + s) for m in MAGNITUDES for e in PLANAR_EFFECTS]
            cases += [Case("planar", "none", "medium", seed + k) for k in (3 * s - 2, 3 * s - 1, 3 * s)]
            if s == 1:
                cases += [Case("tabletop", e, m, seed + 1) for e in TABLETOP_EFFECTS for m in MAGNITUDES]
            cases.append(Case("tabletop", "none", "medium", seed + s))
        return cases
    raise DiagnosisError(f"unknown proof size {size!r}; sizes: {', '.join(SIZES)}")


# --- checking a verdict against the truth ------------------------------------------------------------------------
@dataclass(frozen=True)
class Recovery:
    ok: bool
    error: float | None  # the compared quantity's error, in its unit
    unit: str
    text: str


def recovery(truth: Truth, run: DiagnosisRun, odb: ObjectDatabase, world) -> Recovery:
    """Did the diagnosis find the right parameters? Tolerances per effect, stated in the text."""
    w = run.identification.winner
    p, t = w.params, truth.params
    e = truth.effect
    if e == "none":
        return Recovery(True, None, "", "clean")
    if e == "friction":
        mus = {a.target: a.values()["mu"] for a in w.model if a.effect == "friction"}
        obj = next(n for n, o in world.objects.items() if not odb.get(o.type).fixed)
        surf = truth.target
        mu_o = mus.get(obj, odb.get(world.objects[obj].type).physics.friction)
        mu_s = mus.get(surf, odb.get(world.objects[surf].type).physics.friction)
        err = abs(combined_friction(mu_o, mu_s) - truth.extra["pair_mu"])
        tol = 0.25 * truth.extra["pair_mu"]
        return Recovery(err <= tol, err, "", f"pair mu {combined_friction(mu_o, mu_s):.3f} vs {truth.extra['pair_mu']:.3f} "
                                             f"(tolerance 25 %)")
    if e == "mass":
        err = abs(p["mass"] - t["mass"])
        return Recovery(err <= 0.3 * t["mass"], err, "kg", f"mass {p['mass']:.3f} vs {t['mass']:.3f} kg (30 %)")
    if e == "com_offset":
        d = math.hypot(p["dx"] - t["dx"], p["dy"] - t["dy"])
        size = math.hypot(t["dx"], t["dy"])
        return Recovery(d <= 0.35 * size + 0.002, d, "m",
                        f"offset ({p['dx'] * 1e3:.1f}, {p['dy'] * 1e3:.1f}) vs ({t['dx'] * 1e3:.1f}, "
                        f"{t['dy'] * 1e3:.1f}) mm (35 % + 2 mm)")
    if e == "surface_tilt":
        d = math.hypot(p["slope_x"] - t["slope_x"], p["slope_y"] - t["slope_y"])
        size = math.hypot(t["slope_x"], t["slope_y"])
        return Recovery(d <= 0.3 * size + 0.005, d, "rad",
                        f"slope ({math.degrees(p['slope_x']):.2f}, {math.degrees(p['slope_y']):.2f}) vs "
                        f"({math.degrees(t['slope_x']):.2f}, {math.degrees(t['slope_y']):.2f}) deg (30 % + 0.3 deg)")
    if e == "friction_patch":
        mus = {a.target: a.values()["mu"] for a in w.model if a.effect == "friction"}
        obj = next(n for n, o in world.objects.items() if not odb.get(o.type).fixed)
        mu_o = mus.get(obj, odb.get(world.objects[obj].type).physics.friction)
        pair = combined_friction(mu_o, p["mu"])
        err = abs(pair - t["mu"])
        return Recovery(err <= 0.3 * t["mu"], err, "", f"pair mu inside {pair:.3f} vs {t['mu']:.3f} (30 %)")
    if e == "latency":
        err = abs(p["dt"] - t["dt"])
        return Recovery(err <= 0.2 * abs(t["dt"]) + 0.01, err, "s", f"dt {p['dt'] * 1e3:.0f} vs {t['dt'] * 1e3:.0f} ms "
                                                                       f"(20 % + 10 ms)")
    if e == "pusher_offset":
        keys = [k for k in t]
        d = math.sqrt(sum((p.get(k, 0.0) - t[k]) ** 2 for k in keys))
        size = math.sqrt(sum(t[k] ** 2 for k in keys))
        return Recovery(d <= 0.3 * size + 0.001, d, "m", f"offset {d * 1e3:.1f} mm off a {size * 1e3:.1f} mm offset "
                                                          f"(30 % + 1 mm)")
    if e == "hidden_obstacle":
        d = math.hypot(p["x"] - t["x"], p["y"] - t["y"])
        return Recovery(d <= 0.025, d, "m", f"post {d * 1e3:.0f} mm from the box centre (25 mm)")
    return Recovery(False, None, "", f"no recovery check for {e}")


_TARGET_OK = {"friction": ("object", "surface"), "mass": ("object",), "com_offset": ("object",),
              "surface_tilt": ("surface",), "friction_patch": ("surface",), "hidden_obstacle": ("surface",),
              "latency": ("robot",), "pusher_offset": ("robot",)}


def target_ok(truth: Truth, run: DiagnosisRun, world, odb: ObjectDatabase) -> bool:
    w = run.identification.winner
    if truth.effect == "none" or w.effect != truth.effect:
        return w.effect == truth.effect
    kinds = _TARGET_OK[truth.effect]
    target = w.target
    if "robot" in kinds and world.robot is not None and (target == world.robot.name
                                                         or target.startswith(world.robot.name + ":")):
        return True
    if target in world.objects:
        fixed = odb.get(world.objects[target].type).fixed
        return ("surface" in kinds and fixed) or ("object" in kinds and not fixed)
    return False


# --- running ------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class CaseResult:
    case: Case
    truth: Truth
    verdict: str
    target: str
    target_ok: bool
    recovery: Recovery
    params: dict[str, float]
    runner_up: str | None
    margin: float | None
    held_out_before: float | None  # the paper's pose error e on the held-out recordings
    held_out_after: float | None
    seconds: float
    simulations: int
    held_out_excess_reduction: float | None = None  # of the residual above the noise floor (report.excess_reduction)

    @property
    def right(self) -> bool:
        return self.verdict == self.truth.effect

    @property
    def held_out_reduction(self) -> float | None:
        if self.held_out_before is None or self.held_out_after is None or self.held_out_before <= 0:
            return None
        return 1.0 - self.held_out_after / self.held_out_before

    def to_json(self) -> dict[str, Any]:
        return {"case": self.case.name, "scene": self.case.scene, "effect": self.truth.effect,
                "magnitude": self.case.magnitude, "seed": self.case.seed, "truth": self.truth.to_json(),
                "verdict": self.verdict, "target": self.target, "target_ok": self.target_ok,
                "recovered": self.recovery.ok, "recovery": self.recovery.text, "params": self.params,
                "runner_up": self.runner_up, "margin": self.margin,
                "held_out_before": self.held_out_before, "held_out_after": self.held_out_after,
                "held_out_reduction": self.held_out_reduction,
                "held_out_excess_reduction": self.held_out_excess_reduction, "seconds": round(self.seconds, 1),
                "simulations": self.simulations}


@dataclass(frozen=True)
class ProofResult:
    size: str
    results: tuple[CaseResult, ...]
    seconds: float

    @property
    def rows(self) -> list[dict[str, Any]]:
        return [r.to_json() for r in self.results]

    def confusion(self) -> tuple[list[str], dict[str, dict[str, int]]]:
        return confusion(self.rows)

    def summary(self) -> dict[str, Any]:
        return summarise(self.rows)

    def text(self) -> str:
        return proof_text(self.rows)

    def to_json(self) -> dict[str, Any]:
        return proof_json(self.size, self.rows, self.seconds)


# --- figures from case rows (CaseResult.to_json(); also what the benchmark's progress.json holds) ----------------
def confusion(rows: Sequence[dict[str, Any]]) -> tuple[list[str], dict[str, dict[str, int]]]:
    labels = [e for e in EFFECTS if any(r["effect"] == e or r["verdict"] == e for r in rows)]
    matrix = {t: {v: 0 for v in labels} for t in labels}
    for r in rows:
        matrix[r["effect"]][r["verdict"]] += 1
    return labels, matrix


def summarise(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    concealed = [r for r in rows if r["effect"] != "none"]
    clean = [r for r in rows if r["effect"] == "none"]
    right = [r for r in concealed if r["verdict"] == r["effect"]]
    reductions = [r["held_out_excess_reduction"] for r in right if r.get("held_out_excess_reduction") is not None]
    e_reductions = [r["held_out_reduction"] for r in right if r.get("held_out_reduction") is not None]
    seconds = [r["seconds"] for r in rows]
    return {
        "cases": len(rows),
        "concealed": len(concealed),
        "verdict_right": _frac(len(right), len(concealed)),
        "target_right": _frac(sum(r["target_ok"] for r in concealed), len(concealed)),
        "params_recovered_when_right": _frac(sum(r["recovered"] for r in right), len(right)),
        "none_on_clean": _frac(sum(r["verdict"] == "none" for r in clean), len(clean)),
        "held_out_excess_reduction_when_right_median": float(np.median(reductions)) if reductions else None,
        "held_out_excess_reduction_when_right_min": float(np.min(reductions)) if reductions else None,
        "held_out_excess_reduction_at_least_70pct": _frac(sum(x >= 0.7 for x in reductions), len(reductions)),
        "held_out_e_reduction_when_right_median": float(np.median(e_reductions)) if e_reductions else None,
        "seconds_per_case_median": float(np.median(seconds)) if seconds else None,
        "seconds_per_case_max": float(np.max(seconds)) if seconds else None,
    }


def proof_text(rows: Sequence[dict[str, Any]]) -> str:
    labels, matrix = confusion(rows)
    short = {e: e[:9] for e in labels}
    lines = ["confusion matrix (rows: concealed effect, columns: verdict)",
             f"{'':16s}" + "".join(f"{short[v]:>10s}" for v in labels)]
    for t in labels:
        if sum(matrix[t].values()) == 0:
            continue
        lines.append(f"{t:16s}" + "".join(f"{matrix[t][v]:10d}" for v in labels))
    lines.append("")
    lines.append(f"{'case':36s} {'verdict':16s} {'target':7s} {'params':7s} {'held-out e (m)':>21s} "
                 f"{'excess':>7s} {'s':>6s}  recovery")
    for r in rows:
        before, after = r.get("held_out_before"), r.get("held_out_after")
        ho = f"{before:.5f}->{after:.5f}" if before is not None and after is not None else "-"
        x = r.get("held_out_excess_reduction")
        ex = f"{-100 * x:+.0f}%" if x is not None else "-"
        lines.append(f"{r['case']:36s} {r['verdict']:16s} {str(r['target_ok']):7s} {str(r['recovered']):7s} "
                     f"{ho:>21s} {ex:>7s} {r['seconds']:6.1f}  {r['recovery']}")
    lines.append("")
    for k, v in summarise(rows).items():
        lines.append(f"{k}: {v if not isinstance(v, float) else round(v, 3)}")
    return "\n".join(lines)


def proof_json(size: str, rows: Sequence[dict[str, Any]], seconds: float) -> dict[str, Any]:
    labels, matrix = confusion(rows)
    return {"size": size, "seconds": round(seconds, 1), "summary": summarise(rows),
            "confusion": {"labels": labels, "matrix": matrix}, "cases": list(rows)}


def _frac(a: int, b: int) -> float | None:
    return round(a / b, 4) if b else None


def run_case(case: Case, odb: ObjectDatabase, folder: Path, settings: ProofSettings, *, workers: int | None = None,
             log: Callable[[str], None] | None = None) -> CaseResult:
    """Generate the case's recordings, diagnose them blind (from the folders), compare with the truth."""
    from ..fit.trials import load_trials

    paths, truth = generate_case(case, odb, folder, settings.recordings)
    started = time.perf_counter()
    trials = load_trials(paths, odb)
    (folder / "diagnosis").mkdir(parents=True, exist_ok=True)
    with open(folder / "diagnosis" / "log.txt", "w", encoding="utf-8") as handle:
        def say(message: str) -> None:
            handle.write(message + "\n")
            handle.flush()
            if log:
                log(message)

        run = run_diagnosis(trials, odb, folder / "diagnosis", held_out=settings.held_out, workers=workers,
                            options=settings.options, plots=False, log=say)
    seconds = time.perf_counter() - started
    ident = run.identification
    world = trials[0].world
    e = run.data["error"]
    return CaseResult(case, truth, ident.verdict, ident.winner.target, target_ok(truth, run, world, odb),
                      recovery(truth, run, odb, world) if ident.verdict == truth.effect else
                      Recovery(False, None, "", f"verdict {ident.verdict}"),
                      dict(ident.winner.params), ident.runner_up.effect if ident.runner_up else None,
                      round(ident.margin, 2) if math.isfinite(ident.margin) else None,
                      e.get("held_out_before", {}).get("e"), e.get("held_out_after", {}).get("e"), seconds,
                      ident.simulations, e.get("held_out_excess_reduction"))


def run_proof(out: str | Path, odb: ObjectDatabase, *, size: str = "small", cases: Sequence[Case] | None = None,
              workers: int | None = None, log: Callable[[str], None] | None = None) -> ProofResult:
    settings = SETTINGS[size] if size in SETTINGS else None
    if settings is None:
        raise DiagnosisError(f"unknown proof size {size!r}; sizes: {', '.join(SIZES)}")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    cases = list(cases) if cases is not None else proof_cases(size)
    started = time.perf_counter()
    results = []
    for k, case in enumerate(cases):
        result = run_case(case, odb, out / case.name, settings, workers=workers)
        results.append(result)
        if log:
            log(f"[{k + 1}/{len(cases)}] {case.name}: verdict {result.verdict} (target ok {result.target_ok}, "
                f"params {result.recovery.text}), {result.seconds:.0f} s")
        partial = ProofResult(size, tuple(results), time.perf_counter() - started)
        write_atomic(out / "proof.json", json.dumps(partial.to_json(), indent=2) + "\n")
    proof = ProofResult(size, tuple(results), time.perf_counter() - started)
    write_atomic(out / "proof.json", json.dumps(proof.to_json(), indent=2) + "\n")
    write_atomic(out / "proof.md", "# Proof: concealed effects diagnosed blind\n\n```\n" + proof.text() + "\n```\n")
    return proof
