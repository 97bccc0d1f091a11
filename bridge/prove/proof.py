"""The proof: recordings with each effect concealed (by a physical mechanism, `generate.py`), diagnosed blind.

For each case the generator writes recording folders (world.yaml, telemetry.csv, observed.csv) and, beside them,
truth.json; the diagnosis reads only the recordings. The result is a confusion matrix (true effect x verdict),
parameter recovery against the truth (with the tolerances below) and the error before and after on held-out
recordings.

Sizes: `small` (CI: every planar effect once at a large magnitude, clean data; the tabletop only in `full`) and `full`
(benchmarks/prove_benchmark.py: every planar effect at three magnitudes with two seeds, tabletop com_offset and
hidden_obstacle at three magnitudes, and clean cases).
"""
from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterator, Sequence

import numpy as np

from ..diagnosis.effects import EFFECTS, Recovery, Truth, get_effect
from ..diagnosis.identify import Options
from ..diagnosis.pipeline import DiagnosisRun, run_diagnosis
from ..diagnosis.runs import default_workers
from ..errors import DiagnosisError
from ..files import write_atomic, write_set
from ..odb import ObjectDatabase
from ..rollout.executors import Executor, make_executor
from ..timelimit import TimeLimit
from .generate import MIT_RATE, generate_case
from .scenes import MAGNITUDES, PLANAR_EFFECTS, TABLETOP_EFFECTS, Case

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


WORLDS = ("matched", "mismatched", "both")
# the mismatched proof's shapes (the MIT dataset's meshes, `--dataset mit-push=PATH`): boxes, ellipses of two
# aspect ratios, a hexagon, a triangle and a non-convex outline
MISMATCHED_SHAPES = ("rect1", "ellip1", "ellip3", "hex", "tri1", "butter")
MISMATCHED_EFFECTS = PLANAR_EFFECTS + ("pressure_distribution", "anisotropic_friction")
# errors of the object model (what the recording tracks on the object, its size): after each seed's cases above, so that
# adding one leaves every earlier case's shape (and name) as it was
OBJECT_MODEL_EFFECTS = ("object_frame", "object_scale")
CI_SHAPE = "steel_block"  # a dataset-free box in the MIT format (odb/types/proof.yaml)
TABLETOP_MISMATCHED = ("none", "friction", "mass", "com_offset", "surface_tilt", "friction_patch", "latency",
                       "pusher_offset", "hidden_obstacle")


def proof_cases(size: str, seed: int = 0, world: str = "matched") -> list[Case]:
    """The cases of a proof: `world` "matched" (recordings from the diagnosis' own model), "mismatched" (worlds
    that differ from it beneath the effect, `prove.mismatch`, recorded as MIT pushing h5 files) or "both"."""
    if world == "both":
        return proof_cases(size, seed, "matched") + proof_cases(size, seed, "mismatched")
    if world == "mismatched":
        return _mismatched_cases(size, seed)
    if world != "matched":
        raise DiagnosisError(f"unknown proof world {world!r}; worlds: {', '.join(WORLDS)}")
    if size == "small":
        cases = [Case("planar", e, "large", seed + 1) for e in PLANAR_EFFECTS]
        cases.append(Case("planar", "none", "medium", seed + 1))
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


def _mismatched_cases(size: str, seed: int) -> list[Case]:
    """small (CI, no dataset needed): a clean world of the steel block, its frictions moved; full: every effect of the
    catalog at three magnitudes, two seeds, the shapes taken in turn, a clean world of every shape per seed, and
    the tabletop's effects at the medium magnitude."""
    if size == "small":
        # the world of seed 3: named `friction`, held-out e down 60 %. Of the first three worlds of this case, seed
        # 1's is named `surface_tilt` (0.17-0.19 deg) and seed 2's `friction` with its held-out e doubled
        # (docs/diagnosis.md, section 6): the small proof shows the pipeline end to end, the full one the rates
        return [Case(f"mit_{CI_SHAPE}", "none", "large", seed + 3, "mismatched")]
    if size != "full":
        raise DiagnosisError(f"unknown proof size {size!r}; sizes: {', '.join(SIZES)}")
    cases = []
    for s in (1, 2):  # seed by seed, so that a run cut short still covers every effect, magnitude and shape
        pairs = [(m, e) for m in MAGNITUDES for e in MISMATCHED_EFFECTS]
        cases += [Case(f"mit_{MISMATCHED_SHAPES[(k + s) % len(MISMATCHED_SHAPES)]}", e, m, seed + s, "mismatched")
                  for k, (m, e) in enumerate(pairs)]
        cases += [Case(f"mit_{shape}", "none", "medium", seed + s, "mismatched") for shape in MISMATCHED_SHAPES]
        model_pairs = [(m, e) for e in OBJECT_MODEL_EFFECTS for m in MAGNITUDES]  # a new effect after the others
        cases += [Case(f"mit_{MISMATCHED_SHAPES[(k + 2 * s) % len(MISMATCHED_SHAPES)]}", e, m, seed + s, "mismatched")
                  for k, (m, e) in enumerate(model_pairs)]
        if s == 1:  # the tabletop (the small box on the table, the rod 3 cm above it; recording folders): every
            # effect it can show, medium
            cases += [Case("tabletop", e, "medium", seed + 1, "mismatched") for e in TABLETOP_MISMATCHED]
    return cases


# --- checking a verdict against the truth ------------------------------------------------------------------
def recovery(truth: Truth, run: DiagnosisRun, odb: ObjectDatabase, world) -> Recovery:
    """Did the diagnosis find the right parameters? The effect's own check (`Effect.recovered`), its tolerance
    stated in the text."""
    w = run.identification.winner
    return get_effect(truth.effect).recovered(truth, w.params, w.model, world, odb)


def target_ok(truth: Truth, run: DiagnosisRun, world, odb: ObjectDatabase) -> bool:
    """The verdict is the concealed effect, on the concealed target (`Effect.target_matches`)."""
    w = run.identification.winner
    if truth.effect == "none" or w.effect != truth.effect:
        return w.effect == truth.effect
    return get_effect(truth.effect).target_matches(truth.target, w.target, world, odb)


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
    alike: tuple[str, ...] = ()  # accepted effects the recordings did not tell apart from the verdict

    @property
    def right(self) -> bool:
        return right_verdict(self.truth.to_json(), self.verdict)

    @property
    def held_out_reduction(self) -> float | None:
        if self.held_out_before is None or self.held_out_after is None or self.held_out_before <= 0:
            return None
        return 1.0 - self.held_out_after / self.held_out_before

    def to_json(self) -> dict[str, Any]:
        return {"case": self.case.name, "scene": self.case.scene, "world": self.case.world, "effect": self.truth.effect,
                "magnitude": self.case.magnitude, "seed": self.case.seed, "truth": self.truth.to_json(),
                "verdict": self.verdict, "target": self.target, "target_ok": self.target_ok,
                "recovered": self.recovery.ok, "recovery": self.recovery.text, "params": self.params,
                "runner_up": self.runner_up, "margin": self.margin,
                "held_out_before": self.held_out_before, "held_out_after": self.held_out_after,
                "held_out_reduction": self.held_out_reduction,
                "held_out_excess_reduction": self.held_out_excess_reduction, "alike": list(self.alike),
                "seconds": round(self.seconds, 1),
                "simulations": self.simulations}


@dataclass(frozen=True)
class ProofResult:
    size: str
    results: tuple[CaseResult, ...]
    seconds: float
    planned: int | None = None  # cases planned (None: as many as results)
    limit: dict[str, Any] | None = None  # `TimeLimit.to_json`: "stopped", "time_limit_s", ...

    @property
    def partial(self) -> bool:
        return bool(self.limit and self.limit.get("stopped"))

    @property
    def rows(self) -> list[dict[str, Any]]:
        return [r.to_json() for r in self.results]

    def confusion(self) -> tuple[list[str], dict[str, dict[str, int]]]:
        return confusion(self.rows)

    def summary(self) -> dict[str, Any]:
        return summarise(self.rows)

    def text(self) -> str:
        text = proof_text(self.rows)
        if self.partial:
            text = (f"partial: the time limit of {self.limit['time_limit_s']:g} s stopped the proof after "
                    f"{len(self.results)} of {self.planned} case(s)\n\n" + text)
        return text

    def to_json(self) -> dict[str, Any]:
        data = proof_json(self.size, self.rows, self.seconds)
        data["cases_planned"] = self.planned if self.planned is not None else len(self.results)
        data.update(self.limit or {"stopped": None, "time_limit_s": None})
        return data


# --- figures from case rows (CaseResult.to_json(); also what the benchmark's progress.json holds) ----------------
def confusion(rows: Sequence[dict[str, Any]]) -> tuple[list[str], dict[str, dict[str, int]]]:
    labels = [e for e in EFFECTS if any(r["effect"] == e or r["verdict"] == e for r in rows)]
    matrix = {t: {v: 0 for v in labels} for t in labels}
    for r in rows:
        matrix[r["effect"]][r["verdict"]] += 1
    return labels, matrix


def right_verdict(truth: dict[str, Any], verdict: str) -> bool:
    """The concealed effect; on a clean world `none`, or `friction` when the world's own coefficients were moved
    away from the object database's (a mismatched world, `prove.mismatch`): fitting them is then the answer."""
    if verdict == truth["effect"]:
        return True
    moved = (truth.get("extra") or {}).get("mismatch", {}).get("surface_friction") is not None
    return truth["effect"] == "none" and verdict == "friction" and moved


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
        "none_on_clean": _frac(sum(right_verdict(r["truth"], r["verdict"]) for r in clean), len(clean)),
        # the verdict right but the recordings did not tell it from another accepted effect (`identify._alike`),
        # and the concealed effect among the verdict and those: what a user reading the rivals would consider
        "right_with_rivals": _frac(sum(bool(r.get("alike")) for r in right), len(right)),
        "truth_supported": _frac(sum(r["effect"] in (r["verdict"], *r.get("alike", ())) for r in concealed),
                                 len(concealed)),
        "held_out_excess_reduction_when_right_median": float(np.median(reductions)) if reductions else None,
        "held_out_excess_reduction_when_right_min": float(np.min(reductions)) if reductions else None,
        "held_out_excess_reduction_at_least_70pct": _frac(sum(x >= 0.7 for x in reductions), len(reductions)),
        "held_out_e_reduction_when_right_median": float(np.median(e_reductions)) if e_reductions else None,
        "seconds_per_case_median": float(np.median(seconds)) if seconds else None,
        "seconds_per_case_max": float(np.max(seconds)) if seconds else None,
    }


def summaries(rows: Sequence[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """`summarise` per world (matched, mismatched) that has cases."""
    return {w: summarise([r for r in rows if r.get("world", "matched") == w]) for w in WORLDS[:2]
            if any(r.get("world", "matched") == w for r in rows)}


def summary_table(rows: Sequence[dict[str, Any]]) -> str:
    """The summaries of the worlds side by side, one figure per line."""
    by = summaries(rows)
    keys = list(next(iter(by.values())).keys()) if by else []
    lines = [f"{'':44s}" + "".join(f"{w:>14s}" for w in by)]
    for k in keys:
        cells = [by[w][k] for w in by]
        lines.append(f"{k:44s}" + "".join(f"{'-' if v is None else round(v, 3) if isinstance(v, float) else v!s:>14}"
                                          for v in cells))
    return "\n".join(lines)


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
                     f"{ho:>21s} {ex:>7s} {r['seconds']:6.1f}  {r['recovery']}"
                     + (f" (alike: {', '.join(r['alike'])})" if r.get("alike") else ""))
    lines.append("")
    lines.append(summary_table(rows))
    return "\n".join(lines)


def proof_json(size: str, rows: Sequence[dict[str, Any]], seconds: float) -> dict[str, Any]:
    labels, matrix = confusion(rows)
    return {"size": size, "seconds": round(seconds, 1), "summary": summarise(rows), "worlds": summaries(rows),
            "confusion": {"labels": labels, "matrix": matrix}, "cases": list(rows)}


def _frac(a: int, b: int) -> float | None:
    return round(a / b, 4) if b else None


def run_case(case: Case, odb: ObjectDatabase, folder: Path, settings: ProofSettings, *, workers: int | None = None,
             executor: Executor | None = None, log: Callable[[str], None] | None = None) -> CaseResult:
    """Generate the case's recordings, diagnose them blind (from the folders), compare with the truth."""
    from ..rollout.trials import load_trials

    paths, truth = generate_case(case, odb, folder, settings.recordings)
    started = time.perf_counter()
    mit = paths and paths[0].suffix == ".h5"  # every sample of the motion capture, as `bridge diagnose` reads them
    trials = load_trials(paths, odb, observation_rate=MIT_RATE if mit else None)
    (folder / "diagnosis").mkdir(parents=True, exist_ok=True)
    with open(folder / "diagnosis" / "log.txt", "w", encoding="utf-8") as handle:
        def say(message: str) -> None:
            handle.write(message + "\n")
            handle.flush()
            if log:
                log(message)

        run = run_diagnosis(trials, odb, folder / "diagnosis", held_out=settings.held_out, workers=workers,
                            executor=executor, options=settings.options, plots=False, log=say)
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
                      ident.simulations, e.get("held_out_excess_reduction"), tuple(a.effect for a in ident.alike))


def run_cases(cases: Sequence[Case], odb: ObjectDatabase, out: Path, settings: ProofSettings, *,
              workers: int | None = None) -> Iterator[CaseResult]:
    """Each case run in turn (`run_case`, folder `out/<case name>`), yielded as it ends: a caller that stops
    iterating starts no further case."""
    n = workers or default_workers()
    for case in cases:
        # workers of their own per case: a pool kept for the whole full proof grew to 12 GB a worker after some 40
        # cases (docs/diagnosis.md, section 6); starting one costs seconds of a case's minutes
        with make_executor("serial" if n == 1 else "process", odb, workers=n) as executor:
            result = run_case(case, odb, out / case.name, settings, executor=executor)
        yield result


def run_proof(out: str | Path, odb: ObjectDatabase, *, size: str = "small", world: str = "both",
              cases: Sequence[Case] | None = None, workers: int | None = None, log: Callable[[str], None] | None = None,
              progress: Callable[[int, int], None] | None = None, time_limit: float | None = None) -> ProofResult:
    """Every case of `size` and `world` (or `cases`), one after the other; proof.json is rewritten after each case.
    `progress(done, total)` after each case. `time_limit` (s, from the call): no case starts once it has passed
    (the first always runs); proof.json and proof.md then cover the cases done and say "stopped": "time limit"."""
    settings = SETTINGS[size] if size in SETTINGS else None
    if settings is None:
        raise DiagnosisError(f"unknown proof size {size!r}; sizes: {', '.join(SIZES)}")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    cases = list(cases) if cases is not None else proof_cases(size, world=world)
    started = time.perf_counter()
    limit = TimeLimit(time_limit)
    stopped = False
    results = []
    for k, result in enumerate(run_cases(cases, odb, out, settings, workers=workers)):
        results.append(result)
        if log:
            log(f"[{k + 1}/{len(cases)}] {result.case.name}: verdict {result.verdict} (target ok {result.target_ok}, "
                f"params {result.recovery.text}), {result.seconds:.0f} s")
        if progress is not None:
            progress(k + 1, len(cases))
        partial = ProofResult(size, tuple(results), time.perf_counter() - started, len(cases), limit.to_json(False))
        write_atomic(out / "proof.json", json.dumps(partial.to_json(), indent=2) + "\n")
        if k + 1 < len(cases) and limit.expired():
            stopped = True
            if log:
                log(f"{limit.text()} reached: stopping after {k + 1} of {len(cases)} case(s)")
            break
    proof = ProofResult(size, tuple(results), time.perf_counter() - started, len(cases),
                        limit.to_json(stopped))
    title = "# Proof: concealed effects diagnosed blind" + (" (partial)" if stopped else "")
    write_set({out / "proof.json": json.dumps(proof.to_json(), indent=2) + "\n",
               out / "proof.md": title + "\n\n```\n" + proof.text() + "\n```\n"})
    return proof
